#include "holoflow/engine/mesh_loader.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <tuple>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

namespace holoflow::engine {
namespace {

PolygonSoup soup_of(std::vector<double> positions, std::vector<std::vector<std::int64_t>> polygons) {
    PolygonSoup s;
    s.positions = std::move(positions);
    for (const auto& p : polygons) {
        s.indices.insert(s.indices.end(), p.begin(), p.end());
        s.offsets.push_back(s.indices.size());
    }
    return s;
}

// Octahedron: closed genus 0, 6 vertices, 8 faces, all wound outward.
PolygonSoup octahedron() {
    return soup_of({1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1},
                   {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                    {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}});
}

// Two triangles touching at vertex 0 only.
PolygonSoup bow_tie() { return soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0}, {{0, 1, 2}, {0, 3, 4}}); }

// Two octahedra, the second's vertex 1 being the first's vertex 0.
PolygonSoup octahedra_sharing_a_vertex() {
    PolygonSoup twin = octahedron();
    const std::size_t n = twin.n_vertices();
    for (std::size_t i = 0; i < n * 3; ++i) twin.positions.push_back(octahedron().positions[i] + (i % 3 == 0 ? 2 : 0));
    for (std::size_t i = 0; i < 24; ++i) {
        const std::int64_t v = octahedron().indices[i];
        twin.indices.push_back(v == 1 ? 0 : v + static_cast<std::int64_t>(n));
    }
    twin.offsets.clear();
    for (std::size_t i = 0; i <= 16; ++i) twin.offsets.push_back(3 * i);
    return twin;
}

MeshErrorKind kind_of(const PolygonSoup& soup, const LoadOptions& options = {}) {
    try {
        mesh_from_soup(soup, options);
    } catch (const MeshError& e) {
        return e.kind;
    }
    ADD_FAILURE() << "expected a MeshError";
    return MeshErrorKind::ParseError;
}

TEST(MeshLoader, OctahedronIsClosedGenusZero) {
    const LoadedMesh m = mesh_from_soup(octahedron());
    const kernels::Topology t = kernels::compute_topology(*m.mesh);
    EXPECT_EQ(t.vertices, 6);
    EXPECT_EQ(t.edges, 12);
    EXPECT_EQ(t.faces, 8);
    EXPECT_EQ(t.genus, 0);
    EXPECT_EQ(m.report.reoriented_faces, 0u);
}

TEST(MeshLoader, InconsistentWindingIsFixedAndCounted) {
    PolygonSoup s = octahedron();
    std::swap(s.indices[1], s.indices[2]);     // face 0 reversed
    std::swap(s.indices[13], s.indices[14]);   // face 4 reversed
    const LoadedMesh m = mesh_from_soup(s);
    EXPECT_EQ(m.report.reoriented_faces, 2u);  // the minority is flipped back
    EXPECT_TRUE(m.mesh->is_closed());
    // Every face now agrees with the original winding.
    const LoadedMesh reference = mesh_from_soup(octahedron());
    EXPECT_EQ(m.mesh->F, reference.mesh->F);
}

TEST(MeshLoader, PolygonsAreTriangulated) {
    // A cube made of quads, plus a non-convex L-shaped hexagon sheet elsewhere (second component).
    PolygonSoup s = soup_of({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1,
                             // L-shape in the plane z = 5
                             0, 0, 5, 2, 0, 5, 2, 1, 5, 1, 1, 5, 1, 2, 5, 0, 2, 5},
                            {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6},
                             {3, 0, 4, 7}, {8, 9, 10, 11, 12, 13}});
    const LoadedMesh m = mesh_from_soup(s);
    EXPECT_EQ(m.report.triangulated_polygons, 7u);
    EXPECT_EQ(m.report.triangles_from_polygons, 12u + 4u);
    EXPECT_EQ(m.report.components, 2u);
    const kernels::Topology t = kernels::compute_topology(*m.mesh);
    EXPECT_EQ(t.components, 2);
    EXPECT_EQ(t.boundary_loops, 1);
    // Ear clipping keeps the L-shape's area (3) exactly: no triangle over the notch.
    double area = 0;
    for (Index f = 0; f < m.mesh->n_faces(); ++f) {
        const Eigen::Vector3d a = m.mesh->V.row(m.mesh->F(f, 0)), b = m.mesh->V.row(m.mesh->F(f, 1)),
                              c = m.mesh->V.row(m.mesh->F(f, 2));
        if (a.z() == 5) area += 0.5 * (b - a).cross(c - a).norm();
    }
    EXPECT_DOUBLE_EQ(area, 3.0);
}

