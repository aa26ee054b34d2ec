#include "holoflow/kernels/zeros.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>

#include <tbb/global_control.h>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/subdivision.h"
#include "support/plane_zeros.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

ZeroSet zeros_of(const MeshView& mesh) {
    const engine::ConformalResult c = engine::compute_conformal(mesh);
    return find_zeros(*c.surface, c.tau);
}

// femur rotated about z and scaled 1 : 2.5 : 0.6: thin fins where its form is rounding noise.
MeshView stretched_femur() {
    MeshView femur = *test::corpus_mesh("femur");
    const double c = std::cos(0.7), s = std::sin(0.7);
    for (Index v = 0; v < femur.n_vertices(); ++v) {
        const double x = femur.V(v, 0), y = femur.V(v, 1);
        femur.V.row(v) << c * x - s * y, 2.5 * (s * x + c * y), 0.6 * femur.V(v, 2);
    }
    return femur;
}

// The same zero set: image windings and flips, saddles, unresolved vertices and the zeros.
void expect_same_zeros(const ZeroSet& a, const ZeroSet& b) {
    EXPECT_EQ(a.winding, b.winding);
    EXPECT_EQ(a.face_flip, b.face_flip);
    EXPECT_EQ(a.total_index, b.total_index);
    EXPECT_EQ(a.saddle_order, b.saddle_order);
    EXPECT_EQ(a.unresolved_vertices, b.unresolved_vertices);
    ASSERT_EQ(a.zeros.size(), b.zeros.size());
    for (std::size_t i = 0; i < a.zeros.size(); ++i) {
        EXPECT_EQ(a.zeros[i].vertex, b.zeros[i].vertex);
        EXPECT_EQ(a.zeros[i].order, b.zeros[i].order);
    }
}

int saddle_sum(const ZeroSet& z) { return std::accumulate(z.saddle_order.begin(), z.saddle_order.end(), 0); }

TEST(Zeros, CorpusCountIsExactlyTwoGenusMinusTwo) {
    for (const auto& [name, genus] : {std::pair{"eight", 2}, {"femur", 2}, {"elephant", 3}, {"helmet", 3},
                                      {"anchor", 4}, {"couplingdown", 9}}) {
        SCOPED_TRACE(name);
        const ZeroSet z = zeros_of(*test::corpus_mesh(name));
        EXPECT_EQ(z.total_index, 2 * genus - 2);
        EXPECT_EQ(z.total_order, 2 * genus - 2);
        int orders = 0;
        for (const Zero& zero : z.zeros) orders += zero.order;
        EXPECT_EQ(orders, 2 * genus - 2);
        std::printf("%s: zeros %zu clusters %zu artifacts %d folds %d merged %d nonpositive w %d flips %d\n", name,
                    z.zeros.size(), z.clusters.size(), z.artifact_clusters, z.fold_clusters,
                    z.merged_negative_clusters, z.nonpositive_winding_vertices,
                    static_cast<int>(std::count(z.face_flip.begin(), z.face_flip.end(), 1)));
    }
}

// The discrete maximum principle on the intrinsic Delaunay triangulation: every vertex's
// saddle order is >= 0, so the well-shaped corpus (CAD meshes included) has no artifact, and
// the orders add up to 2g - 2 exactly.
TEST(Zeros, SaddlesOnTheIntrinsicDelaunayTriangulationHaveNoArtifacts) {
    for (const auto& [name, genus] : {std::pair{"eight", 2}, {"femur", 2}, {"elephant", 3}, {"helmet", 3},
                                      {"anchor", 4}, {"couplingdown", 9}, {"turbine", 11}}) {
        SCOPED_TRACE(name);
        const ZeroSet z = zeros_of(*test::corpus_mesh(name));
        EXPECT_TRUE(z.intrinsic);
        EXPECT_EQ(saddle_sum(z), 2 * genus - 2);
        EXPECT_GE(*std::min_element(z.saddle_order.begin(), z.saddle_order.end()), 0);
        EXPECT_EQ(z.artifact_clusters, 0);
        EXPECT_EQ(z.merged_negative_clusters, 0);
        EXPECT_EQ(z.total_order, 2 * genus - 2);
        for (const Zero& zero : z.zeros) {
            ASSERT_GE(zero.vertex, 0);
            EXPECT_GT(z.saddle_order[zero.vertex], 0);  // a zero sits on a saddle
        }
    }
}

