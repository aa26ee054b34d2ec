#include "holoflow/kernels/intrinsic_delaunay.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/subdivision.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

// Lengths, areas and cotangents are sums of a few rounded products: 1e-12 relative leaves three
// orders of magnitude over the rounding of meshes with up to ~1e5 faces.
constexpr double kLengthTol = 1e-12;
// A cotan weight counts as negative below -kWeightTol times the cotangent scale of its edge (the
// flip test's own tolerance, 1e-12, plus the rounding of a second, independent evaluation).
constexpr double kWeightTol = 2e-12;
// Planar in-circle determinant, relative to its permanent (sum of absolute terms).
constexpr double kInCircleTol = 1e-10;

//! 16 area^2 by Heron in Kahan's ordering (independent of the kernel's own helper).
double triangle_area(double a, double b, double c) {
    double s[3] = {a, b, c};
    std::sort(s, s + 3, [](double x, double y) { return x > y; });
    const double p = (s[0] + (s[1] + s[2])) * (s[2] - (s[0] - s[1])) * (s[2] + (s[0] - s[1])) *
                     (s[0] + (s[1] - s[2]));
    return 0.25 * std::sqrt(std::max(p, 0.0));
}

std::vector<double> euclidean_lengths(const MeshView& m) {
    std::vector<double> l(m.n_edges());
    for (Index e = 0; e < m.n_edges(); ++e) l[e] = (m.V.row(m.E(e, 1)) - m.V.row(m.E(e, 0))).norm();
    return l;
}

double total_area(const MeshView& m, const std::vector<double>& length) {
    double sum = 0;
    for (Index f = 0; f < m.n_faces(); ++f)
        sum += triangle_area(length[m.halfedge_edge[3 * f]], length[m.halfedge_edge[3 * f + 1]],
                             length[m.halfedge_edge[3 * f + 2]]);
    return sum;
}

//! Integer vertex function (deterministic, no RNG) and its differential: an exact form whose
//! values after any number of flips must still be f(head) - f(tail), bit for bit.
double vertex_function(Index v) { return static_cast<double>((v * 7919LL) % 1009 - 504); }

Eigen::MatrixXd exact_form(const MeshView& m) {
    Eigen::MatrixXd df(m.n_edges(), 1);
    for (Index e = 0; e < m.n_edges(); ++e)
        df(e, 0) = vertex_function(m.E(e, 1)) - vertex_function(m.E(e, 0));
    return df;
}

void expect_exact_differential(const MeshView& m, const Eigen::MatrixXd& forms, Index col) {
    Index wrong = 0;
    for (Index e = 0; e < m.n_edges(); ++e)
        wrong += forms(e, col) != vertex_function(m.E(e, 1)) - vertex_function(m.E(e, 0));
    EXPECT_EQ(wrong, 0) << "edges where the carried df differs from f(head) - f(tail)";
}

//! Largest |sum of a form around a face| (oriented by the mesh's edge signs).
double max_face_sum(const MeshView& m, const Eigen::MatrixXd& forms) {
    double worst = 0;
    for (Index f = 0; f < m.n_faces(); ++f)
        for (Index j = 0; j < forms.cols(); ++j) {
            double s = 0;
            for (Index k = 0; k < 3; ++k)
                s += m.edge_sign(3 * f + k) * forms(m.halfedge_edge[3 * f + k], j);
            worst = std::max(worst, std::abs(s));
        }
    return worst;
}

//! Cotangent of the angle opposite halfedge h from lengths, and the face's cotangent scale.
std::pair<double, double> cot_opposite(const MeshView& m, const std::vector<double>& l, Index h) {
    const double a = l[m.halfedge_edge[h]], b = l[m.halfedge_edge[MeshView::next(h)]],
                 c = l[m.halfedge_edge[MeshView::prev(h)]];
    const double four_area = 4 * triangle_area(a, b, c);
    return {(b * b + c * c - a * a) / four_area, (a * a + b * b + c * c) / four_area};
}

struct WeightCheck {
    Index negative = 0;  // below -kWeightTol * scale
    double worst = 0;    // most negative w_e / scale_e
};