// A quad with a straight corner (vertex 1 on the side 0-2, as a CAD face with a vertex on its
// edge): its shorter diagonal 0-2 would make a flat triangle, so it splits along 1-3.
TEST(MeshLoader, QuadWithAStraightCornerSplitsAlongTheOtherDiagonal) {
    const PolygonSoup s = soup_of({0, 0, 0, 1, 0, 0, 2, 0, 0, 1, 5, 0}, {{0, 1, 2, 3}});
    const LoadedMesh m = mesh_from_soup(s);
    ASSERT_EQ(m.mesh->n_faces(), 2);
    for (Index f = 0; f < 2; ++f) {
        const Eigen::Vector3d a = m.mesh->V.row(m.mesh->F(f, 0)), b = m.mesh->V.row(m.mesh->F(f, 1)),
                              c = m.mesh->V.row(m.mesh->F(f, 2));
        EXPECT_NEAR(0.5 * (b - a).cross(c - a).norm(), 2.5, 1e-12);
    }
}

TEST(MeshLoader, UnreferencedVerticesAreDropped) {
    PolygonSoup s = octahedron();
    s.positions.insert(s.positions.end(), {7, 7, 7, 8, 8, 8});
    const LoadedMesh m = mesh_from_soup(s);
    EXPECT_EQ(m.report.unreferenced_vertices, 2u);
    EXPECT_EQ(m.mesh->n_vertices(), 6);
}

TEST(MeshLoader, LargestComponentPolicy) {
    PolygonSoup s = octahedron();
    // A lone triangle far away: 2 components.
    s.positions.insert(s.positions.end(), {10, 0, 0, 11, 0, 0, 10, 1, 0});
    s.indices.insert(s.indices.end(), {6, 7, 8});
    s.offsets.push_back(s.indices.size());
    const LoadedMesh all = mesh_from_soup(s);
    EXPECT_EQ(kernels::compute_topology(*all.mesh).components, 2);
    LoadOptions largest;
    largest.components = ComponentPolicy::Largest;
    const LoadedMesh one = mesh_from_soup(s, largest);
    EXPECT_EQ(one.report.components, 2u);
    EXPECT_EQ(one.report.dropped_components, 1u);
    EXPECT_EQ(one.report.dropped_faces, 1u);
    EXPECT_EQ(one.mesh->n_faces(), 8);
    EXPECT_EQ(one.mesh->n_vertices(), 6);
}