// The conformal stage's own triangulation (flips replayed on tau) gives what redoing the flips
// gives; one of another mesh is refused.
TEST(Zeros, GivenTriangulationMatchesRecomputedOne) {
    const auto elephant = test::corpus_mesh("elephant"), eight = test::corpus_mesh("eight");
    const engine::ConformalResult c = engine::compute_conformal(*elephant);  // surface: *elephant
    ASSERT_NE(c.intrinsic, nullptr);
    ZeroOptions given;
    given.triangulation = c.intrinsic.get();
    const ZeroSet fresh = find_zeros(*c.surface, c.tau), reused = find_zeros(*c.surface, c.tau, given);
    EXPECT_TRUE(reused.intrinsic);
    expect_same_zeros(reused, fresh);
    const engine::ConformalResult other = engine::compute_conformal(*eight);
    ZeroOptions wrong;
    wrong.triangulation = other.intrinsic.get();
    EXPECT_THROW(find_zeros(*c.surface, c.tau, wrong), InvalidInput);
}

// The conformal stage's cotan weights, given, are what the unresolved-vertex test computes
// itself: the same zero set on the stretched femur (which has unresolved vertices). Weights
// without their triangulation, or of the wrong size, are refused.
TEST(Zeros, GivenWeightsMatchRecomputedOnes) {
    const MeshView femur = stretched_femur();
    const engine::ConformalResult c = engine::compute_conformal(femur);  // surface: femur
    ASSERT_NE(c.intrinsic, nullptr);
    ASSERT_EQ(static_cast<Index>(c.laplace_weights.size()), c.intrinsic->mesh.n_edges());
    ZeroOptions own, given;
    own.triangulation = given.triangulation = c.intrinsic.get();
    given.weights = c.laplace_weights;
    const ZeroSet a = find_zeros(*c.surface, c.tau, own), b = find_zeros(*c.surface, c.tau, given);
    EXPECT_GT(a.unresolved_vertices, 0);
    EXPECT_EQ(b.flat_clusters, a.flat_clusters);
    EXPECT_EQ(b.artifact_clusters, a.artifact_clusters);
    expect_same_zeros(b, a);
    ZeroOptions loose;
    loose.weights = c.laplace_weights;  // no triangulation to belong to
    EXPECT_THROW(find_zeros(*c.surface, c.tau, loose), InvalidInput);
    const std::vector<double> short_weights(c.laplace_weights.begin(), c.laplace_weights.end() - 1);
    given.weights = short_weights;
    EXPECT_THROW(find_zeros(*c.surface, c.tau, given), InvalidInput);
}

TEST(Zeros, ProceduralSurfacesOfHigherGenus) {
    for (int genus : {2, 3}) {
        SCOPED_TRACE(genus);
        const ZeroSet z = zeros_of(shapes::genus_surface(genus, 2));
        EXPECT_EQ(saddle_sum(z), 2 * genus - 2);
        EXPECT_EQ(z.total_order, 2 * genus - 2);
        EXPECT_EQ(z.artifact_clusters, 0);
    }
}

