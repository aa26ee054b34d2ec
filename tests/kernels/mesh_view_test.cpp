#include "holoflow/kernels/mesh_view.h"

#include <algorithm>
#include <array>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

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

// A mesh of over 8k faces (make_mesh_view's passes run in parallel blocks there) with its
// faces and vertices shuffled, as a badly ordered file stores them.
MeshView shuffled(const MeshView& m, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<Index> face(m.n_faces()), vertex(m.n_vertices());
    std::iota(face.begin(), face.end(), 0);
    std::iota(vertex.begin(), vertex.end(), 0);
    std::shuffle(face.begin(), face.end(), rng);
    std::shuffle(vertex.begin(), vertex.end(), rng);
    PointMatrix V(m.n_vertices(), 3);
    for (Index v = 0; v < m.n_vertices(); ++v) V.row(vertex[v]) = m.V.row(v);
    TriangleMatrix F(m.n_faces(), 3);
    for (Index f = 0; f < m.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) F(face[f], k) = vertex[m.F(f, k)];
    return make_mesh_view(std::move(V), std::move(F));
}

// Edges are numbered in halfedge order, each vertex starts at its boundary halfedge if it has
// one, and one thread builds the same arrays as several.
TEST(MeshView, LargeMeshesAreBuiltInHalfedgeOrderWithAnyThreadCount) {
    for (const MeshView& m :
         {shuffled(shapes::torus(1.0, 0.4, 160, 150), 7), shuffled(shapes::flat_grid(170, 150), 8)}) {
        ASSERT_GT(m.n_faces(), 40000);
        EXPECT_TRUE(std::is_sorted(m.edge_halfedge.begin(), m.edge_halfedge.end()));
        Index boundary = 0;
        for (Index h = 0; h < m.n_halfedges(); ++h) {
            const Index t = m.twin[h], e = m.halfedge_edge[h];
            EXPECT_EQ(m.edge_halfedge[e], t == kNoHalfedge ? h : std::min(h, t)) << "halfedge " << h;
            boundary += t == kNoHalfedge;
        }
        EXPECT_EQ(m.n_edges(), (m.n_halfedges() + boundary) / 2);
        for (Index e = 0; e < m.n_edges(); ++e) {
            EXPECT_EQ(m.E(e, 0), m.tail(m.edge_halfedge[e]));
            EXPECT_EQ(m.E(e, 1), m.head(m.edge_halfedge[e]));
        }
        std::vector<char> on_boundary(m.n_vertices(), 0);
        for (Index h = 0; h < m.n_halfedges(); ++h)
            if (m.twin[h] == kNoHalfedge) on_boundary[m.tail(h)] = 1;
        for (Index v = 0; v < m.n_vertices(); ++v) {
            EXPECT_EQ(m.tail(m.vertex_halfedge[v]), v);
            EXPECT_EQ(m.is_boundary_halfedge(m.vertex_halfedge[v]), static_cast<bool>(on_boundary[v]))
                << "vertex " << v;
        }
        tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
        const MeshView serial = make_mesh_view(m.V, m.F, m.twin);
        EXPECT_EQ(serial.halfedge_edge, m.halfedge_edge);
        EXPECT_EQ(serial.edge_halfedge, m.edge_halfedge);
        EXPECT_EQ(serial.E, m.E);
        EXPECT_EQ(serial.vertex_halfedge, m.vertex_halfedge);
    }
}

// On a large mesh, the smallest offender is named whichever block finds it: the first halfedge
// whose twin is wrong, the smallest pinched vertex.
TEST(MeshView, LargeMeshesNameTheSmallestOffender) {
    const MeshView m = shuffled(shapes::torus(1.0, 0.4, 160, 150), 9);
    ASSERT_GT(m.n_halfedges(), 100000);
    std::vector<Index> twin = m.twin;
    const Index late = 95000, early = 30001;  // unpaired: their old twins now point at them alone
    const Index expected = std::min(m.twin[late], m.twin[early]);
    twin[late] = twin[early] = kNoHalfedge;
    try {
        make_mesh_view(m.V, m.F, twin);
        ADD_FAILURE() << "a broken pairing accepted";
    } catch (const InvalidInput& e) {
        EXPECT_TRUE(std::string(e.what()).ends_with("twin is not an involution at halfedge " + std::to_string(expected)))
            << e.what();
    }
    // Two edges far apart swap their twins: still an involution, but pairing halfedges that are
    // not opposite; all four are at fault.
    twin = m.twin;
    const Index a = 90001, b = 20000, ta = m.twin[a], tb = m.twin[b];
    twin[a] = tb, twin[tb] = a, twin[b] = ta, twin[ta] = b;
    try {
        make_mesh_view(m.V, m.F, twin);
        ADD_FAILURE() << "a pairing of halfedges that are not opposite accepted";
    } catch (const InvalidInput& e) {
        EXPECT_TRUE(std::string(e.what()).ends_with("twin halfedges are not opposite at halfedge " +
                                                    std::to_string(std::min({a, b, ta, tb}))))
            << e.what();
    }
    // Two vertices far apart in the numbering each get a second fan (a triangle on two new
    // vertices); the smaller one is named.
    for (const std::array<Index, 2> pinched : {std::array<Index, 2>{20000, 3000}, {100, 23000}}) {
        PointMatrix V(m.n_vertices() + 4, 3);
        V << m.V, PointMatrix::Random(4, 3);
        TriangleMatrix F(m.n_faces() + 2, 3);
        const Index n = m.n_vertices();
        F << m.F, pinched[0], n, n + 1, pinched[1], n + 2, n + 3;
        try {
            make_mesh_view(V, F);
            ADD_FAILURE() << "pinched vertices accepted";
        } catch (const ConnectivityError& e) {
            EXPECT_EQ(e.kind, ConnectivityError::Kind::NonManifoldVertex);
            EXPECT_EQ(e.element, std::min(pinched[0], pinched[1])) << e.what();
        }
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
