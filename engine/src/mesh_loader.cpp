#include "holoflow/engine/mesh_loader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>
#include <span>
#include <sstream>
#include <string>
#include <tuple>

#include <Eigen/Geometry>

#include "holoflow/kernels/union_find.h"

namespace holoflow::engine {
namespace {

using Vec3 = Eigen::Vector3d;

// A triangle is zero-area when its cross product vanishes to rounding relative to its longest
// edge: exactly collinear or coincident corners. Needles with angles of 1e-6 degrees still pass.
constexpr double kZeroAreaRelative = 16 * std::numeric_limits<double>::epsilon();
// Extent of the bounding box the pipeline takes: measured to work on 1e-75 .. 1e75 (a torus),
// with room for edges far shorter than the model.
constexpr double kMinExtent = 1e-60, kMaxExtent = 1e60;
// Ear clipping is quadratic in the polygon size; beyond this a fan is used.
constexpr std::size_t kMaxEarClippingCorners = 256;
// MeshView uses 32-bit halfedge indices (3 per face).
constexpr std::size_t kMaxFaces = (std::size_t{1} << 29) - 1;

[[noreturn]] void fail(MeshErrorKind kind, const std::string& detail) { throw MeshError(kind, detail); }

std::string face_label(std::size_t polygon) { return "face " + std::to_string(polygon); }

Vec3 point(const PolygonSoup& soup, std::int64_t v) {
    return {soup.positions[3 * v], soup.positions[3 * v + 1], soup.positions[3 * v + 2]};
}

// Splits one polygon (corners already checked) into triangles appended to `out`: quads along the
// shorter diagonal, larger polygons by ear clipping in the plane of their Newell normal.
// Corners collinear or coincident, to rounding.
bool zero_area(const Vec3& a, const Vec3& b, const Vec3& c) {
    const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
    return (b - a).cross(c - a).norm() <= kZeroAreaRelative * longest;
}

void triangulate(const PolygonSoup& soup, const std::int64_t* corner, std::size_t n,
                 std::vector<std::array<std::int64_t, 3>>& out) {
    if (n == 3) {
        out.push_back({corner[0], corner[1], corner[2]});
        return;
    }
    if (n == 4) {
        // The shorter diagonal, unless only the other one gives two triangles with an area (a
        // quad with a straight corner, e.g. a CAD face with a vertex on its edge).
        const auto flat = [&](int i, int j, int k) {
            return zero_area(point(soup, corner[i]), point(soup, corner[j]), point(soup, corner[k]));
        };
        const bool split02 = !flat(0, 1, 2) && !flat(0, 2, 3), split13 = !flat(0, 1, 3) && !flat(1, 2, 3);
        const double d02 = (point(soup, corner[0]) - point(soup, corner[2])).squaredNorm();
        const double d13 = (point(soup, corner[1]) - point(soup, corner[3])).squaredNorm();
        if (split02 != split13 ? split02 : d02 <= d13) {
            out.push_back({corner[0], corner[1], corner[2]});
            out.push_back({corner[0], corner[2], corner[3]});
        } else {
            out.push_back({corner[0], corner[1], corner[3]});
            out.push_back({corner[1], corner[2], corner[3]});
        }
        return;
    }
    auto fan = [&] {
        for (std::size_t i = 1; i + 1 < n; ++i) out.push_back({corner[0], corner[i], corner[i + 1]});
    };
    if (n > kMaxEarClippingCorners) return fan();
    Vec3 normal = Vec3::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3 p = point(soup, corner[i]), q = point(soup, corner[(i + 1) % n]);
        normal += Vec3((p.y() - q.y()) * (p.z() + q.z()), (p.z() - q.z()) * (p.x() + q.x()),
                       (p.x() - q.x()) * (p.y() + q.y()));
    }
    if (!(normal.norm() > 0)) return fan();
    normal.normalize();
    std::vector<std::size_t> ring(n);
    std::iota(ring.begin(), ring.end(), 0);
    auto is_ear = [&](std::size_t i) {
        const std::size_t m = ring.size();
        const Vec3 a = point(soup, corner[ring[(i + m - 1) % m]]), b = point(soup, corner[ring[i]]),
                   c = point(soup, corner[ring[(i + 1) % m]]);
        if ((b - a).cross(c - b).dot(normal) <= 0) return false;  // reflex or flat corner
        for (std::size_t j = 0; j < m; ++j) {
            if (j == i || j == (i + 1) % m || j == (i + m - 1) % m) continue;
            const Vec3 p = point(soup, corner[ring[j]]);
            if ((b - a).cross(p - a).dot(normal) >= 0 && (c - b).cross(p - b).dot(normal) >= 0 &&
                (a - c).cross(p - c).dot(normal) >= 0)
                return false;
        }
        return true;
    };
    // The search for the next ear starts next to the last one clipped, where new ears appear.
    // A full turn without an ear means the polygon is not simple (self-intersecting, or doubled
    // back over coincident corners): fan the rest. Clipping such a polygon one corner at a time
    // cost a failed O(n^2) search per corner, O(n^3) in all: seconds per kilobyte of file.
    std::size_t start = 0;
    while (ring.size() > 3) {
        const std::size_t m = ring.size();
        std::size_t tried = 0, ear = start % m;
        while (tried < m && !is_ear(ear)) ++tried, ear = (ear + 1) % m;
        if (tried == m) break;
        out.push_back({corner[ring[(ear + m - 1) % m]], corner[ring[ear]], corner[ring[(ear + 1) % m]]});
        ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(ear));
        start = (ear + m - 2) % (m - 1);  // the clipped corner's predecessor
    }
    for (std::size_t i = 1; i + 1 < ring.size(); ++i)
        out.push_back({corner[ring[0]], corner[ring[i]], corner[ring[i + 1]]});
}

