#include "holoflow/kernels/flow_cut.h"

#include <algorithm>
#include <complex>
#include <cstdint>
#include <map>
#include <optional>
#include <span>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr Index kParallelFaces = 2000;
// The assembly's loops do a few stores per face, halfedge or edge: blocks of this many (fewer
// run on one thread, which is faster then).
constexpr std::size_t kAssemblyGrain = 8192;

// A segment of a trajectory inside one face, by point ids.
struct FaceSegment {
    Index trajectory, from, to;
    bool collision_tail;
    double stop_length;
    std::vector<Index> inner;  // collision points of other curves on it, from `from` to `to`
};

// Where a cut edge lies: on a piece of an input edge (between consecutive points on it), as
// 2 (first piece of the edge + q) + side, side 0 along the edge's orientation; or inside a face.
constexpr Index kInner = -1;

struct Polygon {
    std::vector<Index> points;  // counter-clockwise
    std::vector<Index> edge;    // edge k (points[k] -> points[k+1]): its border label
    std::vector<Index> piece;   // edge k: its input-edge piece, or kInner

    void clear() { points.clear(), edge.clear(), piece.clear(); }
    void push(Index point, Index label, Index on_piece) {
        points.push_back(point), edge.push_back(label), piece.push_back(on_piece);
    }
    void erase(std::size_t i) {
        const auto at = static_cast<std::ptrdiff_t>(i);
        points.erase(points.begin() + at), edge.erase(edge.begin() + at), piece.erase(piece.begin() + at);
    }
};

struct Triangle {
    std::array<Index, 3> v;
    std::array<Index, 3> cut;    // border label of edge k (v[k] -> v[k+1])
    std::array<Index, 3> piece;  // edge k's input-edge piece, or kInner
    std::array<Index, 3> partner{};  // inner edge k: its twin, 3 (triangle of the face) + corner
    std::array<Complex, 3> image{};  // chart positions of v (set once v are point ids)
};

// The face's pieces: polys[0, n) of a pool whose vectors keep their capacity from face to face
// (crossed faces are many small allocations otherwise), with two spare polygons for a split.
struct PolygonPool {
    std::vector<Polygon> polys;
    std::size_t n = 0;
    Polygon a, b;
};

// std::stable_sort, without its buffer allocation for the few segments a face holds.
template <class Less>
void stable_sort_few(std::vector<FaceSegment>& v, Less less) {
    constexpr std::size_t kFew = 32;
    if (v.size() > kFew) return std::stable_sort(v.begin(), v.end(), less);
    for (std::size_t i = 1; i < v.size(); ++i)
        for (std::size_t j = i; j > 0 && less(v[j], v[j - 1]); --j) std::swap(v[j], v[j - 1]);
}

// Splits a piece by a chord between two of its points; false if they are not both on one.
bool split(PolygonPool& pool, const FaceSegment& s) {
    for (std::size_t k = 0; k < pool.n; ++k) {
        Polygon& p = pool.polys[k];
        const auto ip = std::find(p.points.begin(), p.points.end(), s.from) - p.points.begin();
        const auto iq = std::find(p.points.begin(), p.points.end(), s.to) - p.points.begin();
        const auto m = static_cast<std::ptrdiff_t>(p.points.size());
        if (ip == m || iq == m) continue;
        if (s.inner.empty() && ((ip + 1) % m == iq || (iq + 1) % m == ip)) {
            p.edge[(ip + 1) % m == iq ? ip : iq] = s.trajectory;  // already an edge: mark it
            return true;
        }
        Polygon &a = pool.a, &b = pool.b;
        a.clear();
        b.clear();
        // a: boundary from p to q, back along the chord; b: boundary from q to p, then the chord.
        for (auto i = ip; i != iq; i = (i + 1) % m) a.push(p.points[i], p.edge[i], p.piece[i]);
        Index last = s.to;
        for (auto it = s.inner.rbegin(); it != s.inner.rend(); ++it) a.push(last, s.trajectory, kInner), last = *it;
        a.push(last, s.trajectory, kInner);
        for (auto i = iq; i != ip; i = (i + 1) % m) b.push(p.points[i], p.edge[i], p.piece[i]);
        last = s.from;
        for (Index x : s.inner) b.push(last, s.trajectory, kInner), last = x;
        b.push(last, s.trajectory, kInner);
        std::swap(p, a);
        if (pool.n == pool.polys.size()) pool.polys.emplace_back();
        std::swap(pool.polys[pool.n++], b);
        return true;
    }
    return false;
}