//! Weights of cotan_weights_from_lengths on interior edges, each compared with its edge's
//! cotangent scale. Boundary edges never flip, so an obtuse angle opposite one stays negative.
WeightCheck check_intrinsic_weights(const MeshView& m, const std::vector<double>& length) {
    const std::vector<double> w = cotan_weights_from_lengths(m.halfedge_edge, length, m.n_edges());
    WeightCheck check;
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Index h = m.edge_halfedge[e], t = m.twin[h];
        if (t == kNoHalfedge) continue;
        const double scale = cot_opposite(m, length, h).second + cot_opposite(m, length, t).second;
        const double relative = w[e] / (0.5 * scale);
        check.worst = std::min(check.worst, relative);
        check.negative += relative < -kWeightTol;
    }
    return check;
}

void expect_identical(const IntrinsicTriangulation& x, const IntrinsicTriangulation& y) {
    EXPECT_EQ(x.flips, y.flips);
    EXPECT_TRUE(x.mesh.F == y.mesh.F);
    EXPECT_EQ(x.mesh.twin, y.mesh.twin);
    EXPECT_EQ(x.edge_length, y.edge_length);
    EXPECT_TRUE(x.forms == y.forms);
}

TEST(IntrinsicDelaunay, IcosphereIsAlreadyDelaunay) {
    const MeshView sphere = shapes::icosphere(3);
    ASSERT_GT(sphere.n_faces(), 0);
    const Eigen::MatrixXd df = exact_form(sphere);
    const IntrinsicTriangulation r = intrinsic_delaunay(sphere, df);
    EXPECT_EQ(r.flips, 0);
    EXPECT_FALSE(r.hit_flip_limit);
    EXPECT_EQ(r.non_delaunay_edges, 0);
    EXPECT_TRUE(r.mesh.F == sphere.F);
    EXPECT_EQ(r.mesh.twin, sphere.twin);
    EXPECT_EQ(r.edge_length, euclidean_lengths(sphere));
    EXPECT_TRUE(r.forms == df);
}

// Two copies of a 30-30-120 triangle glued along all three sides (a closed "pillow"). Both angles
// opposite the long side are 120 degrees, so it flips into a loop edge at the apex of length
// 2 * height = 1, and the pillow becomes two equilateral triangles of side 1 whose faces repeat
// the apex vertex: the case plain vertex-pair connectivity cannot hold.
TEST(IntrinsicDelaunay, ObtusePillowFlipsToEquilateralLoopTriangles) {
    PointMatrix V(3, 3);
    const double half_base = std::sqrt(3.0) / 2;
    V << -half_base, 0, 0, half_base, 0, 0, 0, 0.5, 0;
    TriangleMatrix F(2, 3);
    F << 0, 1, 2, 1, 0, 2;
    const MeshView pillow = make_mesh_view(V, F);
    ASSERT_EQ(pillow.n_edges(), 3);
    const Eigen::MatrixXd df = exact_form(pillow);

    const IntrinsicTriangulation r = intrinsic_delaunay(pillow, df);
    EXPECT_EQ(r.flips, 1);
    EXPECT_EQ(r.non_delaunay_edges, 0);
    ASSERT_EQ(r.mesh.n_edges(), 3);
    Index loops = 0;
    for (Index e = 0; e < 3; ++e) {
        EXPECT_NEAR(r.edge_length[e], 1.0, kLengthTol) << "edge " << e;
        loops += r.mesh.E(e, 0) == r.mesh.E(e, 1);
    }
    EXPECT_EQ(loops, 1);
    for (Index f = 0; f < 2; ++f) {
        const Index apex_corners =
            (r.mesh.F(f, 0) == 2) + (r.mesh.F(f, 1) == 2) + (r.mesh.F(f, 2) == 2);
        EXPECT_EQ(apex_corners, 2) << "face " << f;
    }
    EXPECT_NEAR(total_area(r.mesh, r.edge_length), total_area(pillow, euclidean_lengths(pillow)),
                kLengthTol);
    expect_exact_differential(r.mesh, r.forms, 0);
}

