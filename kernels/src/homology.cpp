#include "holoflow/kernels/homology.h"

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <limits>
#include <queue>
#include <string>
#include <utility>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

constexpr double kSparseFormsDensity = 0.05;  // below: wedge_matrix multiplies sparse forms

struct ShortestPathTree {
    std::vector<Index> parent_halfedge;  // parent -> v
    std::vector<Index> depth;            // hops from the root
};

// Lengths on an integer grid of 2^-30 of `scale`: sums are exact, so paths of equal length tie
// exactly (and go to the smaller vertex) instead of by rounding, which differs between a mesh
// and its moved or scaled copy (symmetric meshes such as tori of revolution are full of such
// ties). Values stay below 2^30 per step: no overflow below 2^33 vertices on a path.
std::int64_t on_grid(double length, double scale) {
    return std::llround(std::ldexp(length / scale, 30));
}

// Dijkstra with a binary heap of (grid distance, vertex): equal distances pop by vertex index
// and a vertex keeps the first parent that reached it, so the tree depends on nothing but the
// input, and not on its position, orientation or scale.
ShortestPathTree shortest_path_tree(const MeshView& mesh, Index root) {
    const Index n_v = mesh.n_vertices();
    const std::vector<double> length = edge_lengths(mesh);
    const double longest = length.empty() ? 0.0 : *std::max_element(length.begin(), length.end());
    HOLOFLOW_REQUIRE(longest > 0 && std::isfinite(longest), "edge lengths must be finite and not all zero");
    std::vector<std::int64_t> step(length.size());
    for (std::size_t e = 0; e < length.size(); ++e) step[e] = on_grid(length[e], longest);
    std::vector<std::int64_t> dist(n_v, std::numeric_limits<std::int64_t>::max());
    std::vector<char> done(n_v, 0);
    ShortestPathTree tree{std::vector<Index>(n_v, kNoHalfedge), std::vector<Index>(n_v, 0)};
    using Entry = std::pair<std::int64_t, Index>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
    dist[root] = 0;
    heap.emplace(0, root);
    Index reached = 0;
    while (!heap.empty()) {
        const auto [d, v] = heap.top();
        heap.pop();
        if (done[v]) continue;
        done[v] = 1;
        ++reached;
        const Index start = mesh.vertex_halfedge[v];
        Index h = start;
        do {
            const Index w = mesh.head(h);
            if (!done[w]) {
                const std::int64_t nd = d + step[mesh.halfedge_edge[h]];
                if (nd < dist[w]) {
                    dist[w] = nd;
                    tree.parent_halfedge[w] = h;
                    tree.depth[w] = tree.depth[v] + 1;
                    heap.emplace(nd, w);
                }
            }
            h = mesh.rotate(h);
        } while (h != start);
    }
    HOLOFLOW_REQUIRE(reached == n_v, "mesh is not connected (" + std::to_string(n_v - reached) +
                                         " vertices unreachable from the root)");
    return tree;
}

// Closed halfedge loop through generator edge e: tree path down to its tail, the edge along its
// orientation, tree path back up from its head, meeting at the lowest common ancestor.
std::vector<Index> generator_loop(const MeshView& mesh, const ShortestPathTree& tree, Index e) {
    const Index h = mesh.edge_halfedge[e];
    Index a = mesh.tail(h), b = mesh.head(h);
    std::vector<Index> down;  // parent -> child halfedges above a, collected bottom-up
    std::vector<Index> up;    // child -> parent halfedges above b, in walking order
    while (a != b) {
        if (tree.depth[a] >= tree.depth[b]) {
            const Index p = tree.parent_halfedge[a];
            down.push_back(p);
            a = mesh.tail(p);
        } else {
            const Index p = tree.parent_halfedge[b];
            up.push_back(mesh.twin[p]);
            b = mesh.tail(p);
        }
    }
    std::vector<Index> loop(down.rbegin(), down.rend());
    loop.push_back(h);
    loop.insert(loop.end(), up.begin(), up.end());
    return loop;
}

