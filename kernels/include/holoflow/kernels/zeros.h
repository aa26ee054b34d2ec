#pragma once

#include <array>
#include <complex>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Vertices with image winding != 1 and flipped image triangles that touch (share a vertex or
//! an edge between two such vertices), with their signed multiplicity (DESIGN 2.5).
struct ZeroCluster {
    int index = 0;                    //!< sum (w_v - 1) + flipped faces: the zero's order if > 0
    std::vector<Index> vertices;      //!< ascending
    std::vector<Index> flipped_faces; //!< ascending
};

//! A zero point of the form: at a vertex, or inside a face.
struct Zero {
    int order = 0;
    Index cluster = -1;  //!< in ZeroSet::clusters
    Index vertex = -1;   //!< the zero sits at this vertex, or
    Index face = -1;     //!< inside this face, at
    std::array<double, 3> barycentric{};  //!< weights of F(face, 0..2)
    //! Image of the zero minus the image of `vertex` (0) or of F(face, 0): where the integrated
    //! form takes its critical value, in any chart that contains the face.
    std::complex<double> image_offset{};
};

struct ZeroSet {
    std::vector<int> winding;      //!< #V: turns of the image one-ring around the vertex's image
    std::vector<int> face_flip;    //!< #F: 1 for a flipped image triangle, else 0
    std::vector<ZeroCluster> clusters;  //!< ordered by smallest vertex
    std::vector<Zero> zeros;            //!< clusters of positive index, in cluster order
    int total_index = 0;  //!< sum (w_v - 1) + flips = 2g - 2 exactly on a closed surface
    int total_order = 0;  //!< sum of zero orders (= total_index when no cluster is negative)
    //! Clusters of index <= 0 (flips or windings away from any zero: bad weights, slivers).
    Index artifact_clusters = 0;
    //! Negative clusters merged into their nearest positive one, so total_order = total_index.
    Index merged_negative_clusters = 0;
    Index nonpositive_winding_vertices = 0;  //!< w_v <= 0 anywhere
};

//! \brief Zero points of the closed complex 1-form `tau` (one value per edge, along
//! E(e,0) -> E(e,1)) on a closed mesh, by exact image-winding bookkeeping: each corner's image
//! angle is the principal angle between its two image edges, each face's three angles sum to
//! an odd multiple of pi (flipped when -pi), each vertex's to 2 pi w_v, so
//! sum (w_v - 1) + flips = 2g - 2 holds as an integer identity whatever the rounding. An image
//! edge of exactly zero length takes a fixed generic direction from its 3D vector instead
//! (symbolic perturbation). A cluster's position: the vertex of a lone winding-(k+1) vertex,
//! else the critical point of the quadratic through a flipped face's three images (inside the
//! face), else its best vertex. Deterministic; faces in parallel.
//! \pre closed mesh, tau has #E finite values.  \throw InvalidInput.
ZeroSet find_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau);

}  // namespace holoflow::kernels
