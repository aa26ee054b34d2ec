#include "holoflow/kernels/tips.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <queue>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::kernels {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Vertex adjacency in compressed rows, with edge lengths; built from the edge list, so it works
// whatever the face structure around a vertex (boundary fans included).
struct VertexGraph {
    std::vector<Index> start;  // #V + 1
    std::vector<Index> neighbor;
    std::vector<double> length;
    Index n_vertices() const { return static_cast<Index>(start.size()) - 1; }
};

VertexGraph build_graph(const MeshView& mesh) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges();
    VertexGraph g;
    g.start.assign(static_cast<std::size_t>(n_v) + 1, 0);
    for (Index e = 0; e < n_e; ++e) {
        ++g.start[mesh.E(e, 0) + 1];
        ++g.start[mesh.E(e, 1) + 1];
    }
    for (Index v = 0; v < n_v; ++v) g.start[v + 1] += g.start[v];
    g.neighbor.resize(g.start[n_v]);
    g.length.resize(g.start[n_v]);
    std::vector<Index> fill(g.start.begin(), g.start.end() - 1);
    for (Index e = 0; e < n_e; ++e) {
        const Index a = mesh.E(e, 0), b = mesh.E(e, 1);
        const double l = (mesh.V.row(a) - mesh.V.row(b)).norm();
        g.neighbor[fill[a]] = b;
        g.length[fill[a]++] = l;
        g.neighbor[fill[b]] = a;
        g.length[fill[b]++] = l;
    }
    return g;
}

// Dijkstra with a reusable distance array: a bounded or early-stopped run costs only what it
// touches. Ties in the queue go by vertex id, so runs are deterministic.
class Dijkstra {
 public:
    explicit Dijkstra(const VertexGraph& g) : g_(g), dist_(g.n_vertices(), kInf) {}

    // Settles vertices in increasing distance up to `bound`; settle(v, d) returns false to stop.
    template <class Settle>
    void run(std::span<const Index> sources, double bound, Settle settle) {
        for (Index v : touched_) dist_[v] = kInf;
        touched_.clear();
        using Entry = std::pair<double, Index>;
        std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
        for (Index s : sources) {
            if (dist_[s] == 0) continue;
            dist_[s] = 0;
            touched_.push_back(s);
            queue.emplace(0.0, s);
        }
        while (!queue.empty()) {
            const auto [d, v] = queue.top();
            queue.pop();
            if (d > dist_[v]) continue;  // stale entry
            if (!settle(v, d)) return;
            for (Index k = g_.start[v]; k < g_.start[v + 1]; ++k) {
                const Index u = g_.neighbor[k];
                const double du = d + g_.length[k];
                if (du >= dist_[u] || du > bound) continue;
                if (dist_[u] == kInf) touched_.push_back(u);
                dist_[u] = du;
                queue.emplace(du, u);
            }
        }
    }
    std::vector<double> full(std::span<const Index> sources) {
        run(sources, kInf, [](Index, double) { return true; });
        return dist_;
    }
    double dist(Index v) const { return dist_[v]; }

 private:
    const VertexGraph& g_;
    std::vector<double> dist_;
    std::vector<Index> touched_;
};

// Vertices of a manifold mesh are joined by edges exactly when their faces are, so one
// breadth-first pass over the vertex graph decides connectivity.
bool is_connected(const VertexGraph& g) {
    const Index n = g.n_vertices();
    if (n == 0) return false;
    std::vector<char> seen(n, 0);
    std::vector<Index> stack{0};
    seen[0] = 1;
    Index count = 1;
    while (!stack.empty()) {
        const Index v = stack.back();
        stack.pop_back();
        for (Index k = g.start[v]; k < g.start[v + 1]; ++k) {
            const Index u = g.neighbor[k];
            if (!seen[u]) {
                seen[u] = 1;
                ++count;
                stack.push_back(u);
            }
        }
    }
    return count == n;
}

std::vector<char> boundary_vertex_flags(const MeshView& mesh) {
    std::vector<char> on(mesh.n_vertices(), 0);
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (mesh.is_boundary_halfedge(h)) on[mesh.tail(h)] = 1;
    return on;
}