// Repeatedly drops the edge of a vertex with one cut edge left; each vertex's fan is scanned at
// most once when it is peeled, so this is linear.
void prune_dangling(const MeshView& mesh, std::vector<char>& cut) {
    std::vector<Index> degree(mesh.n_vertices(), 0);
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        if (!cut[e]) continue;
        ++degree[mesh.E(e, 0)];
        ++degree[mesh.E(e, 1)];
    }
    std::vector<Index> stack;
    for (Index v = mesh.n_vertices() - 1; v >= 0; --v)
        if (degree[v] == 1) stack.push_back(v);
    while (!stack.empty()) {
        const Index v = stack.back();
        stack.pop_back();
        if (degree[v] != 1) continue;
        const Index start = mesh.vertex_halfedge[v];
        Index h = start;
        while (!cut[mesh.halfedge_edge[h]]) h = mesh.rotate(h);
        cut[mesh.halfedge_edge[h]] = 0;
        degree[v] = 0;
        const Index w = mesh.head(h);
        if (--degree[w] == 1) stack.push_back(w);
    }
}

// Corners around each vertex grouped into wedges: a new wedge starts at every cut edge.
Index assign_wedges(const MeshView& mesh, const std::vector<char>& cut,
                    std::vector<Index>& corner_wedge) {
    corner_wedge.assign(mesh.n_halfedges(), -1);
    Index n_wedges = 0;
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        const Index first = mesh.vertex_halfedge[v];
        Index start = first;
        while (!cut[mesh.halfedge_edge[start]]) {
            start = mesh.rotate(start);
            if (start == first) break;  // no cut edge here: one wedge
        }
        Index wedge = n_wedges++;
        Index h = start;
        do {
            corner_wedge[h] = wedge;  // corner h lies between h and rotate(h)
            h = mesh.rotate(h);
            if (h != start && cut[mesh.halfedge_edge[h]]) wedge = n_wedges++;
        } while (h != start);
    }
    return n_wedges;
}

}  // namespace

Index central_vertex(const MeshView& mesh) {
    const Eigen::RowVector3d centroid = mesh.V.colwise().mean();
    std::vector<double> distance(mesh.n_vertices());
    double farthest = 0;
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        distance[v] = (mesh.V.row(v) - centroid).norm();
        farthest = std::max(farthest, distance[v]);
    }
    if (!(farthest > 0 && std::isfinite(farthest))) return 0;
    // Compared on the grid: vertices equally far (a ring around a torus's hole) tie exactly.
    Index best = 0;
    std::int64_t best_distance = std::numeric_limits<std::int64_t>::max();
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        const std::int64_t d = on_grid(distance[v], farthest);
        if (d < best_distance) best_distance = d, best = v;
    }
    return best;
}

