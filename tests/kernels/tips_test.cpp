#include "holoflow/kernels/tips.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <ostream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/subdivision.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

double mesh_area(const MeshView& m) {
    double a = 0;
    for (Index f = 0; f < m.n_faces(); ++f) {
        const Eigen::RowVector3d p = m.V.row(m.F(f, 0)), q = m.V.row(m.F(f, 1)),
                                 r = m.V.row(m.F(f, 2));
        a += 0.5 * (q - p).cross(r - p).norm();
    }
    return a;
}

double max_edge_length(const MeshView& m) {
    double l = 0;
    for (Index e = 0; e < m.n_edges(); ++e)
        l = std::max(l, (m.V.row(m.E(e, 0)) - m.V.row(m.E(e, 1))).norm());
    return l;
}

// Icosphere with x scaled by 3: an ellipsoid 3:1:1 whose poles (+-3, 0, 0) are vertices.
MeshView ellipsoid_311() {
    const MeshView s = shapes::icosphere(4);
    PointMatrix V = s.V;
    V.col(0) *= 3.0;
    return make_mesh_view(std::move(V), s.F);
}

// Vertex whose position is closest to p.
Index nearest_vertex(const MeshView& m, const Eigen::RowVector3d& p) {
    Index best = 0;
    for (Index v = 1; v < m.n_vertices(); ++v)
        if ((m.V.row(v) - p).squaredNorm() < (m.V.row(best) - p).squaredNorm()) best = v;
    return best;
}

std::vector<Index> one_ring_faces(const MeshView& m, Index v) {
    std::vector<Index> faces;
    const Index h0 = m.vertex_halfedge[v];
    Index h = h0;
    do {
        faces.push_back(MeshView::face(h));
        h = m.rotate(h);
    } while (h != h0 && h != kNoHalfedge);
    return faces;
}

// Every structural claim of SlicedMesh: the maps are injective and faithful, the holes partition
// the removed faces, each contains its tip's one-ring, the result is one connected surface of
// the input's genus with one extra boundary loop per sliced tip, and each new loop runs along
// exactly one hole.
void expect_valid_slice(const MeshView& in, const SlicedMesh& s) {
    const MeshView& m = s.mesh;
    ASSERT_EQ(s.original_vertex.size(), static_cast<std::size_t>(m.n_vertices()));
    ASSERT_EQ(s.original_face.size(), static_cast<std::size_t>(m.n_faces()));
    ASSERT_EQ(s.hole_faces.size(), s.tips.size());
    EXPECT_TRUE(std::is_sorted(s.original_vertex.begin(), s.original_vertex.end()));
    EXPECT_TRUE(std::is_sorted(s.original_face.begin(), s.original_face.end()));
    EXPECT_EQ(std::adjacent_find(s.original_vertex.begin(), s.original_vertex.end()),
              s.original_vertex.end());
    for (Index v = 0; v < m.n_vertices(); ++v)
        EXPECT_EQ(m.V.row(v), in.V.row(s.original_vertex[v])) << "vertex " << v;
    std::vector<int> used(in.n_faces(), 0);
    for (Index f = 0; f < m.n_faces(); ++f) {
        const Index o = s.original_face[f];
        ++used[o];
        for (int k = 0; k < 3; ++k)  // same corners in the same order: same orientation
            EXPECT_EQ(s.original_vertex[m.F(f, k)], in.F(o, k)) << "face " << f;
    }
    // Vertex of the input -> hole containing it (-1 if none); holes share no vertex.
    std::vector<int> hole_of(in.n_vertices(), -1);
    for (std::size_t i = 0; i < s.tips.size(); ++i) {
        for (Index f : s.hole_faces[i]) {
            ++used[f];
            for (int k = 0; k < 3; ++k) {
                const int other = hole_of[in.F(f, k)];
                EXPECT_TRUE(other == -1 || other == static_cast<int>(i))
                    << "holes " << other << " and " << i << " share vertex " << in.F(f, k);
                hole_of[in.F(f, k)] = static_cast<int>(i);
            }
        }
        for (Index f : one_ring_faces(in, s.tips[i]))
            EXPECT_TRUE(std::binary_search(s.hole_faces[i].begin(), s.hole_faces[i].end(), f))
                << "tip " << s.tips[i] << " keeps one-ring face " << f;
    }
    for (Index f = 0; f < in.n_faces(); ++f) EXPECT_EQ(used[f], 1) << "input face " << f;

    const Topology before = compute_topology(in), after = compute_topology(m);
    EXPECT_EQ(after.components, 1);
    EXPECT_EQ(after.genus, before.genus);
    EXPECT_EQ(after.boundary_loops, before.boundary_loops + static_cast<int>(s.tips.size()));
    // New loops: all their vertices on one hole, each hole once.
    std::vector<int> loops_per_hole(s.tips.size(), 0);
    for (const auto& loop : after.boundary_cycles) {
        const int hole = hole_of[s.original_vertex[loop.front()]];
        for (Index v : loop) EXPECT_EQ(hole_of[s.original_vertex[v]], hole);
        if (hole >= 0) ++loops_per_hole[hole];
    }
    for (int n : loops_per_hole) EXPECT_EQ(n, 1);
}

