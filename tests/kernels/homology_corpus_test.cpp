#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <set>
#include <string>
#include <vector>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

// Tree-cotree homology on real meshes: the libcgal-demo corpus (always there) and the optional
// shared collection. Forms are small integers, so closedness, periods and the wedge matrix are
// compared exactly.
namespace holoflow::kernels {
namespace {

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

Eigen::MatrixXi standard_symplectic(int g) {
    Eigen::MatrixXi S = Eigen::MatrixXi::Zero(2 * g, 2 * g);
    S.topRightCorner(g, g).setIdentity();
    S.bottomLeftCorner(g, g) = -Eigen::MatrixXi::Identity(g, g);
    return S;
}

class HomologyCorpus : public testing::TestWithParam<CorpusMesh> {};

TEST_P(HomologyCorpus, BasisInvariants) {
    const CorpusMesh& param = GetParam();
    if (param.optional && !std::filesystem::exists(param.path))
        GTEST_SKIP() << param.path << " not present";
    const engine::LoadedMesh loaded = engine::load_mesh(param.path);
    const MeshView& mesh = *loaded.mesh;
    ASSERT_EQ(compute_topology(mesh).genus, param.genus);

    const HomologyBasis b = compute_homology_basis(mesh);
    const Index n_e = mesh.n_edges(), n_g = 2 * param.genus;
    ASSERT_EQ(b.genus, param.genus);
    ASSERT_EQ(static_cast<Index>(b.generator_edges.size()), n_g);
    ASSERT_EQ(b.closed_forms.rows(), n_e);
    ASSERT_EQ(b.closed_forms.cols(), n_g);

    // Exactly closed on every face.
    Index open_faces = 0;
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(n_g);
        for (Index h = 3 * f; h < 3 * f + 3; ++h)
            sum += mesh.edge_sign(h) * b.closed_forms.row(mesh.halfedge_edge[h]);
        open_faces += sum.cwiseAbs().maxCoeff() != 0.0 ? 1 : 0;
    }
    EXPECT_EQ(open_faces, 0);

    // Loops closed and consecutive; periods exactly delta_ij.
    ASSERT_EQ(static_cast<Index>(b.loops.size()), n_g);
    for (Index j = 0; j < n_g; ++j) {
        const auto& loop = b.loops[j];
        for (std::size_t k = 0; k < loop.size(); ++k)
            ASSERT_EQ(mesh.head(loop[k]), mesh.tail(loop[(k + 1) % loop.size()]))
                << "loop " << j << " step " << k;
        const Eigen::VectorXd periods = integrate_along(mesh, b.closed_forms, loop);
        EXPECT_EQ(periods, Eigen::VectorXd::Unit(n_g, j)) << "loop " << j;
    }

    // Wedge matrix integral and skew; P^T J P = standard with P integral forces
    // det(J) det(P)^2 = 1, i.e. J and P both unimodular.
    const Eigen::MatrixXd A = wedge_matrix(mesh, b.closed_forms);
    const Eigen::MatrixXi J = A.array().round().cast<int>().matrix();
    EXPECT_EQ(A, J.cast<double>());
    EXPECT_EQ(J, Eigen::MatrixXi(-J.transpose()));
    const Eigen::MatrixXi P = symplectic_basis(J);
    EXPECT_EQ(Eigen::MatrixXi(P.transpose() * J * P), standard_symplectic(param.genus));

    // Cut graph without dangling vertices; fundamental domain a disk, its vertices the classes of
    // corners joined across uncut edges (independent union-find).
    std::vector<Index> cut_degree(mesh.n_vertices(), 0);
    for (Index e = 0; e < n_e; ++e) {
        if (!b.cut_edge[e]) continue;
        ++cut_degree[mesh.E(e, 0)];
        ++cut_degree[mesh.E(e, 1)];
    }
    EXPECT_EQ(std::count(cut_degree.begin(), cut_degree.end(), 1), 0);
    std::vector<Index> parent(mesh.n_halfedges());
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](Index x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (!b.cut_edge[mesh.halfedge_edge[h]])
            parent[find(h)] = find(MeshView::next(mesh.twin[h]));
    std::set<Index> classes;
    for (Index h = 0; h < mesh.n_halfedges(); ++h) classes.insert(find(h));
    EXPECT_EQ(static_cast<Index>(classes.size()), b.n_wedges);
    const CutTopology cut = fundamental_domain_topology(mesh, b);
    EXPECT_EQ(cut.euler_characteristic, 1);
    EXPECT_EQ(cut.boundary_loops, 1);

    // Deterministic: a second run gives the same bits.
    const HomologyBasis again = compute_homology_basis(mesh);
    EXPECT_EQ(again.tree_parent_halfedge, b.tree_parent_halfedge);
    EXPECT_EQ(again.generator_edges, b.generator_edges);
    EXPECT_EQ(again.loops, b.loops);
    EXPECT_EQ(0, std::memcmp(again.closed_forms.data(), b.closed_forms.data(),
                             sizeof(double) * b.closed_forms.size()));
    EXPECT_EQ(again.cut_edge, b.cut_edge);
    EXPECT_EQ(again.corner_wedge, b.corner_wedge);
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