HomologyBasis compute_homology_basis(const MeshView& mesh, const HomologyOptions& options) {
    HOLOFLOW_REQUIRE(mesh.n_faces() > 0, "mesh has no faces");
    HOLOFLOW_REQUIRE(mesh.is_closed(), "mesh has boundary");
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges(), n_f = mesh.n_faces();
    HOLOFLOW_REQUIRE(options.root >= -1 && options.root < n_v,
                     "root " + std::to_string(options.root) + " out of range");

    HomologyBasis basis;
    basis.root = options.root >= 0 ? options.root : central_vertex(mesh);
    const ShortestPathTree tree = shortest_path_tree(mesh, basis.root);
    basis.tree_parent_halfedge = tree.parent_halfedge;

    // Edge classes: 1 primal tree, 2 dual tree, 0 leftover.
    std::vector<char> edge_class(n_e, 0);
    for (Index v = 0; v < n_v; ++v)
        if (tree.parent_halfedge[v] != kNoHalfedge)
            edge_class[mesh.halfedge_edge[tree.parent_halfedge[v]]] = 1;

    // Dual spanning tree by BFS over faces; face_parent[f] is f's halfedge facing its parent.
    std::vector<Index> face_order;
    face_order.reserve(n_f);
    std::vector<Index> face_parent(n_f, kNoHalfedge);
    std::vector<char> seen(n_f, 0);
    seen[0] = 1;
    face_order.push_back(0);
    for (std::size_t i = 0; i < face_order.size(); ++i) {
        const Index f = face_order[i];
        for (Index h = 3 * f; h < 3 * f + 3; ++h) {
            const Index e = mesh.halfedge_edge[h];
            if (edge_class[e] != 0) continue;
            const Index t = mesh.twin[h];
            const Index g = MeshView::face(t);
            if (seen[g]) continue;
            seen[g] = 1;
            edge_class[e] = 2;
            face_parent[g] = t;
            face_order.push_back(g);
        }
    }
    for (Index e = 0; e < n_e; ++e)
        if (edge_class[e] == 0) basis.generator_edges.push_back(e);
    const int chi = n_v - n_e + n_f;
    const auto n_gen = static_cast<Index>(basis.generator_edges.size());
    HOLOFLOW_REQUIRE(n_gen == 2 - chi && n_gen % 2 == 0,
                     std::to_string(n_gen) + " leftover edges but 2 - chi = " +
                         std::to_string(2 - chi) + " (dual graph not connected?)");
    basis.genus = n_gen / 2;

    // Peel the dual tree from its leaves: in reverse BFS order every other edge of a face is
    // already known, so closedness fixes the edge to its parent. The face stencils go into flat
    // arrays once, then each form is one tight pass writing its own column. Values stay small
    // integers (the peeled value is the net generator flux below the edge), so sums are exact.
    const Index n_peel = n_f - 1;
    std::vector<Index> peel_edge(3 * static_cast<std::size_t>(n_peel));
    std::vector<double> peel_sign(2 * static_cast<std::size_t>(n_peel));
    for (Index i = 0; i < n_peel; ++i) {
        const Index f = face_order[n_f - 1 - i];
        const Index hp = face_parent[f];
        const Index ha = MeshView::next(hp), hb = MeshView::prev(hp);
        peel_edge[3 * i] = mesh.halfedge_edge[hp];
        peel_edge[3 * i + 1] = mesh.halfedge_edge[ha];
        peel_edge[3 * i + 2] = mesh.halfedge_edge[hb];
        // eta(parent) = -s_p (s_a eta(a) + s_b eta(b)), with s_p = +-1 its own inverse.
        peel_sign[2 * i] = -mesh.edge_sign(hp) * mesh.edge_sign(ha);
        peel_sign[2 * i + 1] = -mesh.edge_sign(hp) * mesh.edge_sign(hb);
    }
    // Form j into a zeroed column `eta` of #E values.
    const auto peel = [&](Index j, double* eta) {
        eta[basis.generator_edges[j]] = 1.0;
        for (Index i = 0; i < n_peel; ++i)
            eta[peel_edge[3 * i]] = peel_sign[2 * i] * eta[peel_edge[3 * i + 1]] +
                                    peel_sign[2 * i + 1] * eta[peel_edge[3 * i + 2]];
        // The root face closes by itself (the face sums add up to 0 over a closed surface).
        double root_sum = 0.0;
        for (Index h = 0; h < 3; ++h) root_sum += mesh.edge_sign(h) * eta[mesh.halfedge_edge[h]];
        if (root_sum != 0.0) throw SolverFailure("compute_homology_basis: root face not closed");
    };
    // One independent pass per form: columns in parallel, each writing only its own column.
    const bool parallel = n_e > 20000;
    if (!options.sparse_forms) {
        basis.closed_forms = Eigen::MatrixXd::Zero(n_e, n_gen);
        par::for_each_index(static_cast<std::size_t>(n_gen), parallel, [&](std::size_t column) {
            const auto j = static_cast<Index>(column);
            peel(j, basis.closed_forms.col(j).data());
        });
    } else {
        basis.sparse_closed_forms = par::sparse_from_columns(n_e, n_gen, parallel, [&](Index j, double* eta) { peel(j, eta); });
    }

    basis.loops.reserve(n_gen);
    for (const Index e : basis.generator_edges)
        basis.loops.push_back(generator_loop(mesh, tree, e));

    basis.cut_edge.assign(n_e, 0);
    for (Index e = 0; e < n_e; ++e) basis.cut_edge[e] = edge_class[e] != 2;
    prune_dangling(mesh, basis.cut_edge);
    basis.n_wedges = assign_wedges(mesh, basis.cut_edge, basis.corner_wedge);
    return basis;
}

