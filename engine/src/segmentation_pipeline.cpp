#include "holoflow/engine/segmentation_pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include "holoflow/engine/output.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/holes.h"
#include "holoflow/kernels/holomorphic.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/subdivision.h"
#include "holoflow/kernels/tips.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::engine {
namespace {

using Complex = std::complex<double>;
using kernels::Trajectory;
using kernels::TrajectoryFamily;

constexpr Index kHomologyCut = -2;  // border label of a torus's cut graph edges
// Where a cylinder's border is no straight loop a transversal may only cut a disk off it; the
// cylinder left is opened in the next round.
constexpr int kCylinderRounds = 4;
// Concave corners are split one per patch and round (a patch with several needs several).
constexpr int kCornerRounds = 8;
// From this many forms (2g of the working surface: two blocks of solves) the conformal stage
// computes the chosen form alone (ConformalOptions::chosen_form_only); the refinement tries
// always do. Below it the basis costs about what the form alone does, and stays as it was.
constexpr Index kChosenFormOnlyForms = 64;
// Where zero fans fail the surface is refined: bisected this many rings around them,
constexpr int kFanZoneRings = 4;
// up to this many times its faces (cheese's bisection of every edge: 4.1x) or, on a small one,
// this many faces (oblong's slivers: 17x),
constexpr Index kMaxFanRefinementGrowth = 8;
constexpr Index kFanRefinementFaces = 100000;
// and first subdivided (midpoint) where that stays this small; a second midpoint step then
// competes with a first bisection round that leaves regions failed (elephant-with-holes,
// hexagonal holes two edges apart: 54 failed, 8 after one step, 4 after two, 7 after a
// bisection instead).
constexpr Index kMaxMidpointRefinedFaces = 20000;
// Holes this many rings from a zero whose fan still fails are filled in a last try; pinholes,
// loops of at most kPinholeEdges, in a first one where the surface's faces times its forms
// (what a refinement try costs) pass kPinholesFirstFaceForms.
constexpr int kUnresolvedHoleRings = 2;
constexpr int kUnresolvedHoleRounds = 3;
constexpr Index kPinholeEdges = 4;
constexpr double kPinholesFirstFaceForms = 1e6;

// The cover's form restricted to its first copy, which is the open input (same faces, same
// vertex order, so halfedge h of the input is halfedge h of the cover).
Eigen::VectorXcd restrict_to_first_copy(const MeshView& open, const MeshView& cover, const Eigen::VectorXcd& tau) {
    Eigen::VectorXcd out(open.n_edges());
    for (Index e = 0; e < open.n_edges(); ++e) {
        const Index h = open.edge_halfedge[e];
        out(e) = static_cast<double>(cover.edge_sign(h)) * tau(cover.halfedge_edge[h]);
    }
    return out;
}

// A torus's periods of its form along its homology generators (the fold fans keep the form's
// class, so the regularised form has the same ones).
std::array<Complex, 2> generator_periods(const SegmentationResult& r) {
    std::array<Complex, 2> period{};
    for (int i = 0; i < 2; ++i)
        for (Index h : r.conformal.homology.loops[i]) period[i] += kernels::form_along(*r.conformal.surface, r.conformal.tau, h);
    return period;
}

// The surface halfedge under halfedge h of a torus's regularised mesh without fans: the one
// with the same two vertices in h's surface face (the torus's corner point may split a face);
// kNoHalfedge for the corner's spokes.
Index surface_halfedge(const SegmentationResult& r, Index h) {
    const MeshView& surface = *r.conformal.surface;
    const MeshView& m = r.regular.mesh;
    const Index face = r.regular.original_face[MeshView::face(h)];
    for (Index s = 3 * face; s < 3 * face + 3; ++s)
        if (surface.tail(s) == m.tail(h) && surface.head(s) == m.head(h)) return s;
    return kNoHalfedge;
}

// A torus's regularised mesh edges on a homology cut graph: kHomologyCut, else kNoBorder. The
// surface's own cut graph where the mesh kept the surface's faces; where fans re-triangulated
// folds, the cut graph of the regularised mesh itself.
std::vector<Index> homology_cut_labels(const SegmentationResult& r) {
    const MeshView& m = r.regular.mesh;
    std::vector<Index> label(m.n_edges(), kernels::kNoBorder);
    const std::vector<Index>& original_face = r.regular.original_face;
    if (std::find(original_face.begin(), original_face.end(), Index{-1}) != original_face.end()) {
        const kernels::HomologyBasis own = kernels::compute_homology_basis(m);
        for (Index e = 0; e < m.n_edges(); ++e)
            if (own.cut_edge[e]) label[e] = kHomologyCut;
        return label;
    }
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Index s = surface_halfedge(r, m.edge_halfedge[e]);
        if (s != kNoHalfedge && r.conformal.homology.cut_edge[r.conformal.surface->halfedge_edge[s]]) label[e] = kHomologyCut;
    }
    return label;
}

Index flipped_uv_triangles(const kernels::Patches& patches) {
    Index flipped = 0;
    for (const kernels::PatchInfo& p : patches.info) flipped += p.flipped_uv_triangles;
    return flipped;
}

// Clusters of the working surface as regions of the traced surface. On a double cover only the
// clusters that reach the first copy count (the others are their mirrors); mirrored vertices
// fold back onto the first copy.
std::vector<kernels::ZeroRegion> zero_regions(const SegmentationResult& r) {
    const kernels::ZeroSet& z = r.zeros;
    const kernels::DoubleCover* cover = r.conformal.cover.get();
    const Index first_copy_vertices = r.traced_input->n_vertices();
    std::vector<Index> zero_of_cluster(z.clusters.size(), -1);
    for (Index i = 0; i < static_cast<Index>(z.zeros.size()); ++i) zero_of_cluster[z.zeros[i].cluster] = i;
    std::vector<kernels::ZeroRegion> regions;
    for (Index c = 0; c < static_cast<Index>(z.clusters.size()); ++c) {
        const kernels::ZeroCluster& cluster = z.clusters[c];
        if (cluster.vertices.empty() || cluster.index < 0) continue;
        if (cover && cluster.vertices.front() >= first_copy_vertices) continue;  // a mirror
        kernels::ZeroRegion region;
        region.order = std::max(cluster.index, 0);
        for (Index v : cluster.vertices) region.vertices.push_back(cover ? cover->original_vertex[v] : v);
        std::sort(region.vertices.begin(), region.vertices.end());
        region.vertices.erase(std::unique(region.vertices.begin(), region.vertices.end()), region.vertices.end());
        const Index zi = zero_of_cluster[c];
        if (zi >= 0) {
            const kernels::Zero& zero = z.zeros[zi];
            if (zero.vertex >= 0) region.vertex = cover ? cover->original_vertex[zero.vertex] : zero.vertex;
        }
        regions.push_back(std::move(region));
    }
    return regions;
}

struct SlicedSurface {
    MeshView mesh;
    kernels::Topology topology;
};

// The sliced surface needs two boundary loops at least (the double cover then has genus >= 1).
// A mesh too coarse for that (a cube: holes that swallow whole faces or merge) is refined by
// midpoint subdivision, which keeps the shape and the vertex ids, and sliced again.
SlicedSurface slice_at_tips(const MeshView& input, const kernels::Topology& topology, const SegmentOptions& options,
                            SegmentationResult& r) {
    constexpr int kMaxRefinements = 8;  // thin triangles need more; the face cap bounds the cost
    constexpr Index kMaxRefinedFaces = 200000;  // refining is for coarse meshes only
    std::shared_ptr<const MeshView> mesh(std::shared_ptr<const MeshView>{}, &input);
    for (int refinement = 0;; ++refinement) {
        try {
            std::vector<Index> tips = options.tips;
            if (tips.empty()) {
                kernels::TipOptions tip_options;
                tip_options.max_tips = std::max(2, options.max_tips);
                tip_options.min_tips = topology.genus == 0 && topology.boundary_loops == 0 ? 2 : 1;
                tips = kernels::find_tips(*mesh, tip_options);
            }
            kernels::SlicedMesh sliced = kernels::slice_tips(*mesh, tips, options.hole_size);
            kernels::Topology cut = kernels::compute_topology(sliced.mesh);
            HOLOFLOW_REQUIRE(cut.components == 1 && (cut.genus > 0 || cut.boundary_loops >= 2),
                             "slicing the tips left " + std::to_string(cut.boundary_loops) +
                                 " boundary loop(s); a genus-0 surface needs two to carry a holomorphic 1-form");
            // Reported as input vertices; one the refinement added is none of them (-1).
            r.tips = sliced.tips;
            for (Index& tip : r.tips)
                if (tip >= input.n_vertices()) tip = -1;
            r.tip_refinements = refinement;
            return {std::move(sliced.mesh), std::move(cut)};
        } catch (const InvalidInput&) {
            if (refinement == kMaxRefinements || 4 * mesh->n_faces() > kMaxRefinedFaces) throw;
        }
        mesh = std::make_shared<const MeshView>(kernels::subdivide_midpoint(*mesh));
    }
}

