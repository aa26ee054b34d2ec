#pragma once

#include <array>
#include <complex>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/segmentation_output.h"
#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/holes.h"
#include "holoflow/kernels/patches.h"
#include "holoflow/kernels/trajectories.h"
#include "holoflow/kernels/zero_fans.h"
#include "holoflow/kernels/zeros.h"

namespace holoflow::engine {

enum class SegmentMode {
    Vertical,  //!< the paper's: vertical critical trajectories only
    Layout,    //!< both families with the motorcycle rule: every patch a rectangle
};

struct SegmentOptions {
    ConformalOptions conformal;
    SegmentMode mode = SegmentMode::Layout;
    //! Tips to slice (input vertex ids); empty = detect automatically. Closed genus-0 surfaces
    //! and disks always have tips sliced; other surfaces where tips are given or slice_tips.
    std::vector<Index> tips;
    //! Slice tips on surfaces of every kind: a holomorphic form decays exponentially along a
    //! protrusion, and a limb of a surface with handles maps to a point (collapsed_area); a hole at
    //! its tip gives the double cover's form a period around it, which keeps its scale.
    bool slice_tips = false;
    //! Where tips were detected and a limb still collapses (collapsed_area at least 1 %: a
    //! protrusion the detection missed, a strip of a disk beyond its one tip), up to two rounds
    //! add a tip at each such limb's deepest point (kernels::collapsed_limb_tips) and segment
    //! again, kept where less collapses and nothing else gets worse. At most max_tips in all.
    bool tips_where_collapsed = true;
    int max_tips = 8;           //!< automatic detection keeps at most this many
    double hole_size = 0.02;    //!< hole radius, fraction of sqrt(area / 4 pi)
    //! Where zero fans fail: the midpoint subdivision (small surfaces) and up to this many
    //! bisections around the failed fans, each a new conformal solve; 0: none.
    int fan_refinement_rounds = 3;
    //! Boundary loops filled before anything else (kernels/holes.h): by size only where asked;
    //! past working genus 128 the shortest ones (a scan's pinholes) until it fits, so that a mesh
    //! with thousands of holes is segmented as the surface it samples instead of being refused.
    kernels::HoleFillOptions holes{.max_loop_edges = 0, .max_working_genus = 128};
    //! Where a zero's fan still fails after the refinements, the holes within two rings of it
    //! (not a component's longest loop, see kernels::fillable_holes) are filled and the surface
    //! solved again, kept where fewer fans fail (never on tip-sliced surfaces).
    bool fill_holes_at_failed_fans = true;
    //! A refinement try over ConformalOptions::max_solver_bytes fails the model (ResourceLimit)
    //! instead of being skipped: for a batch that computes such a model again with more memory,
    //! so that the rest of a result it would throw away is not computed.
    bool stop_at_memory_limit = false;
};

//! A face whose uv scale is under this times the mean counts as collapsed (collapsed_area): in
//! double precision a uv of unit size keeps about 30 bits for it.
inline constexpr double kCollapsedScale = 1e-6;

//! Everything the segmentation computes for one mesh (DESIGN 2.5-2.7).
struct SegmentationResult {
    int input_genus = 0;
    //! The open or closed surface the trajectories live on: the input, or the input with tips
    //! sliced (closed genus 0 / disks, others where SegmentOptions asks); open ones are traced on
    //! their double cover's first copy.
    std::shared_ptr<const MeshView> traced_input;
    //! Input vertex ids sliced; -1 for a tip on a vertex that tip_refinements added.
    std::vector<Index> tips;
    //! Midpoint subdivisions of a genus-0 input too coarse to slice (0 usually); they keep the
    //! input's vertex ids and add vertices after them, where a tip may then be found.
    int tip_refinements = 0;
    //! Area of the traced surface, and of its part (faces of `cut`) whose patch uv is under
    //! kCollapsedScale of the mean scale (kernels::collapsed_area): protrusions where the form
    //! decayed.
    kernels::CollapsedArea collapsed;
    //! Of tips, those SegmentOptions::tips_where_collapsed added.
    int tips_added_where_collapsed = 0;
    //! Boundary loops filled (SegmentOptions::holes, then fill_holes_at_failed_fans) and the
    //! triangles that closed them, which traced_input holds after the faces it had (the input's,
    //! or a refinement's); loops chosen but left open (no triangulation without a repeated edge
    //! or a flat triangle).
    Index filled_holes = 0, filled_hole_faces = 0, holes_left_open = 0;
    //! Of filled_holes, those filled because a zero next to them kept a failed fan after every
    //! refinement (SegmentOptions::fill_holes_at_failed_fans).
    Index holes_filled_at_failed_fans = 0;
    //! Refinements of the traced surface kept because fewer zero fans failed on them (its
    //! midpoint subdivision while small, then bisections around the failed fans, see
    //! SegmentOptions::fan_refinement_rounds): traced_input is then the refined one, with the
    //! same vertex ids for the vertices it had; 0 where every fan worked.
    int fan_refinements = 0;
    //! Refinement tries skipped because they would need more memory than
    //! ConformalOptions::max_solver_bytes: with a higher limit the result may differ.
    Index tries_over_memory_limit = 0;
    ConformalResult conformal;
    kernels::ZeroSet zeros;                   //!< on the working (closed) surface
    kernels::RegularisedForm regular;         //!< traced_input with zero fans
    std::vector<Index> zero_vertices;         //!< per trace start: its vertex of regular.mesh
    //! Critical trajectories, then (layout mode) the transversals that opened cylinders or split
    //! patches at concave corners.
    std::vector<kernels::Trajectory> trajectories;
    Index transversals = 0;                   //!< the last ones of `trajectories`
    kernels::CutMesh cut;
    kernels::Patches patches;
    kernels::FlowComplex complex;
    SegmentMode mode = SegmentMode::Layout;
    StageTimes timings_ms;                    //!< conformal stages, then segmentation stages

