#pragma once

#include <array>
#include <complex>
#include <cstdint>
#include <ostream>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::engine {

//! What the segmentation writers draw, as plain arrays (filled by the segmentation pipeline).
struct SegmentationPicture {
    PointMatrix V;                              //!< cut mesh: patch borders are mesh edges
    TriangleMatrix F;
    std::vector<Index> face_patch;              //!< #F, patch id in 0 .. n_patches - 1
    //! 3 #F: uv of corner k of face f (index 3 f + k) in its patch's chart; the patch's
    //! rectangle is [0, width] x [0, height] (cylinders: u wraps with period width).
    std::vector<std::complex<double>> corner_uv;
    std::vector<std::array<double, 2>> patch_size;  //!< per patch: width, height
    enum class Family : std::uint8_t { Vertical, Horizontal, Boundary };
    struct Polyline {
        Family family = Family::Vertical;
        std::vector<Eigen::Vector3d> points;
    };
    std::vector<Polyline> trajectories;
    Index n_patches() const { return static_cast<Index>(patch_size.size()); }
};

//! Deterministic, well separated colour of a patch (golden-ratio hues), shared by every picture.
//! Hue steps of 1/phi turn (consecutive ids 137.5 degrees apart), saturation 0.55, value 0.93.
//! \throw InvalidInput if patch < 0.
std::array<std::uint8_t, 3> patch_colour(Index patch);

// Common to the writers below: the picture is checked before the first byte is written, the
// output is streamed through a small buffer (never assembled in memory), and no NaN or inf
// reaches the file (our loader refuses them): a non-finite position or corner uv is written as
// 0 in the PLY and OBJ and its triangle is not drawn in the SVG. The mesh writers (all but
// write_trajectories_obj) \throw InvalidInput, naming the writer and the problem, if
// face_patch or corner_uv do not have #F and 3 #F entries, a patch id is outside
// 0 .. n_patches() - 1 or a face refers to a vertex outside V.

//! `segments.ply`: binary little-endian PLY. Vertices are split per patch, so each carries
//! `x y z` (double) and its patch-chart `u v` (double); faces carry `vertex_indices`
//! (uchar count, int indices), `patch` (int) and `red green blue` (uchar, patch_colour).
//! One output vertex per (vertex, patch) pair in use, numbered in order of first use when
//! scanning the faces in order; its `u v` come from that first corner. Header comments
//! `holoflow segments` and `patches <n>`.
void write_segments_ply(std::ostream& out, const SegmentationPicture& picture);

//! `patches.obj`: the cut mesh with one `vt` per corner in its patch's chart and a group
//! `g patch_<id>` per patch.
//! `v` per vertex of V, `vt` per corner (corner 3 f + k is vt number 3 f + k + 1), then every
//! patch's group in id order (also a patch without faces) with its faces in index order as
//! `f v/vt v/vt v/vt`.
void write_patches_obj(std::ostream& out, const SegmentationPicture& picture);

//! `trajectories.obj`: the polylines as `l` elements, grouped `g vertical` / `g horizontal` /
//! `g boundary`.
//! All `v` lines first (polyline order), then the groups in that order, empty ones omitted. A
//! polyline is split at non-finite points; pieces of fewer than 2 points are left out.
//! \throw InvalidInput for a family outside the enum.
void write_trajectories_obj(std::ostream& out, const SegmentationPicture& picture);

//! `domains.svg`: every patch's rectangle laid out in the plane (shelf packing, largest first,
//! common scale), filled with the patch's colour, its uv triangles drawn thinly and its id
//! written in it.
//! Standalone SVG 1.1, at most 1600 px wide; one `<g id="patch-<id>">` per patch holding one
//! `<rect>`, the triangles as one clipped `<path>` (v up; a triangle crossing u = 0 or
//! u = width is drawn again one period over, for cylinders) and a `<text>` label. Shelves are
//! filled tallest first (ties by id); the scale is the one giving the most 16:10-like page. A
//! patch whose size is not finite and positive is a dashed 24 px placeholder without triangles.
void write_domains_svg(std::ostream& out, const SegmentationPicture& picture);

}  // namespace holoflow::engine