// Curves stopped at the length cap.
Index unfinished_trajectories(const SegmentationResult& r) {
    return std::count_if(r.trajectories.begin(), r.trajectories.end(),
                         [](const Trajectory& t) { return t.end == Trajectory::End::LengthCap; });
}

}  // namespace

namespace segment_stage {

SegmentationWork prepare(std::shared_ptr<const MeshView> input_ptr, SegmentOptions options) {
    HOLOFLOW_REQUIRE(input_ptr != nullptr, "no mesh");
    SegmentationWork work;
    work.given = input_ptr;
    work.input = std::move(input_ptr);
    work.options = std::move(options);
    SegmentationResult& r = work.result;
    r.mode = work.options.mode;
    // The paper's mode traces the vertical family alone. Where a generic form's vertical leaves
    // can be dense (the surface has handles), it takes a form with integer periods: its leaves all
    // close, so the critical ones are saddle connections and the patches cylinders (or rectangles
    // against a boundary). A planar domain (genus 0 with holes: tips sliced, or open input such
    // as head) has no dense leaf, nor a closed one for a generic form, whose periods around the
    // holes are not 0: its critical leaves end at zeros or on the boundary, and the patches are
    // rectangles. There integer periods would put a whole period around each small tip hole
    // (or zeros on its border), where the mesh cannot follow (bench/README, "Vertical mode on
    // the unseen variants").
    const auto choose_form = [&](const kernels::Topology& surface) {
        if (r.mode == SegmentMode::Vertical && !(surface.genus == 0 && surface.boundary_loops > 0))
            work.options.conformal.form = FormChoice::IntegerPeriods;
    };
    StageClock clock(r.timings_ms);

    kernels::Topology topology = kernels::compute_topology(*work.input);
    r.input_genus = topology.genus;
    require_connected(topology);
    for (Index tip : work.options.tips)  // ids of the input (slicing may first refine it)
        if (tip < 0 || tip >= work.input->n_vertices())
            throw InvalidInput("tip " + std::to_string(tip) + " is not a vertex of the mesh (it has " +
                               std::to_string(work.input->n_vertices()) + " vertices)");
    // Small holes filled first (a scan's pinholes: each would add a handle to the double cover).
    const std::vector<Index> holes = kernels::holes_to_fill(*work.input, topology, work.options.holes);
    if (!holes.empty()) {
        kernels::FilledHoles filled = kernels::fill_holes(*work.input, topology, holes);
        r.filled_holes = filled.holes;
        r.filled_hole_faces = filled.faces;
        r.holes_left_open = filled.left_open;
        if (filled.holes > 0) {
            work.input = std::make_shared<const MeshView>(std::move(filled.mesh));
            topology = kernels::compute_topology(*work.input);
        }
        clock.lap("hole_filling");
    }
    const MeshView& input = *work.input;
    // Closed genus 0 and disks: slice small holes at the tips first (DESIGN 2.1); other
    // surfaces where asked (their limbs then keep their scale, see SegmentOptions::slice_tips).
    // There a surface whose detected tips cannot be sliced (every hole would wrap a handle or
    // cut it) is segmented as it is.
    const bool needs_tips = (topology.genus == 0 && topology.boundary_loops <= 1) || !work.options.tips.empty();
    std::optional<SlicedSurface> sliced;
    if (needs_tips || work.options.slice_tips) {
        try {
            sliced = slice_at_tips(input, topology, work.options, r);
        } catch (const InvalidInput&) {
            if (needs_tips) throw;  // else r.tips stay empty
        }
    }
    if (sliced) {
        r.traced_input = std::make_shared<const MeshView>(std::move(sliced->mesh));
        clock.lap("tip_slicing");
        choose_form(sliced->topology);
        work.conformal = conformal_stage::prepare(r.traced_input, work.options.conformal, &sliced->topology);
    } else {
        r.traced_input = work.input;
        choose_form(topology);
        work.conformal = conformal_stage::prepare(r.traced_input, work.options.conformal, &topology);
    }
    // The segmentation needs one form; the basis costs a solve per form (2g of them), the form
    // alone the same few whatever the genus.
    if (work.conformal.form_count() >= kChosenFormOnlyForms) work.conformal.options.chosen_form_only = true;
    return work;
}

namespace {

// The zeros of the finished conformal result's form, and their clusters on the traced surface.
void locate_zeros(SegmentationWork& work) {
    SegmentationResult& r = work.result;
    r.conformal = std::move(work.conformal.result);
    {  // the rest of the conformal work (factor, Laplacian, solve blocks) goes now
        const ConformalWork released = std::move(work.conformal);
    }
    // Saddles are counted where the form is harmonic: on the intrinsic Delaunay triangulation
    // the Laplacian was built on (its flips replayed on tau), else on the mesh with its own
    // cotan weights.
    kernels::ZeroOptions zero_options;
    zero_options.triangulation = r.conformal.intrinsic.get();
    zero_options.intrinsic_delaunay = zero_options.triangulation != nullptr;
    zero_options.weights = r.conformal.laplace_weights;
    r.zeros = kernels::find_zeros(*r.conformal.surface, r.conformal.tau, zero_options);
    r.conformal.intrinsic.reset();  // nothing after the zeros needs them
    r.conformal.laplace_weights = {};
    work.regions = zero_regions(r);
    // A torus has no zero: its fans only re-triangulate folds, so that its sides can close.
    if (r.is_torus()) std::erase_if(work.regions, [](const kernels::ZeroRegion& z) { return z.order > 0; });
}

// Zero fans on the traced surface (the form restricted to the first copy of a double cover).
kernels::RegularisedForm regularised(const SegmentationWork& work, const kernels::FanOptions& options = {}) {
    const SegmentationResult& r = work.result;
    const MeshView& traced = *r.traced_input;
    const Eigen::VectorXcd tau = r.conformal.double_covered
                                     ? restrict_to_first_copy(traced, *r.conformal.surface, r.conformal.tau)
                                     : r.conformal.tau;
    return kernels::regularise_zeros(traced, tau, work.regions, options);
}

// The vertices within kFanZoneRings rings of the regions whose fans failed; none (the whole
// surface) where more than a quarter of the zeros' failed: the mesh is too coarse throughout
// (cheese: 154 of 264; rounds of zones cost it 2.5x a whole refinement and left more failed).
std::vector<char> failed_fan_zone(const MeshView& surface, std::span<const kernels::ZeroRegion> regions,
                                  const kernels::RegularisedForm& regular) {
    Index zeros = 0, failed = 0;
    for (std::size_t i = 0; i < regions.size(); ++i)
        if (regions[i].order > 0) ++zeros, failed += regular.region_vertex[i] < 0;
    if (4 * failed > zeros) return {};
    std::vector<char> zone(surface.n_vertices(), 0);
    for (std::size_t i = 0; i < regions.size(); ++i) {
        if (regular.region_vertex[i] >= 0) continue;
        const kernels::ZeroRegion& region = regions[i];
        for (Index v : region.vertices) zone[v] = 1;
        if (region.vertex >= 0) zone[region.vertex] = 1;
        if (region.face >= 0)
            for (int k = 0; k < 3; ++k) zone[surface.F(region.face, k)] = 1;
    }
    for (int ring = 0; ring < kFanZoneRings; ++ring) {
        std::vector<char> grown = zone;
        for (Index h = 0; h < surface.n_halfedges(); ++h)
            if (zone[surface.tail(h)]) grown[surface.head(h)] = 1;
        zone.swap(grown);
    }
    return zone;
}

// The traced surface with its long edges bisected and its flat parts flipped Delaunay: same
// shape, same vertex ids, room between zeros that were a triangle or two apart, and fewer of
// the slivers on which the form's image folds. Inside a zone the edges longer than half the
// zone's median edge length split (the zeros at elephant-with-holes' small holes, whose edges
// are short already, need them; the median left 7 fans failed there, pizza 5); on the whole
// surface those longer than the median (cheese: 4x the faces). Nothing where no edge splits, or
// past max_faces (a zone of tiny edges beside a long one: a fuzzed mesh of 168 faces grew
// without bound; boeing's coarse CAD part would grow 22x).
std::optional<MeshView> bisected_surface(const MeshView& surface, std::span<const char> zone, Index max_faces) {
    std::vector<double> length;
    for (Index e = 0; e < surface.n_edges(); ++e)
        if (zone.empty() || (zone[surface.E(e, 0)] && zone[surface.E(e, 1)]))
            length.push_back((surface.V.row(surface.E(e, 0)) - surface.V.row(surface.E(e, 1))).norm());
    if (length.empty()) return std::nullopt;
    auto median = length.begin() + static_cast<std::ptrdiff_t>(length.size() / 2);
    std::nth_element(length.begin(), median, length.end());
    const double factor = zone.empty() ? 1.0 : 0.5;
    std::optional<MeshView> bisected = kernels::bisect_long_edges(surface, factor * *median, zone, max_faces);
    if (!bisected || bisected->n_faces() == surface.n_faces()) return std::nullopt;
    return kernels::flip_flat_edges_to_delaunay(*bisected);
}

// Boundary loops of the traced surface within kUnresolvedHoleRings rings of a zero whose fan
// failed, that fillable_holes may close: a zero sitting on a hole of a few edges, which no fan
// resolved at any refinement (its cluster's saddles and image windings disagree there).
std::vector<Index> holes_at_failed_fans(const MeshView& surface, const kernels::Topology& topology,
                                        std::span<const kernels::ZeroRegion> regions,
                                        const kernels::RegularisedForm& regular, Index longest_fillable_loop) {
    std::vector<char> near(surface.n_vertices(), 0);
    for (std::size_t i = 0; i < regions.size(); ++i)
        if (regions[i].order > 0 && regular.region_vertex[i] < 0)
            for (Index v : regions[i].vertices) near[v] = 1;
    // Rings along edges, both ways (failed_fan_zone's halfedge rings do not cross a boundary
    // edge backwards; shared, they changed which holes close: 88 -> 93 on elephant-with-holes).
    for (int ring = 0; ring < kUnresolvedHoleRings; ++ring) {
        std::vector<char> grown = near;
        for (Index e = 0; e < surface.n_edges(); ++e)
            if (near[surface.E(e, 0)] || near[surface.E(e, 1)]) grown[surface.E(e, 0)] = grown[surface.E(e, 1)] = 1;
        near = std::move(grown);
    }
    std::vector<Index> touched;
    for (Index l = 0; l < static_cast<Index>(topology.boundary_cycles.size()); ++l) {
        const std::vector<Index>& loop = topology.boundary_cycles[l];
        if (std::any_of(loop.begin(), loop.end(), [&](Index v) { return near[v] != 0; })) touched.push_back(l);
    }
    return kernels::fillable_holes(surface, topology, touched, longest_fillable_loop);
}

// The conformal stage, the zeros and the fans again on a refinement of the traced surface (same
// shape, same vertex ids); nothing where that fails, would need more memory than allowed (counted
// in `over_memory_limit`) or has more than max_faces. A try is kept only where its failed regions
// weigh less than `failed_now` (RegularisedForm::failed_weight); where not, its fans leave the
// flips no region holds (kernels::FanOptions::leftover_folds_below_failed_weight), which change
// no region's outcome.
std::optional<SegmentationWork> on_refined_surface(MeshView surface, const SegmentOptions& options, Index max_faces,
                                                   Index failed_now, Index& over_memory_limit) {
    if (surface.n_faces() > max_faces) return std::nullopt;
    SegmentationWork refined;
    refined.options = options;
    try {
        auto traced = std::make_shared<const MeshView>(std::move(surface));
        const kernels::Topology topology = kernels::compute_topology(*traced);
        refined.result.traced_input = std::move(traced);
        refined.conformal = conformal_stage::prepare(refined.result.traced_input, options.conformal, &topology);
        conformal_stage::run_after_prepare(refined.conformal, nullptr);  // a new pattern: no cache
        locate_zeros(refined);
        kernels::FanOptions fans;
        fans.leftover_folds_below_failed_weight = failed_now;
        refined.result.regular = regularised(refined, fans);
    } catch (const InvalidInput&) {
        return std::nullopt;
    } catch (const SolverFailure&) {
        return std::nullopt;
    } catch (const ResourceLimit&) {
        ++over_memory_limit;
        if (options.stop_at_memory_limit) throw;
        return std::nullopt;
    }
    return refined;
}

}  // namespace

void zeros(SegmentationWork& work) {
    SegmentationResult& r = work.result;
    const StageTimes conformal_times = work.conformal.result.timings_ms;
    r.timings_ms.insert(r.timings_ms.end(), conformal_times.begin(), conformal_times.end());
    StageClock clock(r.timings_ms);
    locate_zeros(work);
    clock.lap("zeros");
}

void fans(SegmentationWork& work) {
    SegmentationResult& r = work.result;
    StageClock clock(r.timings_ms);
    r.regular = regularised(work);
    // A zero whose fan failed is traced from a vertex of its tangled image, with the curves
    // found there: a patch around it may wind twice, or the form's uv fold (a torus's sides may
    // not close across a failed fold). The regions get room on a refined surface: midpoint
    // subdivisions while small (a tetrahedron's zeros need every face split), then rounds of
    // bisection around the fans still failed; each is kept while fewer regions fail on it. Each
    // try's conformal stages count as those stages (added to them), the rest as the fans'.
    StageTimes refined_conformal;
    const auto tried = [&](const std::optional<SegmentationWork>& refined) {
        if (refined) add_stage_times(refined_conformal, refined->result.conformal.timings_ms);
    };
    // Kept where less fails (failed regions weighed by order: a coarse CAD plate's zeros of
    // order 6 and 4 split into simple ones on a refinement, where most fail again, yet fewer
    // of the zeros) and no artifact is new (a CAD mesh's small part, midpoint subdivided twice,
    // placed every fan but broke the maximum principle twice).
    const auto keep_if_fewer_fail = [&](std::optional<SegmentationWork> refined, bool refinement = true) {
        if (!refined) return false;
        if (refined->result.regular.failed_weight >= r.regular.failed_weight ||
            refined->result.zeros.artifact_clusters > r.zeros.artifact_clusters)
            return false;
        SegmentationResult& f = refined->result;
        r.traced_input = std::move(f.traced_input);
        r.conformal = std::move(f.conformal);
        r.zeros = std::move(f.zeros);
        work.regions = std::move(refined->regions);
        r.regular = std::move(f.regular);
        r.fan_refinements += refinement;
        return true;
    };
    const int rounds = work.options.fan_refinement_rounds;
    const Index max_faces = std::max(kMaxFanRefinementGrowth * r.traced_input->n_faces(), kFanRefinementFaces);
    // A try's memory limit leaves room for the forms the model holds meanwhile.
    const auto try_options = [&] {
        SegmentOptions o = work.options;
        std::size_t& limit = o.conformal.max_solver_bytes;
        const auto held = static_cast<std::size_t>(8 * (r.conformal.harmonic.size() + r.conformal.homology.closed_forms.size()) +
                                                   16 * r.conformal.tau.size());
        if (limit > 0) limit = limit > held ? limit - held : 1;
        o.conformal.chosen_form_only = true;  // a try needs its form, not the period matrix
        return o;
    };
    const auto midpoint_try = [&] {
        std::optional<SegmentationWork> refined =
            on_refined_surface(kernels::subdivide_midpoint(*r.traced_input), try_options(), max_faces,
                               r.regular.failed_weight, r.tries_over_memory_limit);
        tried(refined);
        return refined;
    };
    const auto refine = [&] {
        bool subdivided = false;
        if (rounds > 0 && r.regular.failed_regions > 0 && 4 * r.traced_input->n_faces() <= kMaxMidpointRefinedFaces)
            subdivided = keep_if_fewer_fail(midpoint_try());
        for (int round = 0; round < rounds && r.regular.failed_regions > 0; ++round) {
            std::optional<MeshView> bisected =
                bisected_surface(*r.traced_input, failed_fan_zone(*r.traced_input, work.regions, r.regular), max_faces);
            std::optional<SegmentationWork> next;
            if (bisected)
                next = on_refined_surface(std::move(*bisected), try_options(), max_faces, r.regular.failed_weight,
                                          r.tries_over_memory_limit);
            tried(next);
            // After a midpoint step, a second one competes with a first bisection round that left
            // regions failed; it is kept only where fewer fail on it (it adds more faces).
            if (round == 0 && subdivided && (!next || next->result.regular.failed_regions > 0)) {
                std::optional<SegmentationWork> twice = midpoint_try();
                if (twice && (!next || twice->result.regular.failed_weight < next->result.regular.failed_weight))
                    next = std::move(twice);
            }
            if (!keep_if_fewer_fail(std::move(next))) break;
        }
    };
    // Zeros still unresolved next to small holes (a scan's pinholes, a loop of a few edges
    // holding two zeros of the double cover): those holes are filled, and the surface solved
    // again, kept where fewer regions fail (not on tip-sliced surfaces, whose holes are ours).
    // The new double cover has other zeros, which may sit on other small holes: a few rounds.
    const auto fill_holes_at_failed_fans = [&](Index longest_loop) {
        for (int round = 0; round < kUnresolvedHoleRounds && r.regular.failed_regions > 0 &&
                            work.options.fill_holes_at_failed_fans && r.tips.empty();
             ++round) {
            const kernels::Topology topology = kernels::compute_topology(*r.traced_input);
            const std::vector<Index> holes =
                holes_at_failed_fans(*r.traced_input, topology, work.regions, r.regular, longest_loop);
            if (holes.empty()) break;
            kernels::FilledHoles filled = kernels::fill_holes(*r.traced_input, topology, holes);
            if (filled.holes == 0) break;
            std::optional<SegmentationWork> closed =
                on_refined_surface(std::move(filled.mesh), try_options(), max_faces, r.regular.failed_weight,
                                   r.tries_over_memory_limit);
            tried(closed);
            if (!keep_if_fewer_fail(std::move(closed), false)) break;
            r.filled_holes += filled.holes;
            r.filled_hole_faces += filled.faces;
            r.holes_filled_at_failed_fans += filled.holes;
        }
    };
    // Holes beside failed fans are filled after the refinements, as a last resort: the input's
    // holes stay where a refinement places the fans. Pinholes (a missing triangle or two) go
    // first where refining would cost much: a refinement try solves for every form on up to 8
    // times the faces, and a scan's pinholes give double covers of genus 100 and more, where
    // filling them first places more fans for a fraction of the time (bench/README, "Pinholes
    // first").
    const double forms = 2.0 * r.conformal.basis.genus;
    if (forms * static_cast<double>(r.traced_input->n_faces()) > kPinholesFirstFaceForms)
        fill_holes_at_failed_fans(std::min(kPinholeEdges, work.options.holes.longest_fillable_loop));
    refine();
    fill_holes_at_failed_fans(work.options.holes.longest_fillable_loop);
    // Where regions still fail, they may grow once more from their irregular vertices only
    // (kernels::FanOptions::regrow_failed), kept where fewer fail. Only here, on the surface
    // the refinements chose: as what a region takes changes what the later ones find, it
    // can fail more elsewhere, and a surface that it makes look better can stop refinements
    // that would have placed every fan (polygon_mesh: 3 failed regions left instead of none).
    // Where no failed region could grow again, that run would repeat this one: it is skipped.
    if (r.regular.failed_regions > 0 && r.regular.regrowable_failures > 0) {
        kernels::FanOptions regrow;
        regrow.regrow_failed = true;
        kernels::RegularisedForm regrown = regularised(work, regrow);
        if (regrown.failed_weight < r.regular.failed_weight) r.regular = std::move(regrown);
    }
    if (r.is_torus()) {  // no zeros; the parallelogram made a rectangle (the paper's affine step)
        const std::array<Complex, 2> period = generator_periods(r);
        r.torus_periods = kernels::reduce_lattice(period[0], period[1]);
        r.regular.tau = kernels::rectangle_form(r.regular.tau, r.torus_periods[0], r.torus_periods[1]);
    }
    const MeshView& traced = *r.traced_input;
    const std::vector<kernels::ZeroRegion>& regions = work.regions;

    // Starts (none on a torus): each zero's fan centre, or (fan failed) its cluster's vertex
    // that turns most in the image (its curves are the ones the tracer finds there: a regular
    // point sends too few), the zero's saddle vertex first on ties.
    std::vector<Index> regular_of(traced.n_vertices(), -1);
    for (Index v = 0; v < r.regular.mesh.n_vertices(); ++v)
        if (r.regular.original_vertex[v] >= 0) regular_of[r.regular.original_vertex[v]] = v;
    std::vector<int> turns;  // of the regularised mesh's image, where some region failed
    if (r.regular.failed_regions > 0) {
        const MeshView& m = r.regular.mesh;
        std::vector<Complex> along(m.n_halfedges());
        for (Index h = 0; h < m.n_halfedges(); ++h) along[h] = kernels::form_along(m, r.regular.tau, h);
        std::vector<char> boundary(m.n_vertices());  // half-turns there, as the fans count them
        for (Index v = 0; v < m.n_vertices(); ++v) boundary[v] = m.is_boundary_halfedge(m.vertex_halfedge[v]);
        turns = kernels::image_turns(m.F, m.n_vertices(), along, boundary).turns;
    }
    for (std::size_t i = 0; i < regions.size(); ++i) {
        if (regions[i].order <= 0) continue;
        Index v = r.regular.region_vertex[i];
        if (v < 0) {
            const Index fallback = regions[i].vertex >= 0 ? regions[i].vertex
                                   : regions[i].face >= 0 ? traced.F(regions[i].face, 0)
                                                          : regions[i].vertices.front();
            v = regular_of[fallback];
            for (Index u : regions[i].vertices)
                if (const Index w = regular_of[u]; w >= 0 && (v < 0 || turns[w] > turns[v])) v = w;
        }
        if (v < 0) continue;  // a vertex listed twice starts its curves once (trace_trajectories)
        r.zero_vertices.push_back(v);
    }
    clock.lap("zero_fans");
    for (const auto& stage : refined_conformal) r.timings_ms.back().second -= stage.second;
    add_stage_times(r.timings_ms, refined_conformal);
}

// A mesh and closed form with face `f` split at the point of barycentric weights `w` (a new
// vertex, the last): the form's image of the point is the same weighting of its corners'.
std::pair<MeshView, Eigen::VectorXcd> with_point_in_face(const MeshView& m, const Eigen::VectorXcd& tau, Index f,
                                                        const std::array<double, 3>& w) {
    const Index q = m.n_vertices(), nf = m.n_faces();
    std::vector<Complex> along(m.n_halfedges());
    for (Index h = 0; h < m.n_halfedges(); ++h) along[h] = kernels::form_along(m, tau, h);
    PointMatrix V(q + 1, 3);
    V.topRows(q) = m.V;
    V.row(q) = w[0] * m.V.row(m.F(f, 0)) + w[1] * m.V.row(m.F(f, 1)) + w[2] * m.V.row(m.F(f, 2));
    TriangleMatrix F(nf + 2, 3);
    F.topRows(nf) = m.F;
    F.row(f) << m.F(f, 0), m.F(f, 1), q;
    F.row(nf) << m.F(f, 1), m.F(f, 2), q;
    F.row(nf + 1) << m.F(f, 2), m.F(f, 0), q;
    // Twins carried over (no new pairing by vertex pairs): f's sides 1 and 2 become the first
    // sides of the new faces; the three spokes pair up.
    std::vector<Index> twin(m.twin.begin(), m.twin.end());
    twin.resize(3 * static_cast<std::size_t>(nf + 2), kNoHalfedge);
    const Index b_side = 3 * nf, c_side = 3 * (nf + 1);
    for (const auto& [old_h, new_h] : {std::pair{3 * f + 1, b_side}, {3 * f + 2, c_side}}) {
        twin[new_h] = m.twin[old_h];
        if (m.twin[old_h] != kNoHalfedge) twin[m.twin[old_h]] = new_h;
    }
    const auto pair_up = [&](Index h, Index k) { twin[h] = k, twin[k] = h; };
    pair_up(3 * f + 1, b_side + 2);      // b -> q, q -> b
    pair_up(b_side + 1, c_side + 2);     // c -> q, q -> c
    pair_up(c_side + 1, 3 * f + 2);      // a -> q, q -> a
    MeshView split = make_mesh_view(std::move(V), std::move(F), std::move(twin));
    // Each new face lies in an old one (the pieces of f in f); positions in that face's chart.
    const auto position = [&](Index old_face, Index v) {
        Complex point = 0;
        for (int k = 0; k < 3; ++k) {
            const Complex corner = kernels::chart_corner(along, old_face, k);
            if (m.F(old_face, k) == v) return corner;
            point += w[k] * corner;
        }
        return point;  // v = q, inside f
    };
    Eigen::VectorXcd split_tau(split.n_edges());
    for (Index e = 0; e < split.n_edges(); ++e) {
        const Index h = split.edge_halfedge[e], g = MeshView::face(h);
        const Index old_face = g < nf && g != f ? g : f;
        split_tau(e) = position(old_face, split.head(h)) - position(old_face, split.tail(h));
    }
    return {std::move(split), std::move(split_tau)};
}

// The face a torus's corner goes in: the first whose image is well shaped (quality
// 4 sqrt(3) area / sum of squared sides at least 1/2, area at least half the mean), else the best
// shaped. Not simply face 0: inside a cluster of faces whose images collapse onto a point
// (dancer_25k), the sides leave the corner along a path of no length and, coming round again,
// pass beside the cluster instead of through the corner.
Index corner_face(const MeshView& mesh, const Eigen::VectorXcd& tau) {
    const auto image_area = [&](Index f) {
        const Complex a = kernels::form_along(mesh, tau, 3 * f), b = kernels::form_along(mesh, tau, 3 * f + 1);
        const double squares = std::norm(a) + std::norm(b) + std::norm(a + b);
        const double area = 0.5 * kernels::cross(a, a + b);
        return std::pair{area, squares > 0 ? 4 * std::sqrt(3.0) * area / squares : 0.0};  // and quality
    };
    double total = 0;
    for (Index f = 0; f < mesh.n_faces(); ++f) total += image_area(f).first;
    const double mean = total / static_cast<double>(mesh.n_faces());
    Index best = 0;
    double best_quality = -std::numeric_limits<double>::infinity();
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const auto [area, quality] = image_area(f);
        if (quality >= 0.5 && area >= 0.5 * mean) return f;
        if (quality > best_quality) best = f, best_quality = quality;
    }
    return best;
}

