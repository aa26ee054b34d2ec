#pragma once

#include <array>
#include <complex>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! A cluster to regularise: its vertices and where its zero sits (as in ZeroSet).
struct ZeroRegion {
    int order = 0;                //!< > 0 for a zero, 0 for an artifact cluster
    std::vector<Index> vertices;  //!< cluster vertices (flipped faces' corners included)
    Index vertex = -1;            //!< zero at this vertex, or
    Index face = -1;              //!< inside this face at
    std::array<double, 3> barycentric{};
    std::complex<double> image_offset{};  //!< image minus image of F(face, 0) (face zeros)
};

struct FanOptions {
    //! A region that fails grows once more from only the cluster vertices where the image is not
    //! regular (a flip around, a winding other than 1): a cluster counts saddles of Re, which
    //! may lie where the image is regular, and next to small holes on several boundary loops,
    //! which a region touching the boundary along more than one arc cannot be re-triangulated
    //! around. What a region takes changes what the later ones find, so this can also fail more.
    bool regrow_failed = false;
    //! Flips no region holds become folds of their own, re-triangulated last, where the failed
    //! regions weigh less than this (RegularisedForm::failed_weight); elsewhere they stay
    //! flipped. Which regions fail is the same either way (a fold that takes in an accepted
    //! region places it at the fold's centre, and a failed region holds no faces to take in), so
    //! a caller that keeps a result only where less fails than in another (the pipeline's
    //! refinement tries) skips them where it will not keep it. On stretched meshes they are
    //! most of the work (kitten x30's bisected try: 37.8M of the 39.1M faces developed).
    Index leftover_folds_below_failed_weight = std::numeric_limits<Index>::max();
};

//! The mesh with each cluster's star re-triangulated as a fan around one vertex at the zero.
struct RegularisedForm {
    MeshView mesh;
    Eigen::VectorXcd tau;               //!< #E of `mesh`
    std::vector<Index> original_vertex;  //!< per vertex: input vertex, -1 for inserted zero points
    std::vector<Index> original_face;    //!< per face: input face, -1 for new or edge-flipped faces
    //! Per region: its centre in `mesh` (a fold re-triangulated without one: a vertex of its
    //! border), -1 if failed. Regions re-triangulated together share the centre.
    std::vector<Index> region_vertex;
    Index removed_vertices = 0;          //!< input vertices inside fans (replaced by the centre)
    Index failed_regions = 0;            //!< left as they were (counted, their flips remain)
    //! The failed regions weighed by what they leave unresolved: a zero's order (the zeros it
    //! stands for), 1 for a fold. Surfaces compare by it: a coarse mesh's zeros of order 6 and 4
    //! failing (10) are worse than 7 of the 8 simple and double zeros they split into on its
    //! midpoint subdivision failing (9), though fewer regions fail.
    Index failed_weight = 0;
    //! Regions re-triangulated within another one (a fold next to a zero joins the zero's).
    Index merged_regions = 0;
    Index flipped_faces = 0;             //!< flipped image triangles left in `mesh`
    Index edge_flips = 0;                //!< edges flipped before any region was re-triangulated
    //! Failed solves after which FanOptions::regrow_failed grows the region again (its cluster
    //! has a vertex where the image is regular). Where 0, a run with regrow_failed does exactly
    //! what this one did and gives this same result.
    Index regrowable_failures = 0;
};

//! \brief First flips every edge whose flip turns a flipped image triangle and its neighbour
//! into two counter-clockwise ones (no vertex lost; faces holding a zero's point stay). Then
//! re-triangulates a disk around each region (first the faces touching its vertices) in
//! the image of the form developed over it: its interior vertices go, its border stays, and
//! new triangles join the border to one centre (the zero's vertex or point, another interior
//! vertex or a face centroid nearest it; for a region touching the mesh boundary a boundary
//! vertex): a fan where the border is star-shaped around the centre, else sectors between
//! spokes, each a simple counter-clockwise polygon cut into ears. A fold (order 0) may instead
//! clip its whole border polygon. Kept only if every new image triangle is counter-clockwise,
//! every 3D triangle non-degenerate, the centre winds order + 1 times and every border vertex
//! once; then no flipped image triangle remains there and trajectories leave a zero from a
//! vertex. Otherwise the disk grows towards what broke (flips and windings != 1 at its
//! border, bad spokes), closing small holes, up to a step and size cap; a disk that goes around
//! a handle is cut open where its development disagrees. Zeros are placed first; a fold that
//! meets another region joins it; a zero that fails alone may then take in the other zeros of
//! its tangle (one centre winding sum of orders + 1 times); flips no region holds become folds
//! of their own. A region that is already regular keeps its faces. The form on new edges is
//! the developed image difference (closed). Deterministic.
//! \pre tau closed, #E values; regions' vertices valid.  \throw InvalidInput.
RegularisedForm regularise_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                 std::span<const ZeroRegion> regions, const FanOptions& options = {});

}  // namespace holoflow::kernels
