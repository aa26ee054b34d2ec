#include "holoflow/kernels/zero_fans.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

#include <Eigen/Geometry>
#include <tbb/global_control.h>

#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/shapes.h"
#include "support/plane_zeros.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
using test::face_zero;
using test::form_of;
using test::point;
using test::turned_grid;
constexpr double kClosedTol = 1e-12;  // a face's three form values cancel up to rounding

struct ImageCheck {
    Index flipped = 0;
    double closedness = 0;
    std::vector<int> winding;  // interior vertices; boundary ones 0
    std::vector<int> half_turns;  // boundary vertices (1 where the boundary runs straight); interior ones 0
};

ImageCheck check_image(const MeshView& m, const Eigen::VectorXcd& tau) {
    ImageCheck c;
    std::vector<double> angle(m.n_vertices(), 0);
    std::vector<char> boundary(m.n_vertices(), 0);
    for (Index h = 0; h < m.n_halfedges(); ++h)
        if (m.twin[h] == kNoHalfedge) boundary[m.tail(h)] = boundary[m.head(h)] = 1;
    for (Index f = 0; f < m.n_faces(); ++f) {
        const Complex a = form_along(m, tau, 3 * f), b = form_along(m, tau, 3 * f + 1), d = form_along(m, tau, 3 * f + 2);
        c.closedness = std::max(c.closedness, std::abs(a + b + d) / (std::abs(a) + std::abs(b) + std::abs(d)));
        c.flipped += cross(a, -d) <= 0;
        for (int k = 0; k < 3; ++k) {
            const Complex out = form_along(m, tau, 3 * f + k), in = -form_along(m, tau, 3 * f + (k + 2) % 3);
            angle[m.F(f, k)] += std::arg(in / out);
        }
    }
    c.winding.resize(m.n_vertices());
    c.half_turns.resize(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) {
        c.winding[v] = boundary[v] ? 0 : static_cast<int>(std::lround(angle[v] / (2 * std::numbers::pi)));
        c.half_turns[v] = boundary[v] ? static_cast<int>(std::lround(angle[v] / std::numbers::pi)) : 0;
    }
    return c;
}

// f = z^2 has a simple zero at 0: after the fan the centre winds twice, every other interior
// vertex once, and no image triangle is flipped.
TEST(ZeroFans, SimpleZeroInsideAFaceBecomesAVertexWindingTwice) {
    const MeshView m = turned_grid(14);
    const auto f = [](Complex z) { return z * z; };
    const Complex zero(0.013, -0.021);  // off the grid's symmetry
    std::vector<Complex> shifted(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) shifted[v] = f(point(m, v) - zero);
    const std::vector<ZeroRegion> regions{face_zero(m, zero, 1, [&](Complex z) { return f(z - zero); })};
    const RegularisedForm r = regularise_zeros(m, form_of(m, shifted), regions);
    EXPECT_EQ(r.failed_regions, 0);
    EXPECT_EQ(r.flipped_faces, 0);
    ASSERT_GE(r.region_vertex[0], 0);
    const ImageCheck c = check_image(r.mesh, r.tau);
    EXPECT_EQ(c.flipped, 0);
    EXPECT_LT(c.closedness, kClosedTol);
    for (Index v = 0; v < r.mesh.n_vertices(); ++v)
        if (c.winding[v] != 0) {
            EXPECT_EQ(c.winding[v], v == r.region_vertex[0] ? 2 : 1) << "vertex " << v;
        }
}