// From 8000 faces the windings, the saddles and the unresolved regions are counted side by
// side: the same zero set with one thread, on the intrinsic triangulation and on the mesh.
TEST(Zeros, LargeMeshesGiveTheSameZerosWithAnyThreadCount) {
    const MeshView mesh = subdivide_loop(*test::corpus_mesh("femur"));  // 31192 faces
    ASSERT_GE(mesh.n_faces(), 8000);
    const engine::ConformalResult c = engine::compute_conformal(mesh);
    for (const bool intrinsic : {true, false}) {
        SCOPED_TRACE(intrinsic);
        ZeroOptions options;
        options.intrinsic_delaunay = intrinsic;
        const auto zeros_with = [&](int threads) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            return find_zeros(*c.surface, c.tau, options);
        };
        const ZeroSet one = zeros_with(1), two = zeros_with(2);
        EXPECT_EQ(one.intrinsic, intrinsic);
        EXPECT_EQ(one.total_order, 2);
        expect_same_zeros(one, two);
    }
}

// Counted on the mesh itself (negative cotan weights on a CAD mesh) a saddle order can be -1;
// the total stays exact and the negative cluster joins a zero.
TEST(Zeros, MeshCountStaysExactWithoutTheMaximumPrinciple) {
    const auto mesh = test::corpus_mesh("anchor");  // the result points into it
    const engine::ConformalResult c = engine::compute_conformal(*mesh);
    ZeroOptions options;
    options.intrinsic_delaunay = false;
    const ZeroSet z = find_zeros(*c.surface, c.tau, options);
    EXPECT_FALSE(z.intrinsic);
    EXPECT_EQ(saddle_sum(z), 6);
    EXPECT_EQ(z.total_order, 6);
}

// Any closed form obeys the identity, ties included: an exact form whose potential takes equal
// values on many adjacent vertices (symbolic perturbation breaks them consistently).
TEST(Zeros, TiesKeepTheCountExact) {
    const int genus = 2;
    const MeshView mesh = shapes::genus_surface(genus, 2);
    Eigen::VectorXcd tau(mesh.n_edges());
    const auto potential = [&](Index v) {
        const double u = std::round(4 * mesh.V(v, 0));  // coarse steps: many equal neighbours
        return std::complex<double>(u, 0.0);            // Im = 0: every tie reaches the 3D key
    };
    for (Index e = 0; e < mesh.n_edges(); ++e) tau(e) = potential(mesh.E(e, 1)) - potential(mesh.E(e, 0));
    for (bool intrinsic : {true, false}) {
        ZeroOptions options;
        options.intrinsic_delaunay = intrinsic;
        const ZeroSet z = find_zeros(mesh, tau, options);
        EXPECT_EQ(saddle_sum(z), 2 * genus - 2);
        int clusters = 0;
        for (const ZeroCluster& c : z.clusters) clusters += c.index;
        EXPECT_EQ(clusters, 2 * genus - 2);
    }
}

// On a flat mesh with F = (z - z0)^(k+1) the fit is exact: the refined point is z0, in the face
// holding it, with F(z0) as its image.
TEST(Zeros, RefinementFindsAPlantedZeroInsideAFace) {
    const MeshView m = test::turned_grid(14);
    for (const int order : {1, 2, 3})
        for (const std::complex<double> z0 : {std::complex<double>(0.071, 0.113), {-0.42, 0.3137}, {0.2501, -0.6}}) {
            SCOPED_TRACE(testing::Message() << "order " << order << " at " << z0);
            const auto f = [&](std::complex<double> z) { return std::pow(z - z0, order + 1); };
            std::vector<std::complex<double>> values(m.n_vertices());
            for (Index v = 0; v < m.n_vertices(); ++v) values[v] = f(test::point(m, v));
            const Eigen::VectorXcd tau = test::form_of(m, values);
            std::array<double, 3> bary{};
            const Index face = test::face_containing(m, z0, bary);
            ASSERT_GE(face, 0);
            const int corner = static_cast<int>(std::max_element(bary.begin(), bary.end()) - bary.begin());
            const ZeroPoint p = refine_zero(m, tau, m.F(face, corner), order);
            ASSERT_EQ(p.face, face);
            for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.barycentric[k], bary[k], 1e-9);
            EXPECT_LT(std::abs(p.image_offset - (f(z0) - values[m.F(face, 0)])), 1e-9);
        }
}

