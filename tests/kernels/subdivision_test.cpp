#include "holoflow/kernels/subdivision.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::kernels {
namespace {

constexpr double kAreaRelTol = 1e-12;  // sums of O(#F) products of unit-size coordinates

Eigen::Vector3d corner(const MeshView& m, Index f, int k) { return m.V.row(m.F(f, k)).transpose(); }

Eigen::Vector3d area_vector(const MeshView& m, Index f) {
    return 0.5 * (corner(m, f, 1) - corner(m, f, 0)).cross(corner(m, f, 2) - corner(m, f, 0));
}

struct Case {
    std::string name;
    MeshView mesh;
};

std::vector<Case> cases() {
    std::vector<Case> c;
    c.push_back({"torus", shapes::torus(2.0, 0.7, 9, 6)});
    c.push_back({"icosphere", shapes::icosphere(1)});
    c.push_back({"flat_grid", shapes::flat_grid(4, 3)});
    c.push_back({"cylinder", shapes::cylinder(1.0, 1.0, 7, 2)});
    c.push_back({"genus_2", shapes::genus_surface(2, 1)});
    c.push_back({"perforated_sheet", shapes::perforated_sheet(3, 1)});
    // Every cylinder edge runs between the two rims, so its double cover has pairs of edges on
    // one vertex pair: the midpoints must go by edge index.
    c.push_back(
        {"double_cover_with_parallel_edges", double_cover(shapes::cylinder(1.0, 1.0, 5, 1)).mesh});
    return c;
}

TEST(SubdivideMidpoint, KeepsTopologyAndCounts) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        const MeshView& m = c.mesh;
        const MeshView s = subdivide_midpoint(m);
        EXPECT_EQ(s.n_vertices(), m.n_vertices() + m.n_edges());
        EXPECT_EQ(s.n_edges(), 2 * m.n_edges() + 3 * m.n_faces());
        EXPECT_EQ(s.n_faces(), 4 * m.n_faces());
        const Topology before = compute_topology(m), after = compute_topology(s);
        EXPECT_EQ(after.genus, before.genus);
        EXPECT_EQ(after.euler_characteristic, before.euler_characteristic);
        EXPECT_EQ(after.components, before.components);
        ASSERT_EQ(after.boundary_loops, before.boundary_loops);
        for (int b = 0; b < before.boundary_loops; ++b)
            EXPECT_EQ(after.boundary_cycles[b].size(), 2 * before.boundary_cycles[b].size());
        EXPECT_EQ(s.is_closed(), m.is_closed());
    }
}

TEST(SubdivideMidpoint, KeepsGeometryAndOrientation) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        const MeshView& m = c.mesh;
        const MeshView s = subdivide_midpoint(m);
        // Original vertices keep their positions bit for bit; new ones sit at edge midpoints.
        EXPECT_EQ(s.V.topRows(m.n_vertices()), m.V);
        for (Index e = 0; e < m.n_edges(); ++e) {
            const Eigen::RowVector3d mid = 0.5 * (m.V.row(m.E(e, 0)) + m.V.row(m.E(e, 1)));
            EXPECT_EQ(s.V.row(m.n_vertices() + e), mid);
        }
        // Each face splits into four congruent quarters facing the same way, so areas add up.
        double area_before = 0.0, area_after = 0.0;
        for (Index f = 0; f < m.n_faces(); ++f) {
            const Eigen::Vector3d parent = area_vector(m, f);
            area_before += parent.norm();
            for (Index k = 0; k < 4; ++k) {
                const Eigen::Vector3d child = area_vector(s, 4 * f + k);
                EXPECT_NEAR((4.0 * child - parent).norm(), 0.0, kAreaRelTol * parent.norm());
                area_after += child.norm();
            }
        }
        EXPECT_NEAR(area_after, area_before, kAreaRelTol * area_before);
    }
}

TEST(SubdivideMidpoint, ChildCornersLieOnTheParentFace) {
    const MeshView m = shapes::genus_surface(1, 2);
    const MeshView s = subdivide_midpoint(m);
    for (Index f = 0; f < m.n_faces(); ++f) {
        for (Index k = 0; k < 3; ++k) {
            // Corner triangle 4f + k starts at the parent's corner k.
            EXPECT_EQ(s.F(4 * f + k, 0), m.F(f, k));
            // Every child vertex is a parent corner or the midpoint of one of the parent's edges.
            for (Index j = 0; j < 3; ++j) {
                const Index v = s.F(4 * f + k, j);
                const bool is_corner = v == m.F(f, 0) || v == m.F(f, 1) || v == m.F(f, 2);
                bool is_midpoint = false;
                for (Index i = 0; i < 3; ++i)
                    is_midpoint |= v == m.n_vertices() + m.halfedge_edge[3 * f + i];
                EXPECT_TRUE(is_corner || is_midpoint);
            }
        }
    }
}

TEST(SubdivideMidpoint, TwiceOnAnIcosahedronGivesTheIcosphereConnectivity) {
    const MeshView ico = shapes::icosphere(0);
    const MeshView twice = subdivide_midpoint(subdivide_midpoint(ico));
    const MeshView level2 = shapes::icosphere(2);
    EXPECT_EQ(twice.F, level2.F);  // icosphere is built by the same split, then projected
    EXPECT_EQ(compute_topology(twice).euler_characteristic, 2);
}

}  // namespace
}  // namespace holoflow::kernels