// ---------------------------------------------------------------------------------------------
// Distances

TEST(EdgePathDistances, BoundEuclideanFromBelowAndGridPathsFromAbove) {
    const MeshView grid = shapes::flat_grid(10, 10);
    const Index corner = 0;
    const std::vector<double> d = edge_path_distances(grid, std::span<const Index>(&corner, 1));
    ASSERT_EQ(d.size(), static_cast<std::size_t>(grid.n_vertices()));
    for (Index v = 0; v < grid.n_vertices(); ++v) {
        const Eigen::RowVector3d p = grid.V.row(v) - grid.V.row(corner);
        EXPECT_GE(d[v], p.norm() - 1e-12);                         // a path is no shorter
        EXPECT_LE(d[v], std::abs(p(0)) + std::abs(p(1)) + 1e-12);  // axis paths exist
    }
    EXPECT_DOUBLE_EQ(d[corner], 0.0);
    const Index bad = grid.n_vertices();
    EXPECT_THROW(edge_path_distances(grid, std::span<const Index>(&bad, 1)), InvalidInput);
    EXPECT_THROW(edge_path_distances(grid, {}), InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Tip detection

TEST(FindTips, EllipsoidTipsAreItsPoles) {
    const MeshView e = ellipsoid_311();
    const TipDetection d = detect_tips(e);
    ASSERT_EQ(d.tips.size(), 2u);  // the poles, nothing on the round waist
    EXPECT_EQ(d.fallback_tips, 0);
    const std::set<Index> expected{nearest_vertex(e, {3, 0, 0}), nearest_vertex(e, {-3, 0, 0})};
    EXPECT_EQ(std::set<Index>(d.tips.begin(), d.tips.end()), expected);
    for (Index t : d.tips) EXPECT_NEAR(std::abs(e.V(t, 0)), 3.0, 1e-12);
    // The geodesic diameter is pole to pole, half the perimeter of the 3:1 ellipse:
    // pi (3 (a + b) - sqrt((3a + b)(a + 3b))) / 2 = 6.682 (Ramanujan). Edge paths on this
    // mesh are within a few percent of it.
    const double half_perimeter = std::numbers::pi * (12 - std::sqrt(60.0)) / 2;
    EXPECT_NEAR(d.measure.diameter, half_perimeter, 0.03 * half_perimeter);
}

TEST(FindTips, RoundSphereFallsBackToFarApartVertices) {
    const MeshView sphere = shapes::icosphere(4);
    const TipDetection two = detect_tips(sphere);
    // A sphere has no extremity: the measure is flat up to sampling noise.
    ASSERT_EQ(two.tips.size(), 2u);
    EXPECT_EQ(two.fallback_tips, 2);
    // Farthest point sampling from the first gives (nearly) its antipode.
    EXPECT_GT((sphere.V.row(two.tips[0]) - sphere.V.row(two.tips[1])).norm(), 1.99);

    TipOptions four;
    four.min_tips = 4;
    const std::vector<Index> tips = find_tips(sphere, four);
    ASSERT_EQ(tips.size(), 4u);
    // Farthest point sampling picks two antipodes, then two points on their equator: ideally
    // every pair is a right angle apart (chord sqrt 2); Dijkstra zigzags shift that by a few %.
    for (std::size_t i = 0; i < tips.size(); ++i)
        for (std::size_t j = i + 1; j < tips.size(); ++j)
            EXPECT_GT((sphere.V.row(tips[i]) - sphere.V.row(tips[j])).norm(),
                      0.95 * std::sqrt(2.0));
}

TEST(FindTips, DiskTipsAreInteriorAndTheFirstIsTheCentre) {
    const MeshView grid = shapes::flat_grid(20, 20);
    const TipDetection d = detect_tips(grid);
    ASSERT_EQ(d.tips.size(), 2u);
    // Distance to the boundary peaks at the centre of the square.
    EXPECT_NEAR(grid.V(d.tips[0], 0), 0.5, 1e-12);
    EXPECT_NEAR(grid.V(d.tips[0], 1), 0.5, 1e-12);
    EXPECT_NEAR(d.measure.value[d.tips[0]], 0.5, 1e-12);
    for (Index t : d.tips) EXPECT_GT(d.measure.value[t], 0.1);  // far from the border
    const SlicedMesh s = slice_tips(grid, d.tips, 0.2);
    expect_valid_slice(grid, s);
    EXPECT_EQ(s.tips.size(), 2u);
}

// A needle's distance to the boundary peaks by its short side, next to the boundary on a coarse
// mesh, where no hole fits. Tips are two rings in, so three midpoint steps (45 vertices) do.
TEST(FindTips, NeedleTipsAreTwoRingsFromTheBoundary) {
    Eigen::MatrixXd V(3, 3);
    V << 0, 0, 0, 0.001, 0, 0, 0.0005, 0.045, 0;
    Eigen::MatrixXi F(1, 3);
    F << 0, 1, 2;
    MeshView needle = make_mesh_view(V, F);
    for (int level = 0; level < 2; ++level) {
        needle = subdivide_midpoint(needle);
        EXPECT_TRUE(find_tips(needle, {.max_tips = 2, .min_tips = 1}).empty()) << "level " << level + 1;
    }
    needle = subdivide_midpoint(needle);
    const std::vector<Index> tips = find_tips(needle, {.max_tips = 2, .min_tips = 1});
    ASSERT_FALSE(tips.empty());
    const Topology before = compute_topology(needle);
    for (Index t : tips) {
        Index h = needle.vertex_halfedge[t];
        const Index h0 = h;
        do {  // no neighbour on the boundary (its stored halfedge would be a boundary one)
            EXPECT_FALSE(needle.is_boundary_halfedge(needle.vertex_halfedge[needle.head(h)]));
            h = needle.rotate(h);
        } while (h != h0);
    }
    const SlicedMesh s = slice_tips(needle, tips, 0.02);
    expect_valid_slice(needle, s);
    EXPECT_EQ(compute_topology(s.mesh).boundary_loops, before.boundary_loops + static_cast<Index>(s.tips.size()));
}

TEST(FindTips, RejectsBadOptionsAndDisconnectedMeshes) {
    const MeshView sphere = shapes::icosphere(2);
    TipOptions o;
    o.min_tips = 0;
    EXPECT_THROW(find_tips(sphere, o), InvalidInput);
    o = {};
    o.max_tips = 1;  // below min_tips = 2
    EXPECT_THROW(find_tips(sphere, o), InvalidInput);
    o = {};
    o.prominence = -0.1;
    EXPECT_THROW(find_tips(sphere, o), InvalidInput);
    o = {};
    o.samples = 0;
    EXPECT_THROW(find_tips(sphere, o), InvalidInput);

    // Two spheres side by side.
    PointMatrix V(2 * sphere.n_vertices(), 3);
    TriangleMatrix F(2 * sphere.n_faces(), 3);
    V << sphere.V, (sphere.V.rowwise() + Eigen::RowVector3d(3, 0, 0));
    F << sphere.F, (sphere.F.array() + sphere.n_vertices()).matrix();
    const MeshView two = make_mesh_view(V, F);
    EXPECT_THROW(find_tips(two), InvalidInput);
    const Index tip = 0;
    EXPECT_THROW(slice_tips(two, std::span<const Index>(&tip, 1), 0.1), InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Slicing

// Per collapsed region, the vertex deepest in it: farthest along edge paths from the faces that
// kept their scale and from the boundary, two rings from the boundary at least. On an icosphere
// with two collapsed caps, each cap's vertex farthest from the rest; on a strip 10 x 1 whose far
// part collapsed, a vertex of its middle line, as far from the kept part as from the sides.
TEST(CollapsedLimbTips, DeepestVertexOfEachCollapsedRegion) {
    const MeshView sphere = shapes::icosphere(3);
    std::vector<char> collapsed(sphere.n_faces(), 0);
    for (Index f = 0; f < sphere.n_faces(); ++f) {
        const double z = (sphere.V(sphere.F(f, 0), 2) + sphere.V(sphere.F(f, 1), 2) + sphere.V(sphere.F(f, 2), 2)) / 3;
        collapsed[f] = std::abs(z) > 0.6;
    }
    std::vector<Index> kept;
    for (Index f = 0; f < sphere.n_faces(); ++f)
        if (!collapsed[f])
            for (int k = 0; k < 3; ++k) kept.push_back(sphere.F(f, k));
    const std::vector<double> depth = edge_path_distances(sphere, kept);
    const std::vector<Index> caps = collapsed_limb_tips(sphere, collapsed, 0.01);
    ASSERT_EQ(caps.size(), 2u);
    for (Index tip : caps) {
        const bool north = sphere.V(tip, 2) > 0;
        for (Index v = 0; v < sphere.n_vertices(); ++v)
            if ((sphere.V(v, 2) > 0) == north) {
                EXPECT_LE(depth[v], depth[tip]) << v;
            }
    }
    EXPECT_TRUE(collapsed_limb_tips(sphere, collapsed, 0.5).empty());  // each cap is a tenth
    EXPECT_TRUE(collapsed_limb_tips(sphere, std::vector<char>(sphere.n_faces(), 0), 0).empty());

    MeshView strip = shapes::flat_grid(120, 12);
    for (Index v = 0; v < strip.n_vertices(); ++v) strip.V(v, 0) *= 10;
    std::vector<char> far(strip.n_faces(), 0);
    for (Index f = 0; f < strip.n_faces(); ++f)
        far[f] = strip.V(strip.F(f, 0), 0) + strip.V(strip.F(f, 1), 0) + strip.V(strip.F(f, 2), 0) > 3 * 6;
    const std::vector<Index> end = collapsed_limb_tips(strip, far, 0.01);
    ASSERT_EQ(end.size(), 1u);
    EXPECT_NEAR(strip.V(end[0], 1), 0.5, 1e-12);
    EXPECT_GT(strip.V(end[0], 0), 6.4);
    // Two rows of faces have no vertex two rings from the boundary: no tip.
    MeshView thin = shapes::flat_grid(40, 2);
    EXPECT_TRUE(collapsed_limb_tips(thin, std::vector<char>(thin.n_faces(), 1), 0).empty());
    EXPECT_THROW(collapsed_limb_tips(thin, std::vector<char>(3, 1), 0), InvalidInput);
    EXPECT_THROW(collapsed_limb_tips(thin, std::vector<char>(thin.n_faces(), 1), 2), InvalidInput);
}

TEST(SliceTips, IcosphereGetsOneSmallHolePerTip) {
    const MeshView sphere = shapes::icosphere(4);
    const std::vector<Eigen::RowVector3d> axes{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0},
                                               {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    const double hole_radius = 0.2;
    const double area = mesh_area(sphere);
    const double R = std::sqrt(area / (4 * std::numbers::pi));  // ~1
    const double h = max_edge_length(sphere);
    for (std::size_t k = 1; k <= axes.size(); ++k) {
        SCOPED_TRACE("tips: " + std::to_string(k));
        std::vector<Index> tips;
        for (std::size_t i = 0; i < k; ++i) tips.push_back(nearest_vertex(sphere, axes[i]));
        const SlicedMesh s = slice_tips(sphere, tips, hole_radius);
        EXPECT_EQ(s.tips, tips);  // axis points are far apart: nothing dropped
        expect_valid_slice(sphere, s);

        // Removed faces lie within Dijkstra distance r of their tip, plus at most one ring
        // from the clean-up, and Dijkstra distance bounds the geodesic one from above: each hole
        // fits in a spherical cap of radius r + h, area 2 pi (1 - cos(r + h)) on the unit sphere
        // (flat triangles are smaller than their spherical images).
        const double r = hole_radius * R;
        const double removed = 1.0 - mesh_area(s.mesh) / area;
        const double cap_fraction = (1 - std::cos(r + h)) / 2;
        EXPECT_LT(removed, static_cast<double>(k) * cap_fraction * (4 * std::numbers::pi / area));
        // And they are not vanishingly small: at least the cap of radius r - h (Dijkstra on
        // this mesh is within ~10% of the geodesic distance).
        EXPECT_GT(removed, static_cast<double>(k) * (1 - std::cos(r / 1.1 - h)) / 2);

        const DoubleCover dc = double_cover(s.mesh);
        EXPECT_TRUE(dc.mesh.is_closed());
        EXPECT_EQ(compute_topology(dc.mesh).genus, static_cast<int>(k) - 1);
    }
}

TEST(SliceTips, ZeroRadiusRemovesExactlyTheOneRing) {
    const MeshView sphere = shapes::icosphere(3);
    const Index tip = 17;
    const SlicedMesh s = slice_tips(sphere, std::span<const Index>(&tip, 1), 0.0);
    expect_valid_slice(sphere, s);
    EXPECT_EQ(s.hole_faces[0].size(), one_ring_faces(sphere, tip).size());
    EXPECT_EQ(s.mesh.n_vertices(), sphere.n_vertices() - 1);  // only the tip goes
}

TEST(SliceTips, LaterOverlappingTipIsDropped) {
    const MeshView sphere = shapes::icosphere(3);
    const Index a = nearest_vertex(sphere, {0, 0, 1});
    const Index b = sphere.F(one_ring_faces(sphere, a)[0], 0) == a
                        ? sphere.F(one_ring_faces(sphere, a)[0], 1)
                        : sphere.F(one_ring_faces(sphere, a)[0], 0);  // a neighbour of a
    const Index c = nearest_vertex(sphere, {0, 0, -1});
    const std::vector<Index> tips{a, b, c};
    const SlicedMesh s = slice_tips(sphere, tips, 0.1);
    EXPECT_EQ(s.tips, (std::vector<Index>{a, c}));
    expect_valid_slice(sphere, s);
}

TEST(SliceTips, OpenSurfacesGetHolesAdded) {
    const MeshView grid = shapes::flat_grid(20, 20);
    const Index centre = nearest_vertex(grid, {0.5, 0.5, 0});
    const SlicedMesh disk = slice_tips(grid, std::span<const Index>(&centre, 1), 0.3);
    expect_valid_slice(grid, disk);
    // An annulus: its double cover is a torus.
    EXPECT_EQ(compute_topology(double_cover(disk.mesh).mesh).genus, 1);

    const MeshView tube = shapes::cylinder(0.5, 2.0, 32, 16);
    const Index side = nearest_vertex(tube, {0.5, 0, 1});
    const SlicedMesh pants = slice_tips(tube, std::span<const Index>(&side, 1), 0.2);
    expect_valid_slice(tube, pants);
    EXPECT_EQ(compute_topology(pants.mesh).boundary_loops, 3);
    EXPECT_EQ(compute_topology(double_cover(pants.mesh).mesh).genus, 2);
}

TEST(SliceTips, HoleReachingTheBoundaryIsDropped) {
    const MeshView grid = shapes::flat_grid(20, 20);
    const Index centre = nearest_vertex(grid, {0.5, 0.5, 0});
    const Index near_edge = nearest_vertex(grid, {0.5, 0.1, 0});  // two cells from the border
    const std::vector<Index> tips{centre, near_edge};
    // R = sqrt(1 / (4 pi)) ~ 0.28, so radius 0.5 R ~ 0.14 reaches the border from near_edge
    // but not from the centre.
    const SlicedMesh s = slice_tips(grid, tips, 0.5);
    EXPECT_EQ(s.tips, std::vector<Index>{centre});
    expect_valid_slice(grid, s);
    EXPECT_THROW(slice_tips(grid, std::span<const Index>(&near_edge, 1), 0.5), InvalidInput);
}

TEST(SliceTips, EnclosedPocketJoinsTheHole) {
    // A 40 x 40 grid (cells 0.025) with one vertex, 2 cells from the tip, raised by 1. The ball
    // of radius 0.3 (12 cells) holds every vertex around it but not the spike itself, so the
    // spike's faces are left standing inside the hole: a pocket, which must join the hole.
    const MeshView grid = shapes::flat_grid(40, 40);
    const Index tip = nearest_vertex(grid, {0.5, 0.5, 0});
    const Index spike = nearest_vertex(grid, {0.55, 0.5, 0});
    PointMatrix V = grid.V;
    V(spike, 2) = 1.0;
    const MeshView m = make_mesh_view(std::move(V), grid.F);
    const double R = std::sqrt(mesh_area(m) / (4 * std::numbers::pi));
    const double r = 0.3;
    const std::vector<double> from_tip = edge_path_distances(m, std::span<const Index>(&tip, 1));
    ASSERT_GT(from_tip[spike], r);  // the spike is outside the ball: only the clean-up removes it

    const SlicedMesh s = slice_tips(m, std::span<const Index>(&tip, 1), r / R);
    expect_valid_slice(m, s);
    for (Index f : one_ring_faces(m, spike))
        EXPECT_TRUE(std::binary_search(s.hole_faces[0].begin(), s.hole_faces[0].end(), f))
            << "spike face " << f << " left in the hole";
    EXPECT_FALSE(std::binary_search(s.original_vertex.begin(), s.original_vertex.end(), spike));
}

// Random tips and radii: whatever shape the Dijkstra balls take, the result is a valid surface
// with one loop per sliced tip, the first tip is never dropped, and the only refusal is a hole
// that cuts the mesh in two (a random vertex mid-leg with a large radius).
void slice_random_tips(const MeshView& mesh, std::mt19937_64& rng, int trials, double max_radius,
                       int& dropped, int& refused) {
    std::uniform_int_distribution<Index> pick(0, mesh.n_vertices() - 1);
    std::uniform_real_distribution<double> radius(0.0, max_radius);
    for (int trial = 0; trial < trials; ++trial) {
        std::vector<Index> tips;
        while (static_cast<int>(tips.size()) < 1 + trial % 8) {
            const Index t = pick(rng);
            if (std::find(tips.begin(), tips.end(), t) == tips.end()) tips.push_back(t);
        }
        const double r = radius(rng);
        SCOPED_TRACE("trial " + std::to_string(trial) + " radius " + std::to_string(r));
        try {
            const SlicedMesh s = slice_tips(mesh, tips, r);
            ASSERT_FALSE(s.tips.empty());
            EXPECT_EQ(s.tips.front(), tips.front());
            dropped += static_cast<int>(tips.size() - s.tips.size());
            expect_valid_slice(mesh, s);
        } catch (const InvalidInput& e) {
            ++refused;
            EXPECT_NE(std::string(e.what()).find("cuts the mesh into pieces"), std::string::npos)
                << e.what();
        }
    }
}

TEST(SliceTips, RandomTipsOnJitteredSpheresGiveValidSurfaces) {
    constexpr std::uint64_t kSeed = 20240611;
    SCOPED_TRACE("seed " + std::to_string(kSeed));
    std::mt19937_64 rng(kSeed);
    const MeshView base = shapes::icosphere(3);
    std::normal_distribution<double> jitter(0.0, 0.02);
    int dropped = 0, refused = 0;
    for (int round = 0; round < 20; ++round) {
        PointMatrix V = base.V;
        for (Index v = 0; v < V.rows(); ++v)
            for (int k = 0; k < 3; ++k) V(v, k) += jitter(rng);
        slice_random_tips(make_mesh_view(std::move(V), base.F), rng, 3, 0.6, dropped, refused);
    }
    EXPECT_GT(dropped, 0);  // the overlap rule was exercised
    EXPECT_EQ(refused, 0);  // a sphere has no neck to cut
}

TEST(SliceTips, RandomTipsOnTheBullGiveValidSurfaces) {
    const std::shared_ptr<const MeshView> bull = test::corpus_mesh("bull");
    constexpr std::uint64_t kSeed = 7;
    SCOPED_TRACE("seed " + std::to_string(kSeed));
    std::mt19937_64 rng(kSeed);
    int dropped = 0, refused = 0;
    slice_random_tips(*bull, rng, 40, 0.4, dropped, refused);
    EXPECT_GT(dropped, 0);
    EXPECT_LT(refused, 40 / 4);  // most random holes are fine
}

TEST(SliceTips, RefusesHolesThatCutTheSurfaceOrWrapAHandle) {
    // Open tube pinched to radius 0.1 at z = 2 (a ring of mesh edges, circumference 0.63):
    // radius 1 at both ends, area ~10, R ~ 0.9. A hole of radius 0.5 R around a waist vertex
    // wraps the waist and leaves two halves, each far larger than the hole: disconnected.
    const MeshView tube = shapes::cylinder(1.0, 4.0, 64, 64);
    PointMatrix V = tube.V;
    for (Index v = 0; v < V.rows(); ++v) {
        const double u = (V(v, 2) - 2.0) / 2.0, scale = 0.1 + 0.9 * u * u;
        V(v, 0) *= scale;
        V(v, 1) *= scale;
    }
    const MeshView waisted = make_mesh_view(std::move(V), tube.F);
    const Index waist = nearest_vertex(waisted, {0.1, 0, 2});
    ASSERT_NEAR(waisted.V(waist, 2), 2.0, 1e-12);
    const SlicedMesh small = slice_tips(waisted, std::span<const Index>(&waist, 1), 0.1);
    expect_valid_slice(waisted, small);
    try {
        slice_tips(waisted, std::span<const Index>(&waist, 1), 0.5);
        ADD_FAILURE() << "a hole cutting the tube in two was accepted";
    } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("cuts the mesh into pieces"), std::string::npos)
            << e.what();
    }

    // Torus tube circumference pi: a hole of radius R ~ 1.77 wraps the tube (an annulus).
    const MeshView torus = shapes::torus(2.0, 0.5, 64, 32);
    const Index t = 0;
    const SlicedMesh punctured = slice_tips(torus, std::span<const Index>(&t, 1), 0.2);
    expect_valid_slice(torus, punctured);  // genus 1 kept, one loop
    try {
        slice_tips(torus, std::span<const Index>(&t, 1), 1.0);
        ADD_FAILURE() << "a hole wrapping the tube was accepted";
    } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("not a disk"), std::string::npos) << e.what();
    }
}

TEST(SliceTips, RejectsBadTips) {
    const MeshView sphere = shapes::icosphere(2);
    const MeshView grid = shapes::flat_grid(4, 4);
    auto slice = [](const MeshView& m, std::vector<Index> tips, double r) {
        return slice_tips(m, tips, r);
    };
    EXPECT_THROW(slice(sphere, {}, 0.1), InvalidInput);
    EXPECT_THROW(slice(sphere, {-1}, 0.1), InvalidInput);
    EXPECT_THROW(slice(sphere, {sphere.n_vertices()}, 0.1), InvalidInput);
    EXPECT_THROW(slice(sphere, {3, 5, 3}, 0.1), InvalidInput);
    EXPECT_THROW(slice(sphere, {3}, -0.1), InvalidInput);
    EXPECT_THROW(slice(sphere, {3}, std::nan("")), InvalidInput);
    EXPECT_THROW(slice(sphere, {3}, 10.0), InvalidInput);  // the hole would be everything
    EXPECT_THROW(slice(grid, {0}, 0.1), InvalidInput);     // a corner: on the boundary
    try {
        slice(sphere, {3, 3}, 0.1);
        FAIL() << "duplicate accepted";
    } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("tip 3 is given twice"), std::string::npos)
            << e.what();
    }
}