// A fold (a vertex's image pushed just across the opposite edge of one of its triangles) is
// repaired by one edge flip, without losing the vertex. A hexagon around vertex 0 with a
// strictly convex link, and one triangle beyond each link edge.
TEST(ZeroFans, FoldAcrossOneEdgeIsRepairedByAnEdgeFlip) {
    PointMatrix V(13, 3);
    V.row(0) << 0, 0, 0;
    for (int k = 0; k < 6; ++k) {
        const double t = k * std::numbers::pi / 3, s = t + std::numbers::pi / 6;
        V.row(1 + k) << std::cos(t), std::sin(t), 0;
        V.row(7 + k) << 2 * std::cos(s), 2 * std::sin(s), 0;
    }
    TriangleMatrix F(12, 3);
    for (int k = 0; k < 6; ++k) {
        F.row(k) << 0, 1 + k, 1 + (k + 1) % 6;
        F.row(6 + k) << 1 + k, 7 + k, 1 + (k + 1) % 6;
    }
    const MeshView m = make_mesh_view(V, F);
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = point(m, v);
    const Complex mid = (image[1] + image[2]) / 2.0;
    image[0] = mid * 1.05;  // just beyond the link edge 1-2
    ASSERT_EQ(check_image(m, form_of(m, image)).flipped, 1);
    ZeroRegion fold;
    fold.vertices = {0};
    const RegularisedForm r = regularise_zeros(m, form_of(m, image), std::vector<ZeroRegion>{fold});
    EXPECT_EQ(r.edge_flips, 1);
    EXPECT_EQ(r.removed_vertices, 0);
    EXPECT_EQ(r.failed_regions, 0);
    EXPECT_EQ(r.mesh.n_faces(), m.n_faces());
    const ImageCheck c = check_image(r.mesh, r.tau);
    EXPECT_EQ(c.flipped, 0);
    EXPECT_EQ(c.winding[0], 1);
    // A fold no region names (a torus whose zero finder saw no fold cluster there) is
    // repaired the same way.
    const RegularisedForm unnamed = regularise_zeros(m, form_of(m, image), {});
    EXPECT_EQ(unnamed.edge_flips, 1);
    EXPECT_EQ(unnamed.flipped_faces, 0);
    EXPECT_EQ(check_image(unnamed.mesh, unnamed.tau).flipped, 0);
}

// A vertex whose image lies far outside its link (winding 0, several flips) needs a
// re-triangulation of its star: the fold goes and every interior vertex winds once.
TEST(ZeroFans, FoldWithoutAZeroIsReTriangulated) {
    const MeshView m = shapes::flat_grid(10, 10);
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = point(m, v);
    const Index v = 5 * 11 + 5;
    image[v] += Complex(0.17, 0.11);  // about 1.5 cells away: beyond its whole one-ring
    ASSERT_GT(check_image(m, form_of(m, image)).flipped, 1);
    ZeroRegion fold;
    fold.vertices = {v};
    const RegularisedForm r = regularise_zeros(m, form_of(m, image), std::vector<ZeroRegion>{fold});
    EXPECT_EQ(r.failed_regions, 0);
    const ImageCheck c = check_image(r.mesh, r.tau);
    EXPECT_EQ(c.flipped, 0);
    EXPECT_LT(c.closedness, kClosedTol);
    for (int w : c.winding) EXPECT_LE(w, 1);
}

// Two folds like the one above: one given as a region, one no region holds (a leftover).
// Where leftover folds are not wanted at that many failed regions, the leftover stays
// flipped, and which regions fail is the same.
TEST(ZeroFans, LeftoverFoldsCanBeLeftWithoutChangingWhichRegionsFail) {
    const MeshView m = shapes::flat_grid(12, 12);
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = point(m, v);
    const Index given = 3 * 13 + 3, leftover = 8 * 13 + 8;
    image[given] += Complex(0.14, 0.09);  // about 1.5 cells away: beyond its whole one-ring
    image[leftover] += Complex(-0.09, 0.14);
    const Eigen::VectorXcd tau = form_of(m, image);
    ZeroRegion fold;
    fold.vertices = {given};
    const std::vector<ZeroRegion> regions{fold};
    const RegularisedForm full = regularise_zeros(m, tau, regions);
    FanOptions comparable;
    comparable.leftover_folds_below_failed_weight = 1;  // kept: none failed
    const RegularisedForm kept = regularise_zeros(m, tau, regions, comparable);
    EXPECT_EQ(kept.flipped_faces, 0);
    comparable.leftover_folds_below_failed_weight = 0;  // not kept below 0 failed: leftovers skipped
    const RegularisedForm partial = regularise_zeros(m, tau, regions, comparable);
    EXPECT_EQ(full.failed_regions, 0);
    EXPECT_EQ(partial.failed_regions, full.failed_regions);
    EXPECT_EQ(partial.failed_weight, full.failed_weight);
    EXPECT_EQ(full.flipped_faces, 0);
    EXPECT_EQ(check_image(full.mesh, full.tau).flipped, 0);
    EXPECT_GT(partial.flipped_faces, 0);
    EXPECT_EQ(check_image(partial.mesh, partial.tau).flipped, partial.flipped_faces);
}

