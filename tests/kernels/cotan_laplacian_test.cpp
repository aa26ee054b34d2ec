#include "holoflow/kernels/cotan_laplacian.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <Eigen/Sparse>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/mesh_view.h"
#include "holoflow/kernels/shapes.h"

namespace holoflow::kernels {
namespace {

constexpr double kCotTol = 1e-14;     // a few roundings of O(1) cotangents
constexpr double kRowSumTol = 1e-12;  // sums over ~10 entries of O(1..100) values
constexpr std::uint64_t kLaplacianSeed = 20240611;

Eigen::SparseMatrix<double> full_matrix(const LaplacianMatrix& L) {
    std::vector<Eigen::Triplet<double>> t;
    for (Index j = 0; j < L.n; ++j) {
        for (Index s = L.col_start[j]; s < L.col_start[j + 1]; ++s) {
            t.emplace_back(L.row[s], j, L.value[s]);
            if (L.row[s] != j) t.emplace_back(j, L.row[s], L.value[s]);
        }
    }
    Eigen::SparseMatrix<double> A(L.n, L.n);
    A.setFromTriplets(t.begin(), t.end());
    return A;
}

//! Side lengths of every edge of a mesh, for the intrinsic formula.
std::vector<double> side_lengths(const MeshView& mesh) {
    std::vector<double> l(static_cast<std::size_t>(mesh.n_edges()));
    for (Index e = 0; e < mesh.n_edges(); ++e)
        l[e] = (mesh.V.row(mesh.E(e, 1)) - mesh.V.row(mesh.E(e, 0))).norm();
    return l;
}

//! Edge of the mesh joining a and b (either orientation), -1 if none.
Index find_edge(const MeshView& mesh, Index a, Index b) {
    for (Index e = 0; e < mesh.n_edges(); ++e)
        if ((mesh.E(e, 0) == a && mesh.E(e, 1) == b) || (mesh.E(e, 0) == b && mesh.E(e, 1) == a))
            return e;
    return -1;
}

MeshView right_isosceles() {
    PointMatrix V(3, 3);
    V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    TriangleMatrix F(1, 3);
    F << 0, 1, 2;
    return make_mesh_view(V, F);
}

TEST(CotanWeights, RightIsoscelesTriangle) {
    const MeshView mesh = right_isosceles();
    const std::vector<double> w = cotan_weights(mesh);
    // Legs face the 45 degree corners (cot = 1, one face: 1/2); the hypotenuse faces 90 degrees.
    EXPECT_NEAR(w[find_edge(mesh, 0, 1)], 0.5, kCotTol);
    EXPECT_NEAR(w[find_edge(mesh, 2, 0)], 0.5, kCotTol);
    EXPECT_NEAR(w[find_edge(mesh, 1, 2)], 0.0, kCotTol);
    const std::vector<double> wl =
        cotan_weights_from_lengths(mesh.halfedge_edge, side_lengths(mesh), mesh.n_edges());
    for (Index e = 0; e < mesh.n_edges(); ++e) EXPECT_NEAR(wl[e], w[e], kCotTol);
}

TEST(CotanWeights, RectangularGridHasAspectRatioWeights) {
    const int nx = 4, ny = 3;  // cells 1/4 wide, 1/3 tall: right triangles with legs dx, dy
    const MeshView mesh = shapes::flat_grid(nx, ny);
    const std::vector<double> w = cotan_weights(mesh);
    const double dx = 1.0 / nx, dy = 1.0 / ny;
    int n_horizontal = 0, n_vertical = 0, n_diagonal = 0;
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        const Eigen::RowVector3d a = mesh.V.row(mesh.E(e, 0)), b = mesh.V.row(mesh.E(e, 1));
        const bool boundary = mesh.twin[mesh.edge_halfedge[e]] == kNoHalfedge;
        const double faces = boundary ? 1.0 : 2.0;
        // A leg of length dx faces the angle atan(dx/dy): cot = dy/dx per adjacent triangle.
        if (std::abs(a.y() - b.y()) < 1e-12) {
            EXPECT_NEAR(w[e], faces * 0.5 * dy / dx, kCotTol) << "edge " << e;
            ++n_horizontal;
        } else if (std::abs(a.x() - b.x()) < 1e-12) {
            EXPECT_NEAR(w[e], faces * 0.5 * dx / dy, kCotTol) << "edge " << e;
            ++n_vertical;
        } else {
            EXPECT_NEAR(w[e], 0.0, kCotTol) << "diagonal edge " << e;  // faces right angles
            ++n_diagonal;
        }
    }
    EXPECT_EQ(n_horizontal, nx * (ny + 1));
    EXPECT_EQ(n_vertical, (nx + 1) * ny);
    EXPECT_EQ(n_diagonal, nx * ny);
}

TEST(CotanWeights, IntrinsicEqualsExtrinsic) {
    for (const MeshView& mesh : {shapes::icosphere(2), shapes::torus(2.0, 0.7, 16, 9)}) {
        const std::vector<double> w = cotan_weights(mesh);
        const std::vector<double> wl =
            cotan_weights_from_lengths(mesh.halfedge_edge, side_lengths(mesh), mesh.n_edges());
        ASSERT_EQ(w.size(), wl.size());
        for (std::size_t e = 0; e < w.size(); ++e) EXPECT_NEAR(wl[e], w[e], 1e-12) << e;
    }
}

TEST(CotanWeights, SameBitsOnOneOrTwoThreads) {
    const MeshView mesh = shapes::torus(2.0, 0.7, 100, 60);  // 18000 edges: parallel loops
    const std::vector<double> lengths = side_lengths(mesh);
    std::vector<double> serial, parallel, serial_l, parallel_l;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        serial = cotan_weights(mesh);
        serial_l = cotan_weights_from_lengths(mesh.halfedge_edge, lengths, mesh.n_edges());
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        parallel = cotan_weights(mesh);
        parallel_l = cotan_weights_from_lengths(mesh.halfedge_edge, lengths, mesh.n_edges());
    }
    EXPECT_EQ(serial, parallel);
    EXPECT_EQ(serial_l, parallel_l);
}

