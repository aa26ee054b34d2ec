#pragma once

#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

enum class TrajectoryFamily : std::uint8_t { Vertical, Horizontal };  //!< iso-u, iso-v

//! Where a traced curve crosses halfedge h (leaving face(h) for face(twin h)): tail + t (head - tail).
struct EdgeCrossing {
    Index halfedge = kNoHalfedge;
    double t = 0;
    double length = 0;  //!< image length travelled up to here
};

struct Trajectory {
    enum class End : std::uint8_t {
        Zero,       //!< reached a zero vertex (its own start: a closed critical loop)
        Boundary,   //!< crossed a boundary edge, or reached a boundary vertex at its level
        Collision,  //!< hit an earlier trajectory (layout mode, motorcycle rule)
        LengthCap,  //!< stopped by the length cap: unfinished
    };
    Index start_vertex = -1;  //!< the zero it leaves from (a transversal: the vertex it starts at)
    Index first_face = -1;    //!< face of the first segment (around start_vertex)
    TrajectoryFamily family = TrajectoryFamily::Vertical;
    //! In order; segment j < crossings.size() lies in face(crossings[j].halfedge) and ends there.
    std::vector<EdgeCrossing> crossings;
    End end = End::LengthCap;
    //! Zero, or Boundary at a vertex: a last segment runs from the last crossing to this vertex.
    Index end_vertex = -1;
    //! Collision: a last segment runs to this point of its face (barycentric of F(face, 0..2)),
    //! on segment `blocker_segment` of trajectory `blocker`, which got there at image length
    //! `blocker_length` (its own arrival order along the blocker).
    std::array<double, 3> end_barycentric{};
    Index blocker = -1, blocker_segment = -1;
    double blocker_length = 0;
    double length = 0;  //!< image length travelled (|delta v| vertical, |delta u| horizontal)

    //! A last segment after the last crossing (ends at a vertex or a collision point).
    bool has_tail_segment() const { return end == End::Zero || end == End::Collision || end_vertex >= 0; }
    Index n_segments() const { return static_cast<Index>(crossings.size()) + (has_tail_segment() ? 1 : 0); }
    //! Face of segment j.
    Index segment_face(const MeshView& mesh, Index j) const;
};

struct TraceOptions {
    bool motorcycle = false;  //!< layout mode: a trajectory stops where it hits an earlier one
    //! Length cap in units of sqrt(total image area).
    double length_cap = 16;
    //! Every leaf of the traced families closes (the level's form has integer periods:
    //! engine FormChoice::IntegerPeriods, vertical family), so each critical curve ends at a
    //! zero or the boundary after crossing each face about once. No length cap then; a curve
    //! may cross 2 #F edges, all curves together 64 #F (instead of 16 #F), which only a curve
    //! lost in a fold the fans could not regularise reaches.
    bool closed_leaves = false;
};

//! \brief Critical trajectories of the closed form `tau` on a mesh without flipped image
//! triangles near the zeros (regularise_zeros): from each zero vertex, every direction where the
//! level u = u(zero) (vertical) or v = v(zero) (horizontal) leaves its one-ring. Traced face by
//! face with the level's offsets carried along edges (d(head) = d(tail) + Re/Im tau), a vertex
//! exactly at the level counting as above it (symbolic perturbation), so a curve never passes
//! through a vertex and every face has 0 or 2 crossing edges; a level that leaves along an
//! inner edge to a boundary vertex is that edge (a curve without crossings). Stops at zero vertices (within
//! 1e-9 of the local edge image), boundary edges, boundary vertices at the level, the length
//! cap (also: all curves share 16 #F crossings, 16 #F / #curves + 64 each; see
//! closed_leaves), or (motorcycle) an earlier trajectory: all curves advance in rounds of
//! doubling image length concurrently, collisions are resolved afterwards in order of the later arrival time
//! (ties by id), so the result does not depend on the thread count. A curve traced from both
//! of its zeros (a saddle connection, a closed critical loop) is kept once, whole: a second copy,
//! complete or stopped on the way, is dropped and curves it stopped stop on the kept one; two
//! copies that both ran into the cap and overlap are joined into the whole curve.
//! `families`: which families to trace. \throw InvalidInput on bad zero vertices.
std::vector<Trajectory> trace_trajectories(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                           std::span<const Index> zero_vertices,
                                           std::span<const TrajectoryFamily> families,
                                           const TraceOptions& options = {});

//! A transversal to trace: the curves of `family` through a regular `vertex`.
struct TransversalStart {
    Index vertex = -1;
    TrajectoryFamily family = TrajectoryFamily::Vertical;
};

//! \brief Transversals that cut patches open (a cylinder that no critical trajectory crosses):
//! from each start vertex, every direction of its family's level (two at a regular vertex),
//! traced as trace_trajectories does. Each stops at its first meeting with a curve of
//! `earlier` of the other family (Collision, with `blocker` an index into `earlier`), a zero,
//! or the boundary; the earlier curves are never stopped. A start with a curve that reaches
//! the length cap instead is left out whole (a cut ending nowhere opens nothing). Deterministic.
//! \pre `earlier` traced on `mesh` with `tau`.  \throw InvalidInput on bad vertices.
std::vector<Trajectory> trace_transversals(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                           std::span<const Index> zero_vertices,
                                           std::span<const TransversalStart> starts,
                                           std::span<const Trajectory> earlier, const TraceOptions& options = {});

}  // namespace holoflow::kernels
