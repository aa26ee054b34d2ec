#pragma once

#include <vector>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Two copies of an open surface glued along its boundary: the closed orientable double.
//!
//! Layout: cover face f < #F is input face f; cover face #F + f is input face f reversed. Cover
//! vertex v < #V is input vertex v (copy 0, boundary vertices included); the interior vertices of
//! copy 1 follow in increasing input order. Positions of both copies are the input positions.
struct DoubleCover {
    MeshView mesh;                         //!< closed: copy 0 = input faces, copy 1 reversed
    std::vector<Index> vertex_involution;  //!< #V of cover: the orientation-reversing swap s
                                           //!< (fixes exactly the boundary vertices)
    std::vector<Index> face_involution;    //!< #F of cover: f <-> its mirror face
    std::vector<Index> original_vertex;    //!< #V of cover -> input vertex
    std::vector<Index> original_face;      //!< #F of cover -> input face
};

//! Closed double cover of an open mesh; genus 2g + b - 1 per connected input of genus g with b
//! boundary loops. The twin array is built directly, so interior edges joining two boundary
//! vertices (two cover edges on one vertex pair) are fine.
//! \pre the mesh has boundary.  \throw InvalidInput otherwise.
DoubleCover double_cover(const MeshView& open_mesh);

}  // namespace holoflow::kernels