TEST(MeshLoader, EachBadInputHasItsKind) {
    PolygonSoup s = octahedron();
    s.positions[4] = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(kind_of(s), MeshErrorKind::NonFiniteCoordinate);
    s = octahedron();
    s.positions[0] = std::numeric_limits<double>::infinity();
    EXPECT_EQ(kind_of(s), MeshErrorKind::NonFiniteCoordinate);

    s = octahedron();
    s.indices[5] = 6;
    EXPECT_EQ(kind_of(s), MeshErrorKind::IndexOutOfRange);
    s.indices[5] = -1;
    EXPECT_EQ(kind_of(s), MeshErrorKind::IndexOutOfRange);
    s.indices[5] = std::int64_t{1} << 33;
    EXPECT_EQ(kind_of(s), MeshErrorKind::IndexOutOfRange);

    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0}, {{0, 1}})), MeshErrorKind::DegenerateFace);
    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0}, {{0, 1, 1}})),
              MeshErrorKind::RepeatedVertex);
    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0, 2, 0, 0}, {{0, 1, 2}})),
              MeshErrorKind::ZeroAreaFace);
    // Two distinct vertices at one position make a zero-area face too.
    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0, 1, 0, 0}, {{0, 1, 2}})),
              MeshErrorKind::ZeroAreaFace);
    LoadOptions no_duplicates;
    no_duplicates.duplicate_faces = DuplicateFacePolicy::Refuse;
    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0}, {{0, 1, 2}, {0, 2, 1}}), no_duplicates),
              MeshErrorKind::DuplicateFace);
    EXPECT_EQ(kind_of(soup_of({}, {})), MeshErrorKind::EmptyFile);

    // Three triangles on one edge, when asked to refuse them (MeshLoader.NonManifoldEdgesAreSplit).
    LoadOptions no_fins;
    no_fins.non_manifold_edges = NonManifoldEdgePolicy::Refuse;
    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1},
                              {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}), no_fins),
              MeshErrorKind::NonManifoldEdge);
    // Pinched vertices, when asked to refuse them (MeshLoader.PinchedVerticesAreSplitIntoFans).
    LoadOptions refuse;
    refuse.pinched_vertices = PinchedVertexPolicy::Refuse;
    EXPECT_EQ(kind_of(bow_tie(), refuse), MeshErrorKind::NonManifoldVertex);
    EXPECT_EQ(kind_of(octahedra_sharing_a_vertex(), refuse), MeshErrorKind::NonManifoldVertex);

    LoadOptions limit;
    limit.max_faces = 7;
    EXPECT_EQ(kind_of(octahedron(), limit), MeshErrorKind::TooLarge);
}

// Smallest face area over the longest squared edge of its face (> 0: no flat face).
double smallest_relative_area(const MeshView& m) {
    double smallest = std::numeric_limits<double>::infinity();
    for (Index f = 0; f < m.n_faces(); ++f) {
        const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
        const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
        smallest = std::min(smallest, (b - a).cross(c - a).norm() / longest);
    }
    return smallest;
}

// Zero-area triangles: two on an edge whose ends coincide (the octahedron's top vertex doubled,
// as an unwelded export leaves it) go with that edge; one with a corner inside its opposite edge
// (a T-junction closed by a flat cap) goes by flipping that edge with the triangle beyond it.
// Both give closed genus-0 surfaces again; with ZeroAreaPolicy::Refuse they are refused.
TEST(MeshLoader, ZeroAreaTrianglesAreRepairedUnlessRefused) {
    std::vector<double> doubled = octahedron().positions;
    doubled.insert(doubled.end(), {0, 0, 1});  // vertex 6 on vertex 4
    const PolygonSoup coincident = soup_of(doubled, {{0, 2, 4}, {2, 1, 4}, {1, 3, 6}, {3, 0, 6}, {2, 0, 5}, {1, 2, 5},
                                                     {3, 1, 5}, {0, 3, 5}, {4, 1, 6}, {0, 4, 6}});
    std::vector<double> on_edge = octahedron().positions;
    on_edge.insert(on_edge.end(), {0.5, 0.5, 0});  // vertex 6 inside edge 0-2
    const PolygonSoup cap = soup_of(on_edge, {{0, 6, 4}, {6, 2, 4}, {0, 2, 6}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                              {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}});
    for (const auto& [soup, collapsed, flipped, vertices] :
         {std::tuple{coincident, 1u, 0u, 6}, std::tuple{cap, 0u, 1u, 7}}) {
        const LoadedMesh m = mesh_from_soup(soup);
        EXPECT_EQ(m.report.collapsed_edges, collapsed);
        EXPECT_EQ(m.report.flipped_edges, flipped);
        EXPECT_EQ(m.report.collapsed_faces, 2 * collapsed);
        EXPECT_EQ(m.report.unreferenced_vertices, 0u);
        const kernels::Topology t = kernels::compute_topology(*m.mesh);
        EXPECT_EQ(t.vertices, vertices);
        EXPECT_EQ(t.components, 1);
        EXPECT_EQ(t.boundary_loops, 0);
        EXPECT_EQ(t.euler_characteristic, 2);
        EXPECT_GT(smallest_relative_area(*m.mesh), 0.1);
        LoadOptions refuse;
        refuse.zero_area_faces = ZeroAreaPolicy::Refuse;
        EXPECT_EQ(kind_of(soup, refuse), MeshErrorKind::ZeroAreaFace);
    }
}

