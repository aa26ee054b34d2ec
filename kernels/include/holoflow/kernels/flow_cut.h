#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/mesh_view.h"
#include "holoflow/kernels/trajectories.h"

namespace holoflow::kernels {

//! Label of an edge that is no patch border.
constexpr Index kNoBorder = -1;

//! A mesh refined so that traced trajectories run along its edges.
struct CutMesh {
    MeshView mesh;
    Eigen::VectorXcd tau;                 //!< the form on the new edges (closed)
    std::vector<Index> original_face;     //!< per face: the face of the traced mesh it lies in
    std::vector<Index> original_vertex;   //!< per vertex: traced-mesh vertex, -1 if inserted
    //! Per edge: the trajectory running along it, the label it inherits from `edge_label`, or
    //! kNoBorder.
    std::vector<Index> edge_trajectory;
    //! Segments that could not be inserted (reported); the collision point of one that ends
    //! nowhere is no vertex.
    Index skipped_segments = 0;
};

//! \brief Splits every face crossed by the trajectories: crossing points become vertices on the
//! edges (shared by both faces), collision points vertices inside faces, and each face is cut
//! along its segments (purely combinatorially: a segment splits the one sub-polygon that has
//! both its end points, with the collision points of later curves on it in arrival order; where
//! segments stop on each other in a cycle, a pinwheel, the face's pieces are instead those of
//! the plane graph its border and segments make in its image chart) and the pieces triangulated
//! by ear clipping in that chart. Faces in parallel.
//! `edge_label` (empty, or one per edge of `mesh`, kNoBorder for none) marks further borders,
//! e.g. a homology cut graph (labels other than trajectory ids); sub-edges inherit it.
//! \pre trajectories traced on `mesh` with `tau` (trace_trajectories).  \throw InvalidInput.
CutMesh cut_along_trajectories(const MeshView& mesh, const Eigen::VectorXcd& tau,
                               std::span<const Trajectory> trajectories,
                               std::span<const Index> edge_label = {});

}  // namespace holoflow::kernels
