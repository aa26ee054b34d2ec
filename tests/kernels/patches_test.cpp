#include "holoflow/kernels/patches.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <complex>
#include <numbers>
#include <vector>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/shapes.h"
#include "support/plane_zeros.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
using test::form_of;
using test::point;

constexpr double kBulge = 1e-4;  // repaired sides bulge out by at most this much of their length

// The grid [0, 2] x [0, 1] (nx by ny cells) and its identity image.
struct Sheet {
    MeshView mesh;
    std::vector<Complex> image;
};

Sheet sheet(int nx, int ny) {
    Sheet s{shapes::flat_grid(nx, ny), {}};
    for (Index v = 0; v < s.mesh.n_vertices(); ++v) s.mesh.V(v, 0) *= 2;
    for (Index v = 0; v < s.mesh.n_vertices(); ++v) s.image.push_back(point(s.mesh, v));
    return s;
}

Index nearest_vertex(const MeshView& m, Complex z) {
    Index best = 0;
    for (Index v = 1; v < m.n_vertices(); ++v)
        if (std::abs(point(m, v) - z) < std::abs(point(m, best) - z)) best = v;
    return best;
}

// Smallest uv area of the patch's triangles over their longest squared edge (> 0: none
// flipped or degenerate).
double smallest_relative_area(const MeshView& m, const Patches& p, Index patch) {
    double smallest = std::numeric_limits<double>::infinity();
    for (Index f = 0; f < m.n_faces(); ++f) {
        if (p.face_patch[f] != patch) continue;
        const Complex a = p.corner_uv[3 * f], b = p.corner_uv[3 * f + 1], c = p.corner_uv[3 * f + 2];
        smallest = std::min(smallest, cross(b - a, c - a) / std::max({std::norm(b - a), std::norm(c - b), std::norm(a - c)}));
    }
    return smallest;
}

// On shapes::cylinder with `around` vertices per ring: the form running around it (one chord
// per step, wrapped to -1, 0, 1 steps; period `around` chords, real) and up it (imaginary),
// sheared by `shear` (Re gains shear times the rise).
Eigen::VectorXcd around_and_up(const MeshView& m, int around, double shear) {
    const double chord = 2 * std::sin(std::numbers::pi / around);
    Eigen::VectorXcd tau(m.n_edges());
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Index a = m.E(e, 0), b = m.E(e, 1);
        Index steps = (b % around - a % around + around) % around;
        if (steps > around / 2) steps -= around;
        const double rise = m.V(b, 2) - m.V(a, 2);
        tau(e) = Complex(chord * static_cast<double>(steps) + shear * rise, rise);
    }
    return tau;
}

// A tube with a form whose period around it is real: one cylinder patch. The transversal
// through a vertex at mid-height (an iso-u line; the form is sheared so that it meets no other
// vertex) opens it into a disk whose uv is exactly the rectangle period x height.
// A face collapses where its uv scale sqrt(uv area / area) is under the ratio times the mean
// sqrt(sum uv area / sum area): half a sheet shrunk by 1e-9 is half its area; the scale of the
// whole uv changes nothing; a uv that is one point is all collapsed.
TEST(CollapsedArea, CountsFacesUnderTheMeanScale) {
    const Sheet s = sheet(8, 4);
    const Index nf = s.mesh.n_faces();
    std::vector<Complex> uv(3 * static_cast<std::size_t>(nf));
    for (Index f = 0; f < nf; ++f)
        for (int k = 0; k < 3; ++k) uv[3 * f + k] = s.image[s.mesh.F(f, k)];
    const CollapsedArea identity = collapsed_area(s.mesh, uv, 1e-6);
    EXPECT_NEAR(identity.total, 2.0, 1e-12);
    EXPECT_EQ(identity.collapsed, 0.0);
    EXPECT_EQ(std::count(identity.faces.begin(), identity.faces.end(), 1), 0);
    for (Index f = 0; f < nf; ++f) {
        const double x = (s.mesh.V(s.mesh.F(f, 0), 0) + s.mesh.V(s.mesh.F(f, 1), 0) + s.mesh.V(s.mesh.F(f, 2), 0)) / 3;
        if (x < 1)
            for (int k = 0; k < 3; ++k) uv[3 * f + k] *= 1e-9;
    }
    const CollapsedArea half = collapsed_area(s.mesh, uv, 1e-6);
    EXPECT_NEAR(half.collapsed, 1.0, 1e-12);
    EXPECT_NEAR(half.fraction(), 0.5, 1e-12);
    ASSERT_EQ(half.faces.size(), static_cast<std::size_t>(nf));
    EXPECT_EQ(std::count(half.faces.begin(), half.faces.end(), 1), nf / 2);
    EXPECT_EQ(collapsed_area(s.mesh, uv, 1e-12).collapsed, 0.0);  // 1e-9 is over that
    for (Complex& z : uv) z *= 1e-30;
    EXPECT_NEAR(collapsed_area(s.mesh, uv, 1e-6).fraction(), 0.5, 1e-12);
    std::fill(uv.begin(), uv.end(), Complex(3, 4));
    EXPECT_EQ(collapsed_area(s.mesh, uv, 1e-6).fraction(), 1.0);
    EXPECT_THROW(collapsed_area(s.mesh, std::span(uv).first(uv.size() - 1), 1e-6), InvalidInput);
    EXPECT_THROW(collapsed_area(s.mesh, uv, 0), InvalidInput);
}

