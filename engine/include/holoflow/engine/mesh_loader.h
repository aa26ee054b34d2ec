#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "holoflow/engine/mesh_reader.h"
#include "holoflow/kernels/mesh_view.h"

namespace holoflow::engine {

enum class ComponentPolicy { All, Largest };

//! A vertex whose faces form several fans (two holes touching at a corner, surfaces meeting at a
//! point): one vertex per fan, at the same position, or a non_manifold_vertex refusal.
enum class PinchedVertexPolicy { Split, Refuse };

//! A triangle whose corners are collinear or coincide: repaired where an edge collapse (two
//! corners at one place) or an edge flip (a corner on the opposite edge) removes it without
//! changing the surface's topology, or a zero_area_face refusal.
enum class ZeroAreaPolicy { Repair, Refuse };

//! A triangle on the same three vertices as an earlier one, in either winding (an STL with a
//! body written twice, a sheet exported two-sided): dropped, or a duplicate_face refusal.
enum class DuplicateFacePolicy { Drop, Refuse };

//! Two boundary edges on the same two positions, running opposite ways (a triangle soup, vertices
//! duplicated along texture seams or CAD patch borders): zipped into one edge, or kept as two
//! boundaries.
enum class SeamPolicy { Zip, Keep };

//! An edge shared by more than two faces (a fin, sheets meeting along a line): the first face
//! keeps one partner there and the others are detached (their ends split like pinched vertices),
//! or a non_manifold_edge refusal.
enum class NonManifoldEdgePolicy { Split, Refuse };

struct LoadOptions {
    ComponentPolicy components = ComponentPolicy::All;
    std::size_t max_faces = 0;  //!< 0: no limit beyond 32-bit indices
    std::uint64_t max_file_bytes = 0;  //!< a larger file is refused unread (the memory limit; 0: none)
    PinchedVertexPolicy pinched_vertices = PinchedVertexPolicy::Split;
    ZeroAreaPolicy zero_area_faces = ZeroAreaPolicy::Repair;
    DuplicateFacePolicy duplicate_faces = DuplicateFacePolicy::Drop;
    SeamPolicy seams = SeamPolicy::Zip;
    NonManifoldEdgePolicy non_manifold_edges = NonManifoldEdgePolicy::Split;
};

//! What the loader changed on the way from file to MeshView (all counts; 0 when untouched).
struct LoadReport {
    std::size_t file_vertices = 0;
    std::size_t file_polygons = 0;
    std::size_t triangulated_polygons = 0;  //!< polygons with more than three corners
    std::size_t triangles_from_polygons = 0;
    std::size_t reoriented_faces = 0;       //!< faces flipped to make the winding consistent
    std::size_t unreferenced_vertices = 0;  //!< dropped
    std::size_t welded_vertices = 0;        //!< STL corners merged by position
    std::size_t ignored_lines = 0;          //!< OFF lines after the faces its header announces, not read
    std::size_t split_vertices = 0;         //!< vertices added by splitting pinched vertices into fans
    std::size_t collapsed_edges = 0;        //!< zero-area repair: edges whose two ends coincide, merged
    std::size_t collapsed_faces = 0;        //!< the faces on those edges, gone with them, and faces
                                            //!< left with under 3 corners by dropping a repeat in a row
    std::size_t flipped_edges = 0;          //!< zero-area repair: edges with a corner on them, flipped
    std::size_t duplicate_faces = 0;        //!< on the vertices of an earlier face, dropped
    std::size_t split_edges = 0;            //!< non-manifold edges whose extra faces were detached
    std::size_t zipped_edges = 0;           //!< boundary edge pairs at the same positions, joined
    std::size_t zipped_vertices = 0;        //!< their ends merged into another vertex
    std::size_t components = 0;             //!< in the file
    std::size_t dropped_components = 0;     //!< with ComponentPolicy::Largest
    std::size_t dropped_faces = 0;          //!< faces of the dropped components
};

struct LoadedMesh {
    std::shared_ptr<const MeshView> mesh;
    LoadReport report;
    //! Per vertex of `mesh`: the file's vertex it comes from (vertex ids move as unreferenced
    //! vertices are dropped and seams or collapsed edges merge vertices; a split pinched vertex's
    //! copies share its id). What a user names by vertex id (--tips) is a file id.
    std::vector<Index> file_vertex;
};

//! The loaded mesh's vertices for tips given as vertex ids of the file (--tips; a split pinched
//! vertex: its first copy). \throw InvalidInput naming an id that is no vertex of the file, or one the loader
//! dropped (no face uses it) or merged into another.
std::vector<Index> tip_vertices(const LoadedMesh& loaded, const std::vector<Index>& file_ids);

//! Reads, validates and repairs (see README "Input checks"). \throw MeshError.
LoadedMesh load_mesh(const std::string& path, const LoadOptions& options = {});

//! The validation and repair part alone, for soups made in memory. \throw MeshError.
LoadedMesh mesh_from_soup(const PolygonSoup& soup, const LoadOptions& options = {});

}  // namespace holoflow::engine
