#include "holoflow/kernels/zeros.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>

#include <Eigen/Geometry>
#include <Eigen/QR>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/parallel.h"
#include "holoflow/kernels/union_find.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr Index kParallelFaces = 8000;
// A vertex whose harmonicity residual |sum_e w_e du_e| is above this fraction of sum_e w_e |du_e|
// has du that are rounding noise: resolved vertices sit at 1e-13 and below, noise at 0.1-1
// (femur, lion, pizza, cheese and elephant-with-holes stretched 2.5:0.6 or jittered; dancer's
// decaying form spreads between).
constexpr double kUnresolvedResidual = 1e-3;

// Image of halfedge h; an exactly zero image takes a generic linear image of the 3D edge vector
// (then of the edge's orientation), so no corner angle is atan2(0, 0).
Complex image_direction(const MeshView& mesh, const Eigen::VectorXcd& tau, Index h) {
    const Complex image = form_along(mesh, tau, h);
    if (image != Complex(0)) return image;
    const Index e = mesh.halfedge_edge[h];
    const double sign = mesh.edge_sign(h);
    const Eigen::RowVector3d d = mesh.V.row(mesh.E(e, 1)) - mesh.V.row(mesh.E(e, 0));
    const Complex generic(d(0) + 0.3719 * d(1) + 0.6113 * d(2), 0.5347 * d(0) - d(1) + 0.2953 * d(2));
    return sign * (generic != Complex(0) ? generic : Complex(1, 0));
}

// Image windings and flips of the mesh's piecewise linear image.
void count_windings(const MeshView& mesh, const Eigen::VectorXcd& tau, ZeroSet& z) {
    std::vector<Complex> along(mesh.n_halfedges());
    par::for_each_range(static_cast<std::size_t>(mesh.n_halfedges()), 3 * kParallelFaces,
                        [&](std::size_t begin, std::size_t end) {
                            for (std::size_t h = begin; h < end; ++h)
                                along[h] = image_direction(mesh, tau, static_cast<Index>(h));
                        });
    ImageTurns turns = image_turns(mesh.F, mesh.n_vertices(), along);
    z.face_flip = std::move(turns.face_flip);
    z.winding = std::move(turns.turns);
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        z.total_index += z.winding[v] - 1;
        z.nonpositive_winding_vertices += z.winding[v] <= 0;
    }
    for (Index f = 0; f < mesh.n_faces(); ++f) z.total_index += z.face_flip[f];
}

// Saddle orders m_v of u on triangulation t, du = Re tau and dv = Im tau on its edges. Each
// halfedge gets a sign (u(head) > u(tail) after symbolic perturbation); a corner changes sign
// when its two edges' signs from the corner differ. A face whose three halfedges all carry the
// same sign (only through rounding of a closed form near 0) has three changes; it adds -1 to
// its corner 0 so the total stays exact.
std::vector<int> count_saddles(const MeshView& t, Eigen::Ref<const Eigen::VectorXd> du,
                              Eigen::Ref<const Eigen::VectorXd> dv) {
    const Index nv = t.n_vertices();
    std::vector<double> key(nv);
    for (Index v = 0; v < nv; ++v)
        key[v] = t.V(v, 0) + 0.3719 * t.V(v, 1) + 0.6113 * t.V(v, 2);  // generic direction
    const auto rising = [&](Index h) {
        const Index e = t.halfedge_edge[h];
        const double s = t.edge_sign(h);
        if (du(e) != 0) return s * du(e) > 0;
        if (dv(e) != 0) return s * dv(e) > 0;
        const Index a = t.tail(h), b = t.head(h);
        if (key[a] != key[b]) return key[b] > key[a];
        if (a != b) return b > a;
        return s > 0;
    };
    std::vector<int> changes(nv, 0);
    std::vector<int> cyclic(nv, 0);
    for (Index f = 0; f < t.n_faces(); ++f) {
        const bool r[3] = {rising(3 * f), rising(3 * f + 1), rising(3 * f + 2)};
        for (int k = 0; k < 3; ++k)
            if (r[k] == r[(k + 2) % 3]) ++changes[t.F(f, k)];  // out edge k, in edge k - 1
        if (r[0] == r[1] && r[1] == r[2]) ++cyclic[t.F(f, 0)];
    }
    std::vector<int> m(nv);
    for (Index v = 0; v < nv; ++v) m[v] = changes[v] / 2 - 1 - cyclic[v];
    // A vertex with a single outgoing halfedge lies inside a folded triangle: harmonicity forces
    // u there to its neighbour's value, its link cannot change sign, and its -1 belongs to the
    // neighbour's count (the pair is one point of the smooth picture).
    for (Index v = 0; v < nv; ++v) {
        const Index h = t.vertex_halfedge[v];
        if (h == kNoHalfedge || t.rotate(h) != h || t.head(h) == v) continue;
        m[t.head(h)] += m[v];
        m[v] = 0;
    }
    return m;
}