// The torus's rectangle sides: the vertical and the horizontal line through `corner`, each
// closing after one period; none unless both close there (rounding, folds of the form).
std::vector<Trajectory> torus_sides(const MeshView& mesh, const Eigen::VectorXcd& tau, Index corner,
                                    const std::array<Complex, 2>& periods) {
    const TrajectoryFamily both[] = {TrajectoryFamily::Vertical, TrajectoryFamily::Horizontal};
    // A side that closes is one period long: |A| Im(B / A) vertical, |A| horizontal, in units of
    // sqrt(area) = |A| sqrt(Im(B / A)) at most sqrt(Im(B / A)) (>= sqrt(3) / 2 when reduced). A
    // curve lost in a fold stops a little after that.
    kernels::TraceOptions options;
    options.length_cap = 1.5 * std::sqrt((periods[1] / periods[0]).imag()) + 1;
    const std::vector<Trajectory> traced =
        kernels::trace_trajectories(mesh, tau, std::span(&corner, 1), both, options);
    // Each line is traced from both ends of its one curve; the first copy is kept.
    std::vector<Trajectory> sides;
    for (TrajectoryFamily family : both) {
        const auto closed = std::find_if(traced.begin(), traced.end(), [&](const Trajectory& t) {
            return t.family == family && t.end == Trajectory::End::Zero && t.end_vertex == corner;
        });
        if (closed == traced.end()) return {};
        sides.push_back(*closed);
    }
    return sides;
}