//! Sheared lattice i * (1, 0) + j * (shear, height) with the long cell diagonals: very obtuse
//! triangles. Interior vertices are nudged by a deterministic hash so no four are cocircular.
MeshView sheared_grid(int nx, int ny, double shear, double height) {
    PointMatrix V((nx + 1) * (ny + 1), 3);
    auto id = [&](int i, int j) { return j * (nx + 1) + i; };
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            const bool interior = i > 0 && i < nx && j > 0 && j < ny;
            const std::uint64_t hash =
                (static_cast<std::uint64_t>(id(i, j)) + 1) * 0x9E3779B97F4A7C15ULL;
            const double nudge_x =
                interior ? 1e-3 * (static_cast<double>(hash >> 40) / (1 << 24) - 0.5) : 0;
            const double nudge_y =
                interior ? 1e-3 * (static_cast<double>((hash >> 16) & 0xFFFFFF) / (1 << 24) - 0.5)
                         : 0;
            V.row(id(i, j)) << i + shear * j + nudge_x, height * j + nudge_y, 0;
        }
    TriangleMatrix F(2 * nx * ny, 3);
    int f = 0;
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            F.row(f++) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
            F.row(f++) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
        }
    return make_mesh_view(V, F);
}

double cross2(const MeshView& m, Index a, Index b, Index c) {
    const double ux = m.V(b, 0) - m.V(a, 0), uy = m.V(b, 1) - m.V(a, 1);
    const double vx = m.V(c, 0) - m.V(a, 0), vy = m.V(c, 1) - m.V(a, 1);
    return ux * vy - uy * vx;
}

//! In-circle determinant of d against counter-clockwise a, b, c (> 0: d strictly inside), and
//! its permanent as the rounding scale.
std::pair<double, double> in_circle(const MeshView& m, Index a, Index b, Index c, Index d) {
    double r[3][3], p = 0, det = 0;
    const Index abc[3] = {a, b, c};
    for (int i = 0; i < 3; ++i) {
        const double x = m.V(abc[i], 0) - m.V(d, 0), y = m.V(abc[i], 1) - m.V(d, 1);
        r[i][0] = x;
        r[i][1] = y;
        r[i][2] = x * x + y * y;
    }
    for (int i = 0; i < 3; ++i) {
        const double term = r[0][i] * (r[1][(i + 1) % 3] * r[2][(i + 2) % 3] -
                                       r[1][(i + 2) % 3] * r[2][(i + 1) % 3]);
        det += term;
        p += std::abs(r[0][i]) * (std::abs(r[1][(i + 1) % 3] * r[2][(i + 2) % 3]) +
                                  std::abs(r[1][(i + 2) % 3] * r[2][(i + 1) % 3]));
    }
    return {det, p};
}

TEST(IntrinsicDelaunay, ShearedPlanarGridBecomesPlanarDelaunay) {
    constexpr int nx = 12, ny = 10;
    constexpr double shear = 2.3, height = 0.35;
    const MeshView grid = sheared_grid(nx, ny, shear, height);
    const std::vector<double> w_before = cotan_weights(grid);
    EXPECT_GT(std::count_if(w_before.begin(), w_before.end(), [](double w) { return w < 0; }), 0);

    const IntrinsicTriangulation r = intrinsic_delaunay(grid, exact_form(grid));
    EXPECT_GT(r.flips, 0);
    EXPECT_EQ(r.non_delaunay_edges, 0);
    EXPECT_FALSE(r.hit_flip_limit);
    const MeshView& m = r.mesh;
    ASSERT_EQ(m.n_edges(), grid.n_edges());

    // In the plane the intrinsic metric is the Euclidean one: every new edge is a straight segment
    // whose length is the distance of its endpoints, and the faces tile the parallelogram.
    const std::vector<double> straight = euclidean_lengths(m);
    for (Index e = 0; e < m.n_edges(); ++e)
        ASSERT_NEAR(r.edge_length[e], straight[e], kLengthTol * straight[e]) << "edge " << e;
    double signed_area = 0;
    for (Index f = 0; f < m.n_faces(); ++f) {
        const double twice = cross2(m, m.F(f, 0), m.F(f, 1), m.F(f, 2));
        EXPECT_GT(twice, 0) << "face " << f << " is folded";
        signed_area += 0.5 * twice;
    }
    const double parallelogram = nx * (ny * height);
    EXPECT_NEAR(signed_area, parallelogram, kLengthTol * parallelogram);
    EXPECT_NEAR(total_area(m, r.edge_length), parallelogram, kLengthTol * parallelogram);

    // Locally Delaunay in a planar triangulation of a convex domain = globally Delaunay.
    Index inside = 0;
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Index h = m.edge_halfedge[e], t = m.twin[h];
        if (t == kNoHalfedge) continue;
        const auto [det, permanent] = in_circle(m, m.tail(h), m.head(h), m.tail(MeshView::prev(h)),
                                                m.tail(MeshView::prev(t)));
        inside += det > kInCircleTol * permanent;
    }
    EXPECT_EQ(inside, 0) << "edges whose opposite vertex lies inside the circumcircle";
    EXPECT_EQ(check_intrinsic_weights(m, r.edge_length).negative, 0);
    expect_exact_differential(m, r.forms, 0);
}

