#pragma once

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

}  // namespace holoflow::kernels