void trace(SegmentationWork& work) {
    SegmentationResult& r = work.result;
    StageClock clock(r.timings_ms);
    if (r.is_torus()) {
        // The corner is a point inside a face, away from the mesh's vertex rows: on a symmetric
        // mesh the lines through a vertex run through other vertices and the cut would leave
        // slivers. (Where the form folds, the lines may not make one disk: see cut.)
        const Index face = corner_face(r.regular.mesh, r.regular.tau);
        auto [mesh, tau] = with_point_in_face(r.regular.mesh, r.regular.tau, face, {0.30711, 0.32735, 0.36554});
        const Index corner = mesh.n_vertices() - 1;
        r.trajectories = torus_sides(mesh, tau, corner, r.torus_periods);
        if (!r.trajectories.empty()) {  // the regularised mesh gets the corner and its face's pieces
            kernels::RegularisedForm& reg = r.regular;
            reg.mesh = std::move(mesh);
            reg.tau = std::move(tau);
            reg.original_vertex.push_back(-1);
            reg.original_face.insert(reg.original_face.end(), 2, reg.original_face[face]);
        }
        clock.lap("tracing");
        return;
    }
    std::vector<TrajectoryFamily> families{TrajectoryFamily::Vertical};
    if (work.options.mode == SegmentMode::Layout) families.push_back(TrajectoryFamily::Horizontal);
    kernels::TraceOptions trace_options;
    trace_options.motorcycle = work.options.mode == SegmentMode::Layout;
    // Only Re tau has integer periods: the vertical family alone closes.
    trace_options.closed_leaves =
        r.conformal.form == FormChoice::IntegerPeriods && work.options.mode == SegmentMode::Vertical;
    r.trajectories = kernels::trace_trajectories(r.regular.mesh, r.regular.tau, r.zero_vertices, families, trace_options);
    clock.lap("tracing");
}

