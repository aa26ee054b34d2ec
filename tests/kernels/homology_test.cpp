#include "holoflow/kernels/homology.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/subdivision.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

// Forms dual to a tree-cotree basis are small integers and the face sums are formed from them in
// doubles, so closedness, periods and wedge matrix are exact: these tests compare with ==.
constexpr double kGeometryTol = 1e-12;  // sums of O(1) products of coordinates in [0, 1]

Eigen::MatrixXi standard_symplectic(int g) {
    Eigen::MatrixXi S = Eigen::MatrixXi::Zero(2 * g, 2 * g);
    S.topRightCorner(g, g).setIdentity();
    S.bottomLeftCorner(g, g) = -Eigen::MatrixXi::Identity(g, g);
    return S;
}

Eigen::MatrixXi rounded(const Eigen::MatrixXd& A) { return A.array().round().cast<int>().matrix(); }

// Independent partition of corners into fundamental-domain vertices: union-find across every
// uncut edge. Returns the number of classes and checks corner_wedge induces the same partition.
Index check_wedges_by_union_find(const MeshView& mesh, const HomologyBasis& b) {
    std::vector<Index> parent(mesh.n_halfedges());
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](Index x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (!b.cut_edge[mesh.halfedge_edge[h]])
            parent[find(h)] = find(MeshView::next(mesh.twin[h]));
    std::map<Index, Index> class_to_wedge, wedge_to_class;
    for (Index h = 0; h < mesh.n_halfedges(); ++h) {
        const Index c = find(h), w = b.corner_wedge[h];
        const auto [it1, new1] = class_to_wedge.emplace(c, w);
        const auto [it2, new2] = wedge_to_class.emplace(w, c);
        EXPECT_EQ(it1->second, w) << "corner " << h;
        EXPECT_EQ(it2->second, c) << "corner " << h;
    }
    return static_cast<Index>(class_to_wedge.size());
}