// A face that repeats a corner in a row is an edge already collapsed (STL exporters write
// facets with two equal corners; welding makes them one vertex): the repair drops the repeat,
// and the face where fewer than three corners are left. A polygon that comes back to a corner
// later touches itself and stays refused, as is a file of collapsed faces only and, with
// ZeroAreaPolicy::Refuse, any repeat.
TEST(MeshLoader, CornersRepeatedInARowAreCollapsed) {
    // The octahedron with its face {0, 2, 4} written as a pentagon with two repeats in a row
    // (one across the wrap-around), and four faces of repeats only.
    const PolygonSoup slivers = soup_of(octahedron().positions, {{0, 2, 2, 4, 0}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5},
                                                                 {0, 0, 2}, {4, 2, 4}, {5, 5, 5}, {1, 3, 3, 1}});
    const LoadedMesh m = mesh_from_soup(slivers);
    EXPECT_EQ(m.report.collapsed_faces, 4u);
    EXPECT_EQ(m.report.collapsed_edges, 0u);
    EXPECT_EQ(m.report.triangulated_polygons, 0u);
    const kernels::Topology t = kernels::compute_topology(*m.mesh);
    EXPECT_EQ(t.faces, 8);
    EXPECT_EQ(t.vertices, 6);
    EXPECT_EQ(t.euler_characteristic, 2);
    EXPECT_EQ(t.boundary_loops, 0);

    LoadOptions refuse;
    refuse.zero_area_faces = ZeroAreaPolicy::Refuse;
    EXPECT_EQ(kind_of(slivers, refuse), MeshErrorKind::RepeatedVertex);
    PolygonSoup touching = octahedron();
    for (std::int64_t v : {0, 2, 4, 0, 5, 2}) touching.indices.push_back(v);
    touching.offsets.push_back(touching.indices.size());
    EXPECT_EQ(kind_of(touching), MeshErrorKind::RepeatedVertex);
    EXPECT_EQ(kind_of(soup_of({0, 0, 0, 1, 0, 0}, {{0, 1, 1}, {1, 0, 0, 1}})), MeshErrorKind::RepeatedVertex);
}