void cut(SegmentationWork& work) {
    SegmentationResult& r = work.result;
    StageClock clock(r.timings_ms);
    std::vector<Index> extra_border;
    std::vector<char> border;
    const auto cut_and_fill = [&] {
        r.cut = kernels::cut_along_trajectories(r.regular.mesh, r.regular.tau, r.trajectories, extra_border);
        border.assign(r.cut.mesh.n_edges(), 0);
        for (Index e = 0; e < r.cut.mesh.n_edges(); ++e) border[e] = r.cut.edge_trajectory[e] != kernels::kNoBorder;
        r.patches = kernels::compute_patches(r.cut.mesh, r.cut.tau, border);
    };
    const auto open_along_homology_cut = [&] {
        r.trajectories.clear();
        extra_border = homology_cut_labels(r);
        cut_and_fill();
    };
    cut_and_fill();
    // A torus whose sides did not close, or cut it into anything but one disk (a fold of the
    // form they crossed), opens along its homology cut graph instead.
    if (r.is_torus() && (r.trajectories.empty() || r.cut.skipped_segments > 0 || r.patches.info.size() != 1 ||
                         r.patches.info[0].type != kernels::PatchInfo::Type::Disk))
        open_along_homology_cut();
    // Layout mode promises rectangles. A disk with a concave corner (where a zero whose fan
    // failed sent no curve into it) is split by the curve from that corner, before each
    // cylinder round; a cylinder (closed curves that no critical trajectory crosses) is opened
    // by the transversal through a vertex inside it. Each round redoes the cut.
    const std::size_t critical = r.trajectories.size();
    const auto add_and_cut = [&](const std::vector<Trajectory>& transversals) {
        r.trajectories.insert(r.trajectories.end(), transversals.begin(), transversals.end());
        cut_and_fill();
    };
    for (int corner_rounds = 0, cylinder_rounds = 0; work.options.mode == SegmentMode::Layout && !r.is_torus();) {
        if (corner_rounds++ < kCornerRounds) {
            const std::vector<Trajectory> corners = kernels::corner_transversals(
                r.regular.mesh, r.regular.tau, r.zero_vertices, r.trajectories, r.cut, border, r.patches);
            if (!corners.empty()) {
                // Undone where the cutter cannot take them whole (a patch that is no true disk,
                // where it skipped pieces of curves already, gets nothing from them).
                const std::size_t before = r.trajectories.size();
                const Index skipped = r.cut.skipped_segments;
                add_and_cut(corners);
                if (r.cut.skipped_segments > skipped) {
                    r.trajectories.resize(before);
                    cut_and_fill();
                    corner_rounds = kCornerRounds;
                }
                continue;
            }
        }
        if (cylinder_rounds++ >= kCylinderRounds) break;
        const std::vector<Trajectory> cylinders = kernels::cylinder_transversals(
            r.regular.mesh, r.regular.tau, r.zero_vertices, r.trajectories, r.cut, border, r.patches);
        if (cylinders.empty()) break;
        add_and_cut(cylinders);
    }
    r.transversals = static_cast<Index>(r.trajectories.size() - critical);
    clock.lap("cutting");
    // Where the form's uv folds (zero regions the fans could not regularise), a valid uv on
    // the same rectangle instead; reported per patch.
    r.patches = kernels::repair_folded_patches(r.cut.mesh, border, std::move(r.patches));
    // A torus whose sides cut a disk the repair could not lay out without flips (rounding where
    // a fold the fans left spans long limbs: dancer_25k stretched 2.5 : 0.6) tries its homology
    // cut too, and keeps the layout with fewer flipped uv triangles (the sides' on ties).
    if (r.is_torus() && !r.trajectories.empty() && flipped_uv_triangles(r.patches) > 0) {
        std::vector<Trajectory> sides = std::move(r.trajectories);
        kernels::CutMesh side_cut = std::move(r.cut);
        kernels::Patches side_patches = std::move(r.patches);
        std::vector<char> side_border = std::move(border);
        open_along_homology_cut();
        r.patches = kernels::repair_folded_patches(r.cut.mesh, border, std::move(r.patches));
        if (flipped_uv_triangles(r.patches) >= flipped_uv_triangles(side_patches)) {
            r.trajectories = std::move(sides);
            r.cut = std::move(side_cut);
            r.patches = std::move(side_patches);
            border = std::move(side_border);
        }
    }
    std::vector<char> is_zero(r.cut.mesh.n_vertices(), 0);
    for (Index v : r.zero_vertices) is_zero[v] = 1;  // the cut keeps the traced mesh's vertex ids
    r.complex = kernels::flow_complex(r.cut.mesh, r.cut.edge_trajectory, r.patches.face_patch, is_zero);
    r.collapsed = kernels::collapsed_area(r.cut.mesh, r.patches.corner_uv, kCollapsedScale);
    clock.lap("patches");
}