Eigen::MatrixXd integrate_along_paths(const MeshView& mesh, const Eigen::MatrixXd& forms,
                                      std::span<const std::vector<Index>> paths) {
    HOLOFLOW_REQUIRE(forms.rows() == mesh.n_edges(), "forms must have one row per edge");
    // The paths as signed edges (path j: [start[j], start[j + 1])), then each form's integrals
    // from its own column: a column is read in place, where a path at a time would read the
    // #E x k matrix row by row. Each sum runs in path order.
    std::vector<std::size_t> start(paths.size() + 1, 0);
    std::vector<Index> edge;
    std::vector<double> sign;
    for (std::size_t j = 0; j < paths.size(); ++j) {
        for (const Index h : paths[j]) {
            HOLOFLOW_REQUIRE(h >= 0 && h < mesh.n_halfedges(), "halfedge " + std::to_string(h) + " out of range");
            edge.push_back(mesh.halfedge_edge[h]);
            sign.push_back(mesh.edge_sign(h));
        }
        start[j + 1] = edge.size();
    }
    Eigen::MatrixXd total(forms.cols(), static_cast<Eigen::Index>(paths.size()));
    const bool parallel = edge.size() * static_cast<std::size_t>(forms.cols()) >= par::kParallelColumnRows;
    par::for_each_index(static_cast<std::size_t>(forms.cols()), parallel, [&](std::size_t c) {
        const auto i = static_cast<Eigen::Index>(c);
        const double* form = forms.col(i).data();
        for (std::size_t j = 0; j < paths.size(); ++j) {
            double sum = 0;
            for (std::size_t k = start[j]; k < start[j + 1]; ++k) sum += sign[k] * form[edge[k]];
            total(i, static_cast<Eigen::Index>(j)) = sum;
        }
    });
    return total;
}

Eigen::MatrixXd integrate_along_paths(const MeshView& mesh, const Eigen::SparseMatrix<double>& forms,
                                      std::span<const std::vector<Index>> paths) {
    HOLOFLOW_REQUIRE(forms.rows() == mesh.n_edges(), "forms must have one row per edge");
    std::vector<Eigen::Triplet<double>> steps;  // path j, edge, sign
    for (std::size_t j = 0; j < paths.size(); ++j)
        for (const Index h : paths[j]) {
            HOLOFLOW_REQUIRE(h >= 0 && h < mesh.n_halfedges(), "halfedge " + std::to_string(h) + " out of range");
            steps.emplace_back(static_cast<Index>(j), mesh.halfedge_edge[h], static_cast<double>(mesh.edge_sign(h)));
        }
    Eigen::SparseMatrix<double> along(static_cast<Eigen::Index>(paths.size()), mesh.n_edges());
    along.setFromTriplets(steps.begin(), steps.end());
    return Eigen::MatrixXd(along * forms).transpose();
}

Eigen::VectorXd integrate_along(const MeshView& mesh, const Eigen::MatrixXd& forms,
                                std::span<const Index> loop) {
    const std::vector<Index> path(loop.begin(), loop.end());
    return integrate_along_paths(mesh, forms, std::span(&path, 1)).col(0);
}