// Per vertex, 1 where neither it nor a neighbour is on the boundary: a hole takes its tip's
// one-ring, so a tip must be two rings from the boundary.
std::vector<char> two_rings_from_boundary(const VertexGraph& g, const std::vector<char>& on_boundary) {
    std::vector<char> eligible(on_boundary.size(), 1);
    for (Index v = 0; v < g.n_vertices(); ++v)
        if (on_boundary[v]) {
            eligible[v] = 0;
            for (Index k = g.start[v]; k < g.start[v + 1]; ++k) eligible[g.neighbor[k]] = 0;
        }
    return eligible;
}

double face_area(const MeshView& mesh, Index f) {
    const Eigen::RowVector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)),
                             c = mesh.V.row(mesh.F(f, 2));
    return 0.5 * (b - a).cross(c - a).norm();
}

// Largest entry, the smallest index among equal ones.
Index argmax(const std::vector<double>& x) {
    return static_cast<Index>(std::max_element(x.begin(), x.end()) - x.begin());
}

TipMeasure measure_on(const MeshView& mesh, const VertexGraph& g, const std::vector<char>& on_boundary,
                      int samples) {
    const Index n_v = mesh.n_vertices();
    Dijkstra dijkstra(g);
    TipMeasure m;
    // Double sweep: the farthest vertex from vertex 0 is an end of an (approximate) diameter.
    const Index origin = 0;
    const Index a = argmax(dijkstra.full(std::span<const Index>(&origin, 1)));
    std::vector<double> from_a = dijkstra.full(std::span<const Index>(&a, 1));
    m.diameter = *std::max_element(from_a.begin(), from_a.end());

    if (std::find(on_boundary.begin(), on_boundary.end(), 1) != on_boundary.end()) {
        // With a boundary, extremities are the vertices far from it (a hole at the border would
        // only notch the existing loop).
        std::vector<Index> border;
        for (Index v = 0; v < n_v; ++v)
            if (on_boundary[v]) border.push_back(v);
        m.value = dijkstra.full(border);
        return m;
    }

    // Farthest point samples, starting at the diameter end a; each distance field is kept for
    // the average. `nearest` assigns every vertex to its closest sample (first sample on ties).
    std::vector<std::vector<double>> fields;
    std::vector<double> nearest_dist = from_a;
    std::vector<Index> nearest(n_v, 0);
    m.sources.push_back(a);
    fields.push_back(std::move(from_a));
    while (static_cast<int>(m.sources.size()) < samples) {
        const Index next = argmax(nearest_dist);
        if (nearest_dist[next] == 0) break;  // every vertex is a sample already
        std::vector<double> d = dijkstra.full(std::span<const Index>(&next, 1));
        m.diameter = std::max(m.diameter, *std::max_element(d.begin(), d.end()));
        const Index id = static_cast<Index>(m.sources.size());
        for (Index v = 0; v < n_v; ++v)
            if (d[v] < nearest_dist[v]) {
                nearest_dist[v] = d[v];
                nearest[v] = id;
            }
        m.sources.push_back(next);
        fields.push_back(std::move(d));
    }

    // Each sample stands for the area of its geodesic Voronoi cell, so that uneven sampling
    // does not tilt the average towards where samples crowd.
    std::vector<double> weight(m.sources.size(), 0.0);
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const double third = face_area(mesh, f) / 3;
        for (int k = 0; k < 3; ++k) weight[nearest[mesh.F(f, k)]] += third;
    }
    double total = 0;
    for (double w : weight) total += w;
    HOLOFLOW_REQUIRE(total > 0, "mesh has zero area");
    m.value.assign(n_v, 0.0);
    for (std::size_t j = 0; j < fields.size(); ++j) {
        const double w = weight[j] / total;
        for (Index v = 0; v < n_v; ++v) m.value[v] += w * fields[j][v];
    }
    return m;
}

// Total order "u is higher than v": larger measure, then smaller id.
struct Higher {
    const std::vector<double>& value;
    bool operator()(Index u, Index v) const {
        return value[u] > value[v] || (value[u] == value[v] && u < v);
    }
};