// The face's pieces as the faces of the plane graph its border and all its segments make (chart
// positions `local`: point id, position), for segments that wait on each other in a cycle (a
// pinwheel: each stops on the next, none has both its end points on a piece before the others
// are in). Each piece is traced with its inside on the left: at each point, on along the first
// edge clockwise from the one it came by. False, leaving `pool` as it was, where that graph is
// no plane one or its pieces no simple counter-clockwise polygons (segments crossing or ending
// on nothing, edges along one line, a face folded in its chart).
bool split_as_arrangement(const Polygon& face, std::span<const FaceSegment> segs,
                          std::span<const std::pair<Index, Complex>> local, PolygonPool& pool) {
    struct Edge {
        Index from, to, label, piece;
    };
    std::vector<Edge> edges;
    const auto m = face.points.size();
    for (std::size_t k = 0; k < m; ++k) edges.push_back({face.points[k], face.points[(k + 1) % m], face.edge[k], face.piece[k]});
    for (const FaceSegment& s : segs) {
        Index last = s.from;
        const auto add = [&](Index to) {
            edges.push_back({last, to, s.trajectory, kInner});
            edges.push_back({to, last, s.trajectory, kInner});
            last = to;
        };
        for (Index x : s.inner) add(x);
        add(s.to);
    }
    const auto position = [&](Index id) -> std::optional<Complex> {
        for (const auto& [point, z] : local)
            if (point == id) return z;
        return std::nullopt;
    };
    std::vector<Complex> from_pos(edges.size()), to_pos(edges.size()), direction(edges.size());
    double scale = 0;
    for (std::size_t i = 0; i < edges.size(); ++i) {
        const std::optional<Complex> a = position(edges[i].from), b = position(edges[i].to);
        if (!a || !b || edges[i].from == edges[i].to) return false;
        from_pos[i] = *a, to_pos[i] = *b;
        direction[i] = *b - *a;  // the way back along it is exactly the other direction, bit for bit
        scale = std::max(scale, std::abs(direction[i]));
    }
    // Out of each point, its edges in counter-clockwise order.
    std::vector<std::size_t> order(edges.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return std::pair{edges[a].from, std::arg(direction[a])} < std::pair{edges[b].from, std::arg(direction[b])};
    });
    for (std::size_t k = 0; k + 1 < order.size(); ++k) {
        const std::size_t a = order[k], b = order[k + 1];
        if (edges[a].from == edges[b].from && std::abs(cross(direction[a], direction[b])) <= 1e-12 * scale * scale &&
            (direction[a] * std::conj(direction[b])).real() > 0)
            return false;  // two edges out of one point along one line
    }
    // No two edges without a common end point may meet (segments crossing in a folded face), nor
    // an end point lie on another edge.
    const double near = 1e-12 * scale * scale;
    const auto inside = [&](std::size_t i, Complex p) {
        const Complex d = direction[i], q = p - from_pos[i];
        const double t = (q * std::conj(d)).real() / std::norm(d);
        return std::abs(cross(d, q)) <= near && t > 0 && t < 1;
    };
    for (std::size_t i = 0; i < edges.size(); ++i)
        for (std::size_t j = i + 1; j < edges.size(); ++j) {
            const Edge &a = edges[i], &b = edges[j];
            if (a.from == b.from || a.from == b.to || a.to == b.from || a.to == b.to) continue;
            const double s1 = cross(direction[i], from_pos[j] - from_pos[i]), s2 = cross(direction[i], to_pos[j] - from_pos[i]);
            const double s3 = cross(direction[j], from_pos[i] - from_pos[j]), s4 = cross(direction[j], to_pos[i] - from_pos[j]);
            if ((s1 * s2 < 0 && s3 * s4 < 0) || inside(i, from_pos[j]) || inside(i, to_pos[j]) || inside(j, from_pos[i]) ||
                inside(j, to_pos[i]))
                return false;
        }
    const auto next = [&](std::size_t e) {  // first edge out of e's head clockwise from the way back
        const double back = std::arg(from_pos[e] - to_pos[e]);
        std::size_t best = edges.size(), largest = edges.size();
        for (std::size_t k : order) {
            if (edges[k].from != edges[e].to) continue;
            largest = k;
            if (std::arg(direction[k]) < back) best = k;
        }
        return best != edges.size() ? best : largest;  // none below: around past the largest
    };
    std::vector<char> used(edges.size(), 0);
    std::vector<Polygon> pieces;
    for (std::size_t start = 0; start < edges.size(); ++start) {
        if (used[start]) continue;
        Polygon piece;
        double twice_area = 0;
        std::size_t e = start;
        do {
            if (e == edges.size() || used[e]) return false;
            if (std::find(piece.points.begin(), piece.points.end(), edges[e].from) != piece.points.end()) return false;
            used[e] = 1;
            piece.push(edges[e].from, edges[e].label, edges[e].piece);
            twice_area += cross(from_pos[e], to_pos[e]);
            e = next(e);
        } while (e != start);
        if (piece.points.size() < 3 || !(twice_area > 0)) return false;
        pieces.push_back(std::move(piece));
    }
    pool.n = 0;
    for (Polygon& piece : pieces) {
        if (pool.n == pool.polys.size()) pool.polys.emplace_back();
        pool.polys[pool.n++] = std::move(piece);
    }
    return true;
}

