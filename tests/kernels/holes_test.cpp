#include "holoflow/kernels/holes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <set>
#include <vector>

#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

using test::pinhole_faces;
using test::without_faces;

// A face as a rotation-free key: its vertex triple rotated to start at the smallest id.
std::array<Index, 3> face_key(Index a, Index b, Index c) {
    if (b < a && b < c) return {b, c, a};
    if (c < a && c < b) return {c, a, b};
    return {a, b, c};
}

TEST(Holes, PinholesOfATorusCloseIntoTheTorus) {
    const MeshView torus = shapes::torus(3, 1, 40, 20);
    const std::vector<Index> drop = pinhole_faces(torus, 30, 37);
    ASSERT_EQ(drop.size(), 30u);
    const MeshView holey = without_faces(torus, drop);
    const Topology t = compute_topology(holey);
    ASSERT_EQ(t.boundary_loops, 30);
    ASSERT_EQ(t.genus, 1);

    HoleFillOptions options;
    options.max_loop_edges = 3;
    const std::vector<Index> holes = holes_to_fill(holey, t, options);
    EXPECT_EQ(holes.size(), 30u);
    const FilledHoles filled = fill_holes(holey, t, holes);
    EXPECT_EQ(filled.holes, 30);
    EXPECT_EQ(filled.faces, 30);
    EXPECT_EQ(filled.left_open, 0);
    ASSERT_EQ(filled.mesh.n_faces(), torus.n_faces());
    EXPECT_TRUE(filled.mesh.is_closed());
    EXPECT_EQ(compute_topology(filled.mesh).genus, 1);
    // A 3-edge hole has one triangulation: the deleted face, with its orientation.
    std::set<std::array<Index, 3>> original, now;
    for (Index f = 0; f < torus.n_faces(); ++f) original.insert(face_key(torus.F(f, 0), torus.F(f, 1), torus.F(f, 2)));
    for (Index f = 0; f < filled.mesh.n_faces(); ++f)
        now.insert(face_key(filled.mesh.F(f, 0), filled.mesh.F(f, 1), filled.mesh.F(f, 2)));
    EXPECT_EQ(now, original);
    // The input's faces keep their ids.
    for (Index f = 0; f < holey.n_faces(); ++f) EXPECT_EQ(filled.mesh.F.row(f), holey.F.row(f));
}

// A tetrahedron without the two faces at edge 2-3: the hole 0, 2, 1, 3 has diagonals 0-1 (an edge
// of the faces left, short, giving the better shaped triangles) and 2-3 (long). Only 2-3 keeps
// the surface manifold.
TEST(Holes, DiagonalTheMeshHasIsNotUsedAgain) {
    PointMatrix V(4, 3);
    V << 0, 0, 0, 1, 0, 0, 0.5, 3, 0.1, 0.5, -3, 0.1;
    TriangleMatrix F(2, 3);
    F << 0, 2, 1, 0, 1, 3;
    const MeshView open = make_mesh_view(V, F);
    const Topology t = compute_topology(open);
    ASSERT_EQ(t.boundary_loops, 1);
    const std::vector<std::array<Index, 3>> triangles = triangulate_hole(open, t.boundary_cycles[0]);
    ASSERT_EQ(triangles.size(), 2u);
    for (const auto& tri : triangles) {
        EXPECT_NE(std::find(tri.begin(), tri.end(), 2), tri.end());
        EXPECT_NE(std::find(tri.begin(), tri.end(), 3), tri.end());
    }
    const std::vector<Index> loop{0};
    const FilledHoles filled = fill_holes(open, t, loop);
    EXPECT_EQ(filled.faces, 2);
    EXPECT_TRUE(filled.mesh.is_closed());
    EXPECT_EQ(compute_topology(filled.mesh).euler_characteristic, 2);
}

// A planar hole: its triangles keep the surface's orientation (normals up like the sheet's) and
// none is flat where a well-shaped triangulation exists.
TEST(Holes, HoleTrianglesFaceTheWayTheSurfaceDoes) {
    const MeshView sheet = shapes::perforated_sheet(2, 3);  // two 3 x 3-cell square holes
    const Topology t = compute_topology(sheet);
    ASSERT_EQ(t.boundary_loops, 3);
    HoleFillOptions options;
    options.max_loop_edges = 12;
    const std::vector<Index> holes = holes_to_fill(sheet, t, options);
    ASSERT_EQ(holes.size(), 2u);  // the outer border (longest, the disk's last loop) stays
    const FilledHoles filled = fill_holes(sheet, t, holes);
    EXPECT_EQ(filled.faces, 2 * (12 - 2));
    const Topology after = compute_topology(filled.mesh);
    EXPECT_EQ(after.boundary_loops, 1);
    EXPECT_EQ(after.genus, 0);
    for (Index f = sheet.n_faces(); f < filled.mesh.n_faces(); ++f) {
        const Eigen::Vector3d a = filled.mesh.V.row(filled.mesh.F(f, 0)), b = filled.mesh.V.row(filled.mesh.F(f, 1)),
                              c = filled.mesh.V.row(filled.mesh.F(f, 2));
        const Eigen::Vector3d n = (b - a).cross(c - a);
        EXPECT_GT(n.z(), 1e-3 * (b - a).squaredNorm()) << "fill face " << f;  // up, and not flat
    }
}