namespace {

// S (#E x #E, skew, two entries per face) with A = Omega^T S Omega: per face with e0 = v0->v1
// and e2 = v2->v0, (a d - b c)/2 = s0 s2 / 2 (x(e2) y(e0) - x(e0) y(e2)), i.e. S(e2, e0) = +w
// and S(e0, e2) = -w.
Eigen::SparseMatrix<double> wedge_operator(const MeshView& mesh) {
    const Index n_e = mesh.n_edges(), n_f = mesh.n_faces();
    // Built column-compressed straight from the face arrays: each edge is e0 or e2 of at most two
    // faces, so a column has <= 2 entries.
    std::vector<Index> start(static_cast<std::size_t>(n_e) + 1, 0);
    for (Index f = 0; f < n_f; ++f) {
        ++start[mesh.halfedge_edge[3 * f] + 1];
        ++start[mesh.halfedge_edge[3 * f + 2] + 1];
    }
    for (Index e = 0; e < n_e; ++e) start[e + 1] += start[e];
    std::vector<Index> rows(start.back());
    std::vector<double> values(start.back());
    {
        std::vector<Index> fill(start.begin(), start.end() - 1);
        for (Index f = 0; f < n_f; ++f) {
            const Index h0 = 3 * f, h2 = 3 * f + 2;
            const Index e0 = mesh.halfedge_edge[h0], e2 = mesh.halfedge_edge[h2];
            const double w = 0.5 * mesh.edge_sign(h0) * mesh.edge_sign(h2);
            rows[fill[e0]] = e2;
            values[fill[e0]++] = w;
            rows[fill[e2]] = e0;
            values[fill[e2]++] = -w;
        }
    }
    // Sort each (tiny) column by row and merge repeats (two faces sharing both edges).
    Eigen::SparseMatrix<double> S(n_e, n_e);
    S.reserve(Eigen::VectorXi::Constant(n_e, 2));
    for (Index e = 0; e < n_e; ++e) {
        const Index b = start[e], en = start[e + 1];
        if (en - b == 2 && rows[b] > rows[b + 1]) {
            std::swap(rows[b], rows[b + 1]);
            std::swap(values[b], values[b + 1]);
        }
        for (Index k = b; k < en; ++k) {
            if (k > b && rows[k] == rows[k - 1]) {
                S.coeffRef(rows[k], e) += values[k];
            } else {
                S.insert(rows[k], e) = values[k];
            }
        }
    }
    S.makeCompressed();
    return S;
}

// A skew-symmetrised: S is exactly skew; this only removes rounding from the two summation orders.
Eigen::MatrixXd skew_part(const Eigen::MatrixXd& A) { return 0.5 * (A - A.transpose()); }

}  // namespace

Eigen::MatrixXd wedge_matrix(const MeshView& mesh, const Eigen::MatrixXd& forms) {
    HOLOFLOW_REQUIRE(forms.rows() == mesh.n_edges(), "forms must have one row per edge");
    const Eigen::SparseMatrix<double> S = wedge_operator(mesh);
    // Forms dual to a tree-cotree basis live on dual paths (a fraction of a percent of the
    // entries are nonzero): a sparse product then beats the dense (2g x #E) x (#E x 2g) one by
    // orders of magnitude at high genus. Harmonic forms are dense and take the dense product.
    const auto nonzeros = (forms.array() != 0.0).count();
    if (static_cast<double>(nonzeros) < kSparseFormsDensity * static_cast<double>(forms.size())) {
        const Eigen::SparseMatrix<double> O = forms.sparseView();
        const Eigen::SparseMatrix<double> SO = S * O;
        return skew_part(Eigen::MatrixXd(O.transpose() * SO));
    }
    const Eigen::MatrixXd SO = S * forms;
    return skew_part(forms.transpose() * SO);
}

Eigen::MatrixXd wedge_matrix(const MeshView& mesh, const Eigen::SparseMatrix<double>& forms) {
    HOLOFLOW_REQUIRE(forms.rows() == mesh.n_edges(), "forms must have one row per edge");
    const Eigen::SparseMatrix<double> S = wedge_operator(mesh);
    const Eigen::SparseMatrix<double> SO = S * forms;
    return skew_part(Eigen::MatrixXd(forms.transpose() * SO));
}