// shapes::torus with every odd ring of the tube turned by 0.45 of a cell around the big circle:
// the diagonals (i, j) -> (i+1, j+1) from even rings then span 1.45 cells, far from Delaunay. The
// index forms du, dv (wrapped grid-index differences, small integers) are closed and their wedge
// is known: every face is a half unit square in index space, counter-clockwise, so
// A = nu nv [[0, 1], [-1, 0]].
TEST(IntrinsicDelaunay, TwistedTorusIndexFormsKeepTheirWedge) {
    constexpr int nu = 12, nv = 16;
    constexpr double big = 2.0, tube = 0.5;
    const MeshView grid = shapes::torus(big, tube, nu, nv);
    PointMatrix V = grid.V;
    for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nv; ++j) {
            const double u = 2 * std::numbers::pi * (i + 0.45 * (j % 2)) / nu;
            const double v = 2 * std::numbers::pi * j / nv;
            V.row(i * nv + j) << (big + tube * std::cos(v)) * std::cos(u),
                (big + tube * std::cos(v)) * std::sin(u), tube * std::sin(v);
        }
    const MeshView torus = make_mesh_view(V, grid.F);
    auto wrap = [](int d, int n) { return d > 1 ? d - n : d < -1 ? d + n : d; };
    Eigen::MatrixXd index_forms(torus.n_edges(), 2);
    for (Index e = 0; e < torus.n_edges(); ++e) {
        const Index a = torus.E(e, 0), b = torus.E(e, 1);
        index_forms(e, 0) = wrap(b / nv - a / nv, nu);
        index_forms(e, 1) = wrap(b % nv - a % nv, nv);
    }
    ASSERT_EQ(max_face_sum(torus, index_forms), 0.0);
    Eigen::Matrix2d expected;
    expected << 0, nu * nv, -nu * nv, 0;
    ASSERT_TRUE(wedge_matrix(torus, index_forms) == expected);

    const IntrinsicTriangulation r = intrinsic_delaunay(torus, index_forms);
    EXPECT_GT(r.flips, 0);
    EXPECT_EQ(r.non_delaunay_edges, 0);
    EXPECT_EQ(check_intrinsic_weights(r.mesh, r.edge_length).negative, 0);
    EXPECT_EQ(max_face_sum(r.mesh, r.forms), 0.0);
    EXPECT_TRUE(wedge_matrix(r.mesh, r.forms) == expected) << wedge_matrix(r.mesh, r.forms);
    const double area = total_area(torus, euclidean_lengths(torus));
    EXPECT_NEAR(total_area(r.mesh, r.edge_length), area, kLengthTol * area);
}