// For every halfedge, the other halfedge on the same vertex pair (or -1 on the boundary).
// Zero-area triangles (and flat caps) removed by local edits that keep the surface's topology, in rounds (an
// edit's neighbours wait for the next round, whose adjacency is fresh):
// - two corners at one place (the shortest edge under 1e-9 of the longest): that edge collapses
//   into its smaller vertex, where the two ends share no neighbour but the triangles' third
//   corners and do not join two boundary points across the inside;
// - a corner m inside the opposite edge x y: that edge flips, its other triangle x y d becoming
//   x m d and m y d, where m and d are not joined yet.
// Triangles whose edits are not allowed stay (and are refused after).
constexpr double kCoincidentRelative = 1e-9;
constexpr int kZeroAreaRounds = 16;
// A cap's two short edges exceed its long one by little: under kFlatCapSlack of it the repair
// flips it like a zero-area triangle where it can; under kLostCapSlack its area is lost to the
// rounding of its edge lengths (Heron's formula, as intrinsic Delaunay computes it, gives 0 or
// less), and what is left of those is refused like a zero-area triangle.
constexpr double kFlatCapSlack = 1e-12;
constexpr double kLostCapSlack = 64 * std::numeric_limits<double>::epsilon();

// The two short edges' excess over the long one, relative to it.
double cap_slack(const Vec3& a, const Vec3& b, const Vec3& c) {
    std::array<double, 3> l{(b - a).norm(), (c - b).norm(), (a - c).norm()};
    std::sort(l.begin(), l.end());
    return l[2] > 0 ? (l[0] + l[1] - l[2]) / l[2] : 0;
}