TEST(CotanWeights, ObtuseTriangleGivesNegativeWeight) {
    PointMatrix V(4, 3);  // rhombus-like pair of triangles sharing edge 0-1 with obtuse apexes
    V << 0, 0, 0, 2, 0, 0, 1, 0.2, 0, 1, -0.2, 0;
    TriangleMatrix F(2, 3);
    F << 0, 1, 2, 1, 0, 3;
    const MeshView mesh = make_mesh_view(V, F);
    const std::vector<double> w = cotan_weights(mesh);
    // Apex angle 2 atan(1/0.2): cot = (0.2^2 - 1) / (2 * 0.2) per face.
    const double cot_apex = (0.2 * 0.2 - 1.0) / (2 * 0.2);
    EXPECT_NEAR(w[find_edge(mesh, 0, 1)], cot_apex, kCotTol);
    EXPECT_LT(w[find_edge(mesh, 0, 1)], 0.0);
}

TEST(CotanWeights, DegenerateInputThrows) {
    PointMatrix V(3, 3);
    V << 0, 0, 0, 1, 0, 0, 2, 0, 0;  // collinear: zero area
    TriangleMatrix F(1, 3);
    F << 0, 1, 2;
    const MeshView mesh = make_mesh_view(V, F);
    EXPECT_THROW(cotan_weights(mesh), InvalidInput);
    const std::vector<double> bad = {1.0, 1.0, 3.0};  // violates the triangle inequality
    EXPECT_THROW(cotan_weights_from_lengths(mesh.halfedge_edge, bad, 3), InvalidInput);
    const std::vector<double> negative = {1.0, -1.0, 1.0};
    EXPECT_THROW(cotan_weights_from_lengths(mesh.halfedge_edge, negative, 3), InvalidInput);
    EXPECT_THROW(cotan_weights_from_lengths(mesh.halfedge_edge, bad, 2), InvalidInput);
}

TEST(Laplacian, ClosedMeshAnnihilatesConstants) {
    for (const MeshView& mesh : {shapes::icosphere(3), shapes::torus(2.0, 0.5, 24, 12)}) {
        const std::vector<double> w = cotan_weights(mesh);
        const LaplacianMatrix L = assemble_laplacian(mesh.n_vertices(), mesh.E, w, {});
        const Eigen::VectorXd ones = Eigen::VectorXd::Ones(L.n);
        const Eigen::VectorXd r = full_matrix(L) * ones;
        EXPECT_LT(r.cwiseAbs().maxCoeff(), kRowSumTol);
        // Not trivially zero: the diagonal carries the weights.
        EXPECT_GT(Eigen::Map<const Eigen::VectorXd>(L.value.data(), L.nonzeros()).norm(), 1.0);
    }
}