TEST(CylinderTransversals, TubeOpensIntoItsRectangle) {
    constexpr int kAround = 24, kAlong = 6;
    constexpr double kHeight = 2, kShear = 0.37;
    const MeshView m = shapes::cylinder(1, kHeight, kAround, kAlong);
    const double chord = 2 * std::sin(std::numbers::pi / kAround);
    const Eigen::VectorXcd tau = around_and_up(m, kAround, kShear);
    const auto fill = [](const CutMesh& cut) {
        std::vector<char> border(cut.mesh.n_edges(), 0);
        for (Index e = 0; e < cut.mesh.n_edges(); ++e) border[e] = cut.edge_trajectory[e] != kNoBorder;
        return std::pair{border, compute_patches(cut.mesh, cut.tau, border)};
    };
    const CutMesh uncut = cut_along_trajectories(m, tau, {});
    const auto [no_border, before] = fill(uncut);
    ASSERT_EQ(before.info.size(), 1u);
    ASSERT_EQ(before.info[0].type, PatchInfo::Type::Cylinder);

    const std::vector<Trajectory> transversal = cylinder_transversals(m, tau, {}, {}, uncut, no_border, before);
    ASSERT_EQ(transversal.size(), 2u);
    for (const Trajectory& t : transversal) {
        EXPECT_EQ(t.start_vertex, kAlong / 2 * kAround);  // the first vertex of the middle ring
        EXPECT_EQ(t.family, TrajectoryFamily::Vertical);
        EXPECT_EQ(t.end, Trajectory::End::Boundary);
    }
    const auto [border, after] = fill(cut_along_trajectories(m, tau, transversal));
    ASSERT_EQ(after.info.size(), 1u);
    const PatchInfo& disk = after.info[0];
    EXPECT_EQ(disk.type, PatchInfo::Type::Disk);
    EXPECT_EQ(disk.flipped_uv_triangles, 0);
    EXPECT_NEAR(disk.width, kAround * chord, 1e-12);
    EXPECT_NEAR(disk.height, kHeight, 1e-12);
    EXPECT_LT(disk.rectangle_error, 1e-12);

    // Zeros are no starts: with every vertex of the middle ring a zero, a ring next to it is taken.
    std::vector<Index> ring;
    for (Index i = 0; i < kAround; ++i) ring.push_back(kAlong / 2 * kAround + i);
    const std::vector<Trajectory> next = cylinder_transversals(m, tau, ring, {}, uncut, no_border, before);
    ASSERT_EQ(next.size(), 2u);
    EXPECT_EQ(std::abs(next[0].start_vertex / kAround - kAlong / 2), 1);
}