// From 8192 faces the new mesh's kept faces are copied in parallel blocks, each pairing its
// halfedges with the fans' chain halfedges across: the same mesh and form with one thread.
TEST(ZeroFans, LargeMeshIsTheSameWithAnyThreadCount) {
    const MeshView m = shapes::flat_grid(80, 80);  // 12800 faces
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = point(m, v);
    std::vector<ZeroRegion> regions;
    for (const Index v : {10 * 81 + 10, 40 * 81 + 41, 70 * 81 + 25}) {  // folds, beyond their one-ring
        image[v] += Complex(0.018, 0.011);
        ZeroRegion fold;
        fold.vertices = {v};
        regions.push_back(fold);
    }
    const Eigen::VectorXcd tau = form_of(m, image);
    const auto regularised_with = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return regularise_zeros(m, tau, regions);
    };
    const RegularisedForm one = regularised_with(1), two = regularised_with(2);
    EXPECT_EQ(one.failed_regions, 0);
    EXPECT_GT(one.removed_vertices, 0);
    EXPECT_EQ(one.flipped_faces, 0);
    EXPECT_EQ(check_image(one.mesh, one.tau).flipped, 0);
    EXPECT_EQ(one.mesh.twin, make_mesh_view(one.mesh.V, one.mesh.F).twin);
    EXPECT_EQ(one.mesh.F, two.mesh.F);
    EXPECT_EQ(one.mesh.twin, two.mesh.twin);
    EXPECT_EQ(one.tau, two.tau);
    EXPECT_EQ(one.original_face, two.original_face);
    EXPECT_EQ(one.original_vertex, two.original_vertex);
}

// A simple zero placed where the image is regular (it winds once) has no fan. Its region is
// grown again from its other cluster vertices only when it has some: a region of the zero's
// vertex alone counts no regrowable failure, and a run with regrow_failed repeats it exactly
// (the pipeline then skips that run).
TEST(ZeroFans, RegrowableFailuresAreCounted) {
    const MeshView m = shapes::flat_grid(12, 12);
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = point(m, v);
    const Eigen::VectorXcd tau = form_of(m, image);
    const Index centre = 6 * 13 + 6;
    ZeroRegion alone;
    alone.order = 1;
    alone.vertex = centre;
    alone.vertices = {centre};
    FanOptions regrow;
    regrow.regrow_failed = true;
    const RegularisedForm once = regularise_zeros(m, tau, std::vector<ZeroRegion>{alone});
    EXPECT_EQ(once.failed_regions, 1);
    EXPECT_EQ(once.regrowable_failures, 0);
    const RegularisedForm again = regularise_zeros(m, tau, std::vector<ZeroRegion>{alone}, regrow);
    EXPECT_EQ(again.failed_regions, once.failed_regions);
    EXPECT_EQ(again.mesh.F, once.mesh.F);
    EXPECT_EQ(again.tau, once.tau);
    EXPECT_EQ(again.region_vertex, once.region_vertex);

    ZeroRegion cluster = alone;
    cluster.vertices = {centre, centre + 1};  // a cluster vertex where the image is regular
    const RegularisedForm grown = regularise_zeros(m, tau, std::vector<ZeroRegion>{cluster});
    EXPECT_EQ(grown.failed_regions, 1);
    EXPECT_GT(grown.regrowable_failures, 0);
}

// Without regions and folds the mesh passes through as it is: the same triangles and form,
// identity maps (a torus without folds keeps the surface's homology cut graph this way).
TEST(ZeroFans, NoRegionAndNoFoldKeepsTheMesh) {
    const MeshView m = shapes::flat_grid(10, 10);
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = point(m, v);
    image[5 * 11 + 5] += Complex(0.03, 0.02);  // moved, not folded
    const Eigen::VectorXcd tau = form_of(m, image);
    ASSERT_EQ(check_image(m, tau).flipped, 0);
    const RegularisedForm r = regularise_zeros(m, tau, {});
    EXPECT_EQ(r.mesh.F, m.F);
    EXPECT_EQ(r.tau, tau);
    for (Index v = 0; v < m.n_vertices(); ++v) EXPECT_EQ(r.original_vertex[v], v);
    for (Index f = 0; f < m.n_faces(); ++f) EXPECT_EQ(r.original_face[f], f);
    EXPECT_EQ(r.flipped_faces, 0);
    EXPECT_EQ(r.edge_flips, 0);
    EXPECT_EQ(r.removed_vertices, 0);
    EXPECT_THROW(regularise_zeros(m, Eigen::VectorXcd(3), {}), InvalidInput);
}

// f = z^3 at a vertex: an order-2 zero, its one-ring already a fan winding three times.
TEST(ZeroFans, ZeroAtAVertexKeepsTheVertex) {
    const MeshView m = shapes::flat_grid(10, 10);
    const Index centre = 5 * 11 + 5;
    std::vector<Complex> image(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) image[v] = std::pow(point(m, v) - point(m, centre), 3);
    ZeroRegion zero;
    zero.order = 2;
    zero.vertex = centre;
    zero.vertices = {centre};
    const RegularisedForm r = regularise_zeros(m, form_of(m, image), std::vector<ZeroRegion>{zero});
    ASSERT_EQ(r.failed_regions, 0);
    EXPECT_EQ(r.original_vertex[r.region_vertex[0]], centre);
    const ImageCheck c = check_image(r.mesh, r.tau);
    EXPECT_EQ(c.flipped, 0);
    EXPECT_EQ(c.winding[r.region_vertex[0]], 3);
}