void repair_zero_area(const PolygonSoup& soup, std::vector<std::array<std::int64_t, 3>>& triangles, LoadReport& report) {
    const auto n_v = static_cast<std::int64_t>(soup.n_vertices());
    for (int round = 0; round < kZeroAreaRounds; ++round) {
        std::vector<std::size_t> flat;
        for (std::size_t t = 0; t < triangles.size(); ++t) {
            const Vec3 a = point(soup, triangles[t][0]), b = point(soup, triangles[t][1]), c = point(soup, triangles[t][2]);
            if (zero_area(a, b, c) || cap_slack(a, b, c) <= kFlatCapSlack) flat.push_back(t);
        }
        if (flat.empty()) return;
        // Triangles around each vertex.
        std::vector<std::size_t> start(static_cast<std::size_t>(n_v) + 1, 0), around(3 * triangles.size());
        for (const auto& tri : triangles)
            for (std::int64_t v : tri) ++start[static_cast<std::size_t>(v) + 1];
        std::partial_sum(start.begin(), start.end(), start.begin());
        std::vector<std::size_t> fill(start.begin(), start.end() - 1);
        for (std::size_t t = 0; t < triangles.size(); ++t)
            for (std::int64_t v : triangles[t]) around[fill[static_cast<std::size_t>(v)]++] = t;
        const auto star = [&](std::int64_t v) {
            return std::span(around).subspan(start[v], start[v + 1] - start[v]);
        };
        const auto contains = [&](std::size_t t, std::int64_t v) {
            return std::find(triangles[t].begin(), triangles[t].end(), v) != triangles[t].end();
        };
        const auto neighbours = [&](std::int64_t v) {  // with the number of triangles on each edge
            std::vector<std::pair<std::int64_t, int>> out;
            for (std::size_t t : star(v))
                for (std::int64_t w : triangles[t])
                    if (w != v) out.emplace_back(w, 1);
            std::sort(out.begin(), out.end());
            std::vector<std::pair<std::int64_t, int>> merged;
            for (const auto& [w, c] : out)
                if (!merged.empty() && merged.back().first == w) ++merged.back().second;
                else merged.emplace_back(w, c);
            return merged;
        };
        const auto on_boundary = [&](const std::vector<std::pair<std::int64_t, int>>& ring) {
            return std::any_of(ring.begin(), ring.end(), [](const auto& n) { return n.second == 1; });
        };
        std::vector<char> touched(static_cast<std::size_t>(n_v), 0), dead(triangles.size(), 0);
        bool changed = false;
        for (std::size_t t : flat) {
            const std::array<std::int64_t, 3> tri = triangles[t];
            if (dead[t] || touched[tri[0]] || touched[tri[1]] || touched[tri[2]]) continue;
            // Corner k faces edge k+1 -> k+2.
            std::array<double, 3> length{};
            for (int k = 0; k < 3; ++k)
                length[k] = (point(soup, tri[(k + 1) % 3]) - point(soup, tri[(k + 2) % 3])).norm();
            const int longest = static_cast<int>(std::max_element(length.begin(), length.end()) - length.begin());
            const int shortest = static_cast<int>(std::min_element(length.begin(), length.end()) - length.begin());
            if (length[shortest] <= kCoincidentRelative * length[longest]) {
                std::int64_t p = tri[(shortest + 1) % 3], q = tri[(shortest + 2) % 3];
                if (q < p) std::swap(p, q);
                const auto ring_p = neighbours(p), ring_q = neighbours(q);
                std::vector<std::int64_t> common, opposite;
                for (const auto& n : ring_p)
                    if (std::any_of(ring_q.begin(), ring_q.end(), [&](const auto& o) { return o.first == n.first; }))
                        common.push_back(n.first);
                for (std::size_t u : star(p))
                    if (contains(u, q))
                        for (std::int64_t w : triangles[u])
                            if (w != p && w != q) opposite.push_back(w);
                std::sort(opposite.begin(), opposite.end());
                const bool inner_edge = opposite.size() == 2;
                if (common != opposite || (inner_edge && on_boundary(ring_p) && on_boundary(ring_q))) continue;
                for (std::size_t u : star(q)) {
                    if (contains(u, p)) dead[u] = 1, ++report.collapsed_faces;
                    else std::replace(triangles[u].begin(), triangles[u].end(), q, p);
                }
                for (const auto& ring : {ring_p, ring_q})
                    for (const auto& [w, c] : ring) touched[w] = 1;
                touched[p] = touched[q] = 1;
                ++report.collapsed_edges;
                changed = true;
            } else {
                const std::int64_t m = tri[longest], x = tri[(longest + 1) % 3], y = tri[(longest + 2) % 3];
                std::vector<std::size_t> across;
                for (std::size_t u : star(x))
                    if (u != t && contains(u, y)) across.push_back(u);
                if (across.size() != 1 || dead[across[0]]) continue;
                const std::size_t u = across[0];
                std::int64_t d = -1;
                for (std::int64_t w : triangles[u])
                    if (w != x && w != y) d = w;
                if (d == m || touched[d]) continue;
                const auto ring_m = neighbours(m);
                if (std::any_of(ring_m.begin(), ring_m.end(), [&](const auto& n) { return n.first == d; })) continue;
                // Keep the winding of x y d.
                const auto at = std::find(triangles[u].begin(), triangles[u].end(), x) - triangles[u].begin();
                const bool x_to_y = triangles[u][(at + 1) % 3] == y;
                const std::int64_t a = x_to_y ? x : y, b = x_to_y ? y : x;
                triangles[t] = {a, m, d};
                triangles[u] = {m, b, d};
                touched[x] = touched[y] = touched[m] = touched[d] = 1;
                ++report.flipped_edges;
                changed = true;
            }
        }
        std::size_t kept = 0;
        for (std::size_t t = 0; t < triangles.size(); ++t)
            if (!dead[t]) triangles[kept++] = triangles[t];
        triangles.resize(kept);
        if (!changed) return;
    }
}