// Topographic prominence of every strict local maximum (0-dimensional persistence of the
// superlevel sets): sweeping vertices from high to low, a maximum dies, with prominence
// peak - current value, when its component joins one with a higher peak. The global maximum
// gets the whole range of the measure. Other vertices get -1.
std::vector<double> peak_prominence(const VertexGraph& g, const std::vector<double>& value) {
    const Index n = g.n_vertices();
    const Higher higher{value};
    std::vector<Index> order(n);
    for (Index v = 0; v < n; ++v) order[v] = v;
    std::sort(order.begin(), order.end(), higher);

    std::vector<Index> parent(n, -1), peak(n, -1);
    auto find = [&](Index v) {
        Index r = v;
        while (parent[r] != r) r = parent[r];
        while (parent[v] != r) v = std::exchange(parent[v], r);
        return r;
    };
    std::vector<double> prominence(n, -1.0);
    std::vector<Index> roots;
    for (Index v : order) {
        roots.clear();
        for (Index k = g.start[v]; k < g.start[v + 1]; ++k)
            if (parent[g.neighbor[k]] != -1) roots.push_back(find(g.neighbor[k]));
        parent[v] = v;
        peak[v] = v;
        if (roots.empty()) continue;  // a new maximum
        std::sort(roots.begin(), roots.end());
        roots.erase(std::unique(roots.begin(), roots.end()), roots.end());
        Index best = roots[0];
        for (Index r : roots)
            if (higher(peak[r], peak[best])) best = r;
        for (Index r : roots)
            if (r != best) {
                prominence[peak[r]] = value[peak[r]] - value[v];
                parent[r] = best;
            }
        parent[v] = best;
    }
    const Index top = order.front(), bottom = order.back();
    prominence[top] = value[top] - value[bottom];
    return prominence;
}

}  // namespace

std::vector<double> edge_path_distances(const MeshView& mesh, std::span<const Index> sources) {
    HOLOFLOW_REQUIRE(!sources.empty(), "no source vertex given");
    for (Index s : sources)
        HOLOFLOW_REQUIRE(s >= 0 && s < mesh.n_vertices(),
                         "source vertex " + std::to_string(s) + " out of range [0, " +
                             std::to_string(mesh.n_vertices()) + ")");
    const VertexGraph g = build_graph(mesh);
    return Dijkstra(g).full(sources);
}

std::vector<Index> collapsed_limb_tips(const MeshView& mesh, std::span<const char> collapsed, double min_share) {
    const Index nf = mesh.n_faces(), nv = mesh.n_vertices();
    HOLOFLOW_REQUIRE(static_cast<Index>(collapsed.size()) == nf, "one collapsed flag per face is needed");
    HOLOFLOW_REQUIRE(min_share >= 0 && min_share <= 1, "min_share must be in [0, 1]");
    // Regions: collapsed faces joined across edges, numbered by their smallest face.
    std::vector<Index> region(nf, -1);
    std::vector<double> area(nf), region_area;
    double total = 0;
    for (Index f = 0; f < nf; ++f) total += area[f] = face_area(mesh, f);
    for (Index seed = 0; seed < nf; ++seed) {
        if (!collapsed[seed] || region[seed] >= 0) continue;
        const Index id = static_cast<Index>(region_area.size());
        region_area.push_back(0);
        std::vector<Index> stack{seed};
        region[seed] = id;
        while (!stack.empty()) {
            const Index f = stack.back();
            stack.pop_back();
            region_area[id] += area[f];
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh.twin[3 * f + k];
                if (t == kNoHalfedge) continue;
                const Index g = MeshView::face(t);
                if (collapsed[g] && region[g] < 0) {
                    region[g] = id;
                    stack.push_back(g);
                }
            }
        }
    }
    if (region_area.empty()) return {};
    // Distances from the faces that kept their scale and from the boundary.
    std::vector<char> kept(nv, 0);
    for (Index f = 0; f < nf; ++f)
        if (!collapsed[f])
            for (int k = 0; k < 3; ++k) kept[mesh.F(f, k)] = 1;
    const std::vector<char> on_boundary = boundary_vertex_flags(mesh);
    const auto sources = [nv](const std::vector<char>& flags) {
        std::vector<Index> out;
        for (Index v = 0; v < nv; ++v)
            if (flags[v]) out.push_back(v);
        return out;
    };
    const VertexGraph g = build_graph(mesh);
    const auto distances = [&](const std::vector<char>& flags) {
        const std::vector<Index> from = sources(flags);
        return from.empty() ? std::vector<double>(nv, kInf) : Dijkstra(g).full(from);
    };
    const std::vector<double> from_kept = distances(kept), from_boundary = distances(on_boundary);
    const std::vector<char> eligible = two_rings_from_boundary(g, on_boundary);
    std::vector<Index> best(region_area.size(), -1);
    std::vector<double> best_depth(region_area.size(), 0);
    for (Index v = 0; v < nv; ++v) {
        if (kept[v] || !eligible[v] || mesh.vertex_halfedge[v] == kNoHalfedge) continue;
        const double depth = std::min(from_kept[v], from_boundary[v]);
        const Index id = region[MeshView::face(mesh.vertex_halfedge[v])];
        if (std::isfinite(depth) && (best[id] < 0 || depth > best_depth[id])) best[id] = v, best_depth[id] = depth;
    }
    std::vector<Index> tips;
    for (std::size_t id = 0; id < region_area.size(); ++id)
        if (best[id] >= 0 && region_area[id] >= min_share * total) tips.push_back(best[id]);
    return tips;
}