// Every invariant of a tree-cotree homology basis on a closed connected mesh of genus g.
void check_homology_basis(const MeshView& mesh, const HomologyBasis& b, int genus) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges(), n_g = 2 * genus;
    ASSERT_EQ(b.genus, genus);
    ASSERT_EQ(static_cast<Index>(b.generator_edges.size()), n_g);
    ASSERT_TRUE(std::is_sorted(b.generator_edges.begin(), b.generator_edges.end()));

    // Primal tree: one parent per vertex but the root, each edge at most once.
    ASSERT_EQ(static_cast<Index>(b.tree_parent_halfedge.size()), n_v);
    std::vector<char> in_tree(n_e, 0);
    for (Index v = 0; v < n_v; ++v) {
        const Index h = b.tree_parent_halfedge[v];
        if (v == b.root) {
            EXPECT_EQ(h, kNoHalfedge);
            continue;
        }
        ASSERT_NE(h, kNoHalfedge) << "vertex " << v;
        EXPECT_EQ(mesh.head(h), v);
        EXPECT_FALSE(in_tree[mesh.halfedge_edge[h]]);
        in_tree[mesh.halfedge_edge[h]] = 1;
    }
    for (const Index e : b.generator_edges) EXPECT_FALSE(in_tree[e]) << "generator " << e;

    // Closed forms: exactly closed on every face, 0 on the tree, identity on the generators.
    ASSERT_EQ(b.closed_forms.rows(), n_e);
    ASSERT_EQ(b.closed_forms.cols(), n_g);
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(n_g);
        for (Index h = 3 * f; h < 3 * f + 3; ++h)
            sum += mesh.edge_sign(h) * b.closed_forms.row(mesh.halfedge_edge[h]);
        for (Index j = 0; j < n_g; ++j) ASSERT_EQ(sum(j), 0.0) << "face " << f << " form " << j;
    }
    for (Index e = 0; e < n_e; ++e) {
        if (!in_tree[e]) continue;
        ASSERT_EQ(b.closed_forms.row(e).cwiseAbs().sum(), 0.0) << "edge " << e;
    }
    for (Index j = 0; j < n_g; ++j)
        for (Index i = 0; i < n_g; ++i)
            EXPECT_EQ(b.closed_forms(b.generator_edges[j], i), i == j ? 1.0 : 0.0);

    // Loops: closed, simple, through their generator once; periods are exactly delta_ij.
    ASSERT_EQ(static_cast<Index>(b.loops.size()), n_g);
    for (Index j = 0; j < n_g; ++j) {
        const auto& loop = b.loops[j];
        ASSERT_FALSE(loop.empty());
        std::set<Index> vertices;
        Index through_generator = 0;
        for (std::size_t k = 0; k < loop.size(); ++k) {
            EXPECT_EQ(mesh.head(loop[k]), mesh.tail(loop[(k + 1) % loop.size()]))
                << "loop " << j << " step " << k;
            EXPECT_TRUE(vertices.insert(mesh.tail(loop[k])).second) << "loop " << j;
            if (mesh.halfedge_edge[loop[k]] == b.generator_edges[j]) ++through_generator;
        }
        EXPECT_EQ(through_generator, 1);
        const Eigen::VectorXd periods = integrate_along(mesh, b.closed_forms, loop);
        for (Index i = 0; i < n_g; ++i) EXPECT_EQ(periods(i), i == j ? 1.0 : 0.0);
    }
    // All loops at once: the same sums, on forms that are not integers too.
    const Eigen::MatrixXd noisy = b.closed_forms + 1e-3 * Eigen::MatrixXd::Random(b.closed_forms.rows(), n_g);
    const Eigen::MatrixXd all = integrate_along_paths(mesh, noisy, b.loops);
    ASSERT_EQ(all.rows(), n_g);
    ASSERT_EQ(all.cols(), n_g);
    for (Index j = 0; j < n_g; ++j) EXPECT_EQ(all.col(j), integrate_along(mesh, noisy, b.loops[j]));

    // Wedge matrix of the dual forms: integral, skew, unimodular; the canonical basis puts it in
    // standard form, also when recomputed from the transformed forms.
    const Eigen::MatrixXd A = wedge_matrix(mesh, b.closed_forms);
    ASSERT_EQ(A.rows(), n_g);
    const Eigen::MatrixXi J = rounded(A);
    EXPECT_EQ(A, J.cast<double>()) << "wedge matrix not integral:\n" << A;
    EXPECT_EQ(J, Eigen::MatrixXi(-J.transpose()));
    if (genus > 0) {
        // P^T J P = standard with P integral forces det(J) det(P)^2 = 1: both unimodular.
        const Eigen::MatrixXi P = symplectic_basis(J);
        EXPECT_EQ(Eigen::MatrixXi(P.transpose() * J * P), standard_symplectic(genus));
        const Eigen::MatrixXd canonical_forms = b.closed_forms * P.cast<double>();
        EXPECT_EQ(wedge_matrix(mesh, canonical_forms), standard_symplectic(genus).cast<double>());
    }

    // Cut graph: a subgraph of tree + generators, containing every generator, with no dangling
    // vertex and cycle rank 2g (one connected graph carrying the 2g independent cycles).
    ASSERT_EQ(static_cast<Index>(b.cut_edge.size()), n_e);
    std::vector<Index> cut_degree(n_v, 0);
    Index n_cut = 0;
    for (Index e = 0; e < n_e; ++e) {
        if (!b.cut_edge[e]) continue;
        ++n_cut;
        ++cut_degree[mesh.E(e, 0)];
        ++cut_degree[mesh.E(e, 1)];
        EXPECT_TRUE(in_tree[e] ||
                    std::binary_search(b.generator_edges.begin(), b.generator_edges.end(), e));
    }
    for (const Index e : b.generator_edges) EXPECT_TRUE(b.cut_edge[e]);
    Index n_cut_vertices = 0;
    for (Index v = 0; v < n_v; ++v) {
        EXPECT_NE(cut_degree[v], 1) << "dangling vertex " << v;
        n_cut_vertices += cut_degree[v] > 0 ? 1 : 0;
    }
    if (genus > 0) {
        EXPECT_EQ(n_cut - n_cut_vertices + 1, n_g);
    }

    // Fundamental domain: a disk (a sphere when there is nothing to cut).
    ASSERT_EQ(static_cast<Index>(b.corner_wedge.size()), mesh.n_halfedges());
    EXPECT_EQ(check_wedges_by_union_find(mesh, b), b.n_wedges);
    const CutTopology cut = fundamental_domain_topology(mesh, b);
    EXPECT_EQ(cut.euler_characteristic, genus > 0 ? 1 : 2);
    EXPECT_EQ(cut.boundary_loops, genus > 0 ? 1 : 0);
    EXPECT_EQ(cut.euler_characteristic, b.n_wedges - (n_e + n_cut) + mesh.n_faces());
}