// The sheet [0, 2] x [0, 1] (12 by 6 cells) less the block [1, 2] x [0.5, 1]: an L whose
// concave corner (1, 0.5) is a vertex. With `slit`, the whole sheet instead, and the edges from
// (0, 0.5) to (1, 0.5) a border: a slit that ends inside at (1, 0.5).
bool on_slit(Complex a, Complex b) { return a.imag() == 0.5 && b.imag() == 0.5 && a.real() <= 1 && b.real() <= 1; }

struct CornerSheet {
    MeshView mesh;
    Eigen::VectorXcd tau;
    std::vector<char> border;
    Index corner = -1;
    explicit CornerSheet(bool slit) {
        const Sheet s = sheet(12, 6);
        std::vector<Index> kept, new_id(s.mesh.n_vertices(), -1);
        for (Index f = 0; f < s.mesh.n_faces(); ++f) {
            const Complex c = (point(s.mesh, s.mesh.F(f, 0)) + point(s.mesh, s.mesh.F(f, 1)) + point(s.mesh, s.mesh.F(f, 2))) / 3.0;
            if (slit || c.real() < 1 || c.imag() < 0.5) kept.push_back(f);
        }
        TriangleMatrix F(static_cast<Index>(kept.size()), 3);
        Index n = 0;
        for (std::size_t i = 0; i < kept.size(); ++i)
            for (int k = 0; k < 3; ++k) {
                Index& id = new_id[s.mesh.F(kept[i], k)];
                if (id < 0) id = n++;
                F(static_cast<Index>(i), k) = id;
            }
        PointMatrix V(n, 3);
        for (Index v = 0; v < s.mesh.n_vertices(); ++v)
            if (new_id[v] >= 0) V.row(new_id[v]) = s.mesh.V.row(v);
        mesh = make_mesh_view(V, F);
        std::vector<Complex> image;
        for (Index v = 0; v < mesh.n_vertices(); ++v) image.push_back(point(mesh, v));
        tau = form_of(mesh, image);
        corner = nearest_vertex(mesh, Complex(1, 0.5));
        border.assign(mesh.n_edges(), 0);
        for (Index e = 0; e < mesh.n_edges() && slit; ++e) {
            border[e] = on_slit(point(mesh, mesh.E(e, 0)), point(mesh, mesh.E(e, 1)));
        }
    }
};

// The curve from the concave corner splits the patch into exact rectangles: the L's along
// -u (the first of the two directions into it, both at 90 degrees from its sides), the slit's
// along its own line beyond its end.
TEST(CornerTransversals, ConcaveCornerIsContinuedIntoItsPatch) {
    for (const bool slit : {false, true}) {
        SCOPED_TRACE(slit ? "slit" : "L");
        const CornerSheet c(slit);
        const CutMesh uncut = cut_along_trajectories(c.mesh, c.tau, {});
        const Patches before = compute_patches(uncut.mesh, uncut.tau, c.border);
        ASSERT_EQ(before.info.size(), 1u);
        ASSERT_EQ(before.info[0].type, PatchInfo::Type::Disk);
        EXPECT_NEAR(before.info[0].rectangle_error, 0.25, 1e-12);  // the corner, 0.5 from two sides

        const std::vector<Trajectory> curves = corner_transversals(c.mesh, c.tau, {}, {}, uncut, c.border, before);
        ASSERT_EQ(curves.size(), 1u);
        const Trajectory& t = curves[0];
        EXPECT_EQ(t.start_vertex, c.corner);
        EXPECT_EQ(t.family, TrajectoryFamily::Horizontal);
        EXPECT_EQ(t.end, Trajectory::End::Boundary);
        EXPECT_NEAR(t.length, 1, 1e-12);
        const CutMesh cut = cut_along_trajectories(c.mesh, c.tau, curves);
        std::vector<char> border(cut.mesh.n_edges(), 0);
        for (Index e = 0; e < cut.mesh.n_edges(); ++e) {
            border[e] = cut.edge_trajectory[e] != kNoBorder ||
                        (slit && on_slit(point(cut.mesh, cut.mesh.E(e, 0)), point(cut.mesh, cut.mesh.E(e, 1))));
        }
        const Patches after = compute_patches(cut.mesh, cut.tau, border);
        ASSERT_EQ(after.info.size(), 2u);
        for (const PatchInfo& info : after.info) {
            EXPECT_EQ(info.type, PatchInfo::Type::Disk);
            EXPECT_LT(info.rectangle_error, 1e-12);
        }
        // Each corner is continued once: with the curve cut in, none is left.
        EXPECT_TRUE(corner_transversals(c.mesh, c.tau, {}, curves, cut, border, after).empty());
    }
    // A rectangle has no concave corner; a zero is no start.
    const CornerSheet l(false);
    const CutMesh uncut = cut_along_trajectories(l.mesh, l.tau, {});
    const Patches p = compute_patches(uncut.mesh, uncut.tau, l.border);
    const std::vector<Index> zero{l.corner};
    EXPECT_TRUE(corner_transversals(l.mesh, l.tau, zero, {}, uncut, l.border, p).empty());
    const Sheet whole = sheet(12, 6);
    const Eigen::VectorXcd tau = form_of(whole.mesh, whole.image);
    const std::vector<char> none(whole.mesh.n_edges(), 0);
    const CutMesh whole_cut = cut_along_trajectories(whole.mesh, tau, {});
    EXPECT_TRUE(corner_transversals(whole.mesh, tau, {}, {}, whole_cut, none,
                                    compute_patches(whole_cut.mesh, whole_cut.tau, none))
                    .empty());
}