TipMeasure compute_tip_measure(const MeshView& mesh, const TipOptions& options) {
    HOLOFLOW_REQUIRE(options.samples >= 1, "samples must be at least 1");
    const VertexGraph g = build_graph(mesh);
    HOLOFLOW_REQUIRE(is_connected(g), "mesh is empty or has several components");
    return measure_on(mesh, g, boundary_vertex_flags(mesh), options.samples);
}

TipDetection detect_tips(const MeshView& mesh, const TipOptions& options) {
    HOLOFLOW_REQUIRE(options.min_tips >= 1, "min_tips must be at least 1");
    HOLOFLOW_REQUIRE(options.max_tips >= options.min_tips, "max_tips must be >= min_tips");
    HOLOFLOW_REQUIRE(options.prominence >= 0 && options.prominence <= 1,
                     "prominence must be in [0, 1] (a fraction of the diameter)");
    HOLOFLOW_REQUIRE(options.samples >= 1, "samples must be at least 1");
    const VertexGraph g = build_graph(mesh);
    HOLOFLOW_REQUIRE(is_connected(g), "mesh is empty or has several components");

    const std::vector<char> on_boundary = boundary_vertex_flags(mesh);
    // A hole always takes its tip's one-ring, so a tip next to the boundary could never be
    // sliced: tips are vertices two rings from the boundary at least. On a coarse or thin disk
    // the measure's maximum can sit next to the boundary (a needle's lies by its short side).
    const std::vector<char> eligible = two_rings_from_boundary(g, on_boundary);
    // The highest eligible vertex of x; -1 when none is eligible.
    auto eligible_argmax = [&](const std::vector<double>& x) {
        Index best = -1;
        for (Index v = 0; v < g.n_vertices(); ++v)
            if (eligible[v] && (best < 0 || x[v] > x[best])) best = v;
        return best;
    };
    TipDetection out;
    out.measure = measure_on(mesh, g, on_boundary, options.samples);
    const std::vector<double>& value = out.measure.value;
    const double diameter = out.measure.diameter;
    const double threshold = options.prominence * diameter;
    const Higher higher{value};

    // Candidates: interior maxima prominent enough, most prominent first.
    const std::vector<double> prominence = peak_prominence(g, value);
    std::vector<Index> candidates;
    for (Index v = 0; v < g.n_vertices(); ++v)
        if (prominence[v] >= 0 && prominence[v] >= threshold && eligible[v])
            candidates.push_back(v);
    std::sort(candidates.begin(), candidates.end(), [&](Index u, Index v) {
        return prominence[u] > prominence[v] || (prominence[u] == prominence[v] && u < v);
    });

    // Isolation, reported: Dijkstra from the tip until the first higher vertex. It needs no
    // test: both measures are 1-Lipschitz along edge paths (each distance field obeys the
    // triangle inequality), and any path to higher ground passes a vertex `prominence` below
    // the tip, so isolation >= prominence >= threshold.
    Dijkstra dijkstra(g);
    for (Index c : candidates) {
        if (static_cast<int>(out.tips.size()) >= options.max_tips) break;
        double isolation = diameter;
        dijkstra.run(std::span<const Index>(&c, 1), kInf, [&](Index v, double d) {
            if (!higher(v, c)) return true;
            isolation = d;
            return false;
        });
        out.tips.push_back(c);
        out.prominence.push_back(diameter > 0 ? prominence[c] / diameter : 0.0);
        out.isolation.push_back(diameter > 0 ? std::min(isolation, diameter) / diameter : 0.0);
    }

    // Too few (a round blob): the highest vertex, then farthest points from the tips so far
    // and from the boundary.
    if (out.tips.empty()) {
        const Index top = eligible_argmax(value);
        if (top >= 0) {
            out.tips.push_back(top);
            out.prominence.push_back(0.0);
            out.isolation.push_back(1.0);
            ++out.fallback_tips;
        }
    }
    while (static_cast<int>(out.tips.size()) < options.min_tips) {
        std::vector<Index> sources = out.tips;
        for (Index v = 0; v < g.n_vertices(); ++v)
            if (on_boundary[v]) sources.push_back(v);
        if (sources.empty()) break;
        const std::vector<double> d = dijkstra.full(sources);
        const Index next = eligible_argmax(d);
        if (next < 0 || !(d[next] > 0)) break;  // no eligible vertex left that is not a tip
        out.tips.push_back(next);
        out.prominence.push_back(0.0);
        out.isolation.push_back(diameter > 0 ? std::min(d[next], diameter) / diameter : 0.0);
        ++out.fallback_tips;
    }
    return out;
}