void expect_identical(const HomologyBasis& a, const HomologyBasis& b) {
    EXPECT_EQ(a.genus, b.genus);
    EXPECT_EQ(a.root, b.root);
    EXPECT_EQ(a.tree_parent_halfedge, b.tree_parent_halfedge);
    EXPECT_EQ(a.generator_edges, b.generator_edges);
    EXPECT_EQ(a.loops, b.loops);
    ASSERT_EQ(a.closed_forms.rows(), b.closed_forms.rows());
    ASSERT_EQ(a.closed_forms.cols(), b.closed_forms.cols());
    EXPECT_EQ(0, std::memcmp(a.closed_forms.data(), b.closed_forms.data(),
                             sizeof(double) * a.closed_forms.size()));
    EXPECT_EQ(a.cut_edge, b.cut_edge);
    EXPECT_EQ(a.corner_wedge, b.corner_wedge);
    EXPECT_EQ(a.n_wedges, b.n_wedges);
}

TEST(Homology, TorusHasTwoGeneratorsAndStandardWedgeMatrix) {
    const MeshView torus = shapes::torus(2.0, 0.5, 24, 12);
    const HomologyBasis b = compute_homology_basis(torus);
    check_homology_basis(torus, b, 1);
    const Eigen::MatrixXd A = wedge_matrix(torus, b.closed_forms);
    const Eigen::MatrixXd S = standard_symplectic(1).cast<double>();
    EXPECT_TRUE(A == S || A == -S) << A;
}

TEST(Homology, GenusSurfacesHaveUnimodularIntersection) {
    for (int g = 2; g <= 4; ++g) {
        SCOPED_TRACE("genus " + std::to_string(g));
        const MeshView mesh = shapes::genus_surface(g, 2);
        check_homology_basis(mesh, compute_homology_basis(mesh), g);
    }
}

// On more than 20000 edges the closed forms are peeled in parallel, each form its own column:
// one thread or two, the same bits.
TEST(Homology, SameBitsOnOneOrTwoThreads) {
    const MeshView mesh = subdivide_midpoint(subdivide_midpoint(subdivide_midpoint(shapes::genus_surface(6, 2))));
    ASSERT_GT(mesh.n_edges(), 20000);
    HomologyBasis one, two;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = compute_homology_basis(mesh);
    }
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
        two = compute_homology_basis(mesh);
    }
    check_homology_basis(mesh, two, 6);
    expect_identical(one, two);
}

// Sparse forms are the dense ones without their zeros, also where the columns are peeled in
// parallel (more than 20000 edges), on one thread or two; their wedge matrix and periods along
// the loops are the dense ones'.
TEST(Homology, SparseFormsAreTheDenseOnes) {
    for (const MeshView& mesh : {shapes::genus_surface(3, 2),
                                 subdivide_midpoint(subdivide_midpoint(subdivide_midpoint(shapes::genus_surface(6, 2))))}) {
        SCOPED_TRACE(std::to_string(mesh.n_edges()) + " edges");
        const HomologyBasis dense = compute_homology_basis(mesh);
        HomologyOptions options;
        options.sparse_forms = true;
        for (int threads : {1, 2}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            const HomologyBasis sparse = compute_homology_basis(mesh, options);
            EXPECT_EQ(sparse.closed_forms.size(), 0);
            EXPECT_TRUE(Eigen::MatrixXd(sparse.sparse_closed_forms) == dense.closed_forms) << threads << " threads";
            EXPECT_EQ(sparse.sparse_closed_forms.nonZeros(), (dense.closed_forms.array() != 0.0).count());
            EXPECT_EQ(sparse.loops, dense.loops);
            EXPECT_EQ(sparse.cut_edge, dense.cut_edge);
            EXPECT_TRUE(wedge_matrix(mesh, sparse.sparse_closed_forms) == wedge_matrix(mesh, dense.closed_forms));
            EXPECT_TRUE(integrate_along_paths(mesh, sparse.sparse_closed_forms, dense.loops) ==
                        integrate_along_paths(mesh, dense.closed_forms, dense.loops));
        }
        EXPECT_EQ(dense.sparse_closed_forms.size(), 0);
    }
}

