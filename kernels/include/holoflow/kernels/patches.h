#pragma once

#include <array>
#include <complex>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/mesh_view.h"
#include "holoflow/kernels/trajectories.h"

namespace holoflow::kernels {

struct PatchInfo {
    enum class Type : std::uint8_t { Disk, Cylinder, Other };
    Type type = Type::Other;
    Index faces = 0;
    int euler_characteristic = 0;
    int border_loops = 0;
    double width = 0, height = 0;  //!< extent of its uv (the rectangle)
    //! Largest distance of a border vertex's uv from the rectangle's sides, over max(width, height):
    //! 0 when the border is made of iso-u and iso-v pieces on the rectangle.
    double rectangle_error = 0;
    Index flipped_uv_triangles = 0;   //!< negative signed uv area beyond rounding
    double distortion_mean = 0, distortion_max = 0;  //!< conformal distortion (1 = conformal)
    Index form_flipped_uv_triangles = 0;  //!< flipped triangles of the form's integral

    //! Its uv is a positive-weight embedding on the rectangle, not the form's integral, which
    //! folded (repair_folded_patches keeps a layout only when it has fewer flips).
    bool repaired() const { return flipped_uv_triangles != form_flipped_uv_triangles; }
};

//! Patches of a cut mesh: faces joined across edges that are neither borders nor boundary.
struct Patches {
    std::vector<Index> face_patch;                //!< #F, patches numbered by smallest face
    std::vector<std::complex<double>> corner_uv;  //!< 3 #F: uv of corner 3 f + k in its patch,
                                                  //!< translated so the rectangle starts at 0
    std::vector<PatchInfo> info;
};

//! \brief Flood fill across non-border edges, then per patch the integral of `tau` by a walk
//! over its faces (single valued on a disk; a cylinder is opened along the walk's seam), its
//! topology (Euler characteristic and border loops), rectangle, rectangle fit error, flipped uv
//! triangles and conformal distortion against the 3D triangles.
//! \pre `border` has #E flags, tau #E values.  \throw InvalidInput.
Patches compute_patches(const MeshView& mesh, const Eigen::VectorXcd& tau, std::span<const char> border);

//! Area of a mesh and of its faces whose uv collapsed (collapsed_area), and those faces.
struct CollapsedArea {
    double collapsed = 0, total = 0;
    std::vector<char> faces;  //!< #F, 1 where collapsed (every face where the whole uv is one point)
    double fraction() const { return total > 0 ? collapsed / total : 0; }
};

//! \brief The mesh's area, and that of its faces that the patches' uv shrinks to under `ratio`
//! times the mean scale. A face's scale is sqrt(|uv area| / area), the mean sqrt(sum |uv area| / sum
//! area) over every face (each patch's uv is the form's integral: one scale for all). A
//! holomorphic form decays exponentially along a protrusion (a limb, a long tube: by e^(-2 pi)
//! per circumference of length on a round one); past rounding its patches there are points of
//! the plane, while flips, rectangle error and distortion stay clean.
//! \pre corner_uv has 3 #F values, ratio > 0.  \throw InvalidInput.
CollapsedArea collapsed_area(const MeshView& mesh, std::span<const std::complex<double>> corner_uv, double ratio);

//! \brief Gives each disk patch whose uv (the integral of the form) has flipped triangles a
//! valid uv on the same rectangle instead. Its border loop is laid on the rectangle's sides:
//! the corners are the border points nearest the rectangle's corners, and each side keeps its
//! points in walking order, at their uv projected on the side where that increases, else at
//! their 3D arc length, and bulges out by 1e-4 of its length (a strictly convex border, so a
//! triangle with three points on one side is not flat). The interior is a Tutte-Floater
//! embedding: each interior point the weighted mean of its neighbours, weights the cotangent
//! weights clamped positive (one sparse SPD solve). With a strictly convex border and positive
//! weights no triangle flips or degenerates; where rounding leaves flips anyway, a layout with
//! uniform weights is tried too, then both again with every side at 3D arc length (where the
//! form nearly vanishes its border points crowd), and the one with fewest flips kept, the first
//! on ties (should that still have as many flips as the form had, the form's uv stays). Flips,
//! distortion and rectangle error are measured again; `form_flipped_uv_triangles` keeps the
//! form's count. A folded cylinder whose two border loops are iso-lines of one coordinate
//! (vertical mode: iso-u) is laid out on its flat cylinder the same way: the loops stay on their
//! lines, their points at the form's coordinate except where it goes back along the loop (there
//! at 3D arc length), and the interior is the same embedding with the period across the seam of
//! the form's walk, first only within two rings of the folds. Other patches, and patches that touch themselves on
//! their border, are left as they are. Deterministic.
//! \pre `patches` from compute_patches on this mesh and border.  \throw InvalidInput.
Patches repair_folded_patches(const MeshView& mesh, std::span<const char> border, Patches patches);

//! \brief Transversals that open every cylinder patch of a cut into a disk (layout mode: a
//! ring of closed curves that no critical trajectory crosses). The transversal of a cylinder is
//! the level curve (trace_transversals) crossing its core (iso-u when the core period is mostly
//! real) through a vertex strictly inside it; of the vertices nearest the middle across the core
//! (64 at most, ties to the smaller id), the first with two curves that end on different border
//! loops is taken (two curves at a regular vertex, more at a fold of the form: a pair of them),
//! else the first with two that end on one loop: where the border is no straight loop that may
//! only cut a disk off, and the cylinder left is for another call. Vertices on the surface
//! boundary with no trajectory at them come after the inside ones (a short tube has none
//! inside): there the one curve into the patch counts, with the start's own loop as the other
//! end. A cylinder without any such start stays. Zeros are no starts.
//! \pre `cut` = cut_along_trajectories(mesh, tau, trajectories, ...), `border` its border
//! flags, `patches` = compute_patches on them.  \throw InvalidInput on mismatched sizes.
std::vector<Trajectory> cylinder_transversals(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                              std::span<const Index> zero_vertices,
                                              std::span<const Trajectory> trajectories, const CutMesh& cut,
                                              std::span<const char> border, const Patches& patches);

//! \brief Curves that make rectangles of disk patches with a concave corner (layout mode: an L,
//! or a slit that ends inside, where a zero whose fan failed sent no curve into the patch) or a
//! branch point (an inner vertex, of `mesh` and not a zero, around which the patch's uv turns
//! twice or more: such a zero traced from another vertex). Per disk without flipped uv triangles
//! with a branch point, every curve of the vertical family through the one that turns most (ties
//! to the smaller id); else the border vertex where the patch's uv angle between two
//! consecutive border edges is largest, if over 225 degrees (a vertex of `mesh`, not a zero,
//! over 1e-6 of the patch's size off its rectangle's sides); from there the level curve
//! (trace_transversals) along the axis direction into that angle farthest from its two edges
//! (a slit's own line beyond its end; at a 270 degree corner the first of the two in the order
//! +u, +v, -u, -v), one curve. Each ends at the first curve of the other family, so it splits
//! the patch; none is one that `trajectories` has already (same start, family and first face).
//! Deterministic.
//! \pre as cylinder_transversals.  \throw InvalidInput on mismatched sizes.
std::vector<Trajectory> corner_transversals(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                            std::span<const Index> zero_vertices,
                                            std::span<const Trajectory> trajectories, const CutMesh& cut,
                                            std::span<const char> border, const Patches& patches);

//! The flow complex G = (V, E, F): nodes (zeros, corners where borders meet or change kind),
//! pieces (maximal border paths between nodes, or node-less loops) and patches.
struct FlowComplex {
    struct Node {
        Index vertex = -1;
        bool zero = false;
    };
    struct Piece {
        std::vector<Index> vertices;  //!< path along mesh vertices (first = last for a loop)
        Index from = -1, to = -1;     //!< node ids, -1 for a node-less loop
        Index label = -1;             //!< its edges' label; kNoBorder for the surface boundary
        std::array<Index, 2> patches{-1, -1};  //!< left and right of its first edge (-1: outside)
    };
    std::vector<Node> nodes;
    std::vector<Piece> pieces;
    std::vector<std::vector<Index>> patch_pieces;  //!< per patch: its pieces, ascending
};

//! \brief Builds G from the cut mesh: `edge_label` per edge is its border label (a trajectory
//! id, another label such as a homology cut, or kNoBorder = -1); boundary edges are borders
//! labelled kNoBorder. A vertex is a node when its border degree
//! is not 2, its two border edges differ in label, or it is a zero.
FlowComplex flow_complex(const MeshView& mesh, std::span<const Index> edge_label,
                         std::span<const Index> face_patch, std::span<const char> is_zero);

}  // namespace holoflow::kernels