TEST(Laplacian, LinearPrecisionOnJitteredPlanarGrid) {
    MeshView mesh = shapes::flat_grid(12, 10);
    std::mt19937_64 rng(kLaplacianSeed);
    SCOPED_TRACE(kLaplacianSeed);
    std::uniform_real_distribution<double> jitter(-0.2, 0.2);  // times the cell size: no fold
    std::vector<char> boundary(static_cast<std::size_t>(mesh.n_vertices()), 0);
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (mesh.is_boundary_halfedge(h)) boundary[mesh.tail(h)] = boundary[mesh.head(h)] = 1;
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        if (boundary[v]) continue;
        mesh.V(v, 0) += jitter(rng) / 12;
        mesh.V(v, 1) += jitter(rng) / 10;
    }
    const LaplacianMatrix L =
        assemble_laplacian(mesh.n_vertices(), mesh.E, cotan_weights(mesh), {});
    const Eigen::SparseMatrix<double> A = full_matrix(L);
    int n_interior = 0;
    for (int c = 0; c < 2; ++c) {
        const Eigen::VectorXd x = mesh.V.col(c);
        const Eigen::VectorXd Lx = A * x;
        for (Index v = 0; v < mesh.n_vertices(); ++v) {
            if (boundary[v]) continue;
            EXPECT_NEAR(Lx[v], 0.0, kRowSumTol) << "vertex " << v << " coordinate " << c;
            n_interior += c == 0;
        }
    }
    EXPECT_EQ(n_interior, 11 * 9);
}

//! Random edge list on n vertices with repeated pairs (both orientations) and loops.
EdgeMatrix random_edges(Index n, Index n_edges, std::mt19937_64& rng) {
    std::uniform_int_distribution<Index> vertex(0, n - 1);
    EdgeMatrix E(n_edges, 2);
    for (Index e = 0; e < n_edges; ++e) E.row(e) << vertex(rng), vertex(rng);
    E.row(0) << 3, 7;
    E.row(1) << 7, 3;  // repeated pair, reversed
    E.row(2) << 3, 7;
    E.row(3) << 5, 5;  // loop
    return E;
}

TEST(Laplacian, AssemblyEqualsTripletReference) {
    std::mt19937_64 rng(kLaplacianSeed);
    SCOPED_TRACE(kLaplacianSeed);
    const Index n = 40;
    const EdgeMatrix E = random_edges(n, 150, rng);
    std::uniform_real_distribution<double> weight(-1.0, 3.0);
    std::vector<double> w(static_cast<std::size_t>(E.rows()));
    for (double& x : w) x = weight(rng);
    const std::vector<Index> pinned = {11, 0};

    const LaplacianMatrix L = assemble_laplacian(n, E, w, pinned);
    // Pattern: strictly increasing rows within a column, all in the upper triangle, diagonal last.
    ASSERT_EQ(L.col_start.size(), static_cast<std::size_t>(n) + 1);
    for (Index j = 0; j < n; ++j) {
        EXPECT_EQ(L.diagonal_slot[j], L.col_start[j + 1] - 1);
        EXPECT_EQ(L.row[L.diagonal_slot[j]], j);
        for (Index s = L.col_start[j] + 1; s < L.col_start[j + 1]; ++s)
            EXPECT_LT(L.row[s - 1], L.row[s]);
    }
    EXPECT_EQ(L.edge_slot[3], -1);
    EXPECT_EQ(L.edge_slot[0], L.edge_slot[1]);
    EXPECT_EQ(L.edge_slot[0], L.edge_slot[2]);

    std::vector<Eigen::Triplet<double>> t;
    for (Index e = 0; e < E.rows(); ++e) {
        const Index a = std::min(E(e, 0), E(e, 1)), b = std::max(E(e, 0), E(e, 1));
        if (a == b) continue;
        t.emplace_back(a, b, -w[e]);
        t.emplace_back(a, a, w[e]);
        t.emplace_back(b, b, w[e]);
    }
    for (Index j = 0; j < n; ++j) t.emplace_back(j, j, 0.0);  // explicit diagonal everywhere
    Eigen::SparseMatrix<double> ref(n, n);
    ref.setFromTriplets(t.begin(), t.end());
    for (Index p : pinned) {
        for (Index k = 0; k < n; ++k) {
            if (k <= p && ref.coeff(k, p) != 0) ref.coeffRef(k, p) = 0;
            if (k >= p && ref.coeff(p, k) != 0) ref.coeffRef(p, k) = 0;
        }
        ref.coeffRef(p, p) = 1.0;
    }
    Index n_ref = 0;
    for (Index j = 0; j < n; ++j) {
        for (Eigen::SparseMatrix<double>::InnerIterator it(ref, j); it; ++it) {
            const Index i = static_cast<Index>(it.row());
            const auto begin = L.row.begin() + L.col_start[j];
            const auto end = L.row.begin() + L.col_start[j + 1];
            const auto found = std::lower_bound(begin, end, i);
            if (found == end || *found != i) {
                EXPECT_EQ(it.value(), 0.0) << "entry (" << i << ", " << j << ") missing";
                continue;
            }
            ++n_ref;
            EXPECT_NEAR(L.value[found - L.row.begin()], it.value(), kRowSumTol)
                << "entry (" << i << ", " << j << ")";
        }
    }
    EXPECT_EQ(n_ref, L.nonzeros());  // no stored entry without a counterpart
}