TEST(Homology, SubdividedSurfaceKeepsInvariants) {
    const MeshView mesh = subdivide_midpoint(shapes::genus_surface(3, 1));
    check_homology_basis(mesh, compute_homology_basis(mesh), 3);
}

TEST(Homology, AnyRootGivesABasis) {
    const MeshView mesh = shapes::genus_surface(2, 1);
    for (const Index root : {Index{0}, mesh.n_vertices() / 2, mesh.n_vertices() - 1}) {
        SCOPED_TRACE("root " + std::to_string(root));
        const HomologyBasis b = compute_homology_basis(mesh, {root});
        EXPECT_EQ(b.root, root);
        check_homology_basis(mesh, b, 2);
    }
}

TEST(Homology, DefaultRootIsNearestTheCentroid) {
    const MeshView mesh = shapes::genus_surface(2, 2);
    const HomologyBasis b = compute_homology_basis(mesh);
    const Eigen::RowVector3d c = mesh.V.colwise().mean();
    const double farthest = (mesh.V.rowwise() - c).rowwise().norm().maxCoeff();
    // Distances are compared on a grid of 2^-30 of the largest.
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        EXPECT_GE((mesh.V.row(v) - c).norm(), (mesh.V.row(b.root) - c).norm() - std::ldexp(farthest, -30));
}

TEST(Homology, MovedTurnedAndScaledTorusGivesTheSameBasis) {
    // A torus of revolution is full of equally long paths (and its centroid is equally far from
    // a whole ring of vertices): the basis must not be picked by rounding, which differs
    // between copies.
    const MeshView mesh = shapes::torus(3.0, 1.0, 24, 12);
    const HomologyBasis b = compute_homology_basis(mesh);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    for (const double scale : {10.0, 1e-3, 3.7}) {
        SCOPED_TRACE(scale);
        MeshView copy = mesh;
        for (Index v = 0; v < copy.n_vertices(); ++v)
            copy.V.row(v) = scale * (R * mesh.V.row(v).transpose()).transpose() + Eigen::RowVector3d(1, -2, 5);
        const HomologyBasis c = compute_homology_basis(copy);
        EXPECT_EQ(c.root, b.root);
        EXPECT_EQ(c.tree_parent_halfedge, b.tree_parent_halfedge);
        EXPECT_EQ(c.generator_edges, b.generator_edges);
    }
}

TEST(Homology, PrimalTreeIsAShortestPathTree) {
    // Distances along the tree satisfy d(w) <= d(v) + |vw| on every edge: Bellman's optimality.
    const MeshView mesh = subdivide_midpoint(shapes::torus(3.0, 1.0, 17, 9));
    const HomologyBasis b = compute_homology_basis(mesh);
    std::vector<double> d(mesh.n_vertices(), -1.0);
    d[b.root] = 0.0;
    auto distance = [&](auto&& self, Index v) -> double {
        if (d[v] >= 0.0) return d[v];
        const Index h = b.tree_parent_halfedge[v];
        const Index u = mesh.tail(h);
        return d[v] = self(self, u) + (mesh.V.row(v) - mesh.V.row(u)).norm();
    };
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        const Index u = mesh.E(e, 0), w = mesh.E(e, 1);
        const double len = (mesh.V.row(u) - mesh.V.row(w)).norm();
        EXPECT_LE(distance(distance, w), distance(distance, u) + len + kGeometryTol);
        EXPECT_LE(distance(distance, u), distance(distance, w) + len + kGeometryTol);
    }
}