// Boundary edges that lie exactly on another boundary edge: a seam the file left open (a soup of
// separate triangles, vertices duplicated along texture seams or between CAD patches). Where
// exactly two boundary edges join the same two positions, running opposite ways (or either way,
// with `turned`: a soup whose faces are not all wound alike, which the orientation repair then
// turns), their ends are merged (into the smaller vertex number), which closes the seam. Zips
// whose merged vertices would put a third face on an edge or two corners of a triangle
// together are left open, as are seams where more than two sheets meet. Returns the vertices
// merged away; counts the edges zipped.
std::size_t zip_seams(const PolygonSoup& soup, std::vector<std::array<std::int64_t, 3>>& triangles, bool turned,
                      std::size_t& zipped_edges) {
    const auto n_v = static_cast<Index>(soup.n_vertices());
    // Vertices by position; `place[v]`: the smallest vertex at v's position.
    std::vector<Index> by_position(n_v), place(n_v);
    std::iota(by_position.begin(), by_position.end(), 0);
    const auto position = [&](Index v) {
        return std::array<double, 3>{soup.positions[3 * v], soup.positions[3 * v + 1], soup.positions[3 * v + 2]};
    };
    std::stable_sort(by_position.begin(), by_position.end(),
                     [&](Index a, Index b) { return position(a) < position(b); });
    bool shared = false;
    for (std::size_t i = 0; i < by_position.size(); ++i) {
        const bool same = i > 0 && position(by_position[i]) == position(by_position[i - 1]);
        place[by_position[i]] = same ? place[by_position[i - 1]] : by_position[i];
        shared = shared || same;
    }
    if (!shared) return 0;

    // Undirected edges with their faces' directed halfedges; boundary edges have one.
    struct Edge {
        Index a, b;  // a < b
        Index halfedge;
        bool operator<(const Edge& o) const { return std::tie(a, b, halfedge) < std::tie(o.a, o.b, o.halfedge); }
    };
    const auto edges_of = [&](const std::vector<Index>& merged) {
        std::vector<Edge> edges;
        edges.reserve(3 * triangles.size());
        for (std::size_t t = 0; t < triangles.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const Index u = merged[triangles[t][k]], w = merged[triangles[t][(k + 1) % 3]];
                edges.push_back({std::min(u, w), std::max(u, w), static_cast<Index>(3 * t + k)});
            }
        std::sort(edges.begin(), edges.end());
        return edges;
    };
    std::vector<Index> identity(n_v);
    std::iota(identity.begin(), identity.end(), 0);
    const std::vector<Edge> edges = edges_of(identity);
    std::vector<char> was_boundary(3 * triangles.size(), 0);
    struct Seam {
        Index tail_a, head_a, tail_b, head_b;  // two boundary halfedges' ends, b's as if it ran opposite to a
    };
    std::vector<std::pair<std::array<Index, 2>, Seam>> candidates;  // keyed by the two positions
    {
        std::vector<std::pair<std::array<Index, 2>, Index>> boundary;  // (positions, halfedge)
        for (std::size_t i = 0; i < edges.size(); ++i) {
            const bool alone = (i == 0 || edges[i - 1].a != edges[i].a || edges[i - 1].b != edges[i].b) &&
                               (i + 1 == edges.size() || edges[i + 1].a != edges[i].a || edges[i + 1].b != edges[i].b);
            if (!alone) continue;
            was_boundary[edges[i].halfedge] = 1;
            const Index pa = place[edges[i].a], pb = place[edges[i].b];
            if (pa != pb) boundary.push_back({{std::min(pa, pb), std::max(pa, pb)}, edges[i].halfedge});
        }
        std::sort(boundary.begin(), boundary.end());
        const auto tail = [&](Index h) { return static_cast<Index>(triangles[h / 3][h % 3]); };
        const auto head = [&](Index h) { return static_cast<Index>(triangles[h / 3][(h % 3 + 1) % 3]); };
        for (std::size_t i = 0; i < boundary.size();) {
            std::size_t j = i;
            while (j < boundary.size() && boundary[j].first == boundary[i].first) ++j;
            if (j - i == 2) {
                const Index h = boundary[i].second, k = boundary[i + 1].second;
                if (place[tail(h)] == place[head(k)])  // opposite ways: one surface, one orientation
                    candidates.push_back({boundary[i].first, {tail(h), head(h), tail(k), head(k)}});
                else if (turned)
                    candidates.push_back({boundary[i].first, {tail(h), head(h), head(k), tail(k)}});
            }
            i = j;
        }
    }
    if (candidates.empty()) return 0;

    // Zip all, then leave out the seams at positions where the result is not a manifold
    // triangle set, until none is left.
    std::vector<char> excluded(n_v, 0);  // by position
    for (int round = 0; round < 8; ++round) {
        kernels::UnionFind merge(n_v);
        std::size_t count = 0;
        for (const auto& [key, seam] : candidates) {
            if (excluded[key[0]] || excluded[key[1]]) continue;
            merge.unite(seam.tail_a, seam.head_b);
            merge.unite(seam.head_a, seam.tail_b);
            ++count;
        }
        if (count == 0) return 0;
        std::vector<Index> root(n_v);
        for (Index v = 0; v < n_v; ++v) root[v] = merge.find(v);
        bool bad = false;
        for (const auto& t : triangles) {
            const Index a = root[t[0]], b = root[t[1]], c = root[t[2]];
            if (a == b || b == c || a == c)
                for (const std::int64_t v : t) excluded[place[v]] = 1, bad = true;
        }
        // A third face on an edge, or (unless `turned`) two boundary edges brought together
        // running the same way: the orientation would have to turn a sheet over.
        const std::vector<Edge> merged = edges_of(root);
        const auto tail = [&](Index h) { return root[triangles[h / 3][h % 3]]; };
        const auto exclude_faces = [&](std::initializer_list<Index> halfedges) {
            for (const Index h : halfedges)
                for (int k = 0; k < 3; ++k) excluded[place[triangles[h / 3][k]]] = 1;
            bad = true;
        };
        for (std::size_t i = 0; i + 1 < merged.size(); ++i) {
            const Edge &e = merged[i], &f = merged[i + 1];
            if (e.a != f.a || e.b != f.b) continue;
            if (i + 2 < merged.size() && merged[i + 2].a == e.a && merged[i + 2].b == e.b)
                exclude_faces({e.halfedge, f.halfedge, merged[i + 2].halfedge});
            else if (!turned && (was_boundary[e.halfedge] || was_boundary[f.halfedge]) &&
                     tail(e.halfedge) == tail(f.halfedge))
                exclude_faces({e.halfedge, f.halfedge});
        }
        if (bad) continue;
        for (auto& t : triangles)
            for (std::int64_t& v : t) v = root[v];
        zipped_edges = count;
        std::size_t gone = 0;
        for (Index v = 0; v < n_v; ++v) gone += root[v] != v;
        return gone;
    }
    return 0;
}