namespace {

// Every stage in order (segment(); tips_where_collapsed segments again).
SegmentationResult all_stages(std::shared_ptr<const MeshView> input, const SegmentOptions& options,
                              FactorizationCache* cache) {
    SegmentationWork work = prepare(std::move(input), options);
    conformal_stage::run_after_prepare(work.conformal, cache);
    zeros(work);
    fans(work);
    trace(work);
    cut(work);
    tips_where_collapsed(work);
    return std::move(work.result);
}

// The vertex of `mesh` at `point`, else the nearest one; ties to the smaller id.
Index vertex_at(const MeshView& mesh, const Eigen::RowVector3d& point) {
    Index best = 0;
    double best_distance = std::numeric_limits<double>::infinity();
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        if (const double d = (mesh.V.row(v) - point).squaredNorm(); d < best_distance) best = v, best_distance = d;
    return best;
}

}  // namespace

void tips_where_collapsed(SegmentationWork& work) {
    constexpr int kRounds = 2;
    constexpr double kLeastShare = 0.01;  // of the surface's area, collapsed in one limb
    if (!work.options.tips_where_collapsed || !work.options.tips.empty()) return;  // given tips stay
    for (int round = 0; round < kRounds; ++round) {
        const SegmentationResult& r = work.result;
        // A tip on a vertex that a refinement added (-1) could not be given again.
        if (r.tips.empty() || std::find(r.tips.begin(), r.tips.end(), -1) != r.tips.end() ||
            r.collapsed.fraction() < kLeastShare)
            return;
        std::vector<Index> tips = r.tips;
        for (Index v : kernels::collapsed_limb_tips(r.cut.mesh, r.collapsed.faces, kLeastShare)) {
            if (static_cast<int>(tips.size()) >= work.options.max_tips) break;
            // The cut mesh keeps the positions of the given mesh's vertices it has.
            const Index tip = vertex_at(*work.given, r.cut.mesh.V.row(v));
            if (std::find(tips.begin(), tips.end(), tip) == tips.end()) tips.push_back(tip);
        }
        if (tips.size() == r.tips.size()) return;
        SegmentOptions options = work.options;
        options.tips = tips;
        options.tips_where_collapsed = false;
        SegmentationResult more;
        try {
            more = all_stages(work.given, options, nullptr);  // a new pattern: no cache
        } catch (const InvalidInput&) {  // a hole there cuts the mesh or wraps a handle
            return;
        } catch (const SolverFailure&) {
            return;
        } catch (const ResourceLimit&) {
            ++work.result.tries_over_memory_limit;
            if (options.stop_at_memory_limit) throw;
            return;
        }
        const bool better = more.collapsed.fraction() < r.collapsed.fraction() &&
                            flipped_uv_triangles(more.patches) <= flipped_uv_triangles(r.patches) &&
                            unfinished_trajectories(more) <= unfinished_trajectories(r) &&
                            more.regular.failed_weight <= r.regular.failed_weight;
        if (!better) {
            add_stage_times(work.result.timings_ms, more.timings_ms);
            return;
        }
        add_stage_times(more.timings_ms, r.timings_ms);
        more.tips_added_where_collapsed = r.tips_added_where_collapsed + static_cast<int>(tips.size() - r.tips.size());
        work.result = std::move(more);
    }
}

}  // namespace segment_stage

SegmentationResult segment(const MeshView& input, const SegmentOptions& options, FactorizationCache* cache) {
    // The caller owns the mesh: a non-owning pointer to it.
    return segment_stage::all_stages(std::shared_ptr<const MeshView>(std::shared_ptr<const MeshView>{}, &input),
                                     options, cache);
}

namespace {

const char* end_name(Trajectory::End end) {
    switch (end) {
        case Trajectory::End::Zero: return "zero";
        case Trajectory::End::Boundary: return "boundary";
        case Trajectory::End::Collision: return "collision";
        case Trajectory::End::LengthCap: return "length_cap";
    }
    return "?";
}

const char* type_name(kernels::PatchInfo::Type type) {
    switch (type) {
        case kernels::PatchInfo::Type::Disk: return "disk";
        case kernels::PatchInfo::Type::Cylinder: return "cylinder";
        case kernels::PatchInfo::Type::Other: return "other";
    }
    return "?";
}

// Vertex ids, null for a tip that is no input vertex (SegmentationResult::tips).
nlohmann::json tips_json(const std::vector<Index>& tips) {
    nlohmann::json out = nlohmann::json::array();
    for (Index tip : tips) out.push_back(tip >= 0 ? nlohmann::json(tip) : nlohmann::json(nullptr));
    return out;
}

}  // namespace