Eigen::MatrixXi symplectic_basis(const Eigen::MatrixXi& J) {
    HOLOFLOW_REQUIRE(J.rows() == J.cols(), "intersection matrix must be square");
    HOLOFLOW_REQUIRE(J.rows() % 2 == 0, "intersection matrix must have even size");
    const Eigen::Index n = J.rows(), g = n / 2;
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j <= i; ++j)
            HOLOFLOW_REQUIRE(J(i, j) == -J(j, i), "intersection matrix is not skew at (" +
                                                      std::to_string(i) + ", " + std::to_string(j) +
                                                      ")");
    using MatL = Eigen::Matrix<std::int64_t, Eigen::Dynamic, Eigen::Dynamic>;
    using VecL = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>;
    const MatL JL = J.cast<std::int64_t>();
    MatL B = MatL::Identity(n, n);  // columns: current lattice basis, unimodular throughout
    constexpr std::int64_t kLimit = std::int64_t{1} << 31;
    VecL c(n);
    for (Eigen::Index p = 0; p < n; p += 2) {
        // c_k = omega(a, B_k) with a = B_p; Euclid by unimodular column operations until one
        // column pairs with a and the rest are orthogonal to it.
        const VecL u = JL.transpose() * B.col(p);
        for (Eigen::Index k = p + 1; k < n; ++k) c(k) = u.dot(B.col(k));
        Eigen::Index pivot = -1;
        for (;;) {
            pivot = -1;
            for (Eigen::Index k = p + 1; k < n; ++k)
                if (c(k) != 0 && (pivot < 0 || std::llabs(c(k)) < std::llabs(c(pivot)))) pivot = k;
            if (pivot < 0) break;
            bool reduced = false;
            for (Eigen::Index k = p + 1; k < n; ++k) {
                if (k == pivot || c(k) == 0) continue;
                const std::int64_t q = c(k) / c(pivot);
                B.col(k) -= q * B.col(pivot);
                c(k) -= q * c(pivot);
                reduced = true;
            }
            if (!reduced) break;
        }
        HOLOFLOW_REQUIRE(pivot >= 0 && std::llabs(c(pivot)) == 1,
                         "intersection matrix is not unimodular");
        // Rotate the partner into place so untouched columns keep their order (standard input
        // comes back as the identity).
        for (Eigen::Index k = pivot; k > p + 1; --k) {
            B.col(k).swap(B.col(k - 1));
            std::swap(c(k), c(k - 1));
        }
        if (c(p + 1) < 0) B.col(p + 1) = -B.col(p + 1);
        // Make the rest orthogonal to b too: B_k -= omega(B_k, b) a keeps omega(a, B_k) = 0.
        const VecL v = JL * B.col(p + 1);
        for (Eigen::Index k = p + 2; k < n; ++k) B.col(k) -= v.dot(B.col(k)) * B.col(p);
        if (B.rightCols(n - p).cwiseAbs().maxCoeff() >= kLimit)  // columns before p are final
            throw SolverFailure("symplectic_basis: coefficients overflow 32 bits");
    }
    MatL P(n, n);
    for (Eigen::Index i = 0; i < g; ++i) {
        P.col(i) = B.col(2 * i);
        P.col(g + i) = B.col(2 * i + 1);
    }
    MatL standard = MatL::Zero(n, n);
    standard.topRightCorner(g, g).setIdentity();
    standard.bottomLeftCorner(g, g) = -MatL::Identity(g, g);
    // P^T J P = standard, checked on two fixed pseudo-random vectors (Freivalds) in wrapping
    // 64-bit arithmetic: exact equality survives the wrap, and a wrong P passes only if its
    // error vanishes modulo 2^64 on both; three matrix-vector products replace the n^3 integer
    // product (a fifth of the basis' time at 2g = 938).
    using VecU = Eigen::Matrix<std::uint64_t, Eigen::Dynamic, 1>;
    const auto times = [n](const MatL& M, const VecU& x, bool transposed) {
        VecU y = VecU::Zero(n);
        for (Eigen::Index j = 0; j < n; ++j)
            for (Eigen::Index i = 0; i < n; ++i) {
                const auto m = static_cast<std::uint64_t>(M(i, j));
                if (transposed) y(j) += m * x(i);
                else y(i) += m * x(j);
            }
        return y;
    };
    std::uint64_t state = 0x9e3779b97f4a7c15ULL;
    for (int trial = 0; trial < 2; ++trial) {
        VecU x(n);
        for (Eigen::Index i = 0; i < n; ++i) {
            state = state * 6364136223846793005ULL + 1442695040888963407ULL;  // deterministic LCG
            x(i) = state;
        }
        if (times(P, times(JL, times(P, x, false), false), true) != times(standard, x, false))
            throw SolverFailure("symplectic_basis: result is not in standard form");
    }
    return P.cast<int>();
}