// A polar disk (a centre, then `rings` rings of 12 vertices) with the image z^2 / 2: one disk
// patch whose uv turns twice around the centre, as around a zero whose fan failed and that was
// traced from another vertex.
struct BranchDisk {
    MeshView mesh;
    Eigen::VectorXcd tau;
    explicit BranchDisk(int rings) {
        constexpr int kAround = 12;
        PointMatrix V(1 + rings * kAround, 3);
        V.row(0).setZero();
        TriangleMatrix F(kAround * (2 * rings - 1), 3);
        Index f = 0;
        const auto ring = [&](int r, int k) { return 1 + (r - 1) * kAround + (k % kAround); };
        for (int r = 1; r <= rings; ++r)
            for (int k = 0; k < kAround; ++k) {
                const double angle = 2 * std::numbers::pi * k / kAround, radius = static_cast<double>(r) / rings;
                V.row(ring(r, k)) << radius * std::cos(angle), radius * std::sin(angle), 0;
                if (r == 1) F.row(f++) << 0, ring(1, k), ring(1, k + 1);
                else F.row(f++) << ring(r - 1, k), ring(r, k), ring(r, k + 1), F.row(f++) << ring(r - 1, k), ring(r, k + 1), ring(r - 1, k + 1);
            }
        mesh = make_mesh_view(V, F);
        std::vector<Complex> image;
        for (Index v = 0; v < mesh.n_vertices(); ++v) image.push_back(point(mesh, v) * point(mesh, v) / 2.0);
        tau = form_of(mesh, image);
    }
};