// Working genus 2g + b - 1 over the cap: the shortest loops go first, until it fits.
TEST(Holes, GenusCapFillsTheShortestLoopsFirst) {
    const MeshView torus = shapes::torus(3, 1, 40, 20);
    std::vector<Index> drop = pinhole_faces(torus, 10, 53);
    ASSERT_EQ(drop.size(), 10u);
    // One longer hole: two faces sharing an edge (a 4-edge loop), away from the pinholes.
    std::vector<char> near(torus.n_vertices(), 0);
    for (Index f : drop)
        for (int k = 0; k < 3; ++k) near[torus.F(f, k)] = 1;
    for (Index f = 0; f < torus.n_faces(); ++f) {
        const Index g = MeshView::face(torus.twin[3 * f]);
        bool free = true;
        for (Index x : {f, g})
            for (int k = 0; k < 3; ++k) free = free && !near[torus.F(x, k)];
        if (!free) continue;
        drop.push_back(f);
        drop.push_back(g);
        break;
    }
    ASSERT_EQ(drop.size(), 12u);
    const MeshView holey = without_faces(torus, drop);
    const Topology t = compute_topology(holey);
    ASSERT_EQ(t.boundary_loops, 11);  // working genus 2 + 11 - 1 = 12
    const auto loop_sizes = [&](const std::vector<Index>& holes) {
        std::vector<std::size_t> sizes;
        for (Index l : holes) sizes.push_back(t.boundary_cycles[l].size());
        return sizes;
    };
    HoleFillOptions options;
    options.max_working_genus = 12;
    EXPECT_TRUE(holes_to_fill(holey, t, options).empty());
    options.max_working_genus = 5;  // b <= 4: seven pinholes filled
    EXPECT_EQ(loop_sizes(holes_to_fill(holey, t, options)), std::vector<std::size_t>(7, 3));
    options.max_working_genus = 2;  // b <= 1: every pinhole, the 4-edge loop stays
    EXPECT_EQ(loop_sizes(holes_to_fill(holey, t, options)), std::vector<std::size_t>(10, 3));
    options.max_working_genus = 1;  // the cap never takes the longest loop
    EXPECT_EQ(holes_to_fill(holey, t, options).size(), 10u);
    options.max_loop_edges = 4;  // by size it does: closed
    const std::vector<Index> all = holes_to_fill(holey, t, options);
    EXPECT_EQ(all.size(), 11u);
    const FilledHoles filled = fill_holes(holey, t, all);
    EXPECT_TRUE(filled.mesh.is_closed());
    EXPECT_EQ(compute_topology(filled.mesh).genus, 1);
    options.longest_fillable_loop = 3;  // the 4-edge loop is too long to fill
    EXPECT_EQ(holes_to_fill(holey, t, options).size(), 10u);
}

// An island of one triangle is a disk: it keeps its loop (closing it would make a flat sphere).
TEST(Holes, DiskKeepsItsLastLoop) {
    PointMatrix V(3, 3);
    V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    TriangleMatrix F(1, 3);
    F << 0, 1, 2;
    const MeshView island = make_mesh_view(V, F);
    HoleFillOptions options;
    options.max_loop_edges = 100;
    options.max_working_genus = 1;
    EXPECT_TRUE(holes_to_fill(island, compute_topology(island), options).empty());
}

// A slit: the hole a -> c -> b runs along one line (a, b, c collinear), so its one triangle is
// flat and the hole stays open, counted.
TEST(Holes, FlatHoleIsLeftOpen) {
    PointMatrix V(5, 3);
    V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 1, 1, 0, 1, -1, 0;  // a, b, c, p, q
    TriangleMatrix F(5, 3);
    F << 1, 0, 3, 2, 1, 3, 0, 2, 4, 3, 0, 4, 4, 2, 3;
    const MeshView slit = make_mesh_view(V, F);
    const Topology t = compute_topology(slit);
    ASSERT_EQ(t.boundary_loops, 1);
    ASSERT_EQ(t.boundary_cycles[0].size(), 3u);
    EXPECT_TRUE(triangulate_hole(slit, t.boundary_cycles[0]).empty());
    const std::vector<Index> loop{0};
    const FilledHoles filled = fill_holes(slit, t, loop);
    EXPECT_EQ(filled.holes, 0);
    EXPECT_EQ(filled.left_open, 1);
    EXPECT_EQ(filled.mesh.F, slit.F);
    // A quality floor above the best triangle's leaves the tetrahedron's hole open too.
    PointMatrix W(4, 3);
    W << 0, 0, 0, 1, 0, 0, 0.5, 3, 0.1, 0.5, -3, 0.1;
    TriangleMatrix G(2, 3);
    G << 0, 2, 1, 0, 1, 3;
    const MeshView open = make_mesh_view(W, G);
    EXPECT_EQ(triangulate_hole(open, compute_topology(open).boundary_cycles[0], 0.1).size(), 2u);
    EXPECT_TRUE(triangulate_hole(open, compute_topology(open).boundary_cycles[0], 0.5).empty());
}

}  // namespace
}  // namespace holoflow::kernels