// Ear clipping in the chart; a fan from the first point when no proper ear is left. `work` is
// scratch.
void triangulate(const Polygon& poly, const std::vector<Complex>& pos, Polygon& work, std::vector<Triangle>& out) {
    work = poly;
    const std::vector<Index>& pts = work.points;
    std::vector<Index>& edge = work.edge;
    std::vector<Index>& piece = work.piece;
    while (pts.size() > 3) {
        const std::size_t m = pts.size();
        double scale = 0;
        for (Index q : pts) scale = std::max(scale, std::norm(pos[q] - pos[pts[0]]));
        std::size_t ear = m;
        for (std::size_t i = 0; i < m && ear == m; ++i) {
            const Complex a = pos[pts[(i + m - 1) % m]], b = pos[pts[i]], c = pos[pts[(i + 1) % m]];
            if (!(cross(b - a, c - a) > 1e-14 * scale)) continue;
            bool empty = true;
            for (std::size_t j = 0; j < m && empty; ++j) {
                if (j == i || j == (i + 1) % m || j == (i + m - 1) % m) continue;
                const Complex x = pos[pts[j]];
                empty = !(cross(b - a, x - a) >= 0 && cross(c - b, x - b) >= 0 && cross(a - c, x - c) >= 0);
            }
            if (empty) ear = i;
        }
        if (ear == m) ear = 1;  // degenerate polygon: clip anyway (zero-area triangle)
        const std::size_t i0 = (ear + m - 1) % m, i2 = (ear + 1) % m;
        out.push_back({{pts[i0], pts[ear], pts[i2]}, {edge[i0], edge[ear], kNoBorder}, {piece[i0], piece[ear], kInner}});
        edge[i0] = kNoBorder;  // the diagonal i0 -> i2 replaces edges i0 and ear
        piece[i0] = kInner;
        work.erase(ear);
    }
    if (pts.size() == 3)
        out.push_back({{pts[0], pts[1], pts[2]}, {edge[0], edge[1], edge[2]}, {piece[0], piece[1], piece[2]}});
}

