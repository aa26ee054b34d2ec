#include "holoflow/kernels/topology.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <utility>
#include <vector>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"

namespace holoflow::kernels {
namespace {

// Disjoint union: faces of `b` follow those of `a`, or are interleaved one by one when asked.
MeshView disjoint_union(const MeshView& a, const MeshView& b, bool interleave = false) {
    PointMatrix V(a.n_vertices() + b.n_vertices(), 3);
    V << a.V, b.V;
    TriangleMatrix F(a.n_faces() + b.n_faces(), 3);
    Index row = 0, fa = 0, fb = 0;
    while (fa < a.n_faces() || fb < b.n_faces()) {
        const bool take_a = fa < a.n_faces() && (!interleave || fb >= b.n_faces() || fa <= fb);
        if (take_a) {
            F.row(row++) = a.F.row(fa++);
        } else {
            F.row(row++) = b.F.row(fb++).array() + a.n_vertices();
        }
    }
    return make_mesh_view(std::move(V), std::move(F));
}

MeshView single_triangle() {
    PointMatrix V(3, 3);
    V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    TriangleMatrix F(1, 3);
    F << 0, 1, 2;
    return make_mesh_view(std::move(V), std::move(F));
}

MeshView corner_tetrahedron() {
    PointMatrix V(4, 3);
    V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    TriangleMatrix F(4, 3);
    F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
    return make_mesh_view(std::move(V), std::move(F));
}

// Every loop is a cycle of boundary edges in order (v_i -> v_{i+1} is a boundary halfedge), the
// loops together use each boundary halfedge exactly once, and no vertex repeats in a loop.
void expect_ordered_boundary(const MeshView& mesh, const Topology& t) {
    std::set<std::pair<Index, Index>> boundary_halfedges;
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (mesh.is_boundary_halfedge(h)) boundary_halfedges.emplace(mesh.tail(h), mesh.head(h));
    std::size_t total = 0;
    for (const std::vector<Index>& loop : t.boundary_cycles) {
        ASSERT_GE(loop.size(), 3u);
        std::set<Index> distinct(loop.begin(), loop.end());
        EXPECT_EQ(distinct.size(), loop.size());
        for (std::size_t i = 0; i < loop.size(); ++i) {
            const std::pair<Index, Index> step{loop[i], loop[(i + 1) % loop.size()]};
            EXPECT_EQ(boundary_halfedges.count(step), 1u)
                << "no boundary edge " << step.first << " -> " << step.second;
        }
        total += loop.size();
    }
    EXPECT_EQ(total, boundary_halfedges.size());
}

TEST(Topology, SingleTriangleIsADiskWithOneOrderedLoop) {
    const MeshView tri = single_triangle();
    const Topology t = compute_topology(tri);
    EXPECT_EQ(t.vertices, 3);
    EXPECT_EQ(t.edges, 3);
    EXPECT_EQ(t.faces, 1);
    EXPECT_EQ(t.components, 1);
    EXPECT_EQ(t.euler_characteristic, 1);
    EXPECT_EQ(t.genus, 0);
    EXPECT_TRUE(t.orientable);
    ASSERT_EQ(t.boundary_loops, 1);
    // The loop runs along the face's own orientation, starting at the first boundary halfedge.
    EXPECT_EQ(t.boundary_cycles[0], (std::vector<Index>{0, 1, 2}));
}

TEST(Topology, TetrahedronIsAClosedSphere) {
    const Topology t = compute_topology(corner_tetrahedron());
    EXPECT_EQ(t.vertices, 4);
    EXPECT_EQ(t.edges, 6);
    EXPECT_EQ(t.faces, 4);
    EXPECT_EQ(t.euler_characteristic, 2);
    EXPECT_EQ(t.boundary_loops, 0);
    EXPECT_TRUE(t.boundary_cycles.empty());
    EXPECT_EQ(t.genus, 0);
    ASSERT_EQ(t.per_component.size(), 1u);
    EXPECT_EQ(t.per_component[0].genus, 0);
}

TEST(Topology, TorusHasGenusOne) {
    for (const auto& [nu, nv] : {std::pair{3, 3}, std::pair{7, 4}, std::pair{40, 24}}) {
        const Topology t = compute_topology(shapes::torus(2.0, 0.5, nu, nv));
        EXPECT_EQ(t.vertices, nu * nv);
        EXPECT_EQ(t.edges, 3 * nu * nv);
        EXPECT_EQ(t.faces, 2 * nu * nv);
        EXPECT_EQ(t.euler_characteristic, 0);
        EXPECT_EQ(t.boundary_loops, 0);
        EXPECT_EQ(t.genus, 1);
    }
}

TEST(Topology, FlatGridIsADiskWithOneLoopOfItsPerimeter) {
    for (const auto& [nx, ny] : {std::pair{1, 1}, std::pair{2, 3}, std::pair{17, 9}}) {
        const MeshView grid = shapes::flat_grid(nx, ny);
        const Topology t = compute_topology(grid);
        EXPECT_EQ(t.euler_characteristic, 1);
        EXPECT_EQ(t.genus, 0);
        ASSERT_EQ(t.boundary_loops, 1);
        EXPECT_EQ(t.boundary_cycles[0].size(), static_cast<std::size_t>(2 * (nx + ny)));
        expect_ordered_boundary(grid, t);
    }
}

TEST(Topology, CylinderHasTwoLoopsAndGenusZero) {
    const MeshView tube = shapes::cylinder(1.0, 2.0, 12, 5);
    const Topology t = compute_topology(tube);
    EXPECT_EQ(t.euler_characteristic, 0);
    EXPECT_EQ(t.genus, 0);
    ASSERT_EQ(t.boundary_loops, 2);
    EXPECT_EQ(t.boundary_cycles[0].size(), 12u);
    EXPECT_EQ(t.boundary_cycles[1].size(), 12u);
    expect_ordered_boundary(tube, t);
    // One loop at z = 0, the other at z = height.
    const double z0 = tube.V(t.boundary_cycles[0][0], 2), z1 = tube.V(t.boundary_cycles[1][0], 2);
    EXPECT_EQ(std::min(z0, z1), 0.0);
    EXPECT_EQ(std::max(z0, z1), 2.0);
}

TEST(Topology, PerforatedSheetHasOneLoopPerHolePlusTheRim) {
    for (int holes = 0; holes <= 4; ++holes) {
        const MeshView sheet = shapes::perforated_sheet(holes, 2);
        const Topology t = compute_topology(sheet);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.boundary_loops, holes + 1);
        EXPECT_EQ(t.euler_characteristic, 1 - holes);
        EXPECT_EQ(t.genus, 0);
        expect_ordered_boundary(sheet, t);
    }
}

TEST(Topology, ComponentsAreOrderedBySmallestFace) {
    // Interleaved faces: face 0 belongs to the torus, face 1 to the sphere, and so on.
    const MeshView torus = shapes::torus(3.0, 1.0, 6, 4);
    const MeshView sphere = corner_tetrahedron();
    const MeshView both = disjoint_union(sphere, torus, /*interleave=*/true);
    const Topology t = compute_topology(both);
    ASSERT_EQ(t.components, 2);
    ASSERT_EQ(t.face_component.size(), static_cast<std::size_t>(both.n_faces()));
    // First 2 * 4 faces alternate sphere, torus; the rest are torus faces.
    for (Index f = 0; f < both.n_faces(); ++f)
        EXPECT_EQ(t.face_component[f], (f < 8 && f % 2 == 0) ? 0 : 1) << "face " << f;
    EXPECT_EQ(t.per_component[0].faces, 4);
    EXPECT_EQ(t.per_component[0].vertices, 4);
    EXPECT_EQ(t.per_component[0].edges, 6);
    EXPECT_EQ(t.per_component[0].genus, 0);
    EXPECT_EQ(t.per_component[1].faces, torus.n_faces());
    EXPECT_EQ(t.per_component[1].vertices, torus.n_vertices());
    EXPECT_EQ(t.per_component[1].edges, torus.n_edges());
    EXPECT_EQ(t.per_component[1].genus, 1);
    EXPECT_EQ(t.genus, 1);
    EXPECT_EQ(t.euler_characteristic, 2);  // 2 + 0
}

// Each component as a mesh of its own: the interleaved union's parts are the sphere and the
// torus again, with their faces and vertices in order and their twins.
TEST(Topology, ComponentMeshesAreThePartsAgain) {
    const MeshView torus = shapes::torus(3.0, 1.0, 6, 4);
    const MeshView sphere = corner_tetrahedron();
    const MeshView both = disjoint_union(sphere, torus, /*interleave=*/true);
    const std::vector<ComponentMesh> parts = component_meshes(both, compute_topology(both));
    ASSERT_EQ(parts.size(), 2u);
    Index first_vertex = 0;  // disjoint_union puts b's vertices after a's
    for (const auto& [part, original] : {std::pair{&parts[0], &sphere}, {&parts[1], &torus}}) {
        EXPECT_EQ(part->mesh.V, original->V);
        EXPECT_EQ(part->mesh.F, original->F);
        EXPECT_EQ(part->mesh.twin, original->twin);
        const Topology t = compute_topology(part->mesh);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.genus, compute_topology(*original).genus);
        ASSERT_EQ(static_cast<Index>(part->source_vertex.size()), original->n_vertices());
        for (Index v = 0; v < original->n_vertices(); ++v) EXPECT_EQ(part->source_vertex[v], first_vertex + v);
        first_vertex += original->n_vertices();
    }
    EXPECT_THROW(component_meshes(both, compute_topology(sphere)), InvalidInput);
}