// For every halfedge, the other halfedge on the same vertex pair (or -1 on the boundary). Where
// more than two faces share an edge, they are paired two by two in halfedge order, each with the
// first later one running the other way (else the next one), an odd one left on the boundary;
// split_pinched_vertices then gives each pair's fans their own copies of the edge's ends.
std::vector<Index> pair_edges(const TriangleMatrix& F, Index n_vertices, NonManifoldEdgePolicy policy,
                              std::size_t& split_edges) {
    const HalfedgeGroups groups = group_halfedges_by_vertex_pair(F, n_vertices);
    const auto tail = [&](Index h) { return F(h / 3, h % 3); };
    std::vector<Index> mate(3 * static_cast<std::size_t>(F.rows()), -1);
    std::deque<Index> runs[2];  // unpaired halfedges of a group, by direction, in index order
    for (Index g = 0; g < groups.n_groups(); ++g) {
        const Index begin = groups.group_start[g], size = groups.group_start[g + 1] - begin;
        if (size < 2) continue;
        if (size > 2) {
            const Index h = groups.halfedges[begin];
            const Index a = F(h / 3, h % 3), b = F(h / 3, (h % 3 + 1) % 3);
            if (policy == NonManifoldEdgePolicy::Refuse)
                fail(MeshErrorKind::NonManifoldEdge,
                     "edge (" + std::to_string(std::min(a, b)) + ", " + std::to_string(std::max(a, b)) +
                         ") has " + std::to_string(size) +
                         " faces (vertex numbers after dropping unreferenced vertices)");
            ++split_edges;
        }
        const Index first_tail = tail(groups.halfedges[begin]);
        for (Index i = begin; i < begin + size; ++i)
            runs[tail(groups.halfedges[i]) != first_tail].push_back(groups.halfedges[i]);
        while (runs[0].size() + runs[1].size() >= 2) {
            // The first unpaired halfedge, and the first later one running the other way, else the next.
            const int d = runs[1].empty() || (!runs[0].empty() && runs[0].front() < runs[1].front()) ? 0 : 1;
            const Index h = runs[d].front();
            runs[d].pop_front();
            std::deque<Index>& other = runs[1 - d].empty() ? runs[d] : runs[1 - d];
            const Index k = other.front();
            other.pop_front();
            mate[h] = k;
            mate[k] = h;
        }
        runs[0].clear();
        runs[1].clear();
    }
    return mate;
}

struct Orientation {
    std::vector<Index> component;  // #F
    std::vector<char> flip;        // #F
    Index n_components = 0;
    std::size_t flipped = 0;
};

// Flood fill across manifold edges: neighbours traversing the shared edge in the same direction
// need opposite flips. Per component keep the majority winding (fewest faces flipped).
Orientation orient(const TriangleMatrix& F, const std::vector<Index>& mate) {
    const Index n_f = static_cast<Index>(F.rows());
    Orientation o;
    o.component.assign(n_f, -1);
    o.flip.assign(n_f, 0);
    std::vector<Index> queue;
    queue.reserve(n_f);
    for (Index seed = 0; seed < n_f; ++seed) {
        if (o.component[seed] != -1) continue;
        const Index c = o.n_components++;
        const std::size_t first = queue.size();
        o.component[seed] = c;
        queue.push_back(seed);
        for (std::size_t q = first; q < queue.size(); ++q) {
            const Index f = queue[q];
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k, m = mate[h];
                if (m < 0) continue;
                const Index g = m / 3;
                const bool same_direction = F(f, k) == F(g, m % 3);
                const char want = static_cast<char>(o.flip[f] ^ (same_direction ? 1 : 0));
                if (o.component[g] == -1) {
                    o.component[g] = c;
                    o.flip[g] = want;
                    queue.push_back(g);
                } else if (o.flip[g] != want) {
                    fail(MeshErrorKind::NonOrientable,
                         "faces " + std::to_string(f) + " and " + std::to_string(g) +
                             " cannot be oriented consistently: the surface is one-sided "
                             "(Moebius band)");
                }
            }
        }
        const std::size_t size = queue.size() - first;
        std::size_t flipped = 0;
        for (std::size_t q = first; q < queue.size(); ++q) flipped += o.flip[queue[q]];
        if (2 * flipped > size) {
            for (std::size_t q = first; q < queue.size(); ++q) o.flip[queue[q]] ^= 1;
            flipped = size - flipped;
        }
        o.flipped += flipped;
    }
    return o;
}

// Keeps the vertices that faces use, renumbered in their original order, with their file ids
// (`file_vertex`, per vertex); returns the count dropped.
std::size_t compact_vertices(PointMatrix& V, TriangleMatrix& F, std::vector<Index>& file_vertex) {
    std::vector<Index> new_index(static_cast<std::size_t>(V.rows()), -1);
    for (Index i = 0; i < F.size(); ++i) new_index[F.data()[i]] = 0;
    Index next = 0;
    for (auto& n : new_index)
        if (n == 0) n = next++;
    const std::size_t dropped = static_cast<std::size_t>(V.rows()) - static_cast<std::size_t>(next);
    if (dropped == 0) return 0;
    PointMatrix kept(next, 3);
    for (Index v = 0; v < V.rows(); ++v)
        if (new_index[v] >= 0) kept.row(new_index[v]) = V.row(v), file_vertex[new_index[v]] = file_vertex[v];
    file_vertex.resize(static_cast<std::size_t>(next));
    for (Index i = 0; i < F.size(); ++i) F.data()[i] = new_index[F.data()[i]];
    V = std::move(kept);
    return dropped;
}

