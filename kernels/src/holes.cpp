#include "holoflow/kernels/holes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>

#include "holoflow/kernels/errors.h"

namespace holoflow::kernels {
namespace {

// 4 sqrt(3) area / sum of squared edge lengths: 1 for an equilateral triangle, 0 for a flat one.
double triangle_quality(const MeshView& mesh, Index a, Index b, Index c) {
    const Eigen::Vector3d pa = mesh.V.row(a), pb = mesh.V.row(b), pc = mesh.V.row(c);
    const double squares = (pb - pa).squaredNorm() + (pc - pb).squaredNorm() + (pa - pc).squaredNorm();
    if (!(squares > 0)) return 0;
    return 2 * std::sqrt(3.0) * (pb - pa).cross(pc - pa).norm() / squares;
}

int working_genus(int genus, int loops) { return loops == 0 ? genus : 2 * genus + loops - 1; }

// A boundary loop by length: fewest edges, then shortest perimeter, then smallest vertex id.
struct LoopSize {
    Index edges;
    double perimeter;
    Index first_vertex;
    Index loop;
    auto key() const { return std::tie(edges, perimeter, first_vertex, loop); }
};

// Each component's loops, shortest first.
std::vector<std::vector<LoopSize>> loops_by_size(const MeshView& mesh, const Topology& topology) {
    const std::vector<std::vector<Index>>& cycles = topology.boundary_cycles;
    std::vector<std::vector<LoopSize>> per_component(topology.per_component.size());
    for (Index l = 0; l < static_cast<Index>(cycles.size()); ++l) {
        const std::vector<Index>& c = cycles[l];
        double perimeter = 0;
        for (std::size_t i = 0; i < c.size(); ++i)
            perimeter += (mesh.V.row(c[(i + 1) % c.size()]) - mesh.V.row(c[i])).norm();
        const Index component = topology.face_component[MeshView::face(mesh.vertex_halfedge[c.front()])];
        per_component[component].push_back(
            {static_cast<Index>(c.size()), perimeter, *std::min_element(c.begin(), c.end()), l});
    }
    for (std::vector<LoopSize>& loops : per_component)
        std::sort(loops.begin(), loops.end(), [](const LoopSize& a, const LoopSize& b) { return a.key() < b.key(); });
    return per_component;
}

}  // namespace

std::vector<std::array<Index, 3>> triangulate_hole(const MeshView& mesh, std::span<const Index> loop,
                                                   double min_quality) {
    const Index n = static_cast<Index>(loop.size());
    HOLOFLOW_REQUIRE(n >= 3, "a hole needs at least 3 boundary vertices, got " + std::to_string(n));
    // The polygon in fill orientation: the loop reversed.
    std::vector<Index> q(loop.rbegin(), loop.rend());
    for (Index v : q) HOLOFLOW_REQUIRE(v >= 0 && v < mesh.n_vertices(), "hole vertex out of range");

    std::vector<Index> sorted(q);
    std::sort(sorted.begin(), sorted.end());
    if (const auto twice = std::adjacent_find(sorted.begin(), sorted.end()); twice != sorted.end())
        throw InvalidInput("triangulate_hole: hole passes vertex " + std::to_string(*twice) + " twice");

    // Best triangulation of the sub-polygon q_i .. q_k (closed by the chord q_i q_k): the one
    // whose worst triangle is best, then the largest quality sum. worst < 0: none valid.
    struct Best {
        double worst = -1, sum = 0;
        Index apex = -1;
    };
    const std::size_t nn = static_cast<std::size_t>(n) * n;
    std::vector<Best> best(nn);
    auto at = [n](Index i, Index k) { return static_cast<std::size_t>(i) * n + k; };
    for (Index i = 0; i + 1 < n; ++i) best[at(i, i + 1)] = {std::numeric_limits<double>::infinity(), 0, -1};
    for (Index gap = 2; gap < n; ++gap) {
        for (Index i = 0; i + gap < n; ++i) {
            const Index k = i + gap;
            const bool chord_is_side = i == 0 && k == n - 1;  // the polygon's own edge q_{n-1} q_0
            // A chord the mesh already has as an edge would double it.
            if (!chord_is_side && joins(mesh.F, mesh.twin, mesh.vertex_halfedge[q[i]], q[k])) continue;
            Best& b = best[at(i, k)];
            for (Index j = i + 1; j < k; ++j) {
                const Best& left = best[at(i, j)];
                const Best& right = best[at(j, k)];
                if (left.worst < 0 || right.worst < 0) continue;
                const double quality = triangle_quality(mesh, q[i], q[j], q[k]);
                if (quality < min_quality) continue;
                const double worst = std::min({left.worst, right.worst, quality});
                const double sum = left.sum + right.sum + quality;
                if (worst > b.worst || (worst == b.worst && sum > b.sum)) b = {worst, sum, j};
            }
        }
    }
    std::vector<std::array<Index, 3>> triangles;
    if (best[at(0, n - 1)].worst < 0) return triangles;
    triangles.reserve(n - 2);
    std::vector<std::pair<Index, Index>> stack{{0, n - 1}};
    while (!stack.empty()) {
        const auto [i, k] = stack.back();
        stack.pop_back();
        if (k - i < 2) continue;
        const Index j = best[at(i, k)].apex;
        triangles.push_back({q[i], q[j], q[k]});
        stack.emplace_back(i, j);
        stack.emplace_back(j, k);
    }
    return triangles;
}

std::vector<Index> holes_to_fill(const MeshView& mesh, const Topology& topology, const HoleFillOptions& options) {
    const std::vector<std::vector<LoopSize>> per_component = loops_by_size(mesh, topology);
    std::vector<Index> chosen;
    for (std::size_t comp = 0; comp < per_component.size(); ++comp) {
        const std::vector<LoopSize>& loops = per_component[comp];
        const int genus = topology.per_component[comp].genus;
        int open = static_cast<int>(loops.size());
        for (const LoopSize& c : loops) {
            if (c.edges > options.longest_fillable_loop) break;  // sorted: every later one is longer
            const bool longest = open == 1;                       // sorted: the last one left
            if (genus == 0 && longest) break;                     // a disk stays a disk
            const bool small = c.edges <= options.max_loop_edges;
            const bool over_cap = !longest && options.max_working_genus > 0 &&
                                  working_genus(genus, open) > options.max_working_genus;
            if (!small && !over_cap) break;
            chosen.push_back(c.loop);
            --open;
        }
    }
    std::sort(chosen.begin(), chosen.end());
    return chosen;
}

std::vector<Index> fillable_holes(const MeshView& mesh, const Topology& topology, std::span<const Index> loops,
                                  Index longest_fillable_loop) {
    std::vector<char> asked(topology.boundary_cycles.size(), 0);
    for (Index l : loops) {
        HOLOFLOW_REQUIRE(l >= 0 && l < static_cast<Index>(asked.size()), "no boundary loop " + std::to_string(l));
        asked[l] = 1;
    }
    const std::vector<std::vector<LoopSize>> per_component = loops_by_size(mesh, topology);
    std::vector<Index> out;
    for (std::size_t comp = 0; comp < per_component.size(); ++comp) {
        const std::vector<LoopSize>& sorted = per_component[comp];
        const std::size_t kept = topology.per_component[comp].genus == 0 ? 2 : 1;  // the longest
        for (std::size_t i = 0; i + kept < sorted.size(); ++i)
            if (asked[sorted[i].loop] && sorted[i].edges <= longest_fillable_loop) out.push_back(sorted[i].loop);
    }
    std::sort(out.begin(), out.end());
    return out;
}

FilledHoles fill_holes(const MeshView& mesh, const Topology& topology, std::span<const Index> holes) {
    HOLOFLOW_REQUIRE(static_cast<Index>(topology.face_component.size()) == mesh.n_faces(),
                     "the topology must be this mesh's");
    FilledHoles out;
    std::vector<std::array<Index, 3>> added;
    std::vector<Index> twin = mesh.twin;
    // (tail, head, halfedge) of one hole's boundary halfedges and new halfedges, to pair them.
    std::vector<std::tuple<Index, Index, Index>> sides;
    for (Index l : holes) {
        HOLOFLOW_REQUIRE(l >= 0 && l < static_cast<Index>(topology.boundary_cycles.size()),
                         "no boundary loop " + std::to_string(l));
        const std::vector<Index>& loop = topology.boundary_cycles[l];
        const std::vector<std::array<Index, 3>> triangles = triangulate_hole(mesh, loop);
        if (triangles.empty()) {
            ++out.left_open;
            continue;
        }
        sides.clear();
        for (Index v : loop) {
            const Index h = mesh.vertex_halfedge[v];  // the boundary halfedge out of v
            sides.emplace_back(mesh.tail(h), mesh.head(h), h);
        }
        const Index first_face = mesh.n_faces() + static_cast<Index>(added.size());
        for (std::size_t t = 0; t < triangles.size(); ++t)
            for (int k = 0; k < 3; ++k)
                sides.emplace_back(triangles[t][k], triangles[t][(k + 1) % 3],
                                   3 * (first_face + static_cast<Index>(t)) + k);
        std::sort(sides.begin(), sides.end());
        twin.resize(twin.size() + 3 * triangles.size(), kNoHalfedge);
        for (const auto& [a, b, h] : sides) {
            const auto it = std::lower_bound(sides.begin(), sides.end(), std::make_tuple(b, a, Index{0}));
            HOLOFLOW_REQUIRE(it != sides.end() && std::get<0>(*it) == b && std::get<1>(*it) == a,
                             "hole filling left edge " + std::to_string(a) + "-" + std::to_string(b) + " unpaired");
            twin[h] = std::get<2>(*it);
        }
        added.insert(added.end(), triangles.begin(), triangles.end());
        ++out.holes;
    }
    out.faces = static_cast<Index>(added.size());
    TriangleMatrix F(mesh.n_faces() + out.faces, 3);
    F.topRows(mesh.n_faces()) = mesh.F;
    for (Index t = 0; t < out.faces; ++t)
        for (int k = 0; k < 3; ++k) F(mesh.n_faces() + t, k) = added[t][k];
    out.mesh = make_mesh_view(mesh.V, std::move(F), std::move(twin));
    return out;
}

}  // namespace holoflow::kernels