TEST(Topology, PerComponentBoundaryAndGenusAddUp) {
    // Disk, cylinder and genus-2 surface, in this face order.
    const MeshView disk_and_tube =
        disjoint_union(shapes::flat_grid(3, 3), shapes::cylinder(1.0, 1.0, 8, 2));
    const MeshView all = disjoint_union(disk_and_tube, shapes::genus_surface(2, 1));
    const Topology t = compute_topology(all);
    ASSERT_EQ(t.components, 3);
    EXPECT_EQ(t.per_component[0].boundary_loops, 1);
    EXPECT_EQ(t.per_component[0].euler_characteristic, 1);
    EXPECT_EQ(t.per_component[1].boundary_loops, 2);
    EXPECT_EQ(t.per_component[1].euler_characteristic, 0);
    EXPECT_EQ(t.per_component[2].boundary_loops, 0);
    EXPECT_EQ(t.per_component[2].genus, 2);
    EXPECT_EQ(t.boundary_loops, 3);
    EXPECT_EQ(t.genus, 2);
    EXPECT_EQ(t.euler_characteristic, 1 + 0 + (2 - 2 * 2));
    Index v = 0, e = 0, f = 0;
    for (const ComponentTopology& c : t.per_component) {
        v += c.vertices;
        e += c.edges;
        f += c.faces;
    }
    EXPECT_EQ(v, t.vertices);
    EXPECT_EQ(e, t.edges);
    EXPECT_EQ(f, t.faces);
    expect_ordered_boundary(all, t);
}

TEST(Topology, IsDeterministic) {
    const MeshView sheet = shapes::perforated_sheet(3, 2);
    const Topology a = compute_topology(sheet), b = compute_topology(sheet);
    EXPECT_EQ(a.boundary_cycles, b.boundary_cycles);
    EXPECT_EQ(a.face_component, b.face_component);
}

}  // namespace
}  // namespace holoflow::kernels