// Where the fit cannot place the zero, it stays at its vertex: a boundary vertex, a zero far
// outside the star, or a form with no critical point there.
TEST(Zeros, RefinementLeavesUnplaceableZerosAtTheirVertex) {
    const MeshView m = test::turned_grid(14);
    std::vector<std::complex<double>> far(m.n_vertices()), linear(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) {
        const std::complex<double> z = test::point(m, v);
        far[v] = (z - std::complex<double>(1.0, 1.0)) * (z - std::complex<double>(1.0, 1.0));
        linear[v] = std::complex<double>(2, 1) * z;
    }
    std::array<double, 3> bary{};
    const Index centre = m.F(test::face_containing(m, {0.01, 0.02}, bary), 0);
    const Eigen::VectorXcd far_tau = test::form_of(m, far);
    EXPECT_EQ(refine_zero(m, far_tau, centre, 1).face, -1);
    EXPECT_EQ(refine_zero(m, test::form_of(m, linear), centre, 1).face, -1);
    EXPECT_EQ(refine_zero(m, far_tau, 0, 1).face, -1);  // a corner of the grid
    EXPECT_THROW(refine_zero(m, far_tau, m.n_vertices(), 1), InvalidInput);
}

// On real meshes the zeros are refined into faces next to their saddle vertex.
TEST(Zeros, RefinedPointsLieAroundTheirSaddleOnRealMeshes) {
    for (const char* name : {"eight", "femur", "elephant", "helmet"}) {
        SCOPED_TRACE(name);
        const auto mesh = test::corpus_mesh(name);
        const engine::ConformalResult c = engine::compute_conformal(*mesh);
        const ZeroSet z = find_zeros(*c.surface, c.tau);
        Index refined = 0;
        for (const Zero& zero : z.zeros) {
            if (zero.point.face < 0) continue;
            ++refined;
            // In the saddle's two-ring: a corner of the face is the saddle or one of its neighbours.
            std::vector<Index> ring{zero.vertex};
            const Index first = c.surface->vertex_halfedge[zero.vertex];
            for (Index h = first;;) {
                ring.push_back(c.surface->head(h));
                if ((h = c.surface->rotate(h)) == first) break;
            }
            const auto corners = c.surface->F.row(zero.point.face);
            EXPECT_TRUE(std::any_of(ring.begin(), ring.end(), [&](Index v) { return (corners.array() == v).any(); }));
            double sum = 0;
            for (double b : zero.point.barycentric) {
                EXPECT_GE(b, 0);
                sum += b;
            }
            EXPECT_NEAR(sum, 1, 1e-12);
            for (int axis = 0; axis < 3; ++axis) {
                double expected = 0;
                for (int k = 0; k < 3; ++k)
                    expected += zero.point.barycentric[k] * c.surface->V(c.surface->F(zero.point.face, k), axis);
                EXPECT_NEAR(zero.point.position[axis], expected, 1e-12 * (1 + std::abs(expected)));
            }
        }
        std::printf("%s: %lld of %zu zeros refined into a face\n", name, static_cast<long long>(refined), z.zeros.size());
        EXPECT_EQ(refined, static_cast<Index>(z.zeros.size()));
    }
}

TEST(Zeros, TorusHasNone) {
    const ZeroSet z = zeros_of(shapes::torus(2, 1, 48, 24));
    EXPECT_EQ(z.total_index, 0);
    EXPECT_EQ(saddle_sum(z), 0);
    EXPECT_TRUE(z.zeros.empty());
    EXPECT_EQ(z.artifact_clusters, 0);
}

