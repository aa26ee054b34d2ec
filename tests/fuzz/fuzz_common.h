#pragma once

// Shared body of the reader fuzzers: bytes -> polygon soup -> validated MeshView -> topology.
// A MeshError on the way is the expected outcome for most inputs; any other exception escapes
// (libFuzzer reports it as a crash), and a broken invariant aborts with a message.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/mesh_reader.h"
#include "holoflow/kernels/topology.h"

#define HOLOFLOW_FUZZ_CHECK(cond)                                                          \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            std::fprintf(stderr, "fuzz invariant failed: %s (%s:%d)\n", #cond, __FILE__, \
                         __LINE__);                                                        \
            std::abort();                                                                  \
        }                                                                                  \
    } while (0)

namespace holoflow::fuzz {

//! Structure every soup a reader returns must have, whatever the bytes were.
inline void check_soup(const engine::PolygonSoup& soup) {
    HOLOFLOW_FUZZ_CHECK(soup.positions.size() % 3 == 0);
    HOLOFLOW_FUZZ_CHECK(!soup.offsets.empty() && soup.offsets.front() == 0);
    HOLOFLOW_FUZZ_CHECK(soup.offsets.back() == soup.indices.size());
    for (std::size_t p = 0; p < soup.n_polygons(); ++p)
        HOLOFLOW_FUZZ_CHECK(soup.offsets[p] <= soup.offsets[p + 1]);
}

//! What a loaded mesh and its topology must satisfy: counts agree, chi = V - E + F per
//! component and in total, every boundary halfedge lies on exactly one boundary cycle.
inline void check_topology(const MeshView& mesh, const kernels::Topology& t) {
    HOLOFLOW_FUZZ_CHECK(t.vertices == mesh.n_vertices() && t.edges == mesh.n_edges() &&
                        t.faces == mesh.n_faces());
    HOLOFLOW_FUZZ_CHECK(mesh.V.allFinite());
    HOLOFLOW_FUZZ_CHECK(t.euler_characteristic == t.vertices - t.edges + t.faces);
    HOLOFLOW_FUZZ_CHECK(static_cast<int>(t.per_component.size()) == t.components);
    Index v = 0, e = 0, f = 0;
    int loops = 0, genus = 0;
    for (const kernels::ComponentTopology& c : t.per_component) {
        HOLOFLOW_FUZZ_CHECK(c.faces > 0 && c.genus >= 0);
        HOLOFLOW_FUZZ_CHECK(c.euler_characteristic == 2 - 2 * c.genus - c.boundary_loops);
        v += c.vertices, e += c.edges, f += c.faces, loops += c.boundary_loops, genus += c.genus;
    }
    HOLOFLOW_FUZZ_CHECK(v == t.vertices && e == t.edges && f == t.faces);
    HOLOFLOW_FUZZ_CHECK(loops == t.boundary_loops && genus == t.genus);
    std::size_t boundary_halfedges = 0;
    for (Index h = 0; h < mesh.n_halfedges(); ++h) boundary_halfedges += mesh.is_boundary_halfedge(h);
    std::size_t cycle_length = 0;
    for (const auto& cycle : t.boundary_cycles) {
        HOLOFLOW_FUZZ_CHECK(cycle.size() >= 3);
        cycle_length += cycle.size();
    }
    HOLOFLOW_FUZZ_CHECK(cycle_length == boundary_halfedges);
    HOLOFLOW_FUZZ_CHECK(2 * static_cast<std::size_t>(t.edges) ==
                        3 * static_cast<std::size_t>(t.faces) + boundary_halfedges);
}

//! Loads with the given policies; false when the loader refuses the soup (a MeshError).
inline bool load(const engine::PolygonSoup& soup, engine::ComponentPolicy policy, engine::LoadedMesh& out,
                 engine::PinchedVertexPolicy pinched = engine::PinchedVertexPolicy::Split) {
    try {
        engine::LoadOptions options;
        options.components = policy;
        options.pinched_vertices = pinched;
        out = engine::mesh_from_soup(soup, options);
        return true;
    } catch (const engine::MeshError&) {
        return false;
    }
}

//! The whole reader path on fuzzer bytes.
inline int read_load_topology(const std::uint8_t* data, std::size_t size, engine::MeshFormat format) {
    engine::PolygonSoup soup;
    try {
        soup = engine::parse_polygon_soup(reinterpret_cast<const char*>(data), size, format);
    } catch (const engine::MeshError&) {
        return 0;
    }
    check_soup(soup);

    engine::LoadedMesh all;
    if (!load(soup, engine::ComponentPolicy::All, all)) return 0;
    const MeshView& mesh = *all.mesh;
    const engine::LoadReport& r = all.report;
    HOLOFLOW_FUZZ_CHECK(r.file_vertices == soup.n_vertices() && r.file_polygons == soup.n_polygons());
    HOLOFLOW_FUZZ_CHECK(r.unreferenced_vertices + r.collapsed_edges + r.zipped_vertices +
                            static_cast<std::size_t>(mesh.n_vertices()) ==
                        soup.n_vertices() + r.split_vertices);
    {   // Refusing pinched vertices refuses exactly the soups that needed a split.
        engine::LoadedMesh strict;
        HOLOFLOW_FUZZ_CHECK(load(soup, engine::ComponentPolicy::All, strict, engine::PinchedVertexPolicy::Refuse) ==
                            (r.split_vertices == 0));
    }
    HOLOFLOW_FUZZ_CHECK(soup.n_polygons() - r.triangulated_polygons + r.triangles_from_polygons - r.duplicate_faces -
                            r.collapsed_faces ==
                        static_cast<std::size_t>(mesh.n_faces()));
    // A loaded mesh is a valid surface: topology must not throw.
    const kernels::Topology t = kernels::compute_topology(mesh);
    check_topology(mesh, t);
    HOLOFLOW_FUZZ_CHECK(static_cast<std::size_t>(t.components) == r.components);

    if (t.components > 1) {
        engine::LoadedMesh largest;
        HOLOFLOW_FUZZ_CHECK(load(soup, engine::ComponentPolicy::Largest, largest));
        const kernels::Topology tl = kernels::compute_topology(*largest.mesh);
        check_topology(*largest.mesh, tl);
        HOLOFLOW_FUZZ_CHECK(tl.components == 1);
        HOLOFLOW_FUZZ_CHECK(largest.report.dropped_components + 1 == r.components);
        HOLOFLOW_FUZZ_CHECK(static_cast<std::size_t>(tl.faces) + largest.report.dropped_faces ==
                            static_cast<std::size_t>(t.faces));
    }
    return 0;
}

}  // namespace holoflow::fuzz