// Gives every fan of faces around a vertex but the first (by smallest corner) a vertex of its
// own at the same position; returns how many were added. Corners of one vertex are in one fan
// when consecutive across a twin: the corner after twin(h) in its face is h's tail again.
std::size_t split_pinched_vertices(PointMatrix& V, TriangleMatrix& F, const std::vector<Index>& twin,
                                   std::vector<Index>& file_vertex) {
    const Index n_corners = 3 * static_cast<Index>(F.rows());
    kernels::UnionFind fans(n_corners);
    for (Index h = 0; h < n_corners; ++h)
        if (twin[h] != kNoHalfedge) fans.unite(h, MeshView::next(twin[h]));
    std::vector<Index> fan_vertex(n_corners, -1);  // per fan root
    std::vector<char> taken(static_cast<std::size_t>(V.rows()), 0);
    std::vector<Index> copied_from;
    for (Index h = 0; h < n_corners; ++h) {
        const Index root = fans.find(h);
        if (fan_vertex[root] < 0) {
            const Index v = F(h / 3, h % 3);
            if (!taken[v]) {
                taken[v] = 1;
                fan_vertex[root] = v;
            } else {
                fan_vertex[root] = static_cast<Index>(V.rows() + copied_from.size());
                copied_from.push_back(v);
            }
        }
        F(h / 3, h % 3) = fan_vertex[root];
    }
    if (copied_from.empty()) return 0;
    const Index old_rows = static_cast<Index>(V.rows());
    V.conservativeResize(old_rows + static_cast<Index>(copied_from.size()), 3);
    for (std::size_t i = 0; i < copied_from.size(); ++i) {
        V.row(old_rows + static_cast<Index>(i)) = V.row(copied_from[i]);
        file_vertex.push_back(file_vertex[copied_from[i]]);
    }
    return copied_from.size();
}