// carry_forms replays the flips column by column, in parallel from 16384 edges: each column must
// get exactly the arithmetic of a replay of its own, also for real-valued forms (where another
// order of the additions would round differently), on one thread or two.
TEST(IntrinsicDelaunay, CarriedFormsAreEachColumnsOwnReplay) {
    const MeshView grid = sheared_grid(100, 90, 2.3, 0.35);
    ASSERT_GE(grid.n_edges(), 16384);
    const IntrinsicTriangulation r = intrinsic_delaunay(grid);
    ASSERT_GT(r.form_flips.size(), 1000u);
    std::mt19937_64 rng(20261207);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd forms(grid.n_edges(), 11);
    for (Eigen::Index k = 0; k < forms.size(); ++k) forms.data()[k] = uniform(rng);
    Eigen::MatrixXd expected(forms.rows(), forms.cols());
    for (Eigen::Index j = 0; j < forms.cols(); ++j) {
        Eigen::VectorXd eta = forms.col(j);
        for (const FormFlip& f : r.form_flips) eta[f.edge] = f.sign_a * eta[f.from_a] + f.sign_b * eta[f.from_b];
        for (Eigen::Index e = 0; e < forms.rows(); ++e) expected(e, j) = r.form_sign[e] * eta[r.form_slot[e]];
    }
    for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        EXPECT_TRUE(carry_forms(r, forms) == expected) << threads << " threads";
        EXPECT_TRUE(carry_forms(r, forms.leftCols(3)) == expected.leftCols(3)) << threads << " threads";
    }
}

// Sparse forms carry to the dense overload's values (its zeros dropped), on one thread or two.
TEST(IntrinsicDelaunay, SparseFormsCarryToTheDenseValues) {
    const MeshView grid = sheared_grid(100, 90, 2.3, 0.35);
    const IntrinsicTriangulation r = intrinsic_delaunay(grid);
    std::mt19937_64 rng(20261208);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd forms = Eigen::MatrixXd::Zero(grid.n_edges(), 7);
    for (Eigen::Index k = 0; k < forms.size(); k += 37) forms.data()[k] = uniform(rng);  // a few nonzeros
    const Eigen::MatrixXd expected = carry_forms(r, forms);
    for (int threads : {1, 2}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const Eigen::SparseMatrix<double> carried = carry_forms(r, Eigen::SparseMatrix<double>(forms.sparseView()));
        EXPECT_TRUE(Eigen::MatrixXd(carried) == expected) << threads << " threads";
        EXPECT_EQ(carried.nonZeros(), (expected.array() != 0.0).count());
    }
    EXPECT_THROW(carry_forms(r, Eigen::SparseMatrix<double>(forms.topRows(5).sparseView())), InvalidInput);
}

TEST(IntrinsicDelaunay, FlipCapStopsEarlyAndReportsIt) {
    const MeshView grid = sheared_grid(8, 6, 2.3, 0.35);
    const IntrinsicTriangulation full = intrinsic_delaunay(grid, exact_form(grid));
    ASSERT_GT(full.flips, 3);
    IntrinsicDelaunayOptions options;
    options.max_flips = 3;
    const IntrinsicTriangulation capped = intrinsic_delaunay(grid, exact_form(grid), options);
    EXPECT_EQ(capped.flips, 3);
    EXPECT_TRUE(capped.hit_flip_limit);
    EXPECT_GT(capped.non_delaunay_edges, 0);
    const double parallelogram = 8 * (6 * 0.35);
    EXPECT_NEAR(total_area(capped.mesh, capped.edge_length), parallelogram,
                kLengthTol * parallelogram);
    expect_exact_differential(capped.mesh, capped.forms, 0);
    options.max_flips = full.flips;  // exactly enough: finishes without hitting the cap
    const IntrinsicTriangulation exact_cap = intrinsic_delaunay(grid, exact_form(grid), options);
    EXPECT_FALSE(exact_cap.hit_flip_limit);
    expect_identical(exact_cap, full);
}

TEST(IntrinsicDelaunay, RejectsBadInput) {
    const MeshView sphere = shapes::icosphere(1);
    EXPECT_THROW(intrinsic_delaunay(sphere, Eigen::MatrixXd::Zero(sphere.n_edges() + 1, 1)),
                 InvalidInput);
    IntrinsicDelaunayOptions options;
    options.max_flips = -2;
    EXPECT_THROW(intrinsic_delaunay(sphere, exact_form(sphere), options), InvalidInput);
    PointMatrix V = sphere.V;
    V.row(sphere.F(0, 1)) = V.row(sphere.F(0, 0));  // face 0 collapses to a segment
    const MeshView flat = make_mesh_view(V, sphere.F);
    EXPECT_THROW(intrinsic_delaunay(flat, exact_form(flat)), InvalidInput);
}

// ---- Real CAD meshes with thousands of obtuse triangles (libcgal-demo corpus). ----