// The same through the STL reader: a tetrahedron with one facet written twice more, once
// with two equal corners and once with all three, loads as the tetrahedron.
TEST(MeshLoader, StlFacetsWithEqualCornersAreCollapsed) {
    const std::array<std::array<double, 3>, 4> p{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    std::string stl = "solid slivers\n";
    for (const std::array<int, 3>& f : std::vector<std::array<int, 3>>{{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3},
                                                                      {1, 1, 2}, {3, 3, 3}}) {
        stl += "facet normal 0 0 0\nouter loop\n";
        for (int v : f) stl += "vertex " + std::to_string(p[v][0]) + " " + std::to_string(p[v][1]) + " " +
                               std::to_string(p[v][2]) + "\n";
        stl += "endloop\nendfacet\n";
    }
    const test::TempDir dir;
    const LoadedMesh m = load_mesh(dir.write("slivers.stl", stl + "endsolid slivers\n"));
    EXPECT_EQ(m.report.collapsed_faces, 2u);
    const kernels::Topology t = kernels::compute_topology(*m.mesh);
    EXPECT_EQ(t.faces, 4);
    EXPECT_EQ(t.euler_characteristic, 2);
    EXPECT_EQ(t.boundary_loops, 0);
}

// Files of another mesh library's test suite (assimp-testmodels, which the test command
// installs) that other tools' exports look like: STL spiders with degenerate facets (56 of
// 1368 with two equal corners), a PLY whose header has Blender 2.4's keyword-less line, and an
// OBJ saved as UTF-16, refused by name.
TEST(MeshLoader, OtherLibrariesTestFiles) {
    const std::string dir = "/usr/share/assimp/models/";
    if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " missing: install assimp-testmodels";
    for (const char* spider : {"STL/Spider_ascii.stl", "STL/Spider_binary.stl"}) {
        const LoadedMesh m = load_mesh(dir + spider);
        EXPECT_EQ(m.report.collapsed_faces, 56u) << spider;
        EXPECT_EQ(m.mesh->n_faces(), 1312) << spider;
    }
    const LoadedMesh wuson = load_mesh(dir + "PLY/Wuson.ply");
    EXPECT_EQ(wuson.report.file_polygons, 3732u);
    try {
        load_mesh(dir + "OBJ/box_UTF16BE.obj");
        ADD_FAILURE() << "UTF-16 text was read";
    } catch (const MeshError& e) {
        EXPECT_NE(std::string(e.what()).find("UTF-16"), std::string::npos) << e.what();
    }
}

// libcgal-demo's degtri_sliding: a disk of 8 triangles, 7 of them flat along one line (corners
// inside opposite edges). Flips make a disk of 8 proper triangles of it.
TEST(MeshLoader, CgalDegenerateSlidingMeshIsRepaired) {
    const LoadedMesh m = load_mesh(test::corpus("degtri_sliding.off"));
    EXPECT_EQ(m.report.flipped_edges, 7u);
    EXPECT_EQ(m.report.collapsed_edges, 0u);
    const kernels::Topology t = kernels::compute_topology(*m.mesh);
    EXPECT_EQ(t.faces, 8);
    EXPECT_EQ(t.boundary_loops, 1);
    EXPECT_EQ(t.euler_characteristic, 1);
    EXPECT_GT(smallest_relative_area(*m.mesh), 1e-3);
}

// A vertex whose faces form several fans gets one vertex per fan at its position: the fan with
// the smallest corner keeps the id, the others get new ones after the file's vertices.
TEST(MeshLoader, PinchedVerticesAreSplitIntoFans) {
    const auto check = [](const PolygonSoup& soup, std::size_t split, Index vertices, Index components,
                          Index boundary_loops, Index euler) {
        const LoadedMesh m = mesh_from_soup(soup);
        EXPECT_EQ(m.report.split_vertices, split);
        const kernels::Topology t = kernels::compute_topology(*m.mesh);
        EXPECT_EQ(t.vertices, vertices);
        EXPECT_EQ(t.components, components);
        EXPECT_EQ(t.boundary_loops, boundary_loops);
        EXPECT_EQ(t.euler_characteristic, euler);
        for (Index v = static_cast<Index>(soup.n_vertices()); v < m.mesh->n_vertices(); ++v)
            EXPECT_EQ(m.mesh->V.row(v), m.mesh->V.row(0));  // every pinch here is at vertex 0
    };
    {
        SCOPED_TRACE("bow tie");
        check(bow_tie(), 1, 6, 2, 2, 2);
    }
    {
        SCOPED_TRACE("two octahedra sharing a vertex");
        check(octahedra_sharing_a_vertex(), 1, 12, 2, 0, 4);
    }
    {
        // An octahedron without two faces that touch only at its vertex 4: the two holes make one
        // boundary loop through the two copies of vertex 4, a disk.
        SCOPED_TRACE("holes touching at a corner");
        PolygonSoup holes = soup_of({1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1},
                                    {{2, 1, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}});
        const LoadedMesh m = mesh_from_soup(holes);
        EXPECT_EQ(m.report.split_vertices, 1u);
        const kernels::Topology t = kernels::compute_topology(*m.mesh);
        EXPECT_EQ(t.vertices, 7);
        EXPECT_EQ(t.boundary_loops, 1);
        EXPECT_EQ(t.euler_characteristic, 1);
        EXPECT_EQ(m.mesh->V.row(6), m.mesh->V.row(4));
    }
    // A manifold mesh is left as it is.
    EXPECT_EQ(mesh_from_soup(octahedron()).report.split_vertices, 0u);
}

// Faces beyond two on an edge are paired off two by two, each pair its own edge: two tetrahedra
// on one edge come apart into two closed ones, a fin's third triangle is detached.
TEST(MeshLoader, NonManifoldEdgesAreSplit) {
    const PolygonSoup tetrahedra = soup_of({0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, 0.3, 1, 0.5, -1, 0, 0.5, -0.3, -1},
                                           {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3},
                                            {0, 4, 1}, {0, 1, 5}, {1, 4, 5}, {4, 0, 5}});
    const LoadedMesh two = mesh_from_soup(tetrahedra);
    const kernels::Topology t = kernels::compute_topology(*two.mesh);
    EXPECT_EQ(two.report.split_edges, 1u);
    EXPECT_EQ(two.report.split_vertices, 2u);
    EXPECT_EQ(t.components, 2);
    EXPECT_EQ(t.boundary_loops, 0);
    EXPECT_EQ(t.euler_characteristic, 4);
    EXPECT_EQ(t.vertices, 8);
    // A fin on the octahedron's equator edge: the octahedron stays closed, the fin hangs apart.
    PolygonSoup finned = octahedron();
    finned.positions.insert(finned.positions.end(), {2, 2, 0});
    finned.indices.insert(finned.indices.end(), {0, 2, 6});
    finned.offsets.push_back(finned.indices.size());
    const LoadedMesh fin = mesh_from_soup(finned);
    const kernels::Topology f = kernels::compute_topology(*fin.mesh);
    EXPECT_EQ(fin.report.split_edges, 1u);
    EXPECT_EQ(f.components, 2);
    EXPECT_EQ(f.per_component[0].genus, 0);
    EXPECT_EQ(f.per_component[0].boundary_loops, 0) << "the octahedron keeps its first two faces on the edge";
    EXPECT_EQ(f.per_component[1].faces, 1);
}

