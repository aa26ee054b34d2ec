#pragma once

#include <array>
#include <complex>
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

//! The mesh with each cluster's star re-triangulated as a fan around one vertex at the zero.
struct RegularisedForm {
    MeshView mesh;
    Eigen::VectorXcd tau;               //!< #E of `mesh`
    std::vector<Index> original_vertex;  //!< per vertex: input vertex, -1 for inserted zero points
    std::vector<Index> original_face;    //!< per face: input face, -1 for fan faces
    std::vector<Index> region_vertex;    //!< per region: its fan centre in `mesh`, -1 if failed
    Index removed_vertices = 0;          //!< input vertices inside fans (replaced by the centre)
    Index failed_regions = 0;            //!< left as they were (counted, their flips remain)
};

//! \brief Replaces each region's star (the faces touching its vertices, grown by up to three
//! rings when needed) by a fan from one centre: the zero's point (face zeros; a new vertex), the
//! zero's vertex, or for a region touching the mesh boundary its boundary vertex nearest the
//! zero. The fan is kept only if every fan triangle's image (the form developed over the star)
//! is counter-clockwise and its 3D triangle non-degenerate; then the centre winds exactly
//! order + 1 times and no flipped image triangle remains there, so trajectories can leave a
//! zero from a vertex. The form on fan edges is the developed image difference (closed).
//! Regions whose stars overlap an earlier region's are left alone (failed). Deterministic.
//! \pre tau closed, #E values; regions' vertices valid.  \throw InvalidInput.
RegularisedForm regularise_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                 std::span<const ZeroRegion> regions);

}  // namespace holoflow::kernels
