#include "holoflow/kernels/double_cover.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::kernels {
namespace {

std::vector<char> boundary_vertices(const MeshView& m) {
    std::vector<char> on(m.n_vertices(), 0);
    for (Index h = 0; h < m.n_halfedges(); ++h)
        if (m.is_boundary_halfedge(h)) on[m.tail(h)] = 1;
    return on;
}

Index boundary_edge_count(const MeshView& m) {
    Index n = 0;
    for (Index h = 0; h < m.n_halfedges(); ++h) n += m.is_boundary_halfedge(h) ? 1 : 0;
    return n;
}

// True if (x0, x1, x2) equals (y0, y1, y2) up to a cyclic shift.
bool same_cycle(const std::array<Index, 3>& x, const std::array<Index, 3>& y) {
    for (int shift = 0; shift < 3; ++shift)
        if (x[0] == y[shift] && x[1] == y[(shift + 1) % 3] && x[2] == y[(shift + 2) % 3])
            return true;
    return false;
}

// Checks every structural claim of DoubleCover against its input.
void expect_valid_cover(const MeshView& in, const DoubleCover& dc) {
    const MeshView& m = dc.mesh;
    EXPECT_TRUE(m.is_closed());
    const std::vector<char> on = boundary_vertices(in);
    const Index n_boundary = static_cast<Index>(std::count(on.begin(), on.end(), 1));
    ASSERT_EQ(m.n_vertices(), 2 * in.n_vertices() - n_boundary);
    ASSERT_EQ(m.n_faces(), 2 * in.n_faces());
    EXPECT_EQ(m.n_edges(), 2 * in.n_edges() - boundary_edge_count(in));
    ASSERT_EQ(dc.vertex_involution.size(), static_cast<std::size_t>(m.n_vertices()));
    ASSERT_EQ(dc.original_vertex.size(), static_cast<std::size_t>(m.n_vertices()));
    ASSERT_EQ(dc.face_involution.size(), static_cast<std::size_t>(m.n_faces()));
    ASSERT_EQ(dc.original_face.size(), static_cast<std::size_t>(m.n_faces()));

    const auto& s = dc.vertex_involution;
    Index fixed = 0;
    for (Index v = 0; v < m.n_vertices(); ++v) {
        ASSERT_GE(s[v], 0);
        ASSERT_LT(s[v], m.n_vertices());
        EXPECT_EQ(s[s[v]], v);
        EXPECT_EQ(dc.original_vertex[s[v]], dc.original_vertex[v]);
        EXPECT_EQ(m.V.row(v), in.V.row(dc.original_vertex[v]));
        // Fixed points are exactly the input's boundary vertices.
        EXPECT_EQ(s[v] == v, on[dc.original_vertex[v]] == 1) << "vertex " << v;
        fixed += s[v] == v ? 1 : 0;
    }
    EXPECT_EQ(fixed, n_boundary);

    for (Index f = 0; f < m.n_faces(); ++f) {
        const Index g = dc.face_involution[f];
        ASSERT_GE(g, 0);
        ASSERT_LT(g, m.n_faces());
        EXPECT_NE(g, f);
        EXPECT_EQ(dc.face_involution[g], f);
        // The mirror face is s applied to f's corners, in reversed order.
        const std::array<Index, 3> image{s[m.F(f, 2)], s[m.F(f, 1)], s[m.F(f, 0)]};
        EXPECT_TRUE(same_cycle({m.F(g, 0), m.F(g, 1), m.F(g, 2)}, image)) << "face " << f;
        // original_face: copy 0 keeps the input order, copy 1 reverses it.
        const Index o = dc.original_face[f];
        EXPECT_EQ(dc.original_face[g], o);
        const std::array<Index, 3> down{dc.original_vertex[m.F(f, 0)],
                                        dc.original_vertex[m.F(f, 1)],
                                        dc.original_vertex[m.F(f, 2)]};
        const std::array<Index, 3> input{in.F(o, 0), in.F(o, 1), in.F(o, 2)};
        const std::array<Index, 3> reversed{in.F(o, 2), in.F(o, 1), in.F(o, 0)};
        EXPECT_TRUE(same_cycle(down, f < in.n_faces() ? input : reversed)) << "face " << f;
    }
}

TEST(DoubleCover, OfAFlatGridIsASphere) {
    for (const auto& [nx, ny] : {std::array{1, 1}, std::array{2, 2}, std::array{6, 4}}) {
        const MeshView grid = shapes::flat_grid(nx, ny);
        const DoubleCover dc = double_cover(grid);
        expect_valid_cover(grid, dc);
        const Topology t = compute_topology(dc.mesh);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.boundary_loops, 0);
        EXPECT_EQ(t.euler_characteristic, 2);
        EXPECT_EQ(t.genus, 0);
    }
}