// The branch point sends every curve of one family (the diagonals x = +-y, four of them), to the
// boundary; they split the disk into four patches around which nothing turns twice. A zero
// there is no start.
TEST(CornerTransversals, BranchPointInsideADiskSendsAllItsCurves) {
    const BranchDisk d(4);
    const std::vector<char> none(d.mesh.n_edges(), 0);
    const CutMesh uncut = cut_along_trajectories(d.mesh, d.tau, {});
    const Patches before = compute_patches(uncut.mesh, uncut.tau, none);
    ASSERT_EQ(before.info.size(), 1u);
    ASSERT_EQ(before.info[0].type, PatchInfo::Type::Disk);
    ASSERT_EQ(before.info[0].flipped_uv_triangles, 0);

    const std::vector<Trajectory> curves = corner_transversals(d.mesh, d.tau, {}, {}, uncut, none, before);
    ASSERT_EQ(curves.size(), 4u);
    for (const Trajectory& t : curves) {
        EXPECT_EQ(t.start_vertex, 0);
        EXPECT_EQ(t.family, TrajectoryFamily::Vertical);
        EXPECT_EQ(t.end, Trajectory::End::Boundary);
        // To the middle of a boundary edge's image: the chord of radius 1/2 between 60 and 120 degrees.
        EXPECT_NEAR(t.length, std::sqrt(3.0) / 4, 1e-12);
    }
    const CutMesh cut = cut_along_trajectories(d.mesh, d.tau, curves);
    std::vector<char> border(cut.mesh.n_edges(), 0);
    for (Index e = 0; e < cut.mesh.n_edges(); ++e) border[e] = cut.edge_trajectory[e] != kNoBorder;
    const Patches after = compute_patches(cut.mesh, cut.tau, border);
    ASSERT_EQ(after.info.size(), 4u);
    for (const PatchInfo& info : after.info) {
        EXPECT_EQ(info.type, PatchInfo::Type::Disk);
        EXPECT_EQ(info.flipped_uv_triangles, 0);
    }
    for (const Trajectory& t : corner_transversals(d.mesh, d.tau, {}, curves, cut, border, after))
        EXPECT_NE(t.start_vertex, 0);
    const std::vector<Index> zero{0};
    EXPECT_TRUE(corner_transversals(d.mesh, d.tau, zero, {}, uncut, none, before).empty());
}

TEST(CornerTransversals, RefusesACutWithOthersBorderOrPatches) {
    const CornerSheet c(false);
    const CutMesh uncut = cut_along_trajectories(c.mesh, c.tau, {});
    const Patches p = compute_patches(uncut.mesh, uncut.tau, c.border);
    const std::vector<char> short_border(3, 0);
    EXPECT_THROW(corner_transversals(c.mesh, c.tau, {}, {}, uncut, short_border, p), InvalidInput);
    EXPECT_THROW(cylinder_transversals(c.mesh, c.tau, {}, {}, uncut, short_border, p), InvalidInput);
    const Sheet other = sheet(5, 4);
    const Patches other_patches = compute_patches(other.mesh, form_of(other.mesh, other.image),
                                                  std::vector<char>(other.mesh.n_edges(), 0));
    EXPECT_THROW(corner_transversals(c.mesh, c.tau, {}, {}, uncut, c.border, other_patches), InvalidInput);
}

TEST(PatchRepair, FoldedDiskIsLaidOnItsRectangleWithNoFlip) {
    Sheet s = sheet(12, 6);
    // Fold the image: three interior points thrown across their neighbours (inside the sheet,
    // so the rectangle stays 2 x 1).
    for (const auto& [from, to] : {std::pair{Complex(0.5, 0.5), Complex(0.9, 0.3)},
                                   {Complex(1.0, 0.5), Complex(0.6, 0.8)}, {Complex(1.5, 1.0 / 3), Complex(1.9, 0.9)}})
        s.image[nearest_vertex(s.mesh, from)] = to;
    const std::vector<char> border(s.mesh.n_edges(), 0);
    const Patches folded = compute_patches(s.mesh, form_of(s.mesh, s.image), border);
    ASSERT_EQ(folded.info.size(), 1u);
    ASSERT_EQ(folded.info[0].type, PatchInfo::Type::Disk);
    const Index flips = folded.info[0].flipped_uv_triangles;
    ASSERT_GT(flips, 0);
    EXPECT_EQ(folded.info[0].form_flipped_uv_triangles, flips);
    EXPECT_FALSE(folded.info[0].repaired());

    const Patches p = repair_folded_patches(s.mesh, border, folded);
    const PatchInfo& info = p.info[0];
    EXPECT_TRUE(info.repaired());
    EXPECT_EQ(info.flipped_uv_triangles, 0);
    EXPECT_EQ(info.form_flipped_uv_triangles, flips);
    EXPECT_GT(smallest_relative_area(s.mesh, p, 0), 1e-6);
    EXPECT_DOUBLE_EQ(info.width, 2);
    EXPECT_DOUBLE_EQ(info.height, 1);
    EXPECT_LE(info.rectangle_error, kBulge);
    EXPECT_GE(info.distortion_mean, 1);
    EXPECT_TRUE(std::isfinite(info.distortion_max));
    // Every point where it was, up to the bulge of the sides: the sheet's own border was a
    // rectangle already, and the interior follows its neighbours.
    for (Index f = 0; f < s.mesh.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) {
            const Index v = s.mesh.F(f, k);
            const Complex z = point(s.mesh, v);
            const bool on_side = z.real() == 0 || z.real() == 2 || z.imag() == 0 || z.imag() == 1;
            if (on_side) {
                EXPECT_LE(std::abs(p.corner_uv[3 * f + k] - z), 2 * kBulge) << v;
            }
        }
}

