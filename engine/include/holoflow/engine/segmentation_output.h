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
std::array<std::uint8_t, 3> patch_colour(Index patch);

//! `segments.ply`: binary little-endian PLY. Vertices are split per patch, so each carries
//! `x y z` (double) and its patch-chart `u v` (double); faces carry `vertex_indices`
//! (uchar count, int indices), `patch` (int) and `red green blue` (uchar).
void write_segments_ply(std::ostream& out, const SegmentationPicture& picture);

//! `patches.obj`: the cut mesh with one `vt` per corner in its patch's chart and a group
//! `g patch_<id>` per patch.
void write_patches_obj(std::ostream& out, const SegmentationPicture& picture);

//! `trajectories.obj`: the polylines as `l` elements, grouped `g vertical` / `g horizontal` /
//! `g boundary`.
void write_trajectories_obj(std::ostream& out, const SegmentationPicture& picture);

//! `domains.svg`: every patch's rectangle laid out in the plane (shelf packing, largest first,
//! common scale), filled with the patch's colour, its uv triangles drawn thinly and its id
//! written in it.
void write_domains_svg(std::ostream& out, const SegmentationPicture& picture);

}  // namespace holoflow::engine