std::vector<Index> find_tips(const MeshView& mesh, const TipOptions& options) {
    return detect_tips(mesh, options).tips;
}

namespace {

// Outcome of cleaning one hole in isolation (other holes ignored); `piece` is the size of the
// kept piece the hole would cut off when CutsMesh.
enum class HoleStatus { Ok, ReachesBoundary, CoversMesh, CutsMesh, NotADisk };
struct HoleResult {
    HoleStatus status = HoleStatus::Ok;
    Index piece = 0;
};

// Makes the edge-connected face set `in_hole` (listed in `faces`) a closed disk, or says why
// not. Pockets, the kept components other than the largest, join the hole when each is no
// larger than it. That is the whole clean-up: where the hole's border touches itself at a vertex
// u (two kept arcs around u), a loop through the hole and u either separates the surface, and
// then the two arcs lie in different kept components, one of them a pocket, or it does not
// (it runs around a handle), and then splitting u leaves a connected surface with boundary, so
// chi(hole) <= 1 - 1 = 0 and the disk test below fails. Growing the hole at u fixes neither
// case. So a connected hole with chi = 1 is a disk with a simple border, and the kept faces
// around each of its border vertices form one arc. `mark` is scratch of #F zeros, kept zero.
HoleResult clean_hole(const MeshView& mesh, const std::vector<char>& on_boundary,
                      std::vector<char>& in_hole, std::vector<Index>& faces,
                      std::vector<Index>& mark) {
    const Index n_f = mesh.n_faces();
    // Kept components by flood fill across edges; label c + 1 for component c.
    std::vector<Index> sizes, stack;
    for (Index seed = 0; seed < n_f; ++seed) {
        if (in_hole[seed] || mark[seed]) continue;
        const Index label = static_cast<Index>(sizes.size()) + 1;
        Index size = 0;
        mark[seed] = label;
        stack.push_back(seed);
        while (!stack.empty()) {
            const Index f = stack.back();
            stack.pop_back();
            ++size;
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh.twin[3 * f + k];
                if (t == kNoHalfedge) continue;
                const Index g = MeshView::face(t);
                if (in_hole[g] || mark[g]) continue;
                mark[g] = label;
                stack.push_back(g);
            }
        }
        sizes.push_back(size);
    }
    HoleResult result;
    if (sizes.empty()) {
        result.status = HoleStatus::CoversMesh;
    } else {
        // The largest component stays (the first of equal ones: deterministic).
        const Index main =
            static_cast<Index>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin()) + 1;
        const Index hole_size = static_cast<Index>(faces.size());
        for (std::size_t c = 0; c < sizes.size(); ++c)
            if (static_cast<Index>(c) + 1 != main && sizes[c] > hole_size) {
                result = {HoleStatus::CutsMesh, sizes[c]};
                break;
            }
        for (Index f = 0; f < n_f; ++f) {
            if (result.status == HoleStatus::Ok && mark[f] != 0 && mark[f] != main) {
                in_hole[f] = 1;
                faces.push_back(f);
            }
            mark[f] = 0;
        }
    }
    if (result.status != HoleStatus::Ok) return result;

    // A hole with a vertex on the input boundary would merge with that boundary loop.
    std::vector<Index> verts;
    Index inner_halfedges = 0, border_halfedges = 0;
    for (Index f : faces)
        for (int k = 0; k < 3; ++k) {
            verts.push_back(mesh.F(f, k));
            const Index t = mesh.twin[3 * f + k];
            if (t != kNoHalfedge && in_hole[MeshView::face(t)])
                ++inner_halfedges;
            else
                ++border_halfedges;
        }
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    for (Index v : verts)
        if (on_boundary[v]) return {HoleStatus::ReachesBoundary, 0};
    // Euler characteristic V - E + F of the closed hole.
    const Index chi = static_cast<Index>(verts.size()) - (inner_halfedges / 2 + border_halfedges) +
                      static_cast<Index>(faces.size());
    if (chi != 1) result.status = HoleStatus::NotADisk;
    return result;
}

}  // namespace

