#pragma once

#include "holoflow/kernels/mesh_view.h"

//! Deterministic procedural meshes with known topology, for tests, benchmarks and examples.
//! All faces are oriented counter-clockwise seen from outside (closed shapes) or from +z (sheets).
namespace holoflow::shapes {

//! Torus of revolution around z: big radius R, tube radius r; nu vertices around the big circle,
//! nv around the tube. V = nu nv, E = 3 nu nv, F = 2 nu nv, genus 1.
//! \pre R > r > 0, nu >= 3, nv >= 3.  \throw InvalidInput.
MeshView torus(double R, double r, int nu, int nv);

//! Unit icosahedron split 1-to-4 `level` times, vertices projected to the unit sphere.
//! V = 10 4^level + 2, E = 30 4^level, F = 20 4^level, genus 0.
//! \pre 0 <= level <= 10.  \throw InvalidInput.
MeshView icosphere(int level);

//! Unit square [0,1]^2 in z = 0 split into nx by ny cells, two triangles each (an open disk).
//! V = (nx+1)(ny+1), F = 2 nx ny, one boundary loop of 2(nx+ny) vertices. When nx, ny >= 2 no
//! triangle has three boundary vertices and no interior edge joins two boundary vertices.
//! \pre nx, ny >= 1.  \throw InvalidInput.
MeshView flat_grid(int nx, int ny);

//! Open tube of the given radius around z from z = 0 to z = height: nu vertices around, nv cells
//! along. V = nu (nv+1), F = 2 nu nv, two boundary loops of nu vertices, genus 0.
//! \pre radius > 0, height > 0, nu >= 3, nv >= 1.  \throw InvalidInput.
MeshView cylinder(double radius, double height, int nu, int nv);

//! Planar sheet in z = 0 with `holes` square holes in a row: genus 0, holes + 1 boundary loops.
//! Cells have side 1/H; each hole is s by s cells with s = resolution, holes and the outer border
//! are m = max(2, s) cells apart, H = s + 2m cells tall and W = max(H, holes s + (holes+1) m)
//! cells wide. V = (W+1)(H+1) - holes (s-1)^2, F = 2 (W H - holes s^2), and
//! B = 2 (W + H) + 4 holes s boundary vertices. No triangle has three boundary vertices and no
//! interior edge joins two boundary vertices, so its double cover is a simple closed surface.
//! \pre holes >= 0, resolution >= 1.  \throw InvalidInput.
MeshView perforated_sheet(int holes, int resolution);

//! Closed surface of the given genus: the double cover of perforated_sheet(genus, resolution)
//! with the copies lifted to z = +h and z = -h, h vanishing on the sheet boundary and growing
//! like the square root of the grid distance to it (capped at m cells). With the sheet's counts
//! V = 2 V_sheet - B, F = 2 F_sheet, E = V + F - 2 + 2 genus. No face has zero area.
//! \pre genus >= 0, resolution >= 1.  \throw InvalidInput.
MeshView genus_surface(int genus, int resolution);

}  // namespace holoflow::shapes