// A file whose faces do not share their vertices along seams (here: every triangle its own three
// corners, a soup) is the surface it shows: seams are zipped unless kept.
TEST(MeshLoader, SeamsAreZippedUnlessKept) {
    const MeshView pretzel = shapes::genus_surface(2, 12);
    PolygonSoup soup;
    for (Index f = 0; f < pretzel.n_faces(); ++f) {
        for (int k = 0; k < 3; ++k) {
            for (int d = 0; d < 3; ++d) soup.positions.push_back(pretzel.V(pretzel.F(f, k), d));
            soup.indices.push_back(3 * f + k);
        }
        soup.offsets.push_back(soup.indices.size());
    }
    const LoadedMesh zipped = mesh_from_soup(soup);
    const kernels::Topology t = kernels::compute_topology(*zipped.mesh), expected = kernels::compute_topology(pretzel);
    EXPECT_EQ(t.genus, 2);
    EXPECT_EQ(t.boundary_loops, 0);
    EXPECT_EQ(std::tie(t.vertices, t.edges, t.faces), std::tie(expected.vertices, expected.edges, expected.faces));
    EXPECT_EQ(zipped.report.zipped_edges, static_cast<std::size_t>(expected.edges));
    EXPECT_EQ(zipped.report.zipped_vertices, static_cast<std::size_t>(3 * pretzel.n_faces() - pretzel.n_vertices()));
    EXPECT_EQ(zipped.report.unreferenced_vertices, 0u);
    LoadOptions keep;
    keep.seams = SeamPolicy::Keep;
    EXPECT_EQ(kernels::compute_topology(*mesh_from_soup(soup, keep).mesh).components, pretzel.n_faces());

    // Three sheets on one spine (positions 0 and 1): which two belong together is not known, so
    // none is zipped; two triangles whose common positions run the same way are zipped, one of
    // them turned over.
    const PolygonSoup book = soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1},
                                     {{0, 1, 2}, {4, 3, 5}, {6, 7, 8}});
    const LoadedMesh pages = mesh_from_soup(book);
    EXPECT_EQ(pages.report.zipped_edges, 0u);
    EXPECT_EQ(kernels::compute_topology(*pages.mesh).components, 3);
    const PolygonSoup same_way = soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -1, 0}, {{0, 1, 2}, {3, 4, 5}});
    const LoadedMesh turned = mesh_from_soup(same_way);
    EXPECT_EQ(turned.report.zipped_edges, 1u);
    EXPECT_EQ(turned.report.reoriented_faces, 1u);
    const PolygonSoup opposite = soup_of({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -1, 0}, {{0, 1, 2}, {4, 3, 5}});
    const LoadedMesh joined = mesh_from_soup(opposite);
    EXPECT_EQ(joined.report.zipped_edges, 1u);
    EXPECT_EQ(kernels::compute_topology(*joined.mesh).vertices, 4);
}