// Twins the inner edges of one face's triangles (chords and diagonals: inside the face, so they
// pair among themselves); false where they do not pair up (then the caller pairs the whole cut
// mesh by vertex pairs, which names the fault).
bool pair_inner_edges(std::vector<Triangle>& tris, std::vector<std::pair<std::uint64_t, Index>>& key) {
    key.clear();
    for (std::size_t i = 0; i < tris.size(); ++i) {
        const auto& v = tris[i].v;
        if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) return false;
        for (int k = 0; k < 3; ++k) {
            if (tris[i].piece[k] != kInner) continue;
            const auto a = static_cast<std::uint32_t>(v[k]), b = static_cast<std::uint32_t>(v[(k + 1) % 3]);
            key.emplace_back(std::uint64_t{std::min(a, b)} << 32 | std::max(a, b), static_cast<Index>(3 * i) + k);
        }
    }
    if (key.size() % 2 != 0) return false;
    std::sort(key.begin(), key.end());
    for (std::size_t j = 0; j < key.size(); j += 2) {
        if (key[j].first != key[j + 1].first || (j + 2 < key.size() && key[j + 2].first == key[j].first)) return false;
        const Index h = key[j].second, k = key[j + 1].second;
        if (tris[h / 3].v[h % 3] == tris[k / 3].v[k % 3]) return false;  // same direction
        tris[h / 3].partner[h % 3] = k;
        tris[k / 3].partner[k % 3] = h;
    }
    return true;
}

// The collision point of a segment that could not be inserted lies in no triangle: such points
// go (inserted points only, so the traced mesh's vertices keep their ids).
void drop_unused_points(PointMatrix& V, TriangleMatrix& F, std::vector<Index>& original_vertex) {
    std::vector<char> used(V.rows(), 0);
    for (Index g = 0; g < F.rows(); ++g)
        for (int k = 0; k < 3; ++k) used[F(g, k)] = 1;
    std::vector<Index> new_id(V.rows(), -1);
    Index kept = 0;
    for (Index v = 0; v < V.rows(); ++v)
        if (used[v] || original_vertex[v] >= 0) new_id[v] = kept++;
    if (kept == V.rows()) return;
    PointMatrix W(kept, 3);
    std::vector<Index> original(kept);
    for (Index v = 0; v < V.rows(); ++v)
        if (new_id[v] >= 0) W.row(new_id[v]) = V.row(v), original[new_id[v]] = original_vertex[v];
    for (Index g = 0; g < F.rows(); ++g)
        for (int k = 0; k < 3; ++k) F(g, k) = new_id[F(g, k)];
    V = std::move(W);
    original_vertex = std::move(original);
}

}  // namespace