TEST(DoubleCover, OfACylinderIsATorus) {
    // nv = 1: every triangle has three boundary vertices and every diagonal joins the two rims,
    // so the cover has two edges on each such vertex pair.
    for (int nv : {1, 2, 5}) {
        const MeshView tube = shapes::cylinder(1.0, 2.0, 8, nv);
        const DoubleCover dc = double_cover(tube);
        expect_valid_cover(tube, dc);
        const Topology t = compute_topology(dc.mesh);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.boundary_loops, 0);
        EXPECT_EQ(t.genus, 1);
    }
}

TEST(DoubleCover, GenusIsTwoGPlusBMinusOne) {
    // A sheet with k holes has g = 0, b = k + 1: the cover has genus k.
    for (int holes = 0; holes <= 5; ++holes) {
        const MeshView sheet = shapes::perforated_sheet(holes, 1);
        const DoubleCover dc = double_cover(sheet);
        expect_valid_cover(sheet, dc);
        EXPECT_EQ(compute_topology(dc.mesh).genus, holes);
    }
    // An open surface of genus 1 with 2 boundary loops: a torus with two faces removed far apart.
    const MeshView torus = shapes::torus(3.0, 1.0, 12, 8);
    TriangleMatrix F(torus.n_faces() - 2, 3);
    Index row = 0;
    for (Index f = 0; f < torus.n_faces(); ++f)
        if (f != 0 && f != torus.n_faces() / 2) F.row(row++) = torus.F.row(f);
    const MeshView punctured = make_mesh_view(torus.V, F);
    const Topology pt = compute_topology(punctured);
    ASSERT_EQ(pt.genus, 1);
    ASSERT_EQ(pt.boundary_loops, 2);
    const DoubleCover dc = double_cover(punctured);
    expect_valid_cover(punctured, dc);
    EXPECT_EQ(compute_topology(dc.mesh).genus, 2 * 1 + 2 - 1);
}

TEST(DoubleCover, KeepsComponentsApart) {
    const MeshView grid = shapes::flat_grid(3, 3), tube = shapes::cylinder(1.0, 1.0, 6, 2);
    PointMatrix V(grid.n_vertices() + tube.n_vertices(), 3);
    V << grid.V, tube.V;
    TriangleMatrix F(grid.n_faces() + tube.n_faces(), 3);
    F << grid.F, tube.F.array() + grid.n_vertices();
    const MeshView both = make_mesh_view(std::move(V), std::move(F));
    const DoubleCover dc = double_cover(both);
    expect_valid_cover(both, dc);
    const Topology t = compute_topology(dc.mesh);
    ASSERT_EQ(t.components, 2);
    EXPECT_EQ(t.per_component[0].genus, 0);
    EXPECT_EQ(t.per_component[1].genus, 1);
}

TEST(DoubleCover, RejectsClosedMeshes) {
    EXPECT_THROW(double_cover(shapes::torus(2.0, 0.5, 6, 4)), InvalidInput);
}

}  // namespace
}  // namespace holoflow::kernels