class CorpusIntrinsicDelaunay : public testing::TestWithParam<const char*> {};

TEST_P(CorpusIntrinsicDelaunay, RemovesNegativeWeightsAndCarriesFormsExactly) {
    const auto mesh_ptr = test::corpus_mesh(GetParam());
    const MeshView& mesh = *mesh_ptr;
    const std::vector<double> w_before = cotan_weights(mesh);
    const auto negative_before =
        std::count_if(w_before.begin(), w_before.end(), [](double w) { return w < 0; });
    EXPECT_GT(negative_before, 0);

    const HomologyBasis basis = compute_homology_basis(mesh);
    ASSERT_GT(basis.genus, 0);
    Eigen::MatrixXd forms(mesh.n_edges(), basis.closed_forms.cols() + 1);
    forms << basis.closed_forms, exact_form(mesh);
    const Index k = static_cast<Index>(basis.closed_forms.cols());

    const IntrinsicTriangulation r = intrinsic_delaunay(mesh, forms);
    const MeshView& m = r.mesh;
    RecordProperty("flips", r.flips);
    const WeightCheck after = check_intrinsic_weights(m, r.edge_length);
    std::printf("[ %s ] %td negative cotan weights before, %d flips, min w_e / scale_e after %g\n",
                GetParam(), static_cast<std::ptrdiff_t>(negative_before), r.flips, after.worst);
    EXPECT_GT(r.flips, 0);
    EXPECT_FALSE(r.hit_flip_limit);
    EXPECT_EQ(r.non_delaunay_edges, 0);

    EXPECT_EQ(after.negative, 0) << "most negative w_e / scale_e: " << after.worst;

    ASSERT_EQ(m.n_edges(), mesh.n_edges());
    EXPECT_EQ(m.n_faces(), mesh.n_faces());
    EXPECT_EQ(m.n_vertices() - m.n_edges() + m.n_faces(),
              mesh.n_vertices() - mesh.n_edges() + mesh.n_faces());
    EXPECT_TRUE(m.is_closed());
    const double area = total_area(mesh, euclidean_lengths(mesh));
    EXPECT_NEAR(total_area(m, r.edge_length), area, kLengthTol * area);

    // Integer forms: the flip sums are exact, so closedness and the wedge pairing (a cohomology
    // invariant) must hold with ==, not up to a tolerance.
    EXPECT_EQ(max_face_sum(m, r.forms.leftCols(k)), 0.0);
    const Eigen::MatrixXd wedge_before = wedge_matrix(mesh, basis.closed_forms);
    const Eigen::MatrixXd wedge_after = wedge_matrix(m, r.forms.leftCols(k));
    EXPECT_TRUE(wedge_after == wedge_before) << "before\n"
                                             << wedge_before << "\nafter\n"
                                             << wedge_after;
    expect_exact_differential(m, r.forms, k);

    expect_identical(intrinsic_delaunay(mesh, forms), r);  // deterministic
}

INSTANTIATE_TEST_SUITE_P(Libcgal, CorpusIntrinsicDelaunay,
                         testing::Values("femur", "anchor", "turbine"),
                         [](const testing::TestParamInfo<const char*>& p) { return p.param; });

// Midpoint subdivision keeps every triangle's shape, so the obtuse configurations survive at
// four times the size; the result must still be Delaunay with the forms carried exactly.
TEST(IntrinsicDelaunay, SubdividedTurbineStaysExact) {
    const auto mesh_ptr = test::corpus_mesh("turbine");
    const MeshView fine = subdivide_midpoint(*mesh_ptr);
    const IntrinsicTriangulation r = intrinsic_delaunay(fine, exact_form(fine));
    EXPECT_GT(r.flips, 0);
    EXPECT_EQ(r.non_delaunay_edges, 0);
    EXPECT_EQ(check_intrinsic_weights(r.mesh, r.edge_length).negative, 0);
    const double area = total_area(fine, euclidean_lengths(fine));
    EXPECT_NEAR(total_area(r.mesh, r.edge_length), area, kLengthTol * area);
    expect_exact_differential(r.mesh, r.forms, 0);
}

}  // namespace
}  // namespace holoflow::kernels