TEST(Laplacian, QuadraticFormAndOrientationIndependence) {
    std::mt19937_64 rng(kLaplacianSeed + 1);
    SCOPED_TRACE(kLaplacianSeed + 1);
    const Index n = 30;
    EdgeMatrix E = random_edges(n, 100, rng);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    std::vector<double> w(static_cast<std::size_t>(E.rows()));
    for (double& x : w) x = uniform(rng);
    const LaplacianMatrix L = assemble_laplacian(n, E, w, {});
    const Eigen::SparseMatrix<double> A = full_matrix(L);
    EXPECT_EQ((A - Eigen::SparseMatrix<double>(A.transpose())).norm(), 0.0);  // symmetric
    for (int trial = 0; trial < 3; ++trial) {
        Eigen::VectorXd x(n);
        for (Index v = 0; v < n; ++v) x[v] = uniform(rng);
        double energy = 0;
        for (Index e = 0; e < E.rows(); ++e)
            energy += w[e] * (x[E(e, 0)] - x[E(e, 1)]) * (x[E(e, 0)] - x[E(e, 1)]);
        EXPECT_NEAR(x.dot(A * x), energy, kRowSumTol);
    }
    EdgeMatrix reversed = E.rowwise().reverse();
    const LaplacianMatrix R = assemble_laplacian(n, reversed, w, {});
    EXPECT_EQ(R.row, L.row);
    EXPECT_EQ(R.col_start, L.col_start);
    EXPECT_EQ(R.value, L.value);
}

TEST(Laplacian, RefillEqualsFreshAssembly) {
    MeshView mesh = shapes::torus(2.0, 0.6, 20, 10);
    const std::vector<Index> pinned = {0};
    LaplacianMatrix L = assemble_laplacian(mesh.n_vertices(), mesh.E, cotan_weights(mesh), pinned);
    const std::vector<Index> row = L.row, col_start = L.col_start;
    std::mt19937_64 rng(kLaplacianSeed + 2);
    SCOPED_TRACE(kLaplacianSeed + 2);
    std::uniform_real_distribution<double> move(-0.05, 0.05);
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        for (int c = 0; c < 3; ++c) mesh.V(v, c) += move(rng);
    const std::vector<double> moved = cotan_weights(mesh);
    const std::vector<double> old_value = L.value;
    fill_laplacian(L, moved);
    const LaplacianMatrix fresh = assemble_laplacian(mesh.n_vertices(), mesh.E, moved, pinned);
    EXPECT_EQ(L.row, row);
    EXPECT_EQ(L.col_start, col_start);
    EXPECT_EQ(L.value, fresh.value);  // bit for bit
    EXPECT_NE(L.value, old_value);
}

TEST(Laplacian, InvalidInputThrows) {
    EdgeMatrix E(2, 2);
    E << 0, 1, 1, 4;
    EXPECT_THROW(laplacian_pattern(4, E, {}), InvalidInput);
    E(1, 1) = 2;
    EXPECT_THROW(laplacian_pattern(4, E, {7}), InvalidInput);
    LaplacianMatrix L = laplacian_pattern(4, E, {});
    const std::vector<double> w = {1.0};
    EXPECT_THROW(fill_laplacian(L, w), InvalidInput);
}

}  // namespace
}  // namespace holoflow::kernels