// ---------------------------------------------------------------------------------------------
// libcgal-demo animals

struct CorpusCase {
    const char* name;
    int up_axis;  // the model's vertical axis
};

// Names the case in test listings (the default prints the struct's bytes, a pointer among them).
void PrintTo(const CorpusCase& c, std::ostream* os) { *os << c.name; }

class CorpusTips : public ::testing::TestWithParam<CorpusCase> {};

TEST_P(CorpusTips, TipsAreFarApartExtremitiesAndSliceCleanly) {
    const CorpusCase c = GetParam();
    const std::shared_ptr<const MeshView> loaded = test::corpus_mesh(c.name);
    const MeshView& mesh = *loaded;

    const auto t0 = std::chrono::steady_clock::now();
    const TipDetection d = detect_tips(mesh);
    const auto t1 = std::chrono::steady_clock::now();
    const double hole_radius = 0.1;
    const SlicedMesh s = slice_tips(mesh, d.tips, hole_radius);
    const auto t2 = std::chrono::steady_clock::now();
    const double find_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
    const double slice_ms = std::chrono::duration<double, std::milli>(t2 - t1).count();
    std::printf("%s: V=%d F=%d diameter=%.4f tips=%zu find_tips=%.1f ms slice_tips=%.1f ms\n",
                c.name, mesh.n_vertices(), mesh.n_faces(), d.measure.diameter, d.tips.size(),
                find_ms, slice_ms);
    for (std::size_t i = 0; i < d.tips.size(); ++i) {
        const Index v = d.tips[i];
        std::printf("  tip %6d at (%8.4f %8.4f %8.4f) prominence %.3f isolation %.3f\n", v,
                    mesh.V(v, 0), mesh.V(v, 1), mesh.V(v, 2), d.prominence[i], d.isolation[i]);
    }
    RecordProperty("find_tips_ms", std::to_string(find_ms));
    RecordProperty("slice_tips_ms", std::to_string(slice_ms));

    // Real extremities, none from the fallback, ranked by prominence.
    ASSERT_GE(d.tips.size(), 2u);
    EXPECT_EQ(d.fallback_tips, 0);
    EXPECT_TRUE(std::is_sorted(d.prominence.rbegin(), d.prominence.rend()));
    const TipOptions defaults;
    const double separation = defaults.prominence * d.measure.diameter;
    for (std::size_t i = 0; i < d.tips.size(); ++i) {
        const Index tip = d.tips[i];
        EXPECT_GE(d.prominence[i], defaults.prominence);
        EXPECT_GE(d.isolation[i], d.prominence[i]);  // the measure is 1-Lipschitz
        // The highest point of its own neighbourhood of radius `separation` (so a strict local
        // maximum of the measure too).
        const std::vector<double> dist =
            edge_path_distances(mesh, std::span<const Index>(&tip, 1));
        for (Index v = 0; v < mesh.n_vertices(); ++v) {
            if (v != tip && dist[v] < separation) {
                EXPECT_LT(d.measure.value[v], d.measure.value[tip]) << "tip " << tip << " v " << v;
            }
        }
        // Mutually far apart along the surface.
        for (std::size_t j = i + 1; j < d.tips.size(); ++j)
            EXPECT_GE(dist[d.tips[j]], separation) << tip << " and " << d.tips[j];
    }

    // Extremities sit at the ends of the model: count tips near the bottom and top.
    const auto up = mesh.V.col(c.up_axis);
    const double low = up.minCoeff(), high = up.maxCoeff(), height = high - low;
    int near_bottom = 0, near_top = 0;
    for (Index t : d.tips) {
        near_bottom += up(t) < low + 0.15 * height ? 1 : 0;
        near_top += up(t) > high - 0.15 * height ? 1 : 0;
    }
    if (std::string(c.name) == "bull") {
        EXPECT_EQ(d.tips.size(), 7u);  // 4 hooves, 2 horns, the tail
        EXPECT_EQ(near_bottom, 4);
        EXPECT_EQ(near_top, 3);
    } else if (std::string(c.name) == "man") {
        EXPECT_EQ(d.tips.size(), 5u);  // 2 feet, 2 hands, the head
        EXPECT_EQ(near_bottom, 2);
        EXPECT_EQ(near_top, 1);
    }

    // Sliced: an open genus-0 surface whose double cover is closed of genus b - 1.
    EXPECT_EQ(s.tips, d.tips);  // with a small radius no hole touches another
    expect_valid_slice(mesh, s);
    const int b = compute_topology(s.mesh).boundary_loops;
    EXPECT_EQ(b, static_cast<int>(d.tips.size()));
    const DoubleCover dc = double_cover(s.mesh);
    EXPECT_TRUE(dc.mesh.is_closed());
    EXPECT_EQ(compute_topology(dc.mesh).genus, b - 1);
    // Holes are small: below 5% of the area in all.
    EXPECT_LT(1.0 - mesh_area(s.mesh) / mesh_area(mesh), 0.05);

    // Deterministic: the same bits twice.
    const TipDetection again = detect_tips(mesh);
    EXPECT_EQ(again.tips, d.tips);
    EXPECT_EQ(again.measure.value, d.measure.value);
    const SlicedMesh s2 = slice_tips(mesh, again.tips, hole_radius);
    EXPECT_EQ(s2.original_face, s.original_face);
    EXPECT_EQ(s2.original_vertex, s.original_vertex);
    EXPECT_EQ(s2.mesh.F, s.mesh.F);
}

INSTANTIATE_TEST_SUITE_P(Animals, CorpusTips,
                         ::testing::Values(CorpusCase{"bull", 1}, CorpusCase{"man", 2},
                                           CorpusCase{"camel", 1}, CorpusCase{"cow", 1}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

}  // namespace
}  // namespace holoflow::kernels