// Where u is not resolved on the counting triangulation t (ZeroSet::unresolved_vertices): the
// form is harmonic for t's cotan weights, so sum_e w_e du_e vanishes at every vertex up to
// rounding, unless the du themselves are rounding noise (the form numerically zero: a thin fin,
// a spike, a neck far from any handle); then their signs, so the saddles counted there, mean
// nothing. `region` per vertex: the unresolved vertices with their one-ring, joined where they
// touch, numbered by smallest vertex; -1 elsewhere (empty where none is unresolved, or t's
// weights are neither given nor computable).
struct UnresolvedRegions {
    Index vertices = 0;
    std::vector<Index> region;
};

UnresolvedRegions unresolved_regions(const MeshView& t, std::span<const double> edge_length,
                                     Eigen::Ref<const Eigen::VectorXd> du, std::span<const double> given_weights) {
    std::vector<double> computed;
    if (given_weights.empty()) {
        try {
            computed = edge_length.empty() ? cotan_weights(t)
                                           : cotan_weights_from_lengths(t.halfedge_edge, edge_length, t.n_edges());
        } catch (const InvalidInput&) {
            return {};
        }
    }
    const std::span<const double> weight = given_weights.empty() ? std::span<const double>(computed) : given_weights;
    HOLOFLOW_REQUIRE(static_cast<Index>(weight.size()) == t.n_edges(), "cotan weights must have one value per edge");
    std::vector<double> residual(t.n_vertices(), 0.0), scale(t.n_vertices(), 0.0);
    for (Index h = 0; h < t.n_halfedges(); ++h) {
        const Index e = t.halfedge_edge[h], v = t.tail(h);
        const double flow = weight[e] * t.edge_sign(h) * du(e);
        residual[v] += flow;
        scale[v] += std::abs(flow);
    }
    UnresolvedRegions out;
    std::vector<char> unresolved(t.n_vertices(), 0);
    for (Index v = 0; v < t.n_vertices(); ++v) {
        unresolved[v] = !(std::abs(residual[v]) <= kUnresolvedResidual * scale[v]) || scale[v] == 0;
        out.vertices += unresolved[v];
    }
    if (out.vertices == 0) return out;
    UnionFind regions(t.n_vertices());
    std::vector<char> in_region = unresolved;
    for (Index e = 0; e < t.n_edges(); ++e) {
        const Index a = t.E(e, 0), b = t.E(e, 1);
        if (!unresolved[a] && !unresolved[b]) continue;
        regions.unite(a, b);
        in_region[a] = in_region[b] = 1;
    }
    out.region.assign(t.n_vertices(), -1);
    std::vector<Index> number(t.n_vertices(), -1);
    Index count = 0;
    for (Index v = 0; v < t.n_vertices(); ++v) {
        if (!in_region[v]) continue;
        Index& n = number[regions.find(v)];
        if (n < 0) n = count++;
        out.region[v] = n;
    }
    return out;
}

// Mesh adjacency between special vertices, CSR (mesh edges, plus intrinsic edges between
// saddle vertices so that a saddle group split by an intrinsic edge stays one group).
struct Adjacency {
    std::vector<Index> start, next;
};

Adjacency special_adjacency(Index nv, const std::vector<std::pair<Index, Index>>& pairs) {
    Adjacency a;
    a.start.assign(nv + 1, 0);
    for (const auto& [x, y] : pairs) ++a.start[x + 1], ++a.start[y + 1];
    for (Index v = 0; v < nv; ++v) a.start[v + 1] += a.start[v];
    a.next.resize(a.start[nv]);
    std::vector<Index> fill(a.start.begin(), a.start.end() - 1);
    for (const auto& [x, y] : pairs) a.next[fill[x]++] = y, a.next[fill[y]++] = x;
    return a;
}

}  // namespace