TEST(ZeroFans, RejectsBadRegions) {
    const MeshView m = shapes::flat_grid(3, 3);
    const Eigen::VectorXcd tau = Eigen::VectorXcd::Zero(m.n_edges());
    ZeroRegion bad;
    bad.vertices = {m.n_vertices()};
    EXPECT_THROW(regularise_zeros(m, tau, std::vector<ZeroRegion>{bad}), InvalidInput);
    EXPECT_THROW(regularise_zeros(m, Eigen::VectorXcd::Zero(2), std::vector<ZeroRegion>{}), InvalidInput);
}

// Corpus meshes whose piecewise linear image folds near and away from the zeros: every fold
// is re-triangulated, so the segmentation has only disks, no flipped uv triangle and exact
// rectangles.
TEST(ZeroFans, CorpusSegmentationsHaveNoFlippedTriangles) {
    for (const char* name : {"femur", "helmet", "couplingdown", "lion"}) {
        SCOPED_TRACE(name);
        const engine::SegmentationResult r = engine::segment(*test::corpus_mesh(name));
        EXPECT_EQ(r.zeros.artifact_clusters, 0);
        EXPECT_EQ(r.regular.failed_regions, 0);
        EXPECT_EQ(r.regular.flipped_faces, 0);
        EXPECT_EQ(r.cut.skipped_segments, 0);
        for (const PatchInfo& p : r.patches.info) {
            EXPECT_EQ(p.type, PatchInfo::Type::Disk);
            EXPECT_EQ(p.flipped_uv_triangles, 0);
            EXPECT_LT(p.rectangle_error, 1e-9);
        }
    }
}

// A zero next to a mesh boundary whose fan reaches the boundary: a boundary point of the fan
// must still turn half a turn (the double cover's whole turn; a zero's own point may keep its
// turns), or the boundary doubles back there, an uncounted zero beside a patch that is no
// rectangle. Rotated copies of double-torus-3-holes scaled 1 : 2.5 : 0.6, where the image
// folds near the small holes. Before the check, 7 of these 40 had an irregular vertex that no
// failed fan accounted for and 7 a rectangle error over 1e-3; now 1 and 3 (the rest: fans
// around a small hole, which fail and are counted). A statistic, with room for rounding.
TEST(ZeroFans, BoundaryPointsOfAFanTurnHalfOnce) {
    const MeshView input = *test::corpus_mesh("double-torus-3-holes");
    constexpr int kCopies = 40;
    int silent = 0, not_rectangles = 0;
    for (int copy = 0; copy < kCopies; ++copy) {
        SCOPED_TRACE(copy);
        MeshView m = input;
        const Eigen::Matrix3d rotation = (Eigen::AngleAxisd(0.4 + 0.7 * copy, Eigen::Vector3d::UnitX()) *
                                          Eigen::AngleAxisd(0.3 + 1.3 * copy, Eigen::Vector3d::UnitZ()))
                                             .toRotationMatrix();
        m.V = (input.V * rotation.transpose()) * Eigen::Vector3d(1, 2.5, 0.6).asDiagonal();
        const engine::SegmentationResult r = engine::segment(m);
        EXPECT_EQ(r.zeros.artifact_clusters, 0);
        // Every vertex but the fans' centres turns once: 2 pi inside, pi on the boundary.
        std::vector<char> centre(r.regular.mesh.n_vertices(), 0);
        for (Index v : r.regular.region_vertex)
            if (v >= 0) centre[v] = 1;
        const ImageCheck c = check_image(r.regular.mesh, r.regular.tau);
        Index irregular = 0;
        for (Index v = 0; v < r.regular.mesh.n_vertices(); ++v)
            irregular += !centre[v] && c.winding[v] + c.half_turns[v] != 1;
        silent += irregular > 0 && r.regular.failed_regions == 0;
        double rectangle_error = 0;
        for (const PatchInfo& p : r.patches.info) rectangle_error = std::max(rectangle_error, p.rectangle_error);
        not_rectangles += rectangle_error > 1e-3;
    }
    EXPECT_LE(silent, 3);
    EXPECT_LE(not_rectangles, 5);
}

}  // namespace
}  // namespace holoflow::kernels
