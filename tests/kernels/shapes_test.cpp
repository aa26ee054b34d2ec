#include "holoflow/kernels/shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <vector>

#include <Eigen/Geometry>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::shapes {
namespace {

constexpr double kCoordTol = 1e-12;  // closed-form positions, a few roundings of unit-size values

Eigen::Vector3d corner(const MeshView& m, Index f, int k) { return m.V.row(m.F(f, k)).transpose(); }

double face_area(const MeshView& m, Index f) {
    return 0.5 *
           (corner(m, f, 1) - corner(m, f, 0)).cross(corner(m, f, 2) - corner(m, f, 0)).norm();
}

// Divergence theorem: positive iff the faces are oriented outward.
double signed_volume(const MeshView& m) {
    double volume = 0.0;
    for (Index f = 0; f < m.n_faces(); ++f)
        volume += corner(m, f, 0).dot(corner(m, f, 1).cross(corner(m, f, 2))) / 6.0;
    return volume;
}

bool has_duplicate_vertex_sets(const MeshView& m) {
    std::set<std::array<Index, 3>> seen;
    for (Index f = 0; f < m.n_faces(); ++f) {
        std::array<Index, 3> key{m.F(f, 0), m.F(f, 1), m.F(f, 2)};
        std::sort(key.begin(), key.end());
        if (!seen.insert(key).second) return true;
    }
    return false;
}

std::vector<char> boundary_vertices(const MeshView& m) {
    std::vector<char> on(m.n_vertices(), 0);
    for (Index h = 0; h < m.n_halfedges(); ++h)
        if (m.is_boundary_halfedge(h)) on[m.tail(h)] = 1;
    return on;
}

// A triangle with three boundary vertices, or an interior edge joining two, would make the
// double cover's two sheets touch along more than the boundary.
void expect_boundary_touches_only_along_edges(const MeshView& m) {
    const std::vector<char> on = boundary_vertices(m);
    for (Index f = 0; f < m.n_faces(); ++f)
        EXPECT_FALSE(on[m.F(f, 0)] && on[m.F(f, 1)] && on[m.F(f, 2)]) << "face " << f;
    for (Index e = 0; e < m.n_edges(); ++e) {
        if (m.is_boundary_halfedge(m.edge_halfedge[e])) continue;
        EXPECT_FALSE(on[m.E(e, 0)] && on[m.E(e, 1)]) << "edge " << e;
    }
}

TEST(Shapes, TorusCountsAndPositions) {
    const double R = 2.0, r = 0.5;
    for (const auto& [nu, nv] : {std::array{3, 3}, std::array{8, 5}, std::array{64, 32}}) {
        const MeshView t = torus(R, r, nu, nv);
        EXPECT_EQ(t.n_vertices(), nu * nv);
        EXPECT_EQ(t.n_edges(), 3 * nu * nv);
        EXPECT_EQ(t.n_faces(), 2 * nu * nv);
        EXPECT_TRUE(t.is_closed());
        const kernels::Topology topo = kernels::compute_topology(t);
        EXPECT_EQ(topo.genus, 1);
        EXPECT_EQ(topo.components, 1);
        for (Index v = 0; v < t.n_vertices(); ++v) {
            const double rho = std::hypot(t.V(v, 0), t.V(v, 1)) - R;
            EXPECT_NEAR(std::hypot(rho, t.V(v, 2)), r, kCoordTol);
        }
        // Inscribed polyhedron: outward, and below the solid torus volume 2 pi^2 R r^2.
        const double volume = signed_volume(t);
        EXPECT_GT(volume, 0.0);
        EXPECT_LT(volume, 2.0 * std::numbers::pi * std::numbers::pi * R * r * r);
    }
}

TEST(Shapes, TorusVolumeConvergesQuadratically) {
    const double R = 2.0, r = 0.5, exact = 2.0 * std::numbers::pi * std::numbers::pi * R * r * r;
    const double coarse = exact - signed_volume(torus(R, r, 32, 16));
    const double fine = exact - signed_volume(torus(R, r, 64, 32));
    // Chordal error is O(h^2): halving h divides it by about 4.
    EXPECT_NEAR(coarse / fine, 4.0, 0.2);
}

TEST(Shapes, IcosphereCountsAndUnitRadius) {
    double previous_volume = 0.0;
    for (int level = 0; level <= 4; ++level) {
        const MeshView s = icosphere(level);
        const Index p = 1 << (2 * level);  // 4^level
        EXPECT_EQ(s.n_vertices(), 10 * p + 2);
        EXPECT_EQ(s.n_edges(), 30 * p);
        EXPECT_EQ(s.n_faces(), 20 * p);
        const kernels::Topology topo = kernels::compute_topology(s);
        EXPECT_EQ(topo.euler_characteristic, 2);
        EXPECT_EQ(topo.genus, 0);
        EXPECT_EQ(topo.boundary_loops, 0);
        for (Index v = 0; v < s.n_vertices(); ++v) EXPECT_NEAR(s.V.row(v).norm(), 1.0, kCoordTol);
        const double volume = signed_volume(s);
        EXPECT_GT(volume, previous_volume);  // outward, and growing towards the ball
        EXPECT_LT(volume, 4.0 * std::numbers::pi / 3.0);
        previous_volume = volume;
    }
}

TEST(Shapes, FlatGridIsAUnitSquareDisk) {
    for (const auto& [nx, ny] : {std::array{1, 1}, std::array{2, 2}, std::array{5, 3}}) {
        const MeshView g = flat_grid(nx, ny);
        EXPECT_EQ(g.n_vertices(), (nx + 1) * (ny + 1));
        EXPECT_EQ(g.n_faces(), 2 * nx * ny);
        double area = 0.0;
        for (Index f = 0; f < g.n_faces(); ++f) {
            // Counter-clockwise seen from +z.
            const Eigen::Vector3d n =
                (corner(g, f, 1) - corner(g, f, 0)).cross(corner(g, f, 2) - corner(g, f, 0));
            EXPECT_GT(n.z(), 0.0);
            area += face_area(g, f);
        }
        EXPECT_NEAR(area, 1.0, kCoordTol);
        const kernels::Topology topo = kernels::compute_topology(g);
        EXPECT_EQ(topo.euler_characteristic, 1);
        ASSERT_EQ(topo.boundary_loops, 1);
        EXPECT_EQ(topo.boundary_cycles[0].size(), static_cast<std::size_t>(2 * (nx + ny)));
        if (nx >= 2 && ny >= 2) expect_boundary_touches_only_along_edges(g);
    }
}

TEST(Shapes, CylinderIsAnOpenTube) {
    const MeshView c = cylinder(1.5, 3.0, 10, 4);
    EXPECT_EQ(c.n_vertices(), 10 * 5);
    EXPECT_EQ(c.n_faces(), 2 * 10 * 4);
    const kernels::Topology topo = kernels::compute_topology(c);
    EXPECT_EQ(topo.boundary_loops, 2);
    EXPECT_EQ(topo.euler_characteristic, 0);
    EXPECT_EQ(topo.genus, 0);
    for (Index v = 0; v < c.n_vertices(); ++v)
        EXPECT_NEAR(std::hypot(c.V(v, 0), c.V(v, 1)), 1.5, kCoordTol);
    // Outward: each face normal points away from the axis.
    for (Index f = 0; f < c.n_faces(); ++f) {
        const Eigen::Vector3d n =
            (corner(c, f, 1) - corner(c, f, 0)).cross(corner(c, f, 2) - corner(c, f, 0));
        const Eigen::Vector3d centre = (corner(c, f, 0) + corner(c, f, 1) + corner(c, f, 2)) / 3;
        EXPECT_GT(n.x() * centre.x() + n.y() * centre.y(), 0.0) << "face " << f;
    }
}

TEST(Shapes, PerforatedSheetCountsMatchTheFormulas) {
    for (int resolution : {1, 2, 3}) {
        for (int holes = 0; holes <= 4; ++holes) {
            SCOPED_TRACE(testing::Message() << "holes " << holes << " resolution " << resolution);
            const int s = resolution, m = std::max(2, s), H = s + 2 * m;
            const int W = std::max(H, holes * s + (holes + 1) * m);
            const MeshView sheet = perforated_sheet(holes, resolution);
            EXPECT_EQ(sheet.n_vertices(), (W + 1) * (H + 1) - holes * (s - 1) * (s - 1));
            EXPECT_EQ(sheet.n_faces(), 2 * (W * H - holes * s * s));
            const std::vector<char> on = boundary_vertices(sheet);
            EXPECT_EQ(std::count(on.begin(), on.end(), 1), 2 * (W + H) + 4 * holes * s);
            const kernels::Topology topo = kernels::compute_topology(sheet);
            EXPECT_EQ(topo.boundary_loops, holes + 1);
            EXPECT_EQ(topo.genus, 0);
            expect_boundary_touches_only_along_edges(sheet);
        }
    }
}

TEST(Shapes, GenusSurfaceHasExactGenusAndNoDegenerateFace) {
    // Smallest face: a lifted grid triangle is at least its planar shadow, half a cell of side
    // 1/H with H <= 9 here, so 1e-4 is far below every face yet far above rounding.
    constexpr double kMinArea = 1e-4;
    for (int resolution : {1, 3}) {
        for (int genus = 0; genus <= 5; ++genus) {
            SCOPED_TRACE(testing::Message() << "genus " << genus << " resolution " << resolution);
            const MeshView s = genus_surface(genus, resolution);
            EXPECT_TRUE(s.is_closed());
            const kernels::Topology topo = kernels::compute_topology(s);
            EXPECT_EQ(topo.components, 1);
            EXPECT_EQ(topo.genus, genus);
            EXPECT_EQ(topo.euler_characteristic, 2 - 2 * genus);
            double min_area = std::numeric_limits<double>::infinity();
            for (Index f = 0; f < s.n_faces(); ++f) min_area = std::min(min_area, face_area(s, f));
            EXPECT_GT(min_area, kMinArea);
            EXPECT_FALSE(has_duplicate_vertex_sets(s));
            EXPECT_GT(signed_volume(s), 0.0);  // outward

            // Counts from the sheet: V = 2 V_sheet - B, F = 2 F_sheet.
            const MeshView sheet = perforated_sheet(genus, resolution);
            const std::vector<char> on = boundary_vertices(sheet);
            const Index B = static_cast<Index>(std::count(on.begin(), on.end(), 1));
            EXPECT_EQ(s.n_vertices(), 2 * sheet.n_vertices() - B);
            EXPECT_EQ(s.n_faces(), 2 * sheet.n_faces());
            EXPECT_EQ(s.n_edges(), s.n_vertices() + s.n_faces() - 2 + 2 * genus);
        }
    }
}

TEST(Shapes, GenusSurfaceSheetsMeetOnlyOnTheRim) {
    const MeshView s = genus_surface(2, 2);
    const MeshView sheet = perforated_sheet(2, 2);
    const std::vector<char> on = boundary_vertices(sheet);
    for (Index v = 0; v < s.n_vertices(); ++v) {
        if (v < sheet.n_vertices() && on[v])
            EXPECT_EQ(s.V(v, 2), 0.0);
        else if (v < sheet.n_vertices())
            EXPECT_GT(s.V(v, 2), 0.0);  // upper copy
        else
            EXPECT_LT(s.V(v, 2), 0.0);  // lower copy
    }
}

TEST(Shapes, RejectInvalidParameters) {
    EXPECT_THROW(torus(1.0, 1.0, 8, 8), InvalidInput);
    EXPECT_THROW(torus(2.0, 0.5, 2, 8), InvalidInput);
    EXPECT_THROW(icosphere(-1), InvalidInput);
    EXPECT_THROW(flat_grid(0, 3), InvalidInput);
    EXPECT_THROW(cylinder(1.0, 1.0, 2, 1), InvalidInput);
    EXPECT_THROW(cylinder(1.0, 0.0, 8, 1), InvalidInput);
    EXPECT_THROW(perforated_sheet(-1, 2), InvalidInput);
    EXPECT_THROW(genus_surface(2, 0), InvalidInput);
}

TEST(Shapes, AreDeterministic) {
    const MeshView a = genus_surface(3, 2), b = genus_surface(3, 2);
    EXPECT_EQ(a.F, b.F);
    EXPECT_EQ(a.V, b.V);
}

}  // namespace
}  // namespace holoflow::shapes