ImageTurns image_turns(const TriangleMatrix& F, Index n_vertices, std::span<const Complex> along,
                       std::span<const char> half) {
    const Index nf = static_cast<Index>(F.rows());
    HOLOFLOW_REQUIRE(static_cast<Index>(along.size()) == 3 * nf && (half.empty() || static_cast<Index>(half.size()) == n_vertices),
                     "image_turns needs 3 values per face and no or one flag per vertex");
    constexpr double kClear = 1e-12;  // |cross| (|imag|) over the product of lengths (|real|)
    const auto on_ray = [](Complex z) { return z.real() > 0 && std::abs(z.imag()) <= kClear * z.real(); };
    ImageTurns out;
    out.face_flip.assign(nf, 0);
    // Per corner: the crossing of the ray (+1, -1, 0), or 2 where its vertex must sum angles.
    constexpr std::int8_t kSum = 2;
    std::vector<std::int8_t> corner(3 * static_cast<std::size_t>(nf), 0);
    par::for_each_range(static_cast<std::size_t>(nf), kParallelFaces, [&](std::size_t begin, std::size_t end) {
        for (Index f = static_cast<Index>(begin); f < static_cast<Index>(end); ++f) {
            std::array<double, 3> side{};
            bool clear = true;
            for (int k = 0; k < 3; ++k) {
                const Complex a = along[3 * f + k], b = -along[MeshView::prev(3 * f + k)];
                side[k] = cross(a, b);
                clear = clear && side[k] * side[k] > kClear * kClear * std::norm(a) * std::norm(b);
            }
            clear = clear && (side[0] > 0) == (side[1] > 0) && (side[1] > 0) == (side[2] > 0);
            if (!clear) {
                out.face_flip[f] = face_flips(along, f);
                for (int k = 0; k < 3; ++k) corner[3 * f + k] = kSum;
                continue;
            }
            out.face_flip[f] = side[0] < 0;
            for (int k = 0; k < 3; ++k) {
                const Complex a = along[3 * f + k], b = -along[MeshView::prev(3 * f + k)];
                if (on_ray(a) || on_ray(b)) corner[3 * f + k] = kSum;
                else if (a.imag() <= 0) corner[3 * f + k] = b.imag() > 0 && side[k] > 0;
                else corner[3 * f + k] = -static_cast<std::int8_t>(b.imag() <= 0 && side[k] < 0);
            }
        }
    });
    const auto tail = [&](Index h) { return F(h / 3, h % 3); };
    std::vector<Index> crossings(n_vertices, 0);
    std::vector<char> summed = half.empty() ? std::vector<char>(n_vertices, 0) : std::vector<char>(half.begin(), half.end());
    for (Index h = 0; h < 3 * nf; ++h) {
        if (corner[h] == kSum) summed[tail(h)] = 1;
        else crossings[tail(h)] += corner[h];
    }
    std::vector<double> total(n_vertices, 0.0);
    for (Index h = 0; h < 3 * nf; ++h)
        if (summed[tail(h)]) total[tail(h)] += tail_angle(along, h);
    out.turns.resize(n_vertices);
    for (Index v = 0; v < n_vertices; ++v) {
        const bool halves = !half.empty() && half[v];
        out.turns[v] = !summed[v] ? crossings[v]
                                  : static_cast<int>(std::lround(total[v] / ((halves ? 1 : 2) * std::numbers::pi)));
    }
    return out;
}