LoadedMesh load_soup(const PolygonSoup& soup, const LoadOptions& options, bool turn_seams) {
    LoadReport report;
    report.file_vertices = soup.n_vertices();
    report.file_polygons = soup.n_polygons();
    report.welded_vertices = soup.welded_vertices;
    report.ignored_lines = soup.ignored_lines;
    if (soup.n_polygons() == 0) fail(MeshErrorKind::EmptyFile, "the file has no faces");
    if (soup.n_vertices() >= static_cast<std::size_t>(std::numeric_limits<Index>::max()))
        fail(MeshErrorKind::TooLarge, std::to_string(soup.n_vertices()) + " vertices");

    for (std::size_t i = 0; i < soup.positions.size(); ++i)
        if (!std::isfinite(soup.positions[i]))
            fail(MeshErrorKind::NonFiniteCoordinate,
                 "vertex " + std::to_string(i / 3) + " has coordinate " + "xyz"[i % 3] + " = " +
                     std::to_string(soup.positions[i]));

    {   // Areas and cotangents multiply up to four lengths: keep those within double range.
        double extent = 0;
        for (int axis = 0; axis < 3; ++axis) {
            double lo = std::numeric_limits<double>::infinity(), hi = -lo;
            for (std::size_t i = axis; i < soup.positions.size(); i += 3)
                lo = std::min(lo, soup.positions[i]), hi = std::max(hi, soup.positions[i]);
            if (hi >= lo) extent = std::max(extent, hi - lo);
        }
        if (extent > kMaxExtent || (extent > 0 && extent < kMinExtent)) {
            std::ostringstream detail;
            detail << "the model is " << extent << " across; supported are " << kMinExtent << " to " << kMaxExtent
                   << " (areas would overflow or underflow): rescale it";
            fail(MeshErrorKind::CoordinateRange, detail.str());
        }
    }

    const auto n_v = static_cast<std::int64_t>(soup.n_vertices());
    const bool repair = options.zero_area_faces == ZeroAreaPolicy::Repair;
    std::vector<std::array<std::int64_t, 3>> triangles;
    triangles.reserve(soup.indices.size() / 3 + 1);
    std::vector<std::int64_t> sorted, distinct;
    std::string first_collapsed;  // what a file of collapsed faces only is refused for
    for (std::size_t p = 0; p < soup.n_polygons(); ++p) {
        const std::int64_t* corner = soup.indices.data() + soup.offsets[p];
        std::size_t n = soup.offsets[p + 1] - soup.offsets[p];
        if (n < 3)
            fail(MeshErrorKind::DegenerateFace,
                 face_label(p) + " has " + std::to_string(n) + " vertices (at least 3 needed)");
        for (std::size_t i = 0; i < n; ++i)
            if (corner[i] < 0 || corner[i] >= n_v)
                fail(MeshErrorKind::IndexOutOfRange,
                     face_label(p) + " refers to vertex " + std::to_string(corner[i]) +
                         " but the file has " + std::to_string(n_v) + " vertices");
        sorted.assign(corner, corner + n);
        std::sort(sorted.begin(), sorted.end());
        if (auto it = std::adjacent_find(sorted.begin(), sorted.end()); it != sorted.end()) {
            const std::string repeated = face_label(p) + " uses vertex " + std::to_string(*it) + " twice";
            if (!repair) fail(MeshErrorKind::RepeatedVertex, repeated);
            // A corner repeated in a row is an edge collapsed already (an STL facet with two
            // equal corners, once welded): the repair drops that corner, and the face where
            // fewer than three are left, as a collapse would.
            distinct.clear();
            for (std::size_t i = 0; i < n; ++i)
                if (distinct.empty() || distinct.back() != corner[i]) distinct.push_back(corner[i]);
            while (distinct.size() > 1 && distinct.back() == distinct.front()) distinct.pop_back();
            sorted = distinct;
            std::sort(sorted.begin(), sorted.end());
            if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
                fail(MeshErrorKind::RepeatedVertex, repeated + ", not in a row (the polygon touches itself)");
            if (distinct.size() < 3) {
                ++report.collapsed_faces;
                if (first_collapsed.empty()) first_collapsed = repeated;
                continue;
            }
            corner = distinct.data();
            n = distinct.size();
        }
        if (n > 3) {
            ++report.triangulated_polygons;
            const std::size_t before = triangles.size();
            triangulate(soup, corner, n, triangles);
            report.triangles_from_polygons += triangles.size() - before;
        } else {
            triangles.push_back({corner[0], corner[1], corner[2]});
        }
        if (triangles.size() > kMaxFaces || (options.max_faces && triangles.size() > options.max_faces))
            fail(MeshErrorKind::TooLarge,
                 "more than " + std::to_string(options.max_faces ? options.max_faces : kMaxFaces) +
                     " triangles");
    }

    if (triangles.empty()) fail(MeshErrorKind::RepeatedVertex, first_collapsed + ", as does every face");
    if (options.seams == SeamPolicy::Zip)
        report.zipped_vertices = zip_seams(soup, triangles, turn_seams, report.zipped_edges);

    {   // duplicated faces: same vertex set, in any order or winding; the first one stays
        std::vector<std::pair<std::array<std::int64_t, 3>, std::size_t>> keys(triangles.size());
        for (std::size_t t = 0; t < triangles.size(); ++t) {
            keys[t] = {triangles[t], t};
            std::sort(keys[t].first.begin(), keys[t].first.end());
        }
        std::sort(keys.begin(), keys.end());
        std::vector<char> duplicate(triangles.size(), 0);
        for (std::size_t i = 1; i < keys.size(); ++i) {
            if (keys[i].first != keys[i - 1].first) continue;
            if (options.duplicate_faces == DuplicateFacePolicy::Refuse)
                fail(MeshErrorKind::DuplicateFace,
                     "triangles " + std::to_string(keys[i - 1].second) + " and " +
                         std::to_string(keys[i].second) + " use the same vertices (" +
                         std::to_string(keys[i].first[0]) + ", " + std::to_string(keys[i].first[1]) +
                         ", " + std::to_string(keys[i].first[2]) + ")");
            duplicate[keys[i].second] = 1;  // equal keys sort by index: the first one stays
        }
        report.duplicate_faces = static_cast<std::size_t>(std::count(duplicate.begin(), duplicate.end(), 1));
        if (report.duplicate_faces > 0) {
            std::size_t kept = 0;
            for (std::size_t t = 0; t < triangles.size(); ++t)
                if (!duplicate[t]) triangles[kept++] = triangles[t];
            triangles.resize(kept);
        }
    }

    if (repair) {
        repair_zero_area(soup, triangles, report);
        if (triangles.empty()) fail(MeshErrorKind::ZeroAreaFace, "every triangle has zero area");
    }
    for (std::size_t t = 0; t < triangles.size(); ++t) {
        const Vec3 a = point(soup, triangles[t][0]), b = point(soup, triangles[t][1]),
                   c = point(soup, triangles[t][2]);
        const bool zero = zero_area(a, b, c);
        if (zero || cap_slack(a, b, c) <= kLostCapSlack)
            fail(MeshErrorKind::ZeroAreaFace,
                 "triangle " + std::to_string(t) + " (vertices " + std::to_string(triangles[t][0]) +
                     ", " + std::to_string(triangles[t][1]) + ", " + std::to_string(triangles[t][2]) +
                     (zero ? ") has zero area" : ") is so flat that its edge lengths lose its area to rounding") +
                     (repair ? " (no edge collapse or flip removes it without changing the topology)" : ""));
    }

    PointMatrix V = Eigen::Map<const PointMatrix>(soup.positions.data(), n_v, 3);
    TriangleMatrix F(static_cast<Eigen::Index>(triangles.size()), 3);
    for (std::size_t t = 0; t < triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) F(static_cast<Eigen::Index>(t), k) = static_cast<Index>(triangles[t][k]);
    triangles = {};
    // Collapses and zips free one vertex each.
    std::vector<Index> file_vertex(static_cast<std::size_t>(n_v));
    std::iota(file_vertex.begin(), file_vertex.end(), Index{0});
    report.unreferenced_vertices = compact_vertices(V, F, file_vertex) - report.collapsed_edges - report.zipped_vertices;

    const std::vector<Index> mate = pair_edges(F, static_cast<Index>(V.rows()), options.non_manifold_edges, report.split_edges);
    const Orientation o = orient(F, mate);
    report.reoriented_faces = o.flipped;
    report.components = static_cast<std::size_t>(o.n_components);

    // Faces kept (all, or the largest component) and their new numbers.
    Index keep_component = -1;
    if (options.components == ComponentPolicy::Largest && o.n_components > 1) {
        std::vector<std::size_t> size(o.n_components, 0);
        for (Index c : o.component) ++size[c];
        keep_component = static_cast<Index>(std::max_element(size.begin(), size.end()) - size.begin());
        report.dropped_components = static_cast<std::size_t>(o.n_components) - 1;
        report.dropped_faces = static_cast<std::size_t>(F.rows()) - size[keep_component];
    }
    std::vector<Index> new_face(F.rows(), -1);
    Index n_kept = 0;
    for (Index f = 0; f < F.rows(); ++f)
        if (keep_component < 0 || o.component[f] == keep_component) new_face[f] = n_kept++;

    // The pairing found above becomes the MeshView's twins directly (no second grouping):
    // flipping a face swaps its corners 1 and 2, which maps its halfedge k to 2 - k.
    TriangleMatrix oriented(n_kept, 3);
    for (Index f = 0; f < F.rows(); ++f) {
        if (new_face[f] < 0) continue;
        oriented.row(new_face[f]) = F.row(f);
        if (o.flip[f]) std::swap(oriented(new_face[f], 1), oriented(new_face[f], 2));
    }
    const auto renumber = [&](Index h) {
        const Index f = h / 3, k = h % 3;
        return 3 * new_face[f] + (o.flip[f] ? 2 - k : k);
    };
    std::vector<Index> twin(3 * static_cast<std::size_t>(n_kept), kNoHalfedge);
    for (Index h = 0; h < 3 * static_cast<Index>(F.rows()); ++h)
        if (new_face[h / 3] >= 0 && mate[h] >= 0) twin[renumber(h)] = renumber(mate[h]);
    F = std::move(oriented);
    if (keep_component >= 0) compact_vertices(V, F, file_vertex);
    if (options.pinched_vertices == PinchedVertexPolicy::Split)
        report.split_vertices = split_pinched_vertices(V, F, twin, file_vertex);

    try {
        return {std::make_shared<const MeshView>(make_mesh_view(std::move(V), std::move(F), std::move(twin))), report,
                std::move(file_vertex)};
    } catch (const ConnectivityError& e) {
        // Edges and winding were checked above; only vertex fans remain to go wrong here.
        const MeshErrorKind kind = e.kind == ConnectivityError::Kind::NonManifoldVertex
                                       ? MeshErrorKind::NonManifoldVertex
                                       : MeshErrorKind::NonManifoldEdge;
        fail(kind, e.what());
    }
}

}  // namespace