nlohmann::json segmentation_report(const SegmentationResult& r) {
    const kernels::ZeroSet& z = r.zeros;
    nlohmann::json zeros = nlohmann::json::array();
    for (const kernels::Zero& zero : z.zeros) {
        nlohmann::json j = {{"order", zero.order}, {"cluster", zero.cluster}};
        j["vertex"] = zero.vertex;
        if (zero.point.face >= 0) {
            j["face"] = zero.point.face;
            j["barycentric"] = zero.point.barycentric;
            j["position"] = zero.point.position;
        }
        zeros.push_back(j);
    }
    nlohmann::json types = {{"disk", 0}, {"cylinder", 0}, {"other", 0}};
    Index flipped = 0, form_flipped = 0, repaired = 0;
    double rect_max = 0, distortion_max = 0, distortion_sum = 0;
    Index faces = 0;
    nlohmann::json patches = nlohmann::json::array();
    for (const kernels::PatchInfo& p : r.patches.info) {
        types[type_name(p.type)] = types[type_name(p.type)].get<int>() + 1;
        flipped += p.flipped_uv_triangles;
        form_flipped += p.form_flipped_uv_triangles;
        repaired += p.repaired();
        rect_max = std::max(rect_max, p.rectangle_error);
        distortion_max = std::max(distortion_max, p.distortion_max);
        distortion_sum += p.distortion_mean * p.faces;
        faces += p.faces;
        patches.push_back({{"type", type_name(p.type)},
                           {"faces", p.faces},
                           {"euler_characteristic", p.euler_characteristic},
                           {"border_loops", p.border_loops},
                           {"width", p.width},
                           {"height", p.height},
                           {"rectangle_error", p.rectangle_error},
                           {"flipped_uv_triangles", p.flipped_uv_triangles},
                           {"repaired", p.repaired()},
                           {"form_flipped_uv_triangles", p.form_flipped_uv_triangles},
                           {"distortion_mean", p.distortion_mean},
                           {"distortion_max", p.distortion_max}});
    }
    nlohmann::json ends = {{"zero", 0}, {"boundary", 0}, {"collision", 0}, {"length_cap", 0}};
    for (const Trajectory& t : r.trajectories) ends[end_name(t.end)] = ends[end_name(t.end)].get<int>() + 1;
    return {
        {"genus", r.input_genus},
        {"working_genus", r.conformal.basis.genus},
        {"double_covered", r.conformal.double_covered},
        {"mode", r.mode == SegmentMode::Layout ? "layout" : "vertical"},
        {"form", form_name(r.conformal.form)},
        {"tips", tips_json(r.tips)},
        {"tip_refinements", r.tip_refinements},
        {"collapsed_area", r.collapsed.fraction()},
        {"tips_added_where_collapsed", r.tips_added_where_collapsed},
        {"filled_holes",
         {{"holes", r.filled_holes},
          {"faces", r.filled_hole_faces},
          {"left_open", r.holes_left_open},
          {"at_failed_fans", r.holes_filled_at_failed_fans}}},
        {"fan_refinements", r.fan_refinements},
        {"tries_over_memory_limit", r.tries_over_memory_limit},
        {"zero_count", z.total_order},
        {"torus_modulus", r.is_torus() ? nlohmann::json::array({(r.torus_periods[1] / r.torus_periods[0]).real(),
                                                                 (r.torus_periods[1] / r.torus_periods[0]).imag()})
                                       : nlohmann::json()},
        {"zero_index_total", z.total_index},
        {"zeros", zeros},
        {"saddle_triangulation", z.intrinsic ? "intrinsic_delaunay" : "mesh"},
        {"artifacts", z.artifact_clusters},
        {"fold_clusters", z.fold_clusters},
        {"flat_clusters", z.flat_clusters},
        {"unresolved_vertices", z.unresolved_vertices},
        {"artifact_details",
         {{"clusters", z.artifact_clusters},
          {"merged_negative_clusters", z.merged_negative_clusters},
          {"nonpositive_winding_vertices", z.nonpositive_winding_vertices},
          {"flipped_faces", std::count(z.face_flip.begin(), z.face_flip.end(), 1)}}},
        {"zero_fans",
         {{"failed", r.regular.failed_regions},
          {"failed_weight", r.regular.failed_weight},
          {"merged", r.regular.merged_regions},
          {"removed_vertices", r.regular.removed_vertices},
          {"edge_flips", r.regular.edge_flips},
          {"flipped_faces", r.regular.flipped_faces}}},
        {"trajectories", r.trajectories.size()},
        {"transversals", r.transversals},
        {"trajectory_ends", ends},
        {"unfinished_trajectories", unfinished_trajectories(r)},
        {"skipped_segments", r.cut.skipped_segments},
        {"patches", patches},
        {"patch_count", r.patches.info.size()},
        {"patch_types", types},
        {"flipped_uv_triangles", flipped},
        {"repaired_patches", repaired},
        {"form_flipped_uv_triangles", form_flipped},
        {"rectangle_error_max", rect_max},
        {"conformal_distortion", {{"mean", faces ? distortion_sum / faces : 0.0}, {"max", distortion_max}}},
        {"vertices", r.cut.mesh.n_vertices()},
        {"faces", r.cut.mesh.n_faces()},
        {"timings_ms", timings_report(r.timings_ms)},
    };
}

nlohmann::json complex_report(const SegmentationResult& r) {
    const kernels::FlowComplex& g = r.complex;
    nlohmann::json nodes = nlohmann::json::array(), edges = nlohmann::json::array(), faces = nlohmann::json::array();
    for (const auto& n : g.nodes) {
        const auto p = r.cut.mesh.V.row(n.vertex);
        nodes.push_back({{"vertex", n.vertex}, {"zero", n.zero}, {"position", {p(0), p(1), p(2)}}});
    }
    for (const auto& piece : g.pieces) {
        std::string kind = "boundary";
        if (piece.label == kHomologyCut) kind = "homology_cut";
        else if (piece.label >= 0)
            kind = r.trajectories[piece.label].family == TrajectoryFamily::Vertical ? "vertical" : "horizontal";
        edges.push_back({{"from", piece.from},
                         {"to", piece.to},
                         {"kind", kind},
                         {"trajectory", piece.label},
                         {"patches", piece.patches},
                         {"vertices", piece.vertices}});
    }
    for (std::size_t p = 0; p < g.patch_pieces.size(); ++p)
        faces.push_back({{"patch", p}, {"edges", g.patch_pieces[p]}});
    return {{"format", "holoflow flow complex 1"}, {"vertices", nodes}, {"edges", edges}, {"faces", faces}};
}

void write_segmentation_folder(const std::filesystem::path& folder, const SegmentationResult& result,
                               const nlohmann::json& report) {
    write_segmentation_folder(folder, std::span(&result, 1), report);
}

void write_segmentation_folder(const std::filesystem::path& folder, std::span<const SegmentationResult> result,
                               const nlohmann::json& report) {
    prepare_output_folder(folder);
    remove_stale_temporaries(folder, kSegmentationFiles);
    const SegmentationPicture picture = segmentation_picture(result);
    FileSet files;  // in kSegmentationFiles order: segmentation.json marks a whole set
    files.add(folder / "segments.ply", [&](std::ostream& out) { write_segments_ply(out, picture); });
    files.add(folder / "patches.obj", [&](std::ostream& out) { write_patches_obj(out, picture); });
    files.add(folder / "trajectories.obj", [&](std::ostream& out) { write_trajectories_obj(out, picture); });
    files.add(folder / "domains.svg", [&](std::ostream& out) { write_domains_svg(out, picture); });
    files.add(folder / "complex.json", json_text(complex_report(result), 1) + "\n");
    files.add(folder / "segmentation.json", json_text(report) + "\n");
    files.commit();
}

