#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/errors.h"

namespace holoflow {

using Index = std::int32_t;  // meshes up to 2^31 - 1 halfedges

using PointMatrix = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using TriangleMatrix = Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor>;
using EdgeMatrix = Eigen::Matrix<Index, Eigen::Dynamic, 2, Eigen::RowMajor>;

constexpr Index kNoHalfedge = -1;

//! Connectivity that no MeshView can hold; `element` is the offending vertex (or an edge's
//! smaller vertex, with `other` its larger one).
struct ConnectivityError : InvalidInput {
    enum class Kind { NonManifoldEdge, InconsistentOrientation, NonManifoldVertex };
    ConnectivityError(Kind kind_, Index element_, Index other_, const std::string& message)
        : InvalidInput(message), kind(kind_), element(element_), other(other_) {}
    Kind kind;
    Index element;
    Index other;
};

//! Immutable, flat, read-only triangle mesh shared by all kernels.
//!
//! Halfedge `h = 3 f + k` runs from `F(f, k)` to `F(f, (k + 1) % 3)`; faces are consistently
//! oriented (counter-clockwise seen from outside). Edge `e` is oriented along its representative
//! halfedge `edge_halfedge[e]` (the smaller index of the pair), so `E(e, 0) -> E(e, 1)` is the
//! direction in which 1-forms on edges are measured. Two edges may join the same vertex pair (a
//! double cover glues such edges), so code goes by edge index, never by vertex pair.
struct MeshView {
    PointMatrix V;                       //!< #V x 3 positions
    TriangleMatrix F;                    //!< #F x 3 vertex indices
    EdgeMatrix E;                        //!< #E x 2, tail and head of edge_halfedge
    std::vector<Index> twin;             //!< #H, opposite halfedge or kNoHalfedge on the boundary
    std::vector<Index> halfedge_edge;    //!< #H, edge of each halfedge
    std::vector<Index> edge_halfedge;    //!< #E, representative halfedge
    std::vector<Index> vertex_halfedge;  //!< #V, an outgoing halfedge; the boundary one if any

    Index n_vertices() const { return static_cast<Index>(V.rows()); }
    Index n_faces() const { return static_cast<Index>(F.rows()); }
    Index n_edges() const { return static_cast<Index>(E.rows()); }
    Index n_halfedges() const { return 3 * n_faces(); }

    static Index face(Index h) { return h / 3; }
    static Index next(Index h) { return h - h % 3 + (h % 3 + 1) % 3; }
    static Index prev(Index h) { return h - h % 3 + (h % 3 + 2) % 3; }
    Index tail(Index h) const { return F(h / 3, h % 3); }
    Index head(Index h) const { return F(h / 3, (h % 3 + 1) % 3); }
    bool is_boundary_halfedge(Index h) const { return twin[h] == kNoHalfedge; }
    //! +1 if halfedge h points along its edge's orientation, -1 otherwise. The representative
    //! is the smaller halfedge of the pair: one load of twin, not two dependent ones.
    int edge_sign(Index h) const {
        const Index t = twin[h];
        return t == kNoHalfedge || h < t ? 1 : -1;
    }
    //! Next outgoing halfedge around tail(h), counter-clockwise; kNoHalfedge at the boundary.
    Index rotate(Index h) const { return twin[prev(h)]; }
    bool is_closed() const;
};

//! Halfedges of a triangle list grouped by their unordered vertex pair: group g is
//! `halfedges[group_start[g] .. group_start[g + 1])`. A counting sort on the smaller vertex,
//! then a sort inside each vertex's bucket: O(H log d) for valence d, never quadratic in d.
struct HalfedgeGroups {
    std::vector<Index> halfedges;
    std::vector<Index> group_start;
    Index n_groups() const { return static_cast<Index>(group_start.size()) - 1; }
};
HalfedgeGroups group_halfedges_by_vertex_pair(const TriangleMatrix& F, Index n_vertices);

//! Builds the connectivity from consistently oriented triangles whose edges each have one or two
//! faces traversing them in opposite directions and whose vertices are manifold.
//! \throw InvalidInput naming the first offending edge or vertex otherwise.
MeshView make_mesh_view(PointMatrix V, TriangleMatrix F);

//! Same with the halfedge pairing given: needed when two edges join one vertex pair (double
//! covers) or a face repeats a vertex (intrinsic triangulations after edge flips).
//! \throw InvalidInput if `twin` is not an involution pairing opposite halfedges.
MeshView make_mesh_view(PointMatrix V, TriangleMatrix F, std::vector<Index> twin);

// Edge flips on a triangle list and its pairing rewritten in place (kernels that flip as they
// go, then build one MeshView at the end).

//! \brief Flips the edge of interior halfedge h = a -> b, in face f = (a, b, c), its twin in
//! g = (b, a, d): f becomes (c, a, d) and g (d, b, c), so halfedge 3f is c -> a, 3f + 1 a -> d,
//! 3f + 2 d -> c, 3g d -> b, 3g + 1 b -> c, 3g + 2 c -> d; the outer four keep their twins.
//! \pre twin[h] is a halfedge of another face.
void flip_edge(TriangleMatrix& F, std::vector<Index>& twin, Index h);

//! An edge joins the tail of halfedge h0 to vertex w (around the tail both ways, up to the
//! boundary).
bool joins(const TriangleMatrix& F, const std::vector<Index>& twin, Index h0, Index w);

}  // namespace holoflow