CutMesh cut_along_trajectories(const MeshView& mesh, const Eigen::VectorXcd& tau,
                               std::span<const Trajectory> trajectories, std::span<const Index> edge_label) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    HOLOFLOW_REQUIRE(edge_label.empty() || static_cast<Index>(edge_label.size()) == mesh.n_edges(),
                     "edge labels must have one value per edge");
    const Index nv = mesh.n_vertices(), nf = mesh.n_faces();
    const Index nt = static_cast<Index>(trajectories.size());

    // Points on edges: one per distinct (edge, position along the edge's orientation).
    std::vector<std::vector<std::pair<double, Index>>> edge_points(mesh.n_edges());
    std::vector<std::vector<Index>> crossing_point(nt);
    Index next_id = nv;
    std::vector<std::pair<Index, double>> point_on_edge;  // new point -> (edge, t along edge)
    for (Index i = 0; i < nt; ++i) {
        for (const EdgeCrossing& c : trajectories[i].crossings) {
            HOLOFLOW_REQUIRE(c.halfedge >= 0 && c.halfedge < mesh.n_halfedges(), "crossing out of range");
            const Index e = mesh.halfedge_edge[c.halfedge];
            const double t = mesh.edge_sign(c.halfedge) > 0 ? c.t : 1 - c.t;
            auto& list = edge_points[e];
            auto it = std::find_if(list.begin(), list.end(), [&](const auto& p) { return p.first == t; });
            Index id;
            if (it != list.end()) {
                id = it->second;
            } else {
                id = next_id++;
                list.emplace_back(t, id);
                point_on_edge.emplace_back(e, t);
            }
            crossing_point[i].push_back(id);
        }
    }
    for (auto& list : edge_points) std::sort(list.begin(), list.end());
    // Collision points, inside faces.
    std::vector<Index> collision_point(nt, -1);
    std::vector<std::pair<Index, std::array<double, 3>>> point_in_face;  // (face, barycentric)
    const Index first_inner = next_id;
    for (Index i = 0; i < nt; ++i)
        if (trajectories[i].end == Trajectory::End::Collision) {
            collision_point[i] = next_id++;
            point_in_face.emplace_back(trajectories[i].segment_face(mesh, trajectories[i].n_segments() - 1),
                                       trajectories[i].end_barycentric);
        }

    // Segments by face (CSR), with the collision points that land on each.
    std::map<std::pair<Index, Index>, std::vector<std::pair<double, Index>>> landing;  // (traj, seg)
    for (Index i = 0; i < nt; ++i)
        if (collision_point[i] >= 0)
            landing[{trajectories[i].blocker, trajectories[i].blocker_segment}].emplace_back(
                trajectories[i].blocker_length, collision_point[i]);
    // Only crossed faces get a slot (an array of #F lists would cost more than the cut itself).
    std::vector<Index> slot_of(nf, -1), crossed;
    std::vector<std::vector<FaceSegment>> face_segments;  // by slot
    for (Index i = 0; i < nt; ++i) {
        const Trajectory& tr = trajectories[i];
        const Index segments = tr.n_segments();
        for (Index j = 0; j < segments; ++j) {
            FaceSegment s{i, j == 0 ? tr.start_vertex : crossing_point[i][j - 1], -1, false, tr.length, {}};
            if (j < static_cast<Index>(tr.crossings.size())) s.to = crossing_point[i][j];
            else if (tr.end == Trajectory::End::Collision) s.to = collision_point[i], s.collision_tail = true;
            else s.to = tr.end_vertex;
            if (auto it = landing.find({i, j}); it != landing.end()) {
                std::sort(it->second.begin(), it->second.end());  // in place: one lookup per segment
                for (const auto& [len, id] : it->second) s.inner.push_back(id);
            }
            const Index f = tr.segment_face(mesh, j);
            if (slot_of[f] < 0) {
                slot_of[f] = static_cast<Index>(crossed.size());
                crossed.push_back(f);
                face_segments.emplace_back();
            }
            face_segments[slot_of[f]].push_back(std::move(s));
        }
    }

    // A face with points on an edge is split even where no curve runs inside it, so that both
    // sides of the edge have its pieces.
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        if (edge_points[e].empty()) continue;
        for (const Index h : {mesh.edge_halfedge[e], mesh.twin[mesh.edge_halfedge[e]]}) {
            if (h == kNoHalfedge || slot_of[MeshView::face(h)] >= 0) continue;
            slot_of[MeshView::face(h)] = static_cast<Index>(crossed.size());
            crossed.push_back(MeshView::face(h));
            face_segments.emplace_back();
        }
    }
    // Pieces of edge e (between consecutive points on it, from E(e, 0)): first_piece[e] + q.
    std::vector<Index> first_piece(mesh.n_edges() + 1, 0);
    for (Index e = 0; e < mesh.n_edges(); ++e)
        first_piece[e + 1] = first_piece[e] + static_cast<Index>(edge_points[e].size()) + 1;

    // Chart position of every point seen from a face (corner 0 at 0).
    const std::vector<Complex> along = forms_along(mesh, tau);
    const auto label = [&](Index h) {
        return edge_label.empty() ? kNoBorder : edge_label[mesh.halfedge_edge[h]];
    };

    // Per face: split and triangulate (each face writes its own slot). A range of slots keeps
    // its triangles in one array, at its first slot: one allocation per range, not per face.
    const Index n_crossed = static_cast<Index>(crossed.size());
    std::vector<std::vector<Triangle>> range_triangles(n_crossed);  // by the range's first slot
    struct Placed {
        Index range, first, count;  // range_triangles[range][first, first + count)
    };
    std::vector<Placed> placed(n_crossed);  // by slot
    std::vector<Index> skipped(n_crossed, 0);
    std::vector<char> inner_unpaired(n_crossed, 0);
    par::for_each_range(static_cast<std::size_t>(n_crossed), kParallelFaces, [&](std::size_t begin, std::size_t end) {
        // Scratch reused face after face (crossed faces are many small allocations otherwise).
        std::vector<Complex> pos;
        Polygon poly;
        std::vector<std::pair<Index, Complex>> local;  // point id -> chart position
        PolygonPool pool;
        Polygon work;
        std::vector<const FaceSegment*> waiting, still;
        std::vector<Triangle> tris;
        std::vector<std::pair<std::uint64_t, Index>> inner_keys;
        std::vector<Triangle>& range_out = range_triangles[begin];
        for (Index slot = static_cast<Index>(begin); slot < static_cast<Index>(end); ++slot) {
            const Index f = crossed[slot];
            auto& segs = face_segments[slot];
            poly.clear();
            local.clear();
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k, e = mesh.halfedge_edge[h];
                const auto& list = edge_points[e];
                const bool forward = mesh.edge_sign(h) > 0;
                const auto n = static_cast<Index>(list.size());
                // Piece q along h is piece q (forward) or n - q of the edge.
                const auto piece = [&](Index q) { return 2 * (first_piece[e] + (forward ? q : n - q)) + !forward; };
                poly.push(mesh.F(f, k), label(h), piece(0));
                local.emplace_back(mesh.F(f, k), chart_corner(along, f, k));
                for (Index q = 0; q < n; ++q) {
                    const auto& [t_edge, id] = list[forward ? q : n - 1 - q];
                    const double t = forward ? t_edge : 1 - t_edge;
                    poly.push(id, label(h), piece(q + 1));
                    local.emplace_back(id, chart_corner(along, f, k) + t * along[h]);
                }
            }
            // Collision points: each ends a curve stopped here (and lies on its blocker's segment).
            for (const FaceSegment& s : segs)
                if (s.collision_tail) {
                    const auto& b = point_in_face[s.to - first_inner].second;
                    local.emplace_back(s.to, b[1] * chart_corner(along, f, 1) + b[2] * chart_corner(along, f, 2));
                }
            // Through-going segments first, then curves stopped here, latest stop first. A
            // collision point exists only once its blocker's segment is in, and a blocker may
            // itself stop here earlier than the curve it blocks: a segment whose end points are
            // not both on one piece yet waits for the next round.
            stable_sort_few(segs, [](const FaceSegment& a, const FaceSegment& b) {
                if (a.collision_tail != b.collision_tail) return !a.collision_tail;
                return a.collision_tail && a.stop_length > b.stop_length;
            });
            if (pool.polys.empty()) pool.polys.emplace_back();
            pool.polys[0] = poly;
            pool.n = 1;
            waiting.clear();
            for (const FaceSegment& s : segs) waiting.push_back(&s);
            for (bool progress = true; progress && !waiting.empty();) {
                progress = false;
                still.clear();
                for (const FaceSegment* s : waiting) {
                    if (split(pool, *s)) progress = true;
                    else still.push_back(s);
                }
                waiting.swap(still);
            }
            if (!waiting.empty() && split_as_arrangement(poly, segs, local, pool)) waiting.clear();
            skipped[slot] += static_cast<Index>(waiting.size());
            // Point ids to dense slots of the face's chart positions.
            std::sort(local.begin(), local.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
            local.erase(std::unique(local.begin(), local.end(),
                                    [](const auto& a, const auto& b) { return a.first == b.first; }),
                        local.end());
            pos.resize(local.size());
            for (std::size_t q = 0; q < local.size(); ++q) pos[q] = local[q].second;
            const auto triangulate_pieces = [&] {
                for (std::size_t k = 0; k < pool.n; ++k)
                    for (Index& id : pool.polys[k].points)
                        id = static_cast<Index>(std::lower_bound(local.begin(), local.end(), id,
                                                                 [](const auto& a, Index x) { return a.first < x; }) -
                                                local.begin());
                tris.clear();
                for (std::size_t k = 0; k < pool.n; ++k) triangulate(pool.polys[k], pos, work, tris);
                for (Triangle& t : tris)
                    for (int k = 0; k < 3; ++k) t.image[k] = pos[t.v[k]], t.v[k] = local[t.v[k]].first;
                return pair_inner_edges(tris, inner_keys);
            };
            if (!triangulate_pieces()) {
                // Pieces whose triangulations share a diagonal (a face folded in its chart,
                // where the curves cross and a piece is no simple polygon): the face's curves
                // are skipped, and only its border is triangulated.
                skipped[slot] = static_cast<Index>(segs.size());
                pool.polys[0] = poly;
                pool.n = 1;
                inner_unpaired[slot] = !triangulate_pieces();
            }
            placed[slot] = {static_cast<Index>(begin), static_cast<Index>(range_out.size()), static_cast<Index>(tris.size())};
            range_out.insert(range_out.end(), tris.begin(), tris.end());
        }
    });
    const auto face_triangles = [&](Index slot) {
        const Placed& p = placed[slot];
        return std::span<const Triangle>(range_triangles[p.range]).subspan(p.first, p.count);
    };

    // Assemble: positions, triangles, the form on the new halfedges.
    CutMesh out;
    const Index n_points = next_id;
    PointMatrix V(n_points, 3);
    V.topRows(nv) = mesh.V;
    out.original_vertex.assign(n_points, -1);
    for (Index v = 0; v < nv; ++v) out.original_vertex[v] = v;
    for (std::size_t q = 0; q < point_on_edge.size(); ++q) {
        const auto& [e, t] = point_on_edge[q];
        V.row(nv + static_cast<Index>(q)) = (1 - t) * mesh.V.row(mesh.E(e, 0)) + t * mesh.V.row(mesh.E(e, 1));
    }
    for (std::size_t q = 0; q < point_in_face.size(); ++q) {
        const auto& [f, b] = point_in_face[q];
        Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
        for (int k = 0; k < 3; ++k) x += b[k] * mesh.V.row(mesh.F(f, k));
        V.row(first_inner + static_cast<Index>(q)) = x;
    }
    // Face f's triangles are rows first_triangle[f] on: every face writes its own rows.
    std::vector<Index> first_triangle(nf + 1, 0);
    for (Index f = 0; f < nf; ++f)
        first_triangle[f + 1] = first_triangle[f] + (slot_of[f] < 0 ? 1 : placed[slot_of[f]].count);
    const Index n_tri = first_triangle[nf];
    TriangleMatrix F(n_tri, 3);
    std::vector<Complex> along_new(3 * static_cast<std::size_t>(n_tri));
    std::vector<Index> halfedge_cut(3 * static_cast<std::size_t>(n_tri));
    // The pairing: pieces of input edges by their two sides, inner edges as their face paired them.
    std::vector<Index> twin(3 * static_cast<std::size_t>(n_tri), kNoHalfedge);
    std::vector<Index> halfedge_piece(3 * static_cast<std::size_t>(n_tri), kInner);
    std::vector<Index> piece_halfedge(2 * static_cast<std::size_t>(first_piece.back()), kNoHalfedge);
    out.original_face.resize(n_tri);
    par::for_each_range(static_cast<std::size_t>(nf), kAssemblyGrain, [&](std::size_t begin, std::size_t end) {
        for (Index f = static_cast<Index>(begin); f < static_cast<Index>(end); ++f) {
            Index g = first_triangle[f];
            if (slot_of[f] < 0) {
                out.original_face[g] = f;
                const std::array<Complex, 3> corner{chart_corner(along, f, 0), chart_corner(along, f, 1),
                                                    chart_corner(along, f, 2)};
                for (int k = 0; k < 3; ++k) {
                    const Index h = 3 * f + k;
                    F(g, k) = mesh.F(f, k);
                    along_new[3 * g + k] = corner[(k + 1) % 3] - corner[k];
                    halfedge_cut[3 * g + k] = label(h);
                    halfedge_piece[3 * g + k] = 2 * first_piece[mesh.halfedge_edge[h]] + (mesh.edge_sign(h) < 0);
                }
                continue;
            }
            const Index first = 3 * g;
            for (const Triangle& t : face_triangles(slot_of[f])) {
                out.original_face[g] = f;
                for (int k = 0; k < 3; ++k) {
                    F(g, k) = t.v[k];
                    along_new[3 * g + k] = t.image[(k + 1) % 3] - t.image[k];
                    halfedge_cut[3 * g + k] = t.cut[k];
                    halfedge_piece[3 * g + k] = t.piece[k];
                    if (t.piece[k] == kInner) twin[3 * g + k] = first + t.partner[k];
                }
                ++g;
            }
        }
    });
    bool pieces_once = true;  // each side of each piece in one triangle (else a degenerate split)
    for (Index h = 0; h < 3 * n_tri; ++h) {
        if (halfedge_piece[h] == kInner) continue;
        pieces_once = pieces_once && piece_halfedge[halfedge_piece[h]] == kNoHalfedge;
        piece_halfedge[halfedge_piece[h]] = h;
    }
    const auto n_halfedges = 3 * static_cast<std::size_t>(n_tri);
    par::for_each_range(n_halfedges, kAssemblyGrain, [&](std::size_t begin, std::size_t end) {
        for (std::size_t h = begin; h < end; ++h)
            if (halfedge_piece[h] != kInner) twin[h] = piece_halfedge[halfedge_piece[h] ^ 1];
    });
    for (Index s : skipped) out.skipped_segments += s;
    if (out.skipped_segments > 0) drop_unused_points(V, F, out.original_vertex);
    // Where the construction does not pair up, the pairing by vertex pairs names the fault.
    const bool paired =
        pieces_once && std::none_of(inner_unpaired.begin(), inner_unpaired.end(), [](char c) { return c; });
    out.mesh = paired ? make_mesh_view(std::move(V), std::move(F), std::move(twin))
                      : make_mesh_view(std::move(V), std::move(F));
    // Per edge: the form along its halfedge (the smaller of the pair), and the label of its
    // later labelled halfedge (the twin's where both have one).
    const MeshView& cut = out.mesh;
    out.tau.resize(cut.n_edges());
    out.edge_trajectory.assign(cut.n_edges(), kNoBorder);
    const auto n_edges = static_cast<std::size_t>(cut.n_edges());
    par::for_each_range(n_edges, kAssemblyGrain, [&](std::size_t begin, std::size_t end) {
        for (Index e = static_cast<Index>(begin); e < static_cast<Index>(end); ++e) {
            const Index h = cut.edge_halfedge[e], t = cut.twin[h];
            out.tau(e) = along_new[h];
            for (const Index side : {h, t})
                if (side != kNoHalfedge && halfedge_cut[side] != kNoBorder)
                    out.edge_trajectory[e] = halfedge_cut[side];
        }
    });
    return out;
}

}  // namespace holoflow::kernels