SegmentationPicture segmentation_picture(const SegmentationResult& r) {
    SegmentationPicture pic;
    pic.V = r.cut.mesh.V;
    pic.F = r.cut.mesh.F;
    pic.face_patch = r.patches.face_patch;
    pic.corner_uv = r.patches.corner_uv;
    for (const auto& p : r.patches.info) pic.patch_size.push_back({p.width, p.height});
    // Trajectories as polylines along the cut mesh: the pieces of the complex, by family.
    for (const auto& piece : r.complex.pieces) {
        SegmentationPicture::Polyline line;
        line.family = piece.label < 0 ? SegmentationPicture::Family::Boundary
                      : r.trajectories[piece.label].family == TrajectoryFamily::Vertical
                          ? SegmentationPicture::Family::Vertical
                          : SegmentationPicture::Family::Horizontal;
        for (Index v : piece.vertices) line.points.push_back(r.cut.mesh.V.row(v).transpose());
        pic.trajectories.push_back(std::move(line));
    }
    return pic;
}

StageTimes summed_times(std::span<const SegmentationResult> components) {
    HOLOFLOW_REQUIRE(!components.empty(), "no component to time");
    StageTimes sum = components.front().timings_ms;
    for (const SegmentationResult& r : components.subspan(1)) add_stage_times(sum, r.timings_ms);
    return sum;
}

nlohmann::json segmentation_report(std::span<const SegmentationResult> components) {
    HOLOFLOW_REQUIRE(!components.empty(), "no component to report");
    if (components.size() == 1) return segmentation_report(components[0]);
    nlohmann::json parts = nlohmann::json::array();
    for (const SegmentationResult& r : components) parts.push_back(segmentation_report(r));
    // Every key of the first report, merged over all: numbers add up, objects of numbers add up
    // per key, lists join (entries tagged with their component); the rest below.
    nlohmann::json total = parts[0];
    const auto add = [](nlohmann::json& into, const nlohmann::json& value) {
        if (into.is_number_integer() && value.is_number_integer()) into = into.get<std::int64_t>() + value.get<std::int64_t>();
        else if (into.is_number() && value.is_number()) into = into.get<double>() + value.get<double>();
    };
    for (auto& [key, value] : total.items()) {
        if (value.is_array()) {
            nlohmann::json joined = nlohmann::json::array();
            for (std::size_t c = 0; c < parts.size(); ++c)
                for (nlohmann::json entry : parts[c][key]) {
                    if (!entry.is_object()) entry = {{"vertex", entry}};  // tips: vertex ids
                    entry["component"] = c;
                    joined.push_back(entry);
                }
            value = joined;
        } else if (value.is_number()) {
            for (std::size_t c = 1; c < parts.size(); ++c) add(value, parts[c][key]);
        } else if (value.is_object() && key != "conformal_distortion" && key != "timings_ms") {
            for (std::size_t c = 1; c < parts.size(); ++c)
                for (const auto& [name, number] : parts[c][key].items()) {
                    if (!value.contains(name)) value[name] = number;
                    else add(value[name], number);
                }
        }
    }
    double rectangle_error = 0, distortion_max = 0, distortion_sum = 0, faces = 0;
    bool double_covered = false;
    for (const nlohmann::json& part : parts) {
        rectangle_error = std::max(rectangle_error, part["rectangle_error_max"].get<double>());
        distortion_max = std::max(distortion_max, part["conformal_distortion"]["max"].get<double>());
        distortion_sum += part["conformal_distortion"]["mean"].get<double>() * part["faces"].get<double>();
        faces += part["faces"].get<double>();
        double_covered = double_covered || part["double_covered"].get<bool>();
    }
    total["rectangle_error_max"] = rectangle_error;
    kernels::CollapsedArea collapsed;  // the areas summed (no per-face flags)
    for (const SegmentationResult& r : components) {
        collapsed.collapsed += r.collapsed.collapsed;
        collapsed.total += r.collapsed.total;
    }
    total["collapsed_area"] = collapsed.fraction();
    total["conformal_distortion"] = {{"mean", faces > 0 ? distortion_sum / faces : 0.0}, {"max", distortion_max}};
    total["double_covered"] = double_covered;
    // Vertical mode chooses the form per component (planar domains keep the generic one).
    for (const nlohmann::json& part : parts)
        if (part["form"] != parts[0]["form"]) total["form"] = "mixed";
    total["timings_ms"] = timings_report(summed_times(components));
    total["torus_modulus"] = nullptr;
    total["component_count"] = parts.size();
    total["components"] = std::move(parts);
    return total;
}

nlohmann::json complex_report(std::span<const SegmentationResult> components) {
    HOLOFLOW_REQUIRE(!components.empty(), "no component to report");
    if (components.size() == 1) return complex_report(components[0]);
    nlohmann::json total = complex_report(components[0]);
    const auto shifted = [](const nlohmann::json& id, std::int64_t by) {
        return id.get<std::int64_t>() < 0 ? id.get<std::int64_t>() : id.get<std::int64_t>() + by;
    };
    std::int64_t vertices = components[0].cut.mesh.n_vertices(), nodes = total["vertices"].size(),
                 edges = total["edges"].size(), patches = components[0].patches.info.size(),
                 trajectories = components[0].trajectories.size();
    for (std::size_t c = 1; c < components.size(); ++c) {
        const SegmentationResult& r = components[c];
        nlohmann::json part = complex_report(r);
        for (nlohmann::json node : part["vertices"]) {
            node["vertex"] = node["vertex"].get<std::int64_t>() + vertices;
            total["vertices"].push_back(node);
        }
        for (nlohmann::json edge : part["edges"]) {
            edge["from"] = shifted(edge["from"], nodes);
            edge["to"] = shifted(edge["to"], nodes);
            edge["trajectory"] = shifted(edge["trajectory"], trajectories);
            for (auto& p : edge["patches"]) p = shifted(p, patches);
            for (auto& v : edge["vertices"]) v = v.get<std::int64_t>() + vertices;
            total["edges"].push_back(edge);
        }
        for (nlohmann::json face : part["faces"]) {
            face["patch"] = face["patch"].get<std::int64_t>() + patches;
            for (auto& e : face["edges"]) e = e.get<std::int64_t>() + edges;
            total["faces"].push_back(face);
        }
        vertices += r.cut.mesh.n_vertices();
        nodes += part["vertices"].size();
        edges += part["edges"].size();
        patches += r.patches.info.size();
        trajectories += r.trajectories.size();
    }
    return total;
}

SegmentationPicture segmentation_picture(std::span<const SegmentationResult> components) {
    HOLOFLOW_REQUIRE(!components.empty(), "no component to draw");
    if (components.size() == 1) return segmentation_picture(components[0]);
    std::vector<SegmentationPicture> parts;
    Index n_vertices = 0, n_faces = 0;
    for (const SegmentationResult& r : components) {
        parts.push_back(segmentation_picture(r));
        n_vertices += static_cast<Index>(parts.back().V.rows());
        n_faces += static_cast<Index>(parts.back().F.rows());
    }
    SegmentationPicture pic;
    pic.V.resize(n_vertices, 3);
    pic.F.resize(n_faces, 3);
    Index vertex_offset = 0, face_offset = 0, patch_offset = 0;
    for (SegmentationPicture& part : parts) {
        pic.V.middleRows(vertex_offset, part.V.rows()) = part.V;
        pic.F.middleRows(face_offset, part.F.rows()) = part.F.array() + vertex_offset;
        for (Index patch : part.face_patch) pic.face_patch.push_back(patch + patch_offset);
        pic.corner_uv.insert(pic.corner_uv.end(), part.corner_uv.begin(), part.corner_uv.end());
        pic.patch_size.insert(pic.patch_size.end(), part.patch_size.begin(), part.patch_size.end());
        for (auto& line : part.trajectories) pic.trajectories.push_back(std::move(line));
        vertex_offset += static_cast<Index>(part.V.rows());
        face_offset += static_cast<Index>(part.F.rows());
        patch_offset += part.n_patches();
    }
    return pic;
}

}  // namespace holoflow::engine
