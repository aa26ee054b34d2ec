#pragma once

#include <optional>
#include <span>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Midpoint (1-to-4) subdivision keeping the geometry: every triangle splits into four, the
//! surface and the orientation stay the same.
//!
//! Layout of the result (this is the map back to the input): vertex v < #V is input vertex v,
//! vertex #V + e is the midpoint of input edge e (by edge index, so two edges on one vertex pair
//! get two midpoints); faces 4f .. 4f + 3 come from input face f: 4f + k is the corner triangle at
//! F(f, k), 4f + 3 the middle one. Counts: V' = V + E, E' = 2E + 3F, F' = 4F; boundary loops
//! double in length; genus and Euler characteristic are unchanged.
MeshView subdivide_midpoint(const MeshView& mesh);

//! \brief Longest-edge bisection keeping the geometry: while an edge is longer than
//! `max_length`, the longest one (ties by vertex ids) is split at its midpoint, and each
//! triangle on it into two through its opposite corner. Splitting the longest edge first
//! (Rivara) at most halves the smallest angle and cuts long thin triangles across, where the
//! 1-to-4 split copies their shape. With a `zone` (#V flags) only edges with both ends in it
//! split (their midpoints join it): the refinement stays where it is asked for, its
//! neighbours split once where they touch it.
//!
//! Layout: vertex v < #V is input vertex v, new vertices follow in split order; face f < #F
//! lies inside input face f, new faces follow. Genus, boundary loops and orientation are
//! unchanged. Deterministic. With `max_faces` > 0 it gives nothing where the result would have
//! more faces than that (a zone of tiny edges beside a long one would otherwise be refined down
//! to their length across its whole area): at once where a lower bound of the count says so
//! (the in-zone edges' halvings, the in-zone faces' areas over the largest triangle of sides
//! `max_length`), else as soon as the splits pass it.
//! \throw InvalidInput if max_length is not positive or zone is neither empty nor #V long.
std::optional<MeshView> bisect_long_edges(const MeshView& mesh, double max_length, std::span<const char> zone = {},
                                          Index max_faces = 0);

//! \brief Lawson's flips where they keep the geometry: an interior edge whose two triangles lie
//! in one plane (the far corner within `flatness` times the longest side of it) and form a
//! convex quadrilateral is flipped while its opposite angles add up to more than pi. Flat parts
//! end up Delaunay (the slivers of CAD meshes and of bisect_long_edges gone where the vertices
//! allow); curved parts stay as they are. Vertices and face count are kept, faces are rewritten
//! in place; no edge doubles another. Deterministic.
//! \throw InvalidInput if flatness is negative.
MeshView flip_flat_edges_to_delaunay(const MeshView& mesh, double flatness = 1e-10);

}  // namespace holoflow::kernels

namespace holoflow::kernels {

//! \brief Closed 1-forms of `mesh` (#E x k) carried exactly to subdivide_midpoint(mesh): every
//! input face is integrated to a local potential (0 at its first corner), midpoints get the
//! mean of their ends, and each new edge the difference. Closed forms stay closed and keep their
//! periods on every loop of input edges, so both meshes share one cohomology basis.
//! \throw InvalidInput if `forms` does not have one row per edge of `mesh` or `fine` is not
//! subdivide_midpoint(mesh).
Eigen::MatrixXd subdivide_forms_midpoint(const MeshView& mesh, const MeshView& fine,
                                         const Eigen::MatrixXd& forms);

}  // namespace holoflow::kernels

namespace holoflow::kernels {

//! \brief One step of Loop subdivision: the connectivity and layout of subdivide_midpoint (vertex
//! v < #V is input vertex v moved, #V + e the new vertex of input edge e, faces 4f .. 4f + 3
//! from face f), with Loop's smoothing rules. Edge vertex: 3/8 (a + b) + 1/8 (c + d) on interior
//! edges (c, d the opposite corners), the midpoint on boundary edges. Input vertex of valence n:
//! (1 - n beta) v + beta (sum of neighbours), Warren's beta = 3 / (8n) for n > 3 and 3/16 for
//! n = 3, inside; 3/4 v + 1/8 (its two boundary neighbours) on the boundary (the boundary curve
//! is a cubic B-spline). Every rule is an affine combination: affine maps commute with it.
//! \cite loop_1987 \cite warren_1995
MeshView subdivide_loop(const MeshView& mesh);

}  // namespace holoflow::kernels