TEST(PatchRepair, OnlyFoldedPatchesChange) {
    Sheet s = sheet(12, 6);
    s.image[nearest_vertex(s.mesh, Complex(0.5, 0.5))] = Complex(0.85, 0.3);  // left half folds
    // Two patches: the column x = 1 is a border.
    std::vector<char> border(s.mesh.n_edges(), 0);
    for (Index e = 0; e < s.mesh.n_edges(); ++e)
        border[e] = s.mesh.V(s.mesh.E(e, 0), 0) == 1 && s.mesh.V(s.mesh.E(e, 1), 0) == 1;
    const Patches before = compute_patches(s.mesh, form_of(s.mesh, s.image), border);
    ASSERT_EQ(before.info.size(), 2u);
    const Index folded = before.info[0].flipped_uv_triangles > 0 ? 0 : 1;
    ASSERT_GT(before.info[folded].flipped_uv_triangles, 0);
    ASSERT_EQ(before.info[1 - folded].flipped_uv_triangles, 0);

    const Patches after = repair_folded_patches(s.mesh, border, before);
    EXPECT_TRUE(after.info[folded].repaired());
    EXPECT_EQ(after.info[folded].flipped_uv_triangles, 0);
    EXPECT_FALSE(after.info[1 - folded].repaired());
    EXPECT_EQ(after.face_patch, before.face_patch);
    for (Index f = 0; f < s.mesh.n_faces(); ++f)
        if (before.face_patch[f] != folded) {
            for (int k = 0; k < 3; ++k) EXPECT_EQ(after.corner_uv[3 * f + k], before.corner_uv[3 * f + k]);
        }
    EXPECT_EQ(after.info[1 - folded].rectangle_error, before.info[1 - folded].rectangle_error);
}

TEST(PatchRepair, EarOnOneSideGetsAnArea) {
    // Bottom points b0..b4, top corners t0, t4, one interior point c. The ear (b1, b2, b3) has
    // its three points on the bottom side: on a straight side it would be flat; the sides
    // bulge so that it is not. c's image is pulled below the bottom side: its lower triangles flip.
    PointMatrix V(8, 3);
    V << 0, 0, 0, 1, 0, 0, 2, 0, 0.5, 3, 0, 0, 4, 0, 0, 4, 1, 0, 0, 1, 0, 2, 0.6, 0;
    enum : Index { b0, b1, b2, b3, b4, t4, t0, c };
    TriangleMatrix F(7, 3);
    F << b1, b2, b3, b0, b1, c, b1, b3, c, b3, b4, c, b4, t4, c, t4, t0, c, t0, b0, c;
    const MeshView m = make_mesh_view(V, F);
    std::vector<Complex> image;
    for (Index v = 0; v < m.n_vertices(); ++v) image.push_back(point(m, v));
    image[c] = Complex(2, -0.01);
    const std::vector<char> border(m.n_edges(), 0);
    const Patches folded = compute_patches(m, form_of(m, image), border);
    ASSERT_GT(folded.info[0].flipped_uv_triangles, 0);
    const Patches p = repair_folded_patches(m, border, folded);
    EXPECT_TRUE(p.info[0].repaired());
    EXPECT_EQ(p.info[0].flipped_uv_triangles, 0);
    EXPECT_GT(smallest_relative_area(m, p, 0), 1e-12);
    EXPECT_LE(p.info[0].rectangle_error, kBulge);
}