TEST(Homology, RunsTwiceBitForBit) {
    for (int g = 1; g <= 4; ++g) {
        const MeshView mesh =
            g == 1 ? shapes::torus(2.0, 0.7, 30, 14) : shapes::genus_surface(g, 2);
        expect_identical(compute_homology_basis(mesh), compute_homology_basis(mesh));
    }
}

TEST(Homology, DoubleCoverWithTwoEdgesOnAVertexPair) {
    // A one-cell-tall tube has only boundary vertices; its double is a torus whose every interior
    // edge of the tube exists twice on the same vertex pair.
    const DoubleCover cover = double_cover(shapes::cylinder(1.0, 0.5, 7, 1));
    const MeshView& mesh = cover.mesh;
    std::map<std::pair<Index, Index>, int> pair_count;
    for (Index e = 0; e < mesh.n_edges(); ++e)
        ++pair_count[std::minmax(mesh.E(e, 0), mesh.E(e, 1))];
    const auto multi = std::count_if(pair_count.begin(), pair_count.end(),
                                     [](const auto& kv) { return kv.second > 1; });
    ASSERT_GT(multi, 0);
    const HomologyBasis b = compute_homology_basis(mesh);
    check_homology_basis(mesh, b, 1);
    expect_identical(b, compute_homology_basis(mesh));
}

TEST(Homology, DoubleCoverOfPerforatedSheet) {
    // genus = 2g + b - 1 = holes for a planar sheet with `holes` holes (b = holes + 1).
    const DoubleCover cover = double_cover(shapes::perforated_sheet(3, 1));
    check_homology_basis(cover.mesh, compute_homology_basis(cover.mesh), 3);
}

TEST(Homology, SphereHasNothingToCut) {
    const MeshView sphere = shapes::icosphere(2);
    const HomologyBasis b = compute_homology_basis(sphere);
    check_homology_basis(sphere, b, 0);
    EXPECT_EQ(std::count(b.cut_edge.begin(), b.cut_edge.end(), 1), 0);
    EXPECT_EQ(b.n_wedges, sphere.n_vertices());
}

TEST(Homology, RejectsOpenDisconnectedAndBadRoot) {
    EXPECT_THROW(compute_homology_basis(shapes::flat_grid(3, 3)), InvalidInput);
    const MeshView a = shapes::torus(2.0, 0.5, 6, 4);
    PointMatrix V(2 * a.n_vertices(), 3);
    V << a.V, a.V.array() + 10.0;
    TriangleMatrix F(2 * a.n_faces(), 3);
    F << a.F, a.F.array() + a.n_vertices();
    const MeshView two = make_mesh_view(std::move(V), std::move(F));
    EXPECT_THROW(compute_homology_basis(two), InvalidInput);
    EXPECT_THROW(compute_homology_basis(a, {a.n_vertices()}), InvalidInput);
    EXPECT_THROW(compute_homology_basis(a, {-2}), InvalidInput);
}

TEST(Homology, IntegrateExactFormAlongPath) {
    // d f for f = x + 2y integrates to f(end) - f(start) along any path, to 0 around any loop.
    const MeshView mesh = shapes::torus(2.0, 0.5, 12, 8);
    Eigen::MatrixXd df(mesh.n_edges(), 1);
    auto f = [&](Index v) { return mesh.V(v, 0) + 2.0 * mesh.V(v, 1); };
    for (Index e = 0; e < mesh.n_edges(); ++e) df(e, 0) = f(mesh.E(e, 1)) - f(mesh.E(e, 0));
    const HomologyBasis b = compute_homology_basis(mesh);
    for (const auto& loop : b.loops)
        EXPECT_NEAR(integrate_along(mesh, df, loop)(0), 0.0, kGeometryTol);
    const std::vector<Index> path{0, MeshView::next(0)};
    EXPECT_NEAR(integrate_along(mesh, df, path)(0), f(mesh.head(path[1])) - f(mesh.tail(0)),
                kGeometryTol);
    const std::vector<Index> bad{mesh.n_halfedges()};
    EXPECT_THROW(integrate_along(mesh, df, bad), InvalidInput);
    EXPECT_THROW(wedge_matrix(mesh, Eigen::MatrixXd(3, 1)), InvalidInput);
}