// A soup whose faces are not all wound alike is zipped whichever way its seams run and then
// oriented; one that would become non-orientable (a Moebius band) keeps the seams that do.
TEST(MeshLoader, SeamsOfInconsistentlyWoundSoupsAreZipped) {
    const PolygonSoup octa = octahedron();
    PolygonSoup soup;
    for (std::size_t f = 0; f < octa.n_polygons(); ++f) {
        std::int64_t corner[3] = {octa.indices[3 * f], octa.indices[3 * f + 1], octa.indices[3 * f + 2]};
        if (f % 3 == 1) std::swap(corner[1], corner[2]);  // every third face turned over
        for (const std::int64_t v : corner) {
            for (int d = 0; d < 3; ++d) soup.positions.push_back(octa.positions[3 * v + d]);
            soup.indices.push_back(static_cast<std::int64_t>(soup.indices.size()));
        }
        soup.offsets.push_back(soup.indices.size());
    }
    const LoadedMesh closed = mesh_from_soup(soup);
    const kernels::Topology t = kernels::compute_topology(*closed.mesh);
    EXPECT_EQ(std::tie(t.vertices, t.edges, t.faces, t.boundary_loops), std::make_tuple(6, 12, 8, 0));
    EXPECT_EQ(closed.report.zipped_edges, 12u);
    EXPECT_GT(closed.report.reoriented_faces, 0u);

    // A band of 5 quads with a half twist, each quad its own four corners.
    std::vector<double> p;
    std::vector<std::vector<std::int64_t>> quads;
    const auto corner_at = [](int i, double side) {
        const double angle = 2 * M_PI * i / 5, r = 1 + side * std::cos(angle / 2);
        return std::array<double, 3>{r * std::cos(angle), r * std::sin(angle), side * std::sin(angle / 2)};
    };
    for (int i = 0; i < 5; ++i) {
        const double far = i == 4 ? -1 : 1;  // the half twist
        for (const auto& c : {corner_at(i, -0.3), corner_at(i + 1, -0.3 * far), corner_at(i + 1, 0.3 * far),
                              corner_at(i, 0.3)})
            p.insert(p.end(), c.begin(), c.end());
        quads.push_back({4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3});
    }
    const LoadedMesh band = mesh_from_soup(soup_of(p, quads));
    const kernels::Topology b = kernels::compute_topology(*band.mesh);
    EXPECT_EQ(band.report.zipped_edges, 4u) << "the seam across the twist stays open";
    EXPECT_EQ(b.components, 1);
    EXPECT_EQ(b.euler_characteristic, 1) << "a strip";
}