// A patch with three border points whose image is flat (a sliver between curves: the three on
// one line) and folded over its inside point: its border goes on three rectangle corners (the
// nearest assignment in border order), the inside point between them.
TEST(PatchRepair, ThreePointBorderGoesOnThreeCorners) {
    PointMatrix V(4, 3);
    V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0.3, 0.3, 0;
    enum : Index { a, b, c, q };
    TriangleMatrix F(3, 3);
    F << a, b, q, b, c, q, c, a, q;
    const MeshView m = make_mesh_view(V, F);
    const std::vector<Complex> image{Complex(0, 0), Complex(1, 1), Complex(0.4, 0.4), Complex(0.2, 0.7)};
    const std::vector<char> border(m.n_edges(), 0);
    const Patches folded = compute_patches(m, form_of(m, image), border);
    ASSERT_EQ(folded.info[0].type, PatchInfo::Type::Disk);
    ASSERT_GT(folded.info[0].flipped_uv_triangles, 0);
    const Patches p = repair_folded_patches(m, border, folded);
    EXPECT_TRUE(p.info[0].repaired());
    EXPECT_EQ(p.info[0].flipped_uv_triangles, 0);
    EXPECT_GT(smallest_relative_area(m, p, 0), 1e-3);
    EXPECT_EQ(p.info[0].rectangle_error, 0);
    // a and b keep their corners, c (nearer the top-left than the bottom-right) takes (0, 1).
    const auto uv_of = [&](Index v) {
        for (Index h = 0; h < m.n_halfedges(); ++h)
            if (m.tail(h) == v) return p.corner_uv[h];
        return Complex(-1, -1);
    };
    EXPECT_EQ(uv_of(a), Complex(0, 0));
    EXPECT_EQ(uv_of(b), Complex(1, 1));
    EXPECT_EQ(uv_of(c), Complex(0, 1));
}

// A tube whose form runs around it and up it (around_and_up, unsheared): one cylinder patch,
// its two loops iso-v lines. `bump` moves vertex v's image by d (an exact form added: the
// period stays).
struct FoldedTube {
    static constexpr int kAround = 24, kAlong = 8;
    MeshView mesh = shapes::cylinder(1, 2, kAround, kAlong);
    Eigen::VectorXcd tau = around_and_up(mesh, kAround, 0);
    void bump(Index v, Complex d) {
        for (Index e = 0; e < mesh.n_edges(); ++e)
            tau(e) += (mesh.E(e, 1) == v ? d : Complex(0)) - (mesh.E(e, 0) == v ? d : Complex(0));
    }
};

