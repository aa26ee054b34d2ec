#pragma once

#include <span>
#include <vector>

#include "holoflow/kernels/mesh_view.h"

//! Tips (extremities) of a closed genus-0 surface or a disk, and small holes sliced around them,
//! so that the surface gets b >= 2 boundary loops and a double cover of genus b - 1 (DESIGN 2.1).
namespace holoflow::kernels {

//! Shortest-path distances along mesh edges (Dijkstra on edge lengths) from the nearest of
//! `sources`; +infinity on vertices another component holds. An upper bound of the geodesic
//! distance on the polyhedral surface (edge paths zigzag, by a few percent on good meshes).
//! \pre sources non-empty, valid vertex ids.  \throw InvalidInput.
std::vector<double> edge_path_distances(const MeshView& mesh, std::span<const Index> sources);

struct TipOptions {
    int max_tips = 8;  //!< at most this many tips are kept, most prominent first
    int min_tips = 2;  //!< at least this many (a closed genus-0 surface needs 2, a disk 1)
    //! A tip rises at least `prominence * diameter` above the highest saddle that joins it to
    //! higher ground (topographic prominence of the measure, which is a length). The measure is
    //! 1-Lipschitz along edge paths, so a tip is then also the highest vertex within edge-path
    //! radius `prominence * diameter` of itself (its isolation is at least its prominence).
    //! 0.05 keeps the legs, horns and tail of the bull and the hands, feet and head of the man,
    //! and none of the ripples of a sphere (whose measure is constant up to sampling noise).
    double prominence = 0.05;
    int samples = 16;  //!< Dijkstra sources of the average geodesic distance (farthest points)
};

//! Per-vertex measure whose local maxima are the tips, with what find_tips derived from it.
struct TipMeasure {
    //! Closed mesh: average geodesic distance (Dijkstra from `sources`, each weighted by the
    //! area of its geodesic Voronoi cell). Mesh with boundary: distance to the boundary, so tips
    //! are the interior extremities, never on the border (a hole there would add no loop).
    std::vector<double> value;
    double diameter = 0;  //!< approximate geodesic diameter: the largest Dijkstra eccentricity
                          //!< seen (a double sweep from vertex 0, then every sample)
    std::vector<Index> sources;  //!< farthest point samples of the average (none with boundary)
};

//! Detected tips with their scores; tips[i] has prominence[i] and isolation[i] (edge-path
//! distance to the nearest higher vertex; 1 for the highest), both relative to the diameter.
//! Fallback tips have prominence 0 and, as isolation, their distance to the tips before them
//! and the boundary (1 for a first fallback tip, the highest vertex).
struct TipDetection {
    TipMeasure measure;
    std::vector<Index> tips;
    std::vector<double> prominence;
    std::vector<double> isolation;
    int fallback_tips = 0;  //!< how many of the tips came from farthest point sampling
};

//! The measure of find_tips: O(samples F log F).
//! \pre the mesh is connected.  \throw InvalidInput otherwise.
TipMeasure compute_tip_measure(const MeshView& mesh, const TipOptions& options = {});

//! Tips: local maxima of compute_tip_measure that pass the `prominence` test and lie two rings
//! from the boundary at least (a hole takes its tip's one-ring), ordered by
//! prominence (decreasing; ties by vertex id), at most max_tips. When fewer than min_tips pass
//! (a round blob), farthest point sampling from the tips found (or, when none passed, from the
//! highest vertex) and from the boundary completes them: on a sphere, two nearly antipodal
//! vertices. Deterministic.
//! \pre the mesh is connected, 1 <= min_tips <= max_tips, samples >= 1, prominence in [0, 1].
//! \throw InvalidInput otherwise.
TipDetection detect_tips(const MeshView& mesh, const TipOptions& options = {});

//! detect_tips(mesh, options).tips.
std::vector<Index> find_tips(const MeshView& mesh, const TipOptions& options = {});

//! \brief A tip for each limb whose map collapsed: per region of `collapsed` faces (joined
//! across edges) holding at least `min_share` of the mesh's area, its vertex farthest along edge
//! paths from both the faces that did not collapse and the boundary (holes sliced already are
//! boundary), among the vertices two rings from the boundary at least (a hole takes its tip's
//! one-ring); ties to the smaller id. Regions in order of their smallest face; one without such
//! a vertex gives none.
//! \pre collapsed has #F flags, min_share in [0, 1].  \throw InvalidInput.
std::vector<Index> collapsed_limb_tips(const MeshView& mesh, std::span<const char> collapsed, double min_share);

struct SlicedMesh {
    MeshView mesh;                       //!< open, same orientation, original vertex positions
    std::vector<Index> original_vertex;  //!< per vertex of `mesh` -> input vertex
    std::vector<Index> original_face;    //!< per face of `mesh` -> input face
    std::vector<Index> tips;             //!< input vertex ids actually sliced, in input order
    std::vector<std::vector<Index>> hole_faces;  //!< per sliced tip: the input faces removed
};

//! Removes a small disk around each tip: the faces reached from the tip's one-ring through
//! faces whose three corners are within Dijkstra distance hole_radius * R of the tip, with
//! R = sqrt(area / (4 pi)) (the radius of the sphere of equal area); the one-ring always goes.
//! Each hole is then cleaned into a topological disk whose border is a simple loop: pockets it
//! encloses (kept pieces no larger than the hole) join it. A border touching itself at a vertex
//! always encloses such a pocket on a genus-0 surface; on a handle it makes the hole a non-disk,
//! which is refused.
//! Tips are processed in the given order; a tip whose cleaned hole shares a vertex with an
//! earlier hole, or reaches the mesh boundary, is dropped (not merged), so the result has exactly
//! one new boundary loop per entry of its `tips`. Remaining faces and vertices keep the input
//! order; unreferenced vertices are dropped.
//! \pre the mesh is connected; tips are distinct, valid, interior vertices; hole_radius >= 0.
//! \throw InvalidInput on bad, duplicate or boundary tips, an empty tip list, a hole that cuts
//! the mesh in two (a kept piece larger than the hole) or wraps a handle, or when no tip is left
//! to slice or the result would be empty.
SlicedMesh slice_tips(const MeshView& mesh, std::span<const Index> tips, double hole_radius);

}  // namespace holoflow::kernels