    //! A closed genus-1 input: the segmentation form's periods reduced (kernels::reduce_lattice),
    //! {0, 0} otherwise. regular.tau is then the form made a rectangle's (kernels::rectangle_form),
    //! and the torus opens along the vertical and horizontal line through a point inside face 0
    //! (regular.mesh gets it as its last vertex), one period each, into one rectangle; along
    //! its homology cut where those lines do not close or make no single disk.
    std::array<std::complex<double>, 2> torus_periods{};

    //! A closed genus-1 input: no zeros; it opens into one parallelogram.
    bool is_torus() const { return !conformal.double_covered && conformal.basis.genus == 1; }
};

//! One model between the segmentation stages (as ConformalWork for the conformal ones, which run
//! between prepare and zeros on `conformal`).
struct SegmentationWork {
    std::shared_ptr<const MeshView> given;  //!< the mesh as given to prepare
    std::shared_ptr<const MeshView> input;  //!< it with small holes filled (SegmentOptions::holes)
    SegmentOptions options;
    SegmentationResult result;
    ConformalWork conformal;
    std::vector<kernels::ZeroRegion> regions;  //!< zero clusters on the traced surface
};

//! The segmentation stages in order (DESIGN 2.1, 2.5-2.7); each throws as segment() does.
namespace segment_stage {
//! Topology checks, tip slicing (closed genus 0 and disks, others where asked), then
//! conformal_stage::prepare.
SegmentationWork prepare(std::shared_ptr<const MeshView> input, SegmentOptions options);
//! Takes the finished conformal result; zeros and their clusters.
void zeros(SegmentationWork& work);
//! Zero fans: every zero becomes a vertex with no flipped image triangle around it.
void fans(SegmentationWork& work);
//! Critical trajectories from every zero (both families with the motorcycle rule in layout mode).
void trace(SegmentationWork& work);
//! Cut along the trajectories (layout mode: transversals open cylinders and split patches at
//! concave corners), patches with their maps, the flow complex.
void cut(SegmentationWork& work);
//! Where limbs collapsed, every stage again with tips added there
//! (SegmentOptions::tips_where_collapsed).
void tips_where_collapsed(SegmentationWork& work);
}  // namespace segment_stage

//! \brief The holomorphic flow segmentation of a validated, connected mesh of any genus: the
//! stages above in sequence (the flow graph in graphs/ runs the same ones as nodes).
//! \throw InvalidInput (several components: the graphs/ SegmentationGraph segments those one
//! by one; genus-0 surface where no tip can be sliced),
//! SolverFailure, ResourceLimit.
SegmentationResult segment(const MeshView& input, const SegmentOptions& options = {},
                           FactorizationCache* cache = nullptr);

//! `segmentation.json` (keys documented in README).
nlohmann::json segmentation_report(const SegmentationResult& result);

//! `complex.json`: the flow complex G = (V, E, F) with adjacency (format in README).
nlohmann::json complex_report(const SegmentationResult& result);

//! The files of a segmentation folder, segmentation.json last (the order they are written in).
inline const std::vector<std::string> kSegmentationFiles = {"segments.ply", "patches.obj", "trajectories.obj",
                                                            "domains.svg", "complex.json", "segmentation.json"};

//! Writes segments.ply, patches.obj, trajectories.obj, domains.svg, complex.json and, last,
//! `report` as segmentation.json into `folder` (created if needed; temporaries a killed run left
//! of these files are removed first), as one FileSet: the folder never holds segmentation.json
//! over files of another run. \throw OutputError.
void write_segmentation_folder(const std::filesystem::path& folder, const SegmentationResult& result,
                               const nlohmann::json& report);

//! The arrays the picture writers draw.
SegmentationPicture segmentation_picture(const SegmentationResult& result);

// A mesh of several components is segmented per component (graphs/); its folder holds the
// same files, the components side by side. With one component each of these is the single
// result's.

//! segmentation.json of the components together: `component_count`, `components` (each one's
//! report), and over all of them the sums of the counts (genus, zero_count, patch_count, ...,
//! and per key of patch_types, zero_fans, timings_ms, ...), the max of rectangle_error_max,
//! the face-weighted mean and the max of conformal_distortion, and the lists (patches, zeros,
//! tips) joined, each entry with its `component`. torus_modulus is per component only.
nlohmann::json segmentation_report(std::span<const SegmentationResult> components);

//! The components' stage times added up per stage, in the first one's order (a stage only later
//! ones have comes after).
StageTimes summed_times(std::span<const SegmentationResult> components);

//! complex.json of the components together: their complexes joined, ids offset.
nlohmann::json complex_report(std::span<const SegmentationResult> components);

//! The pictures of the components joined: vertices, faces, patch ids and polylines offset.
SegmentationPicture segmentation_picture(std::span<const SegmentationResult> components);

//! As above, for the components together.
void write_segmentation_folder(const std::filesystem::path& folder, std::span<const SegmentationResult> components,
                               const nlohmann::json& report);

}  // namespace holoflow::engine