// Repairs the tube's one patch and checks the result: no flip, both loops on their iso-v
// lines, each interior edge the same vector seen from both its faces (the period across the
// seam accounted for), and the faces away from `moved` (vertices whose images were bumped)
// with the form's own uv.
void expect_repaired_tube(const FoldedTube& t, const std::vector<Index>& moved) {
    const std::vector<char> border(t.mesh.n_edges(), 0);
    const Patches folded = compute_patches(t.mesh, t.tau, border);
    ASSERT_EQ(folded.info.size(), 1u);
    ASSERT_EQ(folded.info[0].type, PatchInfo::Type::Cylinder);
    ASSERT_GT(folded.info[0].flipped_uv_triangles, 0);
    const Patches p = repair_folded_patches(t.mesh, border, folded);
    const PatchInfo& info = p.info[0];
    EXPECT_TRUE(info.repaired());
    EXPECT_EQ(info.flipped_uv_triangles, 0);
    EXPECT_GT(smallest_relative_area(t.mesh, p, 0), 1e-6);
    EXPECT_LT(info.rectangle_error, 1e-12);
    const auto uv = [&](Index h) { return p.corner_uv[h]; };
    for (Index h = 0; h < t.mesh.n_halfedges(); ++h) {
        const Index k = t.mesh.twin[h];
        const Complex along = uv(MeshView::next(h)) - uv(h);
        if (k != kNoHalfedge) {
            EXPECT_NEAR(std::abs(along + uv(MeshView::next(k)) - uv(k)), 0, 1e-12) << h;
        } else {  // on a loop: iso-v
            EXPECT_NEAR(along.imag(), 0, 1e-12) << h;
        }
    }
    // Faces beyond three rings of the bumped vertices keep the form's uv.
    std::vector<char> near(t.mesh.n_vertices(), 0);
    for (Index v : moved) near[v] = 1;
    for (int ring = 0; ring < 3; ++ring) {
        std::vector<char> grown = near;
        for (Index f = 0; f < t.mesh.n_faces(); ++f)
            if (near[t.mesh.F(f, 0)] || near[t.mesh.F(f, 1)] || near[t.mesh.F(f, 2)])
                grown[t.mesh.F(f, 0)] = grown[t.mesh.F(f, 1)] = grown[t.mesh.F(f, 2)] = 1;
        near.swap(grown);
    }
    Index kept = 0;
    for (Index f = 0; f < t.mesh.n_faces(); ++f) {
        if (near[t.mesh.F(f, 0)] || near[t.mesh.F(f, 1)] || near[t.mesh.F(f, 2)]) continue;
        ++kept;
        for (int k = 0; k < 3; ++k) {
            const Complex a = p.corner_uv[3 * f + (k + 1) % 3] - p.corner_uv[3 * f + k];
            const Complex b = folded.corner_uv[3 * f + (k + 1) % 3] - folded.corner_uv[3 * f + k];
            EXPECT_NEAR(std::abs(a - b), 0, 1e-12) << "face " << f;
        }
    }
    EXPECT_GT(kept, 0);
}

TEST(PatchRepair, FoldedCylinderIsLaidOnItsFlatCylinder) {
    FoldedTube t;
    // On the middle ring, all the way round (so that a fold straddles the seam where the form's
    // walk closed around the tube), each past its neighbours: their triangles flip.
    std::vector<Index> moved;
    for (Index i = 0; i < FoldedTube::kAround; i += 6) moved.push_back(4 * FoldedTube::kAround + i);
    for (Index v : moved) t.bump(v, Complex(0.6, 0.4));
    expect_repaired_tube(t, moved);
}

// A fold that reaches a loop: the form's coordinate goes back along it. The loop keeps the
// form's places except around the fold, where its points are spread by arc length.
TEST(PatchRepair, CylinderFoldedAtItsLoopKeepsTheLoopOnItsLine) {
    FoldedTube t;
    const Index v = 7;  // on the bottom loop
    t.bump(v, Complex(0.45, 0));
    expect_repaired_tube(t, {v});
}

// The same at every loop point in turn, so that for one of them the fold lies across the point
// the loop walk starts from: there the form's coordinate goes back at once and ends beyond the
// period, and the loop is placed from the point half way round.
TEST(PatchRepair, CylinderFoldedAnywhereOnALoop) {
    constexpr Index kAround = FoldedTube::kAround, kTop = FoldedTube::kAlong * kAround;
    for (Index i = 0; i < 2 * kAround; ++i) {
        const Index v = i < kAround ? i : kTop + i - kAround;
        SCOPED_TRACE(v);
        FoldedTube t;
        t.bump(v, Complex(0.45, 0));
        expect_repaired_tube(t, {v});
    }
}

TEST(PatchRepair, RefusesPatchesOfAnotherMesh) {
    const Sheet s = sheet(4, 4);
    const std::vector<char> border(s.mesh.n_edges(), 0);
    const Patches p = compute_patches(s.mesh, form_of(s.mesh, s.image), border);
    const Sheet other = sheet(5, 4);
    EXPECT_THROW(repair_folded_patches(other.mesh, std::vector<char>(other.mesh.n_edges(), 0), p), InvalidInput);
    EXPECT_THROW(repair_folded_patches(s.mesh, std::vector<char>(3, 0), p), InvalidInput);
}

}  // namespace
}  // namespace holoflow::kernels