SlicedMesh slice_tips(const MeshView& mesh, std::span<const Index> tips, double hole_radius) {
    const Index n_v = mesh.n_vertices(), n_f = mesh.n_faces();
    HOLOFLOW_REQUIRE(!tips.empty(), "no tips given");
    HOLOFLOW_REQUIRE(std::isfinite(hole_radius) && hole_radius >= 0,
                     "hole_radius must be finite and >= 0");
    const std::vector<char> on_boundary = boundary_vertex_flags(mesh);
    {
        std::vector<char> seen(n_v, 0);
        for (Index t : tips) {
            HOLOFLOW_REQUIRE(t >= 0 && t < n_v, "tip " + std::to_string(t) +
                                                    " is not a vertex id in [0, " +
                                                    std::to_string(n_v) + ")");
            HOLOFLOW_REQUIRE(!seen[t], "tip " + std::to_string(t) + " is given twice");
            HOLOFLOW_REQUIRE(!on_boundary[t],
                             "tip " + std::to_string(t) + " lies on the mesh boundary");
            seen[t] = 1;
        }
    }
    const VertexGraph g = build_graph(mesh);
    HOLOFLOW_REQUIRE(is_connected(g), "mesh is empty or has several components");

    double area = 0;
    for (Index f = 0; f < n_f; ++f) area += face_area(mesh, f);
    const double radius = hole_radius * std::sqrt(area / (4 * std::numbers::pi));

    SlicedMesh out;
    std::vector<char> removed(n_f, 0), in_hole(n_f, 0);
    std::vector<char> hole_vertex(n_v, 0);  // vertices of accepted holes
    std::vector<Index> mark(n_f, 0), faces, stack;
    Dijkstra dijkstra(g);
    for (Index tip : tips) {
        // Vertices within the radius (the Dijkstra leaves the others at infinity).
        dijkstra.run(std::span<const Index>(&tip, 1), radius, [](Index, double) { return true; });
        auto inside = [&](Index f) {
            for (int k = 0; k < 3; ++k)
                if (!(dijkstra.dist(mesh.F(f, k)) <= radius)) return false;
            return true;
        };
        // The one-ring, then faces inside the ball reachable across edges from it.
        faces.clear();
        const Index h0 = mesh.vertex_halfedge[tip];
        Index h = h0;
        do {
            in_hole[MeshView::face(h)] = 1;
            faces.push_back(MeshView::face(h));
            h = mesh.rotate(h);
        } while (h != h0);
        stack.assign(faces.begin(), faces.end());
        while (!stack.empty()) {
            const Index f = stack.back();
            stack.pop_back();
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh.twin[3 * f + k];
                if (t == kNoHalfedge) continue;
                const Index n = MeshView::face(t);
                if (in_hole[n] || !inside(n)) continue;
                in_hole[n] = 1;
                faces.push_back(n);
                stack.push_back(n);
            }
        }

        const HoleResult hole = clean_hole(mesh, on_boundary, in_hole, faces, mark);
        const std::string where = "the hole around tip " + std::to_string(tip);
        HOLOFLOW_REQUIRE(hole.status != HoleStatus::CoversMesh,
                         where + " covers the whole mesh: the result would be empty");
        HOLOFLOW_REQUIRE(hole.status != HoleStatus::CutsMesh,
                         where + " cuts the mesh into pieces (" + std::to_string(hole.piece) +
                             " faces would be disconnected): use a smaller hole_radius");
        HOLOFLOW_REQUIRE(hole.status != HoleStatus::NotADisk,
                         where + " is not a disk (it wraps a handle): use a smaller hole_radius");
        // Holes meeting the boundary or an earlier hole are dropped; the others are
        // vertex-disjoint disks, so the remaining faces stay a connected manifold.
        bool keep = hole.status == HoleStatus::Ok;
        for (Index f : faces)
            for (int k = 0; k < 3 && keep; ++k)
                if (hole_vertex[mesh.F(f, k)]) keep = false;
        if (keep) {
            for (Index f : faces) {
                removed[f] = 1;
                for (int k = 0; k < 3; ++k) hole_vertex[mesh.F(f, k)] = 1;
            }
            out.tips.push_back(tip);
            out.hole_faces.emplace_back(faces);
            std::sort(out.hole_faces.back().begin(), out.hole_faces.back().end());
        }
        for (Index f : faces) in_hole[f] = 0;
    }
    HOLOFLOW_REQUIRE(!out.tips.empty(), "no tip could be sliced: every hole reaches the mesh "
                                        "boundary (use a smaller hole size, --hole-size)");

    // Remaining faces and the vertices they use, both in input order.
    std::vector<Index> new_vertex(n_v, -1);
    for (Index f = 0; f < n_f; ++f) {
        if (removed[f]) continue;
        out.original_face.push_back(f);
        for (int k = 0; k < 3; ++k) new_vertex[mesh.F(f, k)] = 0;
    }
    HOLOFLOW_REQUIRE(!out.original_face.empty(), "the holes cover the whole mesh");
    for (Index v = 0; v < n_v; ++v)
        if (new_vertex[v] == 0) {
            new_vertex[v] = static_cast<Index>(out.original_vertex.size());
            out.original_vertex.push_back(v);
        }
    PointMatrix V(static_cast<Index>(out.original_vertex.size()), 3);
    for (std::size_t i = 0; i < out.original_vertex.size(); ++i)
        V.row(static_cast<Index>(i)) = mesh.V.row(out.original_vertex[i]);
    TriangleMatrix F(static_cast<Index>(out.original_face.size()), 3);
    for (std::size_t i = 0; i < out.original_face.size(); ++i)
        for (int k = 0; k < 3; ++k)
            F(static_cast<Index>(i), k) = new_vertex[mesh.F(out.original_face[i], k)];
    out.mesh = make_mesh_view(std::move(V), std::move(F));

    // Holes are vertex-disjoint disks with simple borders, so this holds by construction; it
    // is cheap to make sure.
    const Topology before = compute_topology(mesh), after = compute_topology(out.mesh);
    HOLOFLOW_REQUIRE(after.components == 1, "the result would be disconnected (" +
                                                std::to_string(after.components) +
                                                " components)");
    HOLOFLOW_REQUIRE(after.boundary_loops ==
                         before.boundary_loops + static_cast<int>(out.tips.size()),
                     "slicing gave " + std::to_string(after.boundary_loops) +
                         " boundary loops instead of " +
                         std::to_string(before.boundary_loops + out.tips.size()));
    return out;
}

}  // namespace holoflow::kernels
