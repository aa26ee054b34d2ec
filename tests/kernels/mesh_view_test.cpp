#include "holoflow/kernels/mesh_view.h"

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "holoflow/kernels/shapes.h"

namespace holoflow {
namespace {

// Unit square a=0 (0,0), b=1 (1,1), c=2 (0,1), d=3 (1,0): faces (a, b, c) and (b, a, d) on the
// diagonal a-b; the flip puts them on c-d.
// Each edge is represented by the smaller halfedge of its pair, E runs along it, and edge_sign
// (read off twin alone) agrees: on a sphere, a torus and an open grid.
TEST(MeshView, EdgesRunAlongTheirSmallerHalfedge) {
    for (const MeshView& m : {shapes::icosphere(2), shapes::flat_grid(7, 5), shapes::torus(1.0, 0.4, 12, 7)}) {
        for (Index e = 0; e < m.n_edges(); ++e) {
            const Index h = m.edge_halfedge[e], t = m.twin[h];
            EXPECT_TRUE(t == kNoHalfedge || h < t) << "edge " << e;
            EXPECT_EQ(m.halfedge_edge[h], e);
            EXPECT_EQ(m.E(e, 0), m.tail(h));
            EXPECT_EQ(m.E(e, 1), m.head(h));
        }
        for (Index h = 0; h < m.n_halfedges(); ++h)
            EXPECT_EQ(m.edge_sign(h), m.edge_halfedge[m.halfedge_edge[h]] == h ? 1 : -1) << "halfedge " << h;
    }
}

// Octahedra (and one triangle) glued at single vertices, ids scattered so that the pinched
// vertices fall in different blocks of make_mesh_view's side-by-side fan walks: the error names
// the smallest pinched vertex, as walking one vertex after the other would. Each kind (two
// closed fans, a closed fan beside a boundary one) is the smallest in one of the cases.
TEST(MeshView, EveryPinchedVertexIsFoundAndTheSmallestNamed) {
    const auto octahedron = [](std::array<Index, 6> v, std::vector<std::array<Index, 3>>& F) {
        for (int i = 0; i < 4; ++i) {
            const Index r = v[2 + i], s = v[2 + (i + 1) % 4];
            F.push_back({v[0], r, s});
            F.push_back({v[1], s, r});
        }
    };
    // Vertex 0 joins octahedra A and B, vertex 1 octahedra C and D, vertex 2 octahedron E and a
    // triangle; the other 29 vertices are fine.
    std::vector<std::array<Index, 3>> faces;
    octahedron({0, 3, 4, 5, 6, 7}, faces);
    octahedron({0, 8, 9, 10, 11, 12}, faces);
    octahedron({1, 13, 14, 15, 16, 17}, faces);
    octahedron({1, 18, 19, 20, 21, 22}, faces);
    octahedron({2, 23, 24, 25, 26, 27}, faces);
    faces.push_back({2, 28, 29});
    octahedron({30, 31, 32, 33, 34, 35}, faces);
    const Index n = 36;
    for (const std::array<Index, 3> pinched : {std::array<Index, 3>{33, 17, 21}, {3, 35, 34}, {20, 19, 2}}) {
        std::vector<Index> id(n);  // pinched vertices 0, 1, 2 -> pinched[0..2], the others in turn
        for (Index v = 0, next = 0; v < n; ++v) {
            if (v < 3) {
                id[v] = pinched[v];
                continue;
            }
            while (std::find(pinched.begin(), pinched.end(), next) != pinched.end()) ++next;
            id[v] = next++;
        }
        PointMatrix V = PointMatrix::Random(n, 3);
        TriangleMatrix F(static_cast<Index>(faces.size()), 3);
        for (std::size_t f = 0; f < faces.size(); ++f)
            for (int k = 0; k < 3; ++k) F(static_cast<Index>(f), k) = id[faces[f][k]];
        try {
            make_mesh_view(V, F);
            ADD_FAILURE() << "pinched vertices accepted";
        } catch (const ConnectivityError& e) {
            EXPECT_EQ(e.kind, ConnectivityError::Kind::NonManifoldVertex);
            EXPECT_EQ(e.element, *std::min_element(pinched.begin(), pinched.end())) << e.what();
        }
    }
}

TEST(FlipEdge, TurnsTheDiagonalAndKeepsTheOuterPairing) {
    PointMatrix V(4, 3);
    V << 0, 0, 0, 1, 1, 0, 0, 1, 0, 1, 0, 0;
    TriangleMatrix F(2, 3);
    F << 0, 1, 2, 1, 0, 3;
    const MeshView m = make_mesh_view(V, F);
    TriangleMatrix G = m.F;
    std::vector<Index> twin = m.twin;
    EXPECT_TRUE(joins(G, twin, 0, 1));   // a -> b
    EXPECT_FALSE(joins(G, twin, 2, 3));  // c -> a leaves c; no c-d yet
    flip_edge(G, twin, 0);
    TriangleMatrix expected(2, 3);
    expected << 2, 0, 3, 3, 1, 2;  // (c, a, d), (d, b, c)
    EXPECT_EQ(G, expected);
    EXPECT_EQ(twin[2], 5);  // d -> c and c -> d
    EXPECT_EQ(twin[5], 2);
    for (Index h : {0, 1, 3, 4}) EXPECT_EQ(twin[h], kNoHalfedge);  // the square's sides
    EXPECT_TRUE(joins(G, twin, 0, 3));   // c -> a: c is joined to d now
    EXPECT_FALSE(joins(G, twin, 1, 1));  // a -> d: a is no longer joined to b
    // The pairing is the one make_mesh_view derives from the faces.
    EXPECT_EQ(make_mesh_view(V, G).twin, twin);
}

TEST(FlipEdge, ClosedMeshStaysAClosedPairing) {
    const MeshView m = shapes::icosphere(1);
    TriangleMatrix F = m.F;
    std::vector<Index> twin = m.twin;
    const Index a = m.tail(0), b = m.head(0);
    flip_edge(F, twin, 0);
    const MeshView flipped = make_mesh_view(m.V, F, twin);
    EXPECT_TRUE(flipped.is_closed());
    EXPECT_EQ(flipped.n_edges(), m.n_edges());
    EXPECT_FALSE(joins(F, twin, 1, b));  // halfedge 1 leaves a after the flip (a -> d)
    EXPECT_EQ(F(0, 1), a);
}

}  // namespace
}  // namespace holoflow