// A torus stretched a thousandfold along x, its form harmonic for the mesh's own cotan weights
// and counted there: needles of aspect 1000 have negative weights, so the maximum principle
// fails and saddles of both signs appear where the form is resolved. Negative clusters merged
// into a positive one can drive it negative; it then merges on, so the orders still add up to
// the total index (0: no zero at all), and every cancelled cluster counts as an artifact.
TEST(Zeros, StretchedTorusKeepsTheTotalOrderExact) {
    MeshView torus = shapes::torus(1, 0.4, 40, 20);
    torus.V.col(0) *= 1000;
    engine::ConformalOptions extrinsic;
    extrinsic.laplacian = engine::LaplacianKind::Extrinsic;
    const engine::ConformalResult c = engine::compute_conformal(torus, extrinsic);
    ZeroOptions on_mesh;
    on_mesh.intrinsic_delaunay = false;
    const ZeroSet z = find_zeros(*c.surface, c.tau, on_mesh);
    EXPECT_EQ(z.total_index, 0);
    EXPECT_GT(z.merged_negative_clusters, 0);  // the case this is about
    EXPECT_EQ(z.total_order, 0);
    EXPECT_TRUE(z.zeros.empty());
    EXPECT_GT(z.artifact_clusters, 0);
}

// Counted on the intrinsic Delaunay triangulation the same torus' saddles are noise: the form
// is rounding noise on the needles' short edges (its harmonicity residual as large as the flow
// through the vertex), and each such region's saddles group into one cluster where they cancel.
TEST(Zeros, SaddlesWhereTheFormIsRoundingNoiseCancelInOneCluster) {
    MeshView torus = shapes::torus(1, 0.4, 40, 20);
    torus.V.col(0) *= 1000;
    const ZeroSet z = zeros_of(torus);
    EXPECT_GT(z.unresolved_vertices, 0);  // the case this is about
    EXPECT_GT(z.flat_clusters, 0);
    EXPECT_EQ(z.artifact_clusters, 0);
    EXPECT_EQ(z.merged_negative_clusters, 0);
    EXPECT_EQ(z.total_order, 0);
    EXPECT_TRUE(z.zeros.empty());
}

// A well-shaped genus-2 mesh stretched 2.5 : 0.6 across (femur): a thin fin where the form is
// rounding noise held a local extremum of u (saddle order -1) that merged into a zero. Now no
// artifact, and still 2g - 2.
TEST(Zeros, StretchedFemurHasNoArtifacts) {
    const ZeroSet z = zeros_of(stretched_femur());
    EXPECT_GT(z.unresolved_vertices, 0);
    EXPECT_EQ(z.artifact_clusters, 0);
    EXPECT_EQ(z.merged_negative_clusters, 0);
    EXPECT_EQ(z.total_order, 2);
    EXPECT_EQ(z.zeros.size(), 2u);
}

// atan2_above bounds atan2 from above, within 4e-5 of it, over every direction and scale: the
// axes and diagonals exactly, signed zeros (the +-pi cut), tiny, huge and subnormal components;
// where it cannot tell it says +inf.
TEST(Zeros, Atan2AboveBoundsTheArctangent) {
    const auto check = [](double y, double x) {
        const double exact = std::atan2(y, x), above = atan2_above(y, x);
        EXPECT_GE(above, exact) << "y " << y << " x " << x;
        EXPECT_LE(above, exact + 4e-5) << "y " << y << " x " << x;
    };
    std::mt19937_64 rng(20261206);
    std::uniform_real_distribution<double> angle(-std::numbers::pi, std::numbers::pi);
    std::uniform_real_distribution<double> exponent(-300, 300);
    for (int i = 0; i < 200000; ++i) {
        const double r = std::pow(10.0, exponent(rng)), a = angle(rng);
        check(r * std::sin(a), r * std::cos(a));
    }
    for (int k = 0; k <= 4096; ++k) {  // the polynomial over its whole range, both octants
        const double t = k / 4096.0;
        for (const double sy : {1.0, -1.0})
            for (const double sx : {1.0, -1.0}) check(sy * t, sx * 1.0), check(sy * 1.0, sx * t);
    }
    for (const double y : {0.0, -0.0})
        for (const double x : {1.0, -1.0, 1e-310, -1e-310}) check(y, x), check(x, y);
    check(1e-310, -1e300), check(-1e-310, -1e300), check(1e300, 1e-310);
    EXPECT_EQ(atan2_above(0.0, 0.0), std::numeric_limits<double>::infinity());
    EXPECT_EQ(atan2_above(-0.0, -0.0), std::numeric_limits<double>::infinity());
    EXPECT_EQ(atan2_above(std::nan(""), 1.0), std::numeric_limits<double>::infinity());
    EXPECT_EQ(atan2_above(1.0, -std::numeric_limits<double>::infinity()), std::numeric_limits<double>::infinity());
}