TEST(Homology, WedgeOfCoordinateDifferentialsIsArea) {
    // On the unit square, integral of dx ^ dy = 1 and dx ^ dx = 0, for any triangulation.
    const MeshView square = shapes::flat_grid(5, 3);
    Eigen::MatrixXd forms(square.n_edges(), 2);
    for (Index e = 0; e < square.n_edges(); ++e)
        forms.row(e) =
            square.V.row(square.E(e, 1)).head<2>() - square.V.row(square.E(e, 0)).head<2>();
    const Eigen::MatrixXd A = wedge_matrix(square, forms);
    EXPECT_NEAR(A(0, 1), 1.0, kGeometryTol);
    EXPECT_NEAR(A(1, 0), -1.0, kGeometryTol);
    EXPECT_EQ(A(0, 0), 0.0);
    EXPECT_EQ(A(1, 1), 0.0);
}

TEST(Homology, WedgeMatrixIgnoresExactParts) {
    // Adding d(phi) to closed forms leaves every wedge integral unchanged on a closed surface
    // (per face dphi ^ eta integrates to boundary terms that cancel across each edge). The forms
    // become dense, so this also checks the dense product against the sparse one.
    constexpr double kRoundingTol = 1e-10;  // ~1e4 faces of O(1) products
    const MeshView mesh = shapes::genus_surface(3, 2);
    const HomologyBasis b = compute_homology_basis(mesh);
    const std::uint64_t seed = 42;
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    Eigen::MatrixXd phi(mesh.n_vertices(), b.closed_forms.cols());
    for (Eigen::Index i = 0; i < phi.size(); ++i) phi.data()[i] = unit(rng);
    Eigen::MatrixXd forms = b.closed_forms;
    for (Index e = 0; e < mesh.n_edges(); ++e)
        forms.row(e) += phi.row(mesh.E(e, 1)) - phi.row(mesh.E(e, 0));
    const Eigen::MatrixXd exact = wedge_matrix(mesh, b.closed_forms);
    const Eigen::MatrixXd perturbed = wedge_matrix(mesh, forms);
    EXPECT_LT((perturbed - exact).cwiseAbs().maxCoeff(), kRoundingTol);
    EXPECT_EQ(perturbed, Eigen::MatrixXd(-perturbed.transpose()));
}

TEST(SymplecticBasis, RecoversStandardFormFromScrambledBasis) {
    for (int g = 1; g <= 6; ++g) {
        const std::uint64_t seed = 1234 + g;
        SCOPED_TRACE("genus " + std::to_string(g) + " seed " + std::to_string(seed));
        std::mt19937_64 rng(seed);
        // Q: product of random elementary integer column operations, hence unimodular.
        Eigen::MatrixXi Q = Eigen::MatrixXi::Identity(2 * g, 2 * g);
        std::uniform_int_distribution<int> pick(0, 2 * g - 1), mult(-2, 2);
        for (int step = 0; step < 8 * g; ++step) {
            const int i = pick(rng), j = pick(rng);
            if (i != j) Q.col(i) += mult(rng) * Q.col(j);
            if (step % 5 == 0) Q.col(i).swap(Q.col((i + 1) % (2 * g)));
        }
        const Eigen::MatrixXi J = Q.transpose() * standard_symplectic(g) * Q;
        const Eigen::MatrixXi P = symplectic_basis(J);
        // det J = 1, so P^T J P = standard with P integral makes P unimodular too.
        EXPECT_EQ(Eigen::MatrixXi(P.transpose() * J * P), standard_symplectic(g));
    }
    EXPECT_EQ(symplectic_basis(standard_symplectic(3)), Eigen::MatrixXi::Identity(6, 6));
}