// Real files with seams: CGAL's stitching data, and boeing, whose 122 separately meshed and
// inconsistently wound patches close into one surface.
TEST(MeshLoader, CorpusSeamsAreZipped) {
    const auto topology = [](const std::string& name, SeamPolicy seams) {
        LoadOptions options;
        options.seams = seams;
        return kernels::compute_topology(*load_mesh(test::corpus(name + ".off"), options).mesh);
    };
    const kernels::Topology boeing = topology("boeing", SeamPolicy::Zip);
    EXPECT_EQ(std::make_tuple(boeing.components, boeing.boundary_loops, boeing.genus), std::make_tuple(1, 0, 10));
    EXPECT_EQ(topology("boeing", SeamPolicy::Keep).components, 122);
    const kernels::Topology shuffled = topology("oblong-shuffled", SeamPolicy::Zip), oblong = topology("oblong", SeamPolicy::Keep);
    EXPECT_EQ(std::tie(shuffled.vertices, shuffled.edges, shuffled.boundary_loops),
              std::tie(oblong.vertices, oblong.edges, oblong.boundary_loops));
    EXPECT_EQ(topology("quads_to_stitch", SeamPolicy::Zip).components, 1);
    EXPECT_EQ(topology("quads_to_stitch", SeamPolicy::Keep).components, 2);
}

TEST(MeshLoader, MoebiusBandIsNonOrientable) {
    // A band of 5 quads (10 triangles) with a half twist.
    const int n = 5;
    std::vector<double> p;
    for (int i = 0; i < n; ++i) {
        const double t = 2 * M_PI * i / n, c = std::cos(t), s = std::sin(t), w = std::cos(t / 2),
                     h = std::sin(t / 2);
        for (double side : {-0.3, 0.3}) {
            const double r = 1 + side * w;
            p.insert(p.end(), {r * c, r * s, side * h});
        }
    }
    std::vector<std::vector<std::int64_t>> quads;
    for (int i = 0; i < n; ++i) {
        const std::int64_t a = 2 * i, b = 2 * i + 1;
        std::int64_t c = 2 * ((i + 1) % n), d = c + 1;
        if (i == n - 1) std::swap(c, d);  // the half twist
        quads.push_back({a, c, d, b});
    }
    EXPECT_EQ(kind_of(soup_of(p, quads)), MeshErrorKind::NonOrientable);
}

TEST(MeshLoader, SharedMoebiusFileIsRefused) {
    const std::string path = test::shared_mesh("moebius.obj");
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared/meshes not present";
    try {
        load_mesh(path);
        FAIL() << "moebius.obj loaded";
    } catch (const MeshError& e) {
        EXPECT_EQ(e.kind, MeshErrorKind::NonOrientable) << e.what();
    }
}

TEST(MeshLoader, ErrorKindsHaveDistinctNamesAndExitStatuses) {
    std::set<std::string> names;
    std::set<int> statuses;
    for (int k = 0; k <= static_cast<int>(MeshErrorKind::CoordinateRange); ++k) {
        names.insert(to_string(static_cast<MeshErrorKind>(k)));
        statuses.insert(exit_status(static_cast<MeshErrorKind>(k)));
    }
    EXPECT_EQ(names.size(), static_cast<std::size_t>(MeshErrorKind::CoordinateRange) + 1);
    EXPECT_EQ(statuses.size(), names.size());
    EXPECT_EQ(statuses.count(0), 0u);
}

}  // namespace
}  // namespace holoflow::engine