// Seams are first zipped whichever way their faces run; where that makes the surface
// non-orientable (a Moebius band written as a soup), only those running opposite ways are.
LoadedMesh mesh_from_soup(const PolygonSoup& soup, const LoadOptions& options) {
    try {
        return load_soup(soup, options, true);
    } catch (const MeshError& e) {
        if (e.kind != MeshErrorKind::NonOrientable || options.seams != SeamPolicy::Zip) throw;
    }
    return load_soup(soup, options, false);
}

std::vector<Index> tip_vertices(const LoadedMesh& loaded, const std::vector<Index>& file_ids) {
    if (file_ids.empty()) return {};
    const auto file_vertices = static_cast<Index>(loaded.report.file_vertices);
    std::vector<Index> of_file(static_cast<std::size_t>(file_vertices), -1);
    for (auto v = static_cast<Index>(loaded.file_vertex.size()) - 1; v >= 0; --v) of_file[loaded.file_vertex[v]] = v;
    std::vector<Index> out;
    for (Index id : file_ids) {
        if (id < 0 || id >= file_vertices)
            throw InvalidInput("tip " + std::to_string(id) + " is not a vertex of the mesh (the file has " +
                               std::to_string(file_vertices) + " vertices)");
        if (of_file[id] < 0)
            throw InvalidInput("tip " + std::to_string(id) +
                               " is a vertex the loader dropped (no face uses it) or merged into another");
        out.push_back(of_file[id]);
    }
    return out;
}

LoadedMesh load_mesh(const std::string& path, const LoadOptions& options) {
    return mesh_from_soup(read_polygon_soup(path, options.max_file_bytes), options);
}

}  // namespace holoflow::engine