CutTopology fundamental_domain_topology(const MeshView& mesh, const HomologyBasis& basis) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges(), n_h = mesh.n_halfedges();
    HOLOFLOW_REQUIRE(static_cast<Index>(basis.cut_edge.size()) == n_e, "cut_edge size != #E");
    HOLOFLOW_REQUIRE(static_cast<Index>(basis.corner_wedge.size()) == n_h,
                     "corner_wedge size != #H");
    HOLOFLOW_REQUIRE(mesh.is_closed(), "mesh has boundary");
    const auto& cut = basis.cut_edge;
    const auto& wedge = basis.corner_wedge;

    // corner_wedge must be exactly the partition of corners into classes joined across uncut
    // edges: constant across uncut edges, max(1, cut degree) distinct wedges per vertex, and no
    // wedge shared by two vertices.
    std::vector<Index> wedge_vertex(basis.n_wedges, -1);
    Index n_cut = 0;
    for (Index e = 0; e < n_e; ++e) n_cut += cut[e] ? 1 : 0;
    for (Index h = 0; h < n_h; ++h) {
        const Index w = wedge[h];
        HOLOFLOW_REQUIRE(w >= 0 && w < basis.n_wedges, "wedge index out of range");
        HOLOFLOW_REQUIRE(wedge_vertex[w] == -1 || wedge_vertex[w] == mesh.tail(h),
                         "wedge " + std::to_string(w) + " spans two vertices");
        wedge_vertex[w] = mesh.tail(h);
        if (!cut[mesh.halfedge_edge[h]])
            HOLOFLOW_REQUIRE(
                wedge[MeshView::next(mesh.twin[h])] == w,
                "corner_wedge splits a vertex across uncut halfedge " + std::to_string(h));
    }
    Index classes = 0;
    for (Index v = 0; v < n_v; ++v) {
        const Index start = mesh.vertex_halfedge[v];
        Index cut_degree = 0, changes = 0;
        Index h = start;
        do {
            const Index r = mesh.rotate(h);
            cut_degree += cut[mesh.halfedge_edge[h]] ? 1 : 0;
            changes += wedge[r] != wedge[h] ? 1 : 0;
            h = r;
        } while (h != start);
        const Index expected = std::max<Index>(1, cut_degree);
        HOLOFLOW_REQUIRE(std::max<Index>(1, changes) == expected,
                         "corner_wedge at vertex " + std::to_string(v) + " has " +
                             std::to_string(changes) + " wedge changes for " +
                             std::to_string(cut_degree) + " cut edges");
        classes += expected;
    }
    HOLOFLOW_REQUIRE(classes == basis.n_wedges, "n_wedges disagrees with corner_wedge");
    for (Index w = 0; w < basis.n_wedges; ++w)
        HOLOFLOW_REQUIRE(wedge_vertex[w] >= 0, "wedge " + std::to_string(w) + " is unused");

    CutTopology topology;
    topology.euler_characteristic = basis.n_wedges - (n_e + n_cut) + mesh.n_faces();
    // Boundary of the cut-open mesh, face on the left: after a cut halfedge h swing clockwise
    // around head(h) through uncut edges to the next cut halfedge.
    std::vector<char> visited(n_h, 0);
    for (Index h0 = 0; h0 < n_h; ++h0) {
        if (visited[h0] || !cut[mesh.halfedge_edge[h0]]) continue;
        ++topology.boundary_loops;
        Index h = h0;
        do {
            visited[h] = 1;
            Index g = MeshView::next(h);
            while (!cut[mesh.halfedge_edge[g]]) g = MeshView::next(mesh.twin[g]);
            h = g;
        } while (h != h0);
    }
    return topology;
}

}  // namespace holoflow::kernels
