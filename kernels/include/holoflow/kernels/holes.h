#pragma once

#include <array>
#include <span>
#include <vector>

#include "holoflow/kernels/mesh_view.h"
#include "holoflow/kernels/topology.h"

//! Filling small holes (boundary loops) of a mesh with triangles. Every boundary loop of an open
//! surface adds a handle to its double cover (working genus 2g + b - 1) and the conformal stage
//! holds 2 forms per handle, dense over the edges: a scan with thousands of pinholes would need
//! thousands of forms (tens of GiB at 100k faces) and carries two zeros on each pinhole, which
//! a loop of 3 edges cannot resolve. Filling some loops keeps the genus and lowers b.
namespace holoflow::kernels {

struct HoleFillOptions {
    //! Every boundary loop of at most this many edges is filled (0: none by this rule).
    Index max_loop_edges = 0;
    //! Then, per component, while its working genus (2g + b - 1 with boundary, g closed) is over
    //! this, the shortest loop left is filled (fewest edges, then shortest perimeter, then
    //! smallest vertex id), never its longest loop (a pizza's rim, a scan's outer border: the
    //! cap is for pinholes); 0: no cap.
    int max_working_genus = 0;
    //! Loops longer than this are never filled (their triangulation costs O(n^3)).
    Index longest_fillable_loop = 256;
};

//! Triangles closing one hole: `loop` is a boundary cycle as Topology lists it (along the
//! boundary halfedges), the triangles run the other way round, so that they join the mesh with
//! consistent orientation. Of all triangulations without inner vertices and without an edge
//! the mesh already has between two loop vertices, the one whose worst triangle is best shaped
//! (quality 4 sqrt(3) area / sum of squared edge lengths; ties: the larger sum of qualities).
//! Empty where every such triangulation has a triangle of quality below `min_quality` or a
//! repeated edge. O(n^3) for n loop vertices.
std::vector<std::array<Index, 3>> triangulate_hole(const MeshView& mesh, std::span<const Index> loop,
                                                   double min_quality = 1e-6);

//! The loops (indices into topology.boundary_cycles) that `options` fills. A component of genus 0
//! keeps at least one loop (a disk is sliced at its tips instead; closing an island of a
//! triangle or two would leave a degenerate sphere).
std::vector<Index> holes_to_fill(const MeshView& mesh, const Topology& topology, const HoleFillOptions& options);

//! Of `loops` (indices into topology.boundary_cycles), those that may close without changing
//! which surface is segmented: never a component's longest loop (nor, on genus 0, its second
//! longest, so that it stays an annulus at least), none of more than `longest_fillable_loop`
//! edges. Sorted.
std::vector<Index> fillable_holes(const MeshView& mesh, const Topology& topology, std::span<const Index> loops,
                                  Index longest_fillable_loop = HoleFillOptions{}.longest_fillable_loop);

struct FilledHoles {
    MeshView mesh;                  //!< the input's vertices; its faces first, then the fill triangles
    Index holes = 0;                //!< loops filled
    Index faces = 0;                //!< triangles added
    Index left_open = 0;            //!< loops chosen but left open: no valid triangulation
};

//! The mesh with the loops `holes` (indices into topology.boundary_cycles) triangulated by
//! triangulate_hole. \pre topology of `mesh`.
FilledHoles fill_holes(const MeshView& mesh, const Topology& topology, std::span<const Index> holes);

}  // namespace holoflow::kernels