ZeroSet find_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau, const ZeroOptions& options) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    HOLOFLOW_REQUIRE(tau.allFinite(), "form has non-finite values");
    HOLOFLOW_REQUIRE(mesh.is_closed(), "zero bookkeeping needs a closed surface");
    HOLOFLOW_REQUIRE(options.weights.empty() || options.triangulation || !options.intrinsic_delaunay,
                     "cotan weights need the triangulation they belong to");
    const Index nv = mesh.n_vertices(), nf = mesh.n_faces();
    ZeroSet z;
    // The image windings, the saddles and the unresolved regions read the same form and write
    // their own results: large meshes count them side by side.
    const bool parallel = nf >= kParallelFaces;

    // Saddles, on the intrinsic Delaunay triangulation when asked (same vertices, the form
    // carried exactly through the flips); a mesh it cannot take (zero-area faces) counts on
    // itself. Its edges between two saddles join their groups below.
    std::vector<std::pair<Index, Index>> intrinsic_saddle_edges;
    UnresolvedRegions noise;
    const auto saddles_and_noise = [&] {
        Eigen::MatrixXd forms(mesh.n_edges(), 2);
        forms.col(0) = tau.real();
        forms.col(1) = tau.imag();
        const auto count_on = [&](const MeshView& t, std::span<const double> edge_length, const Eigen::MatrixXd& f) {
            par::run_together(parallel, {[&] { z.saddle_order = count_saddles(t, f.col(0), f.col(1)); },
                                         [&] { noise = unresolved_regions(t, edge_length, f.col(0), options.weights); }});
        };
        if (options.intrinsic_delaunay) {
            try {
                IntrinsicTriangulation computed;
                if (!options.triangulation) computed = intrinsic_delaunay(mesh);
                const IntrinsicTriangulation& t = options.triangulation ? *options.triangulation : computed;
                HOLOFLOW_REQUIRE(t.mesh.n_vertices() == nv && t.mesh.n_edges() == mesh.n_edges(),
                                 "the given intrinsic triangulation is not of this mesh");
                count_on(t.mesh, t.edge_length, carry_forms(t, forms));
                for (Index e = 0; e < t.mesh.n_edges(); ++e) {
                    const Index a = t.mesh.E(e, 0), b = t.mesh.E(e, 1);
                    if (a != b && z.saddle_order[a] != 0 && z.saddle_order[b] != 0)
                        intrinsic_saddle_edges.emplace_back(a, b);
                }
                z.intrinsic = true;
            } catch (const InvalidInput&) {
                if (options.triangulation) throw;  // a wrong triangulation is the caller's bug
            }
        }
        if (!z.intrinsic) count_on(mesh, {}, forms);
    };
    par::run_together(parallel, {[&] { count_windings(mesh, tau, z); }, saddles_and_noise});
    z.unresolved_vertices = noise.vertices;
    const auto in_unresolved_region = [&](Index v) { return !noise.region.empty() && noise.region[v] >= 0; };

    // Special vertices and their adjacency.
    std::vector<char> special(nv, 0);
    for (Index v = 0; v < nv; ++v) special[v] = z.winding[v] != 1 || z.saddle_order[v] != 0;
    for (Index f = 0; f < nf; ++f)
        if (z.face_flip[f])
            for (int k = 0; k < 3; ++k) special[mesh.F(f, k)] = 1;
    std::vector<std::pair<Index, Index>> pairs;
    for (Index e = 0; e < mesh.n_edges(); ++e)
        if (special[mesh.E(e, 0)] && special[mesh.E(e, 1)] && mesh.E(e, 0) != mesh.E(e, 1))
            pairs.emplace_back(mesh.E(e, 0), mesh.E(e, 1));
    pairs.insert(pairs.end(), intrinsic_saddle_edges.begin(), intrinsic_saddle_edges.end());
    const Adjacency adj = special_adjacency(nv, pairs);

    // Saddle groups: adjacent vertices with m_v != 0. Every other special vertex joins the
    // group nearest to it (breadth-first, groups in order of their smallest vertex); special
    // vertices no group reaches form fold-only clusters.
    UnionFind groups(nv);
    for (Index v = 0; v < nv; ++v)
        if (z.saddle_order[v] != 0)
            for (Index i = adj.start[v]; i < adj.start[v + 1]; ++i)
                if (z.saddle_order[adj.next[i]] != 0) groups.unite(v, adj.next[i]);
    // The saddles of one unresolved region make one group: their noise cancels there.
    {
        std::vector<Index> first_saddle(nv, -1);
        for (Index v = 0; v < nv; ++v) {
            if (z.saddle_order[v] == 0 || !in_unresolved_region(v)) continue;
            Index& first = first_saddle[noise.region[v]];
            if (first < 0) first = v;
            else groups.unite(first, v);
        }
    }
    std::vector<Index> owner(nv, -1), queue;
    for (Index v = 0; v < nv; ++v)
        if (z.saddle_order[v] != 0 && groups.find(v) == v) owner[v] = v, queue.push_back(v);
    for (Index v = 0; v < nv; ++v)
        if (z.saddle_order[v] != 0 && owner[v] < 0) owner[v] = groups.find(v), queue.push_back(v);
    UnionFind folds(nv);
    for (std::size_t q = 0; q < queue.size(); ++q) {
        const Index v = queue[q];
        for (Index i = adj.start[v]; i < adj.start[v + 1]; ++i) {
            const Index w = adj.next[i];
            if (owner[w] < 0) owner[w] = owner[v], queue.push_back(w);
        }
    }
    for (Index v = 0; v < nv; ++v)
        if (special[v] && owner[v] < 0)
            for (Index i = adj.start[v]; i < adj.start[v + 1]; ++i) folds.unite(v, adj.next[i]);
    for (Index v = 0; v < nv; ++v)
        if (special[v] && owner[v] < 0) owner[v] = folds.find(v);

    // Clusters numbered by their smallest vertex.
    std::vector<Index> cluster_of_owner(nv, -1);
    for (Index v = 0; v < nv; ++v) {
        if (!special[v]) continue;
        Index& c = cluster_of_owner[owner[v]];
        if (c < 0) {
            c = static_cast<Index>(z.clusters.size());
            z.clusters.emplace_back();
        }
        z.clusters[c].vertices.push_back(v);
        z.clusters[c].index += z.saddle_order[v];
    }
    for (Index f = 0; f < nf; ++f)
        if (z.face_flip[f]) {
            // A flipped face's corners may sit in different clusters after the split: it goes
            // to its first corner's.
            z.clusters[cluster_of_owner[owner[mesh.F(f, 0)]]].flipped_faces.push_back(f);
        }

    // Negative clusters (a broken maximum principle) join the nearest positive one
    // (breadth-first over mesh edges), so the reported orders add up to the exact total. A
    // target driven negative by what joined it joins its own nearest in the next round, until
    // no cluster is negative or none is positive (total index <= 0: a torus, all cancel).
    const auto has_saddle = [&](const ZeroCluster& cluster) {
        return std::any_of(cluster.vertices.begin(), cluster.vertices.end(), [&](Index v) { return z.saddle_order[v] != 0; });
    };
    const auto only_unresolved_saddles = [&](const ZeroCluster& cluster) {
        return std::all_of(cluster.vertices.begin(), cluster.vertices.end(), [&](Index v) {
            return z.saddle_order[v] == 0 || in_unresolved_region(v);
        });
    };
    std::vector<char> was_positive(z.clusters.size(), 0);
    for (std::size_t c = 0; c < z.clusters.size(); ++c) {
        const ZeroCluster& cluster = z.clusters[c];
        if (cluster.index > 0) was_positive[c] = 1;
        else if (!has_saddle(cluster)) ++z.fold_clusters;
        else if (cluster.index == 0 && only_unresolved_saddles(cluster)) ++z.flat_clusters;
        else ++z.artifact_clusters;
    }
    std::vector<Index> nearest(nv);
    std::vector<char> sought(nv, 0);  // first vertices of the negative clusters
    for (bool negative_left = true; negative_left;) {
        negative_left = false;
        std::fill(nearest.begin(), nearest.end(), Index{-1});
        queue.clear();
        Index pending = 0;
        for (Index c = 0; c < static_cast<Index>(z.clusters.size()); ++c) {
            const ZeroCluster& cluster = z.clusters[c];
            if (cluster.index > 0)
                for (Index v : cluster.vertices) nearest[v] = c, queue.push_back(v);
            else if (cluster.index < 0 && !sought[cluster.vertices.front()])
                sought[cluster.vertices.front()] = 1, ++pending;
        }
        // Breadth first from the positive clusters until every negative one is reached (the
        // rest of the surface would not change whom they reach first).
        for (std::size_t q = 0; q < queue.size() && pending > 0; ++q) {
            const Index v = queue[q];
            Index h = mesh.vertex_halfedge[v];
            const Index start = h;
            do {
                const Index w = mesh.head(h);
                if (nearest[w] < 0) {
                    nearest[w] = nearest[v], queue.push_back(w);
                    pending -= sought[w];
                }
                h = mesh.rotate(h);
            } while (h != start && h != kNoHalfedge);
        }
        for (const ZeroCluster& cluster : z.clusters)
            if (!cluster.vertices.empty()) sought[cluster.vertices.front()] = 0;
        for (Index c = 0; c < static_cast<Index>(z.clusters.size()); ++c) {
            ZeroCluster& cluster = z.clusters[c];
            if (cluster.index >= 0 || nearest[cluster.vertices.front()] < 0) continue;
            ZeroCluster& target = z.clusters[nearest[cluster.vertices.front()]];
            negative_left |= target.index <= 0;  // driven down this round: this one waits
            if (target.index <= 0) continue;
            target.index += cluster.index;
            negative_left |= target.index < 0;
            target.vertices.insert(target.vertices.end(), cluster.vertices.begin(), cluster.vertices.end());
            target.flipped_faces.insert(target.flipped_faces.end(), cluster.flipped_faces.begin(), cluster.flipped_faces.end());
            std::sort(target.vertices.begin(), target.vertices.end());
            std::sort(target.flipped_faces.begin(), target.flipped_faces.end());
            cluster = ZeroCluster{};
            ++z.merged_negative_clusters;
        }
    }
    for (std::size_t c = 0; c < z.clusters.size(); ++c)
        if (was_positive[c] && z.clusters[c].index <= 0) ++z.artifact_clusters;  // cancelled out
    for (Index c = 0; c < static_cast<Index>(z.clusters.size()); ++c) {
        const ZeroCluster& cluster = z.clusters[c];
        if (cluster.index <= 0) continue;
        Zero zero;
        zero.order = cluster.index;
        zero.cluster = c;
        zero.vertex = *std::max_element(cluster.vertices.begin(), cluster.vertices.end(),
                                        [&](Index a, Index b) { return z.saddle_order[a] < z.saddle_order[b]; });
        zero.point = refine_zero(mesh, tau, zero.vertex, zero.order);
        z.total_order += zero.order;
        z.zeros.push_back(zero);
    }
    return z;
}

