#include "holoflow/engine/conformal_pipeline.h"

#include <chrono>
#include <cmath>
#include <complex>
#include <cstring>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/subdivision.h"
#include "support/test_support.h"

namespace holoflow::engine {
namespace {

using Complex = std::complex<double>;

constexpr double kUnimodularTol = 1e-9;    // A is a sum of exact small rationals
constexpr double kModulusTol = 0.01;       // issue: 1% at a moderate resolution


Complex torus_modulus(double R, double r, int nu, int nv) {
    const MeshView torus = shapes::torus(R, r, nu, nv);
    const ConformalResult c = compute_conformal(torus);
    EXPECT_EQ(c.basis.genus, 1);
    return kernels::reduce_modulus(c.basis.period_matrix(0, 0));
}

TEST(Conformal, TorusOfRevolutionModulusConverges) {
    for (const auto& [R, r] : {std::pair{2.0, 1.0}, std::pair{4.0, 1.0}}) {
        SCOPED_TRACE("R = " + std::to_string(R) + ", r = " + std::to_string(r));
        // Conformal to a flat torus whose periods have ratio sqrt(R^2 - r^2) / r (or inverse).
        const Complex expected(0, std::sqrt(R * R - r * r) / r);
        const double coarse = std::abs(torus_modulus(R, r, 48, 24) - expected) / std::abs(expected);
        const double fine = std::abs(torus_modulus(R, r, 96, 48) - expected) / std::abs(expected);
        EXPECT_LT(coarse, kModulusTol);
        EXPECT_LT(fine, 0.5 * coarse);  // second order: about a quarter
    }
}

TEST(Conformal, TorusMapIsFlatParallelogram) {
    const MeshView torus = shapes::torus(2, 1, 48, 24);
    const ConformalResult c = compute_conformal(torus);
    EXPECT_EQ(c.quality.flipped, 0);
    EXPECT_EQ(c.quality.degenerate, 0);
    // Smooth torus, 24 vertices around the tube: nearly conformal everywhere.
    EXPECT_LT(c.quality.distortion_max, 1.2);
    EXPECT_EQ(c.input_mesh_quality.flipped, 0);
    EXPECT_LT(c.closedness_max, 1e-12);
    EXPECT_LT(c.coclosedness_max, 1e-9);
}

TEST(Conformal, ClosedGenusZeroAndSeveralComponentsAreRefused) {
    EXPECT_THROW(compute_conformal(shapes::icosphere(2)), InvalidInput);
    EXPECT_THROW(compute_conformal(*test::corpus_mesh("bones")), InvalidInput);
    EXPECT_THROW(compute_conformal(shapes::flat_grid(4, 4)), InvalidInput);  // a disk
}

class ConformalCorpus : public ::testing::TestWithParam<const char*> {};

TEST_P(ConformalCorpus, CertificatesHold) {
    const auto mesh = test::corpus_mesh(GetParam());
    const ConformalResult c = compute_conformal(*mesh);
    EXPECT_NEAR(std::abs(c.star.wedge_det), 1.0, kUnimodularTol);
    EXPECT_LT(c.star.wedge_integrality_error, kUnimodularTol);
    EXPECT_LT(c.basis.period_symmetry_error, 0.1);  // weak measure; stricter under refinement
    EXPECT_GT(c.basis.period_im_min_eigenvalue, 0.0);
    EXPECT_LT(c.closedness_max, 1e-12);
    EXPECT_LT(c.coclosedness_max, 1e-8);
    EXPECT_EQ(c.negative_weights, 0);
}

TEST_P(ConformalCorpus, StarErrorsFallAndPeriodsStayUnderSubdivision) {
    const auto mesh = test::corpus_mesh(GetParam());
    const ConformalResult coarse = compute_conformal(*mesh);
    const MeshView fine_mesh = kernels::subdivide_midpoint(*mesh);
    ConformalOptions carried;
    carried.closed_forms = kernels::subdivide_forms_midpoint(  // the coarse run's own (its root)
        *mesh, fine_mesh, kernels::compute_homology_basis(*coarse.surface).closed_forms);
    const ConformalResult fine = compute_conformal(fine_mesh, carried);
    EXPECT_LT(fine.star.star_square_error, coarse.star.star_square_error);
    EXPECT_LT(fine.star.star_isometry_error, coarse.star.star_isometry_error);
    // Same cohomology basis on both meshes, so the same canonical basis and comparable periods.
    EXPECT_EQ(fine.basis.canonical, coarse.basis.canonical);
    const double change = (fine.basis.period_matrix - coarse.basis.period_matrix).norm() /
                          coarse.basis.period_matrix.norm();
    EXPECT_LT(change, 0.1);
}

INSTANTIATE_TEST_SUITE_P(Corpus, ConformalCorpus,
                         ::testing::Values("eight", "femur", "elephant", "helmet", "anchor",
                                           "couplingdown", "turbine"));

class IntrinsicVsExtrinsic : public ::testing::TestWithParam<const char*> {};

TEST_P(IntrinsicVsExtrinsic, IntrinsicDelaunayIsBetter) {
    const auto mesh = test::corpus_mesh(GetParam());
    ConformalOptions extrinsic;
    extrinsic.laplacian = LaplacianKind::Extrinsic;
    const ConformalResult i = compute_conformal(*mesh);
    const ConformalResult e = compute_conformal(*mesh, extrinsic);
    EXPECT_GT(e.negative_weights, 0);
    EXPECT_EQ(i.negative_weights, 0);
    EXPECT_LT(i.quality.flipped, e.quality.flipped);
    EXPECT_LT(i.star.star_square_error, e.star.star_square_error);
    EXPECT_LT(i.star.star_isometry_error, e.star.star_isometry_error);
}

INSTANTIATE_TEST_SUITE_P(Corpus, IntrinsicVsExtrinsic, ::testing::Values("femur", "anchor", "turbine"));

TEST(Conformal, OpenSurfaceBoundaryIsHorizontal) {
    for (const auto& [name, genus] : {std::pair{"head", 2}, std::pair{"lion", 4}}) {
        SCOPED_TRACE(name);
        const auto mesh = test::corpus_mesh(name);
        const ConformalResult c = compute_conformal(*mesh);
        ASSERT_TRUE(c.double_covered);
        EXPECT_EQ(c.basis.genus, genus);
        // The chosen form is even under the involution: on the fixed set (the original
        // boundary) it is real, so boundary loops are horizontal trajectories.
        double along = 0, across = 0;
        for (Index h = 0; h < mesh->n_halfedges(); ++h) {
            if (!mesh->is_boundary_halfedge(h)) continue;
            const Index a = mesh->tail(h), b = mesh->head(h);
            const MeshView& s = *c.surface;
            for (Index g = s.vertex_halfedge[a], first = g;;) {  // the cover edge a -> b
                if (s.head(g) == b) {
                    const Complex t = static_cast<double>(s.edge_sign(g)) * c.tau(s.halfedge_edge[g]);
                    along += std::abs(t.real());
                    across += std::abs(t.imag());
                    break;
                }
                g = s.rotate(g);
                if (g == first) break;
            }
        }
        ASSERT_GT(along, 0);
        EXPECT_LT(across / along, 0.05);
    }
}

// The memory limit counts the dense 2g-column forms, not only the factor, and refuses before
// the homology allocates them: a limit below the forms of cheese (genus 133) leaves no closed
// form allocated; one above the forms but below forms plus factor refuses at the factorisation.
TEST(Conformal, MemoryLimitRefusesBeforeTheFormsAreAllocated) {
    const auto cheese = test::corpus_mesh("cheese");
    ConformalOptions options;
    options.max_solver_bytes = 1;
    ConformalWork work = conformal_stage::prepare(cheese, options);
    conformal_stage::laplacian(work);
    EXPECT_THROW(conformal_stage::homology_and_factorise(work), ResourceLimit);
    EXPECT_EQ(work.result.homology.closed_forms.size(), 0);

    const auto forms_bytes = static_cast<std::size_t>(8 * 266 * (2 * cheese->n_edges() + 3 * cheese->n_vertices()));
    options.max_solver_bytes = forms_bytes + 1024;  // the forms fit, the factor does not
    ConformalWork fits = conformal_stage::prepare(cheese, options);
    conformal_stage::laplacian(fits);
    try {
        conformal_stage::homology_and_factorise(fits);
        FAIL() << "the factor must not fit";
    } catch (const ResourceLimit& e) {
        EXPECT_NE(std::string(e.what()).find("266 forms"), std::string::npos) << e.what();
    }
    EXPECT_EQ(fits.factor, nullptr);
    options.max_solver_bytes = 0;  // no limit
    EXPECT_NO_THROW(compute_conformal(*cheese, options));
}

// The solves turn the homology's closed forms into the harmonic ones in place: the result keeps
// no closed forms, the harmonic forms keep their periods (delta_ij on the homology loops), and
// the same forms given by the caller (copied) give the same bits.
TEST(Conformal, ClosedFormsBecomeTheHarmonicOnes) {
    for (const auto& [name, laplacian] : {std::pair{"eight", LaplacianKind::IntrinsicDelaunay},
                                          std::pair{"eight", LaplacianKind::Extrinsic},
                                          std::pair{"head", LaplacianKind::IntrinsicDelaunay}}) {
        SCOPED_TRACE(std::string(name) + (laplacian == LaplacianKind::Extrinsic ? " extrinsic" : ""));
        const auto mesh = test::corpus_mesh(name);
        ConformalOptions options;
        options.laplacian = laplacian;
        const ConformalResult c = compute_conformal(*mesh, options);
        EXPECT_EQ(c.homology.closed_forms.size(), 0);
        const Eigen::Index n = c.harmonic.cols();
        ASSERT_EQ(static_cast<std::size_t>(n), c.homology.loops.size());
        Eigen::MatrixXd periods(n, n);
        for (Eigen::Index j = 0; j < n; ++j)
            periods.col(j) = kernels::integrate_along(*c.surface, c.harmonic, c.homology.loops[j]);
        EXPECT_LT((periods - Eigen::MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-9);
        if (c.double_covered) continue;  // given forms need closed input
        options.closed_forms = kernels::compute_homology_basis(*c.surface).closed_forms;
        EXPECT_TRUE(compute_conformal(*mesh, options).harmonic == c.harmonic);
    }
}

TEST(Conformal, SameBitsForOneAndTwoThreads) {
    const auto mesh = test::corpus_mesh("elephant");
    auto run = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return compute_conformal(*mesh);
    };
    const ConformalResult one = run(1), two = run(2);
    ASSERT_EQ(one.tau.size(), two.tau.size());
    EXPECT_EQ(std::memcmp(one.tau.data(), two.tau.data(), sizeof(Complex) * one.tau.size()), 0);
    EXPECT_EQ(one.basis.period_matrix, two.basis.period_matrix);
}

// Solve blocks: as few as kSolveBlockColumns allows, of equal widths up to the last one.
// ChineseDragon-10kv is a closed dragon with two missing triangles; with the one-ring of its top
// vertex removed too, its double cover (genus 2) has a discrete star far from a complex structure
// (square error 9.4), and the first generic form's image folds on 35 % of the intrinsic
// triangles. A later phase folds on under 1 %; a clean mesh keeps phase 1.
TEST(Conformal, AFoldedGenericFormGivesWayToAnotherPhase) {
    const std::shared_ptr<const MeshView> dragon = test::corpus_mesh("ChineseDragon-10kv");
    constexpr Index kTop = 9774;  // the vertex and its faces go; the vertices after it move down
    std::vector<Index> kept;
    for (Index f = 0; f < dragon->n_faces(); ++f)
        if (dragon->F(f, 0) != kTop && dragon->F(f, 1) != kTop && dragon->F(f, 2) != kTop) kept.push_back(f);
    TriangleMatrix F(static_cast<Eigen::Index>(kept.size()), 3);
    for (std::size_t i = 0; i < kept.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            const Index v = dragon->F(kept[i], k);
            F(static_cast<Eigen::Index>(i), k) = v > kTop ? v - 1 : v;
        }
    PointMatrix V(dragon->n_vertices() - 1, 3);
    V.topRows(kTop) = dragon->V.topRows(kTop);
    V.bottomRows(dragon->n_vertices() - kTop - 1) = dragon->V.bottomRows(dragon->n_vertices() - kTop - 1);
    const auto dragon_without_top = std::make_shared<const MeshView>(make_mesh_view(std::move(V), std::move(F)));
    const ConformalResult c = compute_conformal(*dragon_without_top);
    ASSERT_EQ(c.basis.genus, 2);
    EXPECT_GT(c.form_phase, 1);
    EXPECT_LT(static_cast<double>(c.quality.flipped), 0.01 * static_cast<double>(c.intrinsic->mesh.n_faces()));
    EXPECT_EQ(compute_conformal(*test::corpus_mesh("eight")).form_phase, 1);
    ConformalOptions alone;
    alone.chosen_form_only = true;
    EXPECT_EQ(compute_conformal(*dragon_without_top, alone).form_phase, c.form_phase);
}

// The chosen form from its own two solves (what the refinement tries use) is the basis
// combination the full stage makes, up to rounding: closed and open input (the even form of a
// double cover), both Laplacians, both forms; and the same phase where the first one folds.
TEST(Conformal, TheChosenFormAloneIsTheBasisCombination) {
    for (const char* name : {"eight", "head"})
        for (const LaplacianKind laplacian : {LaplacianKind::IntrinsicDelaunay, LaplacianKind::Extrinsic})
            for (const FormChoice form : {FormChoice::Generic, FormChoice::IntegerPeriods}) {
                SCOPED_TRACE(std::string(name) + (laplacian == LaplacianKind::Extrinsic ? " extrinsic " : " intrinsic ") +
                             form_name(form));
                ConformalOptions options;
                options.laplacian = laplacian;
                options.form = form;
                const auto mesh = test::corpus_mesh(name);
                const ConformalResult full = compute_conformal(*mesh, options);
                options.chosen_form_only = true;
                const ConformalResult alone = compute_conformal(*mesh, options);
                EXPECT_EQ(alone.basis.genus, full.basis.genus);
                EXPECT_EQ(alone.harmonic.size(), 0);
                EXPECT_EQ(alone.form_coefficients, full.form_coefficients);
                ASSERT_EQ(alone.tau.size(), full.tau.size());
                EXPECT_LT((alone.tau - full.tau).norm(), 1e-10 * full.tau.norm());
                EXPECT_EQ(alone.quality.flipped, full.quality.flipped);
                EXPECT_LT(alone.closedness_max, 1e-12);
                EXPECT_EQ(alone.intrinsic != nullptr, laplacian == LaplacianKind::IntrinsicDelaunay);
            }
}

TEST(Conformal, SolveBlocksAreFewAndEven) {
    EXPECT_EQ(solve_block_width(2), 2);
    EXPECT_EQ(solve_block_width(kSolveBlockColumns), kSolveBlockColumns);
    EXPECT_EQ(solve_block_width(kSolveBlockColumns + 1), kSolveBlockColumns / 2 + 1);
    for (Eigen::Index columns = 1; columns <= 600; ++columns) {
        const Eigen::Index width = solve_block_width(columns), blocks = (columns + width - 1) / width;
        EXPECT_LE(width, kSolveBlockColumns) << columns;
        EXPECT_EQ(blocks, (columns + kSolveBlockColumns - 1) / kSolveBlockColumns) << columns;
        EXPECT_GT(columns - (blocks - 1) * width, width - blocks) << columns;  // the last block
    }
}

TEST(Conformal, StageTimesAddUpToAtMostTheWallTime) {
    // homology and factorise run side by side; `overlap` takes back the doubly counted time.
    const auto mesh = test::corpus_mesh("femur");
    const auto start = std::chrono::steady_clock::now();
    const ConformalResult r = compute_conformal(*mesh);
    const double wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    double sum = 0;
    bool overlap = false;
    for (const auto& [stage, ms] : r.timings_ms) {
        sum += ms;
        overlap = overlap || stage == "overlap";
    }
    EXPECT_TRUE(overlap);
    EXPECT_GT(sum, 0);
    EXPECT_LE(sum, wall_ms);
}

}  // namespace
}  // namespace holoflow::engine