// image_turns gives exactly the rounded angle sums, through its shortcuts or not: images with
// straight corners, repeated points, points on the ray from a vertex, flipped triangles and
// edges whose two sides differ by rounding, whole turns inside and half-turns on the boundary,
// against the sums of corner_angle.
TEST(Zeros, ImageTurnsAreTheRoundedAngleSums) {
    const MeshView m = shapes::flat_grid(12, 9);
    std::vector<char> boundary(m.n_vertices(), 0);
    for (Index h = 0; h < m.n_halfedges(); ++h)
        if (m.twin[h] == kNoHalfedge) boundary[m.tail(h)] = 1;
    std::mt19937_64 rng(20261203);
    std::uniform_real_distribution<double> jitter(-0.04, 0.04);
    std::uniform_int_distribution<int> pick(0, 9);
    for (int trial = 0; trial < 40; ++trial) {
        SCOPED_TRACE(trial);
        std::vector<std::complex<double>> image(m.n_vertices());
        const std::complex<double> turn = std::polar(1.0, 0.37 * trial);  // trial 0: the grid's own axes
        for (Index v = 0; v < m.n_vertices(); ++v) {
            const std::complex<double> z(m.V(v, 0), m.V(v, 1));
            switch (pick(rng)) {
                case 0: image[v] = z * z * turn; break;                            // folds where z^2 wraps
                case 1: image[v] = std::round(4.0 * z.real()) / 4.0 * turn; break;  // collinear, repeated
                default: image[v] = (z + std::complex<double>(jitter(rng), trial % 3 ? jitter(rng) : 0)) * turn;
            }
        }
        std::vector<std::complex<double>> along(m.n_halfedges());
        for (Index h = 0; h < m.n_halfedges(); ++h) along[h] = image[m.head(h)] - image[m.tail(h)];
        if (trial % 4 == 0)  // the two sides of an edge a rounding apart: links that do not quite close
            for (auto& a : along) a += 1e-13 * std::complex<double>(jitter(rng), jitter(rng));
        const ImageTurns turns = image_turns(m.F, m.n_vertices(), along, boundary);
        std::vector<double> total(m.n_vertices(), 0);
        Index flipped = 0;
        for (Index f = 0; f < m.n_faces(); ++f) {
            double sum = 0;
            for (int k = 0; k < 3; ++k) {
                const double a = corner_angle(along[3 * f + k], -along[MeshView::prev(3 * f + k)]);
                total[m.F(f, k)] += a;
                sum += a;
            }
            EXPECT_EQ(turns.face_flip[f], image_flips(sum)) << "face " << f;
            flipped += image_flips(sum) != 0;
        }
        for (Index v = 0; v < m.n_vertices(); ++v)
            EXPECT_EQ(turns.turns[v], std::lround(total[v] / ((boundary[v] ? 1 : 2) * std::numbers::pi))) << "vertex " << v;
        if (trial == 1) {
            EXPECT_GT(flipped, 0);  // the sweep holds folds, not only clean images
        }
    }
}

TEST(Zeros, RejectsBadInput) {
    const MeshView mesh = shapes::torus(2, 1, 12, 8);
    EXPECT_THROW(find_zeros(mesh, Eigen::VectorXcd::Zero(mesh.n_edges() - 1)), InvalidInput);
    EXPECT_THROW(find_zeros(shapes::flat_grid(3, 3), Eigen::VectorXcd::Zero(shapes::flat_grid(3, 3).n_edges())),
                 InvalidInput);
}

}  // namespace
}  // namespace holoflow::kernels