ZeroPoint refine_zero(const MeshView& mesh, const Eigen::VectorXcd& tau, Index vertex, int order) {
    HOLOFLOW_REQUIRE(vertex >= 0 && vertex < mesh.n_vertices() && tau.size() == mesh.n_edges(),
                     "refine_zero needs a vertex of the mesh and one form value per edge");
    ZeroPoint out;
    if (order < 1) return out;
    // The star counter-clockwise: outgoing halfedges h_i = vertex -> head(h_i).
    std::vector<Index> star;
    const Index start = mesh.vertex_halfedge[vertex];
    for (Index h = start;;) {
        star.push_back(h);
        h = mesh.rotate(h);
        if (h == kNoHalfedge) return out;
        if (h == start) break;
    }
    const int degree = order + 1;
    const Index n = static_cast<Index>(star.size());
    if (n < degree + 1) return out;
    const Eigen::RowVector3d p = mesh.V.row(vertex);
    std::vector<double> radius(n), angle(n + 1, 0.0);  // angle[i]: phi of head(h_i)
    for (Index i = 0; i < n; ++i) {
        const Eigen::RowVector3d a = mesh.V.row(mesh.head(star[i])) - p;
        const Eigen::RowVector3d b = mesh.V.row(mesh.head(MeshView::next(star[i]))) - p;
        radius[i] = a.norm();
        angle[i + 1] = angle[i] + std::atan2(a.cross(b).norm(), a.dot(b));
    }
    const double total = angle[n];
    if (!(total > 0) || !std::isfinite(total)) return out;
    const double s = 2 * std::numbers::pi / total;
    std::vector<Complex> zeta(n);
    double scale = 0;
    for (Index i = 0; i < n; ++i) {
        zeta[i] = std::polar(std::pow(radius[i], s), s * angle[i]);
        scale = std::max(scale, std::abs(zeta[i]));
    }
    if (!(scale > 0) || !std::isfinite(scale)) return out;
    // Least squares over the vertex (F = 0, zeta = 0) and its neighbours, zeta scaled to <= 1.
    Eigen::MatrixXcd fit(n + 1, degree + 1);
    Eigen::VectorXcd rhs(n + 1);
    fit.row(0).setZero();
    fit(0, 0) = 1;
    rhs(0) = 0;
    double image_size = 0;
    for (Index i = 0; i < n; ++i) {
        Complex power = 1;
        for (int m = 0; m <= degree; ++m, power *= zeta[i] / scale) fit(i + 1, m) = power;
        rhs(i + 1) = form_along(mesh, tau, star[i]);
        image_size = std::max(image_size, std::abs(rhs(i + 1)));
    }
    const Eigen::VectorXcd c = fit.colPivHouseholderQr().solve(rhs);
    if (!c.allFinite() || !(std::abs(c(degree)) > 1e-9 * image_size)) return out;
    // The critical points of the fit are the roots of F'; their mean, from Vieta.
    const Complex critical = -static_cast<double>(degree - 1) * c(degree - 1) /
                             (static_cast<double>(degree) * c(degree) * static_cast<double>(order));
    // Back to the star: radius |zeta|^(1/s), angle arg(zeta) / s in [0, total).
    const Complex unscaled = critical * scale;
    double phi = std::arg(unscaled);
    if (phi < 0) phi += 2 * std::numbers::pi;
    phi /= s;
    Index i = 0;
    while (i + 1 < n && angle[i + 1] <= phi) ++i;
    // Face of h_i laid flat (vertex at 0, head(h_i) on the real axis) with its corners' images;
    // a point beyond the star is reached by unfolding the faces across the edges it lies behind.
    Index f = MeshView::face(star[i]);
    std::array<Complex, 3> pos, image;
    {
        const int k = static_cast<int>(star[i] % 3);
        pos[k] = 0;
        pos[(k + 1) % 3] = radius[i];
        pos[(k + 2) % 3] = std::polar(radius[(i + 1) % n], angle[i + 1] - angle[i]);
        image[k] = 0;
        image[(k + 1) % 3] = form_along(mesh, tau, star[i]);
        image[(k + 2) % 3] = -form_along(mesh, tau, MeshView::prev(star[i]));
    }
    const Complex point = std::polar(std::pow(std::abs(unscaled), 1 / s), phi - angle[i]);
    constexpr int kMaxUnfoldedFaces = 6;
    for (int step = 0;; ++step) {
        const double area = cross(pos[1] - pos[0], pos[2] - pos[0]);
        if (!(area > 0)) return out;
        std::array<double, 3> bary;
        for (int k = 0; k < 3; ++k) bary[k] = cross(pos[(k + 1) % 3] - point, pos[(k + 2) % 3] - point) / area;
        const int worst = static_cast<int>(std::min_element(bary.begin(), bary.end()) - bary.begin());
        if (bary[worst] >= 0) {
            out.face = f;
            out.barycentric = bary;
            for (int k = 0; k < 3; ++k)
                for (int axis = 0; axis < 3; ++axis) out.position[axis] += bary[k] * mesh.V(mesh.F(f, k), axis);
            break;
        }
        // Across the edge opposite the most negative corner.
        const Index t = mesh.twin[3 * f + (worst + 1) % 3];
        if (t == kNoHalfedge || step == kMaxUnfoldedFaces) return out;
        const int kt = static_cast<int>(t % 3);
        const Complex a = pos[(worst + 2) % 3], b = pos[(worst + 1) % 3];  // tail and head of t
        const Complex image_a = image[(worst + 2) % 3], image_b = image[(worst + 1) % 3];
        f = MeshView::face(t);
        const Index w = mesh.F(f, (kt + 2) % 3);
        const double la = (mesh.V.row(w) - mesh.V.row(mesh.tail(t))).norm();
        const double lb = (mesh.V.row(w) - mesh.V.row(mesh.head(t))).norm();
        const double d = std::abs(b - a);
        if (!(d > 0)) return out;
        pos[kt] = a;
        pos[(kt + 1) % 3] = b;
        pos[(kt + 2) % 3] = a + (b - a) / d * apex_from_lengths(d, la, lb);
        image[kt] = image_a;
        image[(kt + 1) % 3] = image_b;
        image[(kt + 2) % 3] = image_a - form_along(mesh, tau, MeshView::prev(t));
    }
    Complex value = 0, power = 1;
    for (int m = 0; m <= degree; ++m, power *= critical) value += c(m) * power;
    out.image_offset = value - image[0];
    return out;
}

}  // namespace holoflow::kernels