TEST(SymplecticBasis, RejectsNonUnimodularAndNonSkew) {
    Eigen::MatrixXi twice = 2 * standard_symplectic(1);
    EXPECT_THROW(symplectic_basis(twice), InvalidInput);
    EXPECT_THROW(symplectic_basis(Eigen::MatrixXi::Zero(4, 4)), InvalidInput);
    EXPECT_THROW(symplectic_basis(Eigen::MatrixXi::Identity(2, 2)), InvalidInput);
    EXPECT_THROW(symplectic_basis(Eigen::MatrixXi::Zero(3, 3)), InvalidInput);
    EXPECT_THROW(symplectic_basis(Eigen::MatrixXi::Zero(2, 4)), InvalidInput);
    Eigen::MatrixXi block = Eigen::MatrixXi::Zero(4, 4);  // det 4: one pair fine, one doubled
    block.topLeftCorner(2, 2) = standard_symplectic(1);
    block.bottomRightCorner(2, 2) = 2 * standard_symplectic(1);
    EXPECT_THROW(symplectic_basis(block), InvalidInput);
}

TEST(FundamentalDomain, RejectsInconsistentWedges) {
    const MeshView torus = shapes::torus(2.0, 0.5, 10, 6);
    HomologyBasis b = compute_homology_basis(torus);
    HomologyBasis merged = b;  // one wedge for a whole fan on the cut graph
    const Index v = torus.E(b.generator_edges[0], 0);
    Index h = torus.vertex_halfedge[v];
    do {
        merged.corner_wedge[h] = b.corner_wedge[torus.vertex_halfedge[v]];
        h = torus.rotate(h);
    } while (h != torus.vertex_halfedge[v]);
    EXPECT_THROW(fundamental_domain_topology(torus, merged), InvalidInput);
    HomologyBasis uncut = b;
    std::fill(uncut.cut_edge.begin(), uncut.cut_edge.end(), 0);
    EXPECT_THROW(fundamental_domain_topology(torus, uncut), InvalidInput);
}

// ---- Real meshes: the libcgal-demo corpus (always there) and the optional shared collection.

struct CorpusMesh {
    std::string path;
    int genus;
    bool optional;  // from the shared collection: skipped when absent
};

std::string mesh_name(const testing::TestParamInfo<CorpusMesh>& info) {
    std::string name = std::filesystem::path(info.param.path).stem().string();
    for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    return name;
}

class HomologyCorpus : public testing::TestWithParam<CorpusMesh> {};

TEST_P(HomologyCorpus, BasisInvariants) {
    const CorpusMesh& param = GetParam();
    if (param.optional && !std::filesystem::exists(param.path))
        GTEST_SKIP() << param.path << " not present";
    const auto mesh = engine::load_mesh(param.path).mesh;
    ASSERT_EQ(compute_topology(*mesh).genus, param.genus);
    const HomologyBasis b = compute_homology_basis(*mesh);
    check_homology_basis(*mesh, b, param.genus);
    expect_identical(compute_homology_basis(*mesh), b);
}

INSTANTIATE_TEST_SUITE_P(Cgal, HomologyCorpus,
                         testing::Values(CorpusMesh{test::corpus("eight.off"), 2, false},
                                         CorpusMesh{test::corpus("couplingdown.off"), 9, false},
                                         CorpusMesh{test::corpus("femur.off"), 2, false},
                                         CorpusMesh{test::corpus("elephant.off"), 3, false},
                                         CorpusMesh{test::corpus("anchor.off"), 4, false},
                                         CorpusMesh{test::corpus("turbine.off"), 11, false},
                                         CorpusMesh{test::corpus("cheese.off"), 133, false}),
                         mesh_name);

INSTANTIATE_TEST_SUITE_P(Shared, HomologyCorpus,
                         testing::Values(CorpusMesh{test::shared_mesh("fertility.off"), 4, true},
                                         CorpusMesh{test::shared_mesh("Pegasus.off"), 5, true},
                                         CorpusMesh{test::shared_mesh("rolling_stage.obj"), 7,
                                                    true},
                                         CorpusMesh{test::shared_mesh("boot.obj"), 12, true},
                                         CorpusMesh{test::shared_mesh("skull.obj"), 2, true}),
                         mesh_name);

}  // namespace
}  // namespace holoflow::kernels
