// The numerical kernels of `holoflow segment`, one benchmark each, on the inputs the pipeline
// hands them, for turbine (genus 11, CAD triangles) after L = 0, 1, 2 Loop subdivisions (18.5k,
// 73.8k, 295k faces), named `BM_kernel_<what>/loop:L`:
//   laplacian_assembly   cotan_weights_from_lengths + assemble_laplacian (intrinsic lengths)
//   intrinsic_delaunay   intrinsic_delaunay carrying the 2g closed forms
//   carry_forms          carry_forms of the 2g closed forms onto that intrinsic triangulation
//   cholesky_analyse     CholeskySymbolic::analyse of that Laplacian
//   cholesky_factorize   CholeskyFactor::factorize, numeric only, reusing the analysis
//   cholesky_solve       one solve with the 2g harmonic right-hand sides
//   homology_basis       compute_homology_basis (tree-cotree, closed forms, cut graph)
//   hodge_star           wedge_matrix of the closed forms + hodge_star, as the pipeline's stage
//   integrate_form       integrate_form of the chosen holomorphic form
//   find_zeros           find_zeros of that form
//   regularise_zeros     regularise_zeros of the zero clusters the pipeline's fan stage gets first
//   trace_trajectories   trace_trajectories on the regularised form, layout mode
//   cut_along_trajectories  cut_along_trajectories by the pipeline's curves (transversals too)
//   compute_patches      compute_patches on that cut (flood fill, uv, per-patch measures)
//   make_mesh_view       make_mesh_view of that cut's triangles with its twins (the checks every
//                        kernel's output mesh passes: edges, vertex fans)
//   make_mesh_view_scattered, compute_patches_scattered  the same on that cut with its faces and
//                        vertices in a seeded random order (the order of decimated meshes)
// Everything a benchmark reads is built once per level outside timing (the segmentation
// results come from one engine::segment call); each benchmark validates one call before timing.
//
// `kernels_bench --write-subdivided=PATH,MESH,SCHEME,LEVEL` writes MESH (a corpus name such as
// eight, or a mesh file) after LEVEL steps of SCHEME (loop or midpoint) to PATH as OFF and exits
// without benchmarking; bench/scaling.sh makes its inputs with it.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <oneapi/tbb/task_arena.h>
#include <oneapi/tbb/version.h>

#include "bench_support.h"
#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/output.h"
#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/harmonic.h"
#include "holoflow/kernels/holomorphic.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/patches.h"
#include "holoflow/kernels/subdivision.h"
#include "holoflow/kernels/topology.h"
#include "holoflow/kernels/trajectories.h"
#include "holoflow/kernels/zero_fans.h"
#include "holoflow/kernels/zeros.h"

namespace {

using holoflow::Index;
using holoflow::MeshView;
namespace engine = holoflow::engine;
namespace kernels = holoflow::kernels;
using holoflow::bench::full_matrix;
using holoflow::bench::relative_residual;
using holoflow::bench::subdivided;
using holoflow::bench::turbine_loop;

constexpr int kMaxLevel = 2;
constexpr int kLargestLevelIterations = 3;  // level 2 runs 0.1 to 1 s per call: fixed, predictable
constexpr double kResidualTol = 1e-8;      // relative; a direct solve reaches ~1e-12 here
constexpr double kIdentityTol = 1e-10;     // the same sums in another order: rounding only
constexpr double kIntegrationTol = 1e-9;   // per-face closure error relative to the largest uv
constexpr std::uint64_t kSeed = 20261122;  // random test vector of the Laplacian energy check

// Everything the conformal kernels read, built by the conformal pipeline's own stages.
struct ConformalInputs {
    std::shared_ptr<const MeshView> mesh;
    int genus = 0;
    kernels::HomologyBasis homology;
    kernels::IntrinsicTriangulation intrinsic;  // forms: the closed forms carried by the flips
    std::vector<double> w;                      // cotan weights of the intrinsic triangulation
    kernels::LaplacianMatrix L;
    Eigen::MatrixXd rhs;  // -delta(eta), pinned row zero: #V x 2g
    std::shared_ptr<const kernels::CholeskyFactor> factor;
    Eigen::MatrixXd omega;  // harmonic forms on the intrinsic triangulation's edges
};

// What the segmentation kernels read, taken from one engine::segment run.
struct SegmentationInputs {
    std::shared_ptr<const MeshView> mesh;
    int genus = 0;
    kernels::HomologyBasis homology;
    Eigen::VectorXcd tau;
    kernels::RegularisedForm regular;
    std::vector<Index> zero_vertices;
    std::vector<kernels::TrajectoryFamily> families;
    kernels::TraceOptions trace_options;
    std::size_t trajectories = 0;  // what the pipeline traced, for validation
    std::vector<kernels::Trajectory> cut_by;  // the pipeline's curves with its transversals
    kernels::CutMesh cut;                     // what the pipeline cut, for validation
    std::vector<char> border;                 // its border flags
    std::size_t patches = 0;
};

const ConformalInputs& conformal_inputs(int level) {
    static std::map<int, std::unique_ptr<ConformalInputs>> cache;
    if (auto it = cache.find(level); it != cache.end()) return *it->second;
    auto in = std::make_unique<ConformalInputs>();
    in->mesh = turbine_loop(level);
    holoflow::bench::PipelineLaplacian p = holoflow::bench::pipeline_laplacian(in->mesh);
    in->genus = p.work.result.input_genus;
    in->homology = std::move(p.work.result.homology);
    in->intrinsic = std::move(p.work.intrinsic);
    in->w = std::move(p.work.weights);
    in->L = std::move(p.work.laplacian);
    in->rhs = std::move(p.rhs);
    const MeshView& im = in->intrinsic.mesh;
    in->factor =
        kernels::CholeskyFactor::factorize(kernels::CholeskySymbolic::analyse(in->L), in->L);
    in->omega = kernels::plus_gradient(im.E, in->intrinsic.forms, in->factor->solve(in->rhs));
    return *cache.emplace(level, std::move(in)).first->second;
}

const SegmentationInputs& segmentation_inputs(int level) {
    static std::map<int, std::unique_ptr<SegmentationInputs>> cache;
    if (auto it = cache.find(level); it != cache.end()) return *it->second;
    auto in = std::make_unique<SegmentationInputs>();
    in->mesh = turbine_loop(level);
    const engine::SegmentOptions options;  // layout mode, as the CLI's default
    engine::SegmentationResult r = engine::segment(*in->mesh, options);
    // Turbine is closed with genus > 0: no tips, no cover, the form lives on the input itself.
    if (r.conformal.double_covered || !r.tips.empty())
        throw std::runtime_error("expected a closed surface of genus > 0");
    in->mesh = r.traced_input;  // refined where zero fans failed (turbine loop 0): the form's surface
    in->genus = r.input_genus;
    in->homology = std::move(r.conformal.homology);
    in->tau = std::move(r.conformal.tau);
    in->regular = std::move(r.regular);
    in->zero_vertices = std::move(r.zero_vertices);
    // The families and options engine::segment passes in layout mode.
    in->families = {kernels::TrajectoryFamily::Vertical, kernels::TrajectoryFamily::Horizontal};
    in->trace_options.motorcycle = options.mode == engine::SegmentMode::Layout;
    in->trajectories = r.trajectories.size() - static_cast<std::size_t>(r.transversals);
    in->cut_by = std::move(r.trajectories);
    in->cut = std::move(r.cut);
    in->border.assign(in->cut.mesh.n_edges(), 0);
    for (Index e = 0; e < in->cut.mesh.n_edges(); ++e) in->border[e] = in->cut.edge_trajectory[e] != kernels::kNoBorder;
    in->patches = r.patches.info.size();
    return *cache.emplace(level, std::move(in)).first->second;
}

// What the fan stage gets first: the form on the surface and the zero clusters as regions (at
// loop 0 the stage then refines where fans failed and tries again; this is its first try).
struct FanInputs {
    std::shared_ptr<const MeshView> mesh;
    Eigen::VectorXcd tau;
    std::vector<kernels::ZeroRegion> regions;
    Index zeros = 0;
};

const FanInputs& fan_inputs(int level) {
    static std::map<int, std::unique_ptr<FanInputs>> cache;
    if (auto it = cache.find(level); it != cache.end()) return *it->second;
    auto in = std::make_unique<FanInputs>();
    engine::SegmentationWork work = engine::segment_stage::prepare(turbine_loop(level), engine::SegmentOptions{});
    engine::conformal_stage::run_after_prepare(work.conformal);
    engine::segment_stage::zeros(work);
    if (work.result.conformal.double_covered) throw std::runtime_error("expected a closed surface");
    in->mesh = work.result.traced_input;
    in->tau = std::move(work.result.conformal.tau);
    in->regions = std::move(work.regions);
    in->zeros = static_cast<Index>(work.result.zeros.zeros.size());
    return *cache.emplace(level, std::move(in)).first->second;
}

// Runs `body` on the level's inputs; a missing mesh or a failed set-up skips with its message.
template <class Inputs, class Body>
void with_inputs(benchmark::State& state, const Inputs& (*make)(int), Body body) {
    const Inputs* in = nullptr;
    try {
        in = &make(static_cast<int>(state.range(0)));
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    body(*in);
    if (state.error_occurred()) return;
    state.counters["faces"] = static_cast<double>(in->mesh->n_faces());
    state.SetItemsProcessed(state.iterations() * in->mesh->n_faces());
}

void fail(benchmark::State& state, const std::string& what) {
    state.SkipWithError(what.c_str());
}

void BM_kernel_laplacian_assembly(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        const MeshView& im = in.intrinsic.mesh;
        const Index n = in.mesh->n_vertices();
        const auto assemble = [&] {
            const std::vector<double> w = kernels::cotan_weights_from_lengths(
                im.halfedge_edge, in.intrinsic.edge_length, im.n_edges());
            return kernels::assemble_laplacian(n, im.E, w, {in.homology.root});
        };
        {  // x^T L x = sum_e w_e (x_i - x_j)^2 for x = 0 at the pinned vertex
            const kernels::LaplacianMatrix L = assemble();
            std::mt19937_64 rng(kSeed);
            std::uniform_real_distribution<double> uniform(-1.0, 1.0);
            Eigen::VectorXd x(n);
            for (Index v = 0; v < n; ++v) x(v) = uniform(rng);
            x(in.homology.root) = 0;
            const double quadratic = x.dot(full_matrix(L) * x);
            double energy = 0, scale = 0;
            for (Index e = 0; e < im.n_edges(); ++e) {
                const double d = x(im.E(e, 0)) - x(im.E(e, 1));
                energy += in.w[e] * d * d;
                scale += std::abs(in.w[e]) * d * d;
            }
            if (!(std::abs(quadratic - energy) <= kIdentityTol * scale))
                return fail(state, "x^T L x differs from the edge energy");
            state.counters["nonzeros"] = static_cast<double>(L.nonzeros());
        }
        for (auto _ : state) {
            const kernels::LaplacianMatrix L = assemble();
            benchmark::DoNotOptimize(L.value.data());
        }
    });
}

void BM_kernel_intrinsic_delaunay(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        const Eigen::MatrixXd& eta = in.homology.closed_forms;
        {  // Delaunay reached; integer closed forms stay exactly closed through the flips
            const kernels::IntrinsicTriangulation t = kernels::intrinsic_delaunay(*in.mesh, eta);
            if (t.hit_flip_limit || t.non_delaunay_edges != 0)
                return fail(state, "flipping did not reach a Delaunay triangulation");
            if (kernels::closedness_error(t.mesh, t.forms) != 0)
                return fail(state, "carried forms are not closed");
            state.counters["flips"] = static_cast<double>(t.flips);
        }
        for (auto _ : state) {
            const kernels::IntrinsicTriangulation t = kernels::intrinsic_delaunay(*in.mesh, eta);
            benchmark::DoNotOptimize(t.edge_length.data());
        }
    });
}

void BM_kernel_carry_forms(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        const Eigen::MatrixXd& eta = in.homology.closed_forms;
        const kernels::IntrinsicTriangulation t = kernels::intrinsic_delaunay(*in.mesh, eta);
        if (kernels::closedness_error(t.mesh, kernels::carry_forms(t, eta)) != 0)
            return fail(state, "carried forms are not closed");
        state.counters["flips"] = static_cast<double>(t.form_flips.size());
        state.counters["forms"] = static_cast<double>(eta.cols());
        for (auto _ : state) {
            const Eigen::MatrixXd carried = kernels::carry_forms(t, eta);
            benchmark::DoNotOptimize(carried.data());
        }
    });
}

void BM_kernel_cholesky_analyse(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        {
            const auto symbolic = kernels::CholeskySymbolic::analyse(in.L);
            if (!symbolic->matches(in.L) || symbolic->size() != in.L.n)
                return fail(state, "analysis does not match the Laplacian's pattern");
            state.counters["factor_nnz"] = static_cast<double>(symbolic->factor_nonzeros());
        }
        for (auto _ : state) benchmark::DoNotOptimize(kernels::CholeskySymbolic::analyse(in.L));
    });
}

void BM_kernel_cholesky_factorize(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        const auto symbolic = in.factor->symbolic();
        {
            const auto factor = kernels::CholeskyFactor::factorize(symbolic, in.L);
            const double residual = relative_residual(in.L, factor->solve(in.rhs), in.rhs);
            if (!(residual < kResidualTol))
                return fail(state, "residual " + std::to_string(residual) + " too large");
        }
        for (auto _ : state)
            benchmark::DoNotOptimize(kernels::CholeskyFactor::factorize(symbolic, in.L));
    });
}

void BM_kernel_cholesky_solve(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        {
            const double residual = relative_residual(in.L, in.factor->solve(in.rhs), in.rhs);
            if (!(residual < kResidualTol))
                return fail(state, "residual " + std::to_string(residual) + " too large");
            state.counters["residual"] = residual;
        }
        for (auto _ : state) {
            const Eigen::MatrixXd x = in.factor->solve(in.rhs);
            benchmark::DoNotOptimize(x.data());
        }
        state.counters["rhs"] = static_cast<double>(in.rhs.cols());
    });
}

void BM_kernel_homology_basis(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        {  // 2g exactly closed forms; cutting along the cut graph leaves one disk
            const kernels::HomologyBasis h = kernels::compute_homology_basis(*in.mesh);
            const kernels::CutTopology disk = kernels::fundamental_domain_topology(*in.mesh, h);
            if (h.genus != in.genus || h.closed_forms.cols() != 2 * in.genus)
                return fail(state, "wrong number of generators");
            if (kernels::closedness_error(*in.mesh, h.closed_forms) != 0)
                return fail(state, "closed forms are not closed");
            if (disk.euler_characteristic != 1 || disk.boundary_loops != 1)
                return fail(state, "the fundamental domain is not a disk");
        }
        for (auto _ : state) {
            const kernels::HomologyBasis h = kernels::compute_homology_basis(*in.mesh);
            benchmark::DoNotOptimize(h.closed_forms.data());
        }
        state.counters["genus"] = in.genus;
    });
}

void BM_kernel_hodge_star(benchmark::State& state) {
    with_inputs(state, conformal_inputs, [&](const ConformalInputs& in) {
        const Eigen::SparseMatrix<double> eta = in.intrinsic.forms.sparseView();  // the pipeline keeps it so
        const auto star = [&] {
            return kernels::hodge_star(in.w, eta, in.omega,
                                       kernels::wedge_matrix(*in.mesh, in.homology.closed_forms));
        };
        {  // |det A| = 1, B = omega^T W omega (recomputed with Eigen), A C^T = B
            const kernels::HodgeStar s = star();
            const Eigen::Map<const Eigen::VectorXd> w(in.w.data(), in.omega.rows());
            const Eigen::MatrixXd inner = in.omega.transpose() * w.asDiagonal() * in.omega;
            const double scale = inner.norm();
            if (std::abs(std::abs(s.wedge_det) - 1) > kIdentityTol ||
                s.wedge_integrality_error > kIdentityTol)
                return fail(state, "wedge matrix is not unimodular");
            if ((s.inner - inner).norm() > kIdentityTol * scale)
                return fail(state, "inner products differ from omega^T W omega");
            if ((s.wedge * s.star.transpose() - s.inner).norm() > kIdentityTol * scale)
                return fail(state, "star does not solve A C^T = B");
            state.counters["star_square_error"] = s.star_square_error;
        }
        for (auto _ : state) {
            const kernels::HodgeStar s = star();
            benchmark::DoNotOptimize(s.star.data());
        }
    });
}

void BM_kernel_integrate_form(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        const MeshView& mesh = *in.mesh;
        {  // every face's corner images differ by the form along its halfedges
            const kernels::ConformalMap map = kernels::integrate_form(mesh, in.homology, in.tau);
            double uv_scale = 0, closure = 0;
            for (const auto& uv : map.wedge_uv) uv_scale = std::max(uv_scale, std::abs(uv));
            for (Index h = 0; h < mesh.n_halfedges(); ++h) {
                const auto d = map.corner_uv(in.homology, MeshView::next(h)) -
                               map.corner_uv(in.homology, h);
                closure = std::max(closure, std::abs(d - kernels::form_along(mesh, in.tau, h)));
            }
            if (!(closure <= kIntegrationTol * uv_scale))
                return fail(state, "uv differences do not match the form");
            state.counters["wedges"] = static_cast<double>(map.wedge_uv.size());
        }
        for (auto _ : state) {
            const kernels::ConformalMap map = kernels::integrate_form(mesh, in.homology, in.tau);
            benchmark::DoNotOptimize(map.wedge_uv.data());
        }
    });
}

void BM_kernel_find_zeros(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        {  // Poincare-Hopf: indices add up to 2g - 2 on a closed surface, as an integer identity
            const kernels::ZeroSet z = kernels::find_zeros(*in.mesh, in.tau);
            if (z.total_index != 2 * in.genus - 2 || z.total_order != z.total_index)
                return fail(state, "zero orders do not add up to 2g - 2");
            state.counters["zeros"] = static_cast<double>(z.zeros.size());
            state.counters["artifacts"] = static_cast<double>(z.artifact_clusters);
        }
        for (auto _ : state) {
            const kernels::ZeroSet z = kernels::find_zeros(*in.mesh, in.tau);
            benchmark::DoNotOptimize(z.winding.data());
        }
    });
}

void BM_kernel_regularise_zeros(benchmark::State& state) {
    with_inputs(state, fan_inputs, [&](const FanInputs& in) {
        const auto regularise = [&] { return kernels::regularise_zeros(*in.mesh, in.tau, in.regions); };
        {  // disks re-triangulated as disks: the surface's Euler characteristic stays
            const kernels::RegularisedForm r = regularise();
            const auto chi = [](const MeshView& m) { return m.n_vertices() - m.n_edges() + m.n_faces(); };
            if (chi(r.mesh) != chi(*in.mesh)) return fail(state, "the fans changed the Euler characteristic");
            state.counters["zeros"] = static_cast<double>(in.zeros);
            state.counters["failed"] = static_cast<double>(r.failed_regions);
        }
        for (auto _ : state) {
            const kernels::RegularisedForm r = regularise();
            benchmark::DoNotOptimize(r.mesh.F.data());
        }
    });
}

void BM_kernel_trace_trajectories(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        const auto trace = [&] {
            return kernels::trace_trajectories(in.regular.mesh, in.regular.tau, in.zero_vertices,
                                               in.families, in.trace_options);
        };
        {  // deterministic: the same curves as inside engine::segment
            const std::vector<kernels::Trajectory> t = trace();
            if (t.size() != in.trajectories)
                return fail(state, "trajectory count differs from the pipeline's");
            double crossings = 0, unfinished = 0;
            for (const kernels::Trajectory& c : t) {
                crossings += static_cast<double>(c.crossings.size());
                unfinished += c.end == kernels::Trajectory::End::LengthCap;
            }
            state.counters["trajectories"] = static_cast<double>(t.size());
            state.counters["crossings"] = crossings;
            state.counters["unfinished"] = unfinished;
        }
        for (auto _ : state) {
            const std::vector<kernels::Trajectory> t = trace();
            benchmark::DoNotOptimize(t.data());
        }
    });
}

void BM_kernel_cut_along_trajectories(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        const auto cut = [&] { return kernels::cut_along_trajectories(in.regular.mesh, in.regular.tau, in.cut_by); };
        {  // deterministic: the pipeline's cut
            const kernels::CutMesh c = cut();
            if (c.mesh.F != in.cut.mesh.F || c.tau != in.cut.tau) return fail(state, "cut differs from the pipeline's");
            state.counters["cut_faces"] = static_cast<double>(c.mesh.n_faces());
        }
        for (auto _ : state) {
            const kernels::CutMesh c = cut();
            benchmark::DoNotOptimize(c.mesh.F.data());
        }
    });
}

void BM_kernel_compute_patches(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        const auto fill = [&] { return kernels::compute_patches(in.cut.mesh, in.cut.tau, in.border); };
        {  // the pipeline's patches, before any fold repair
            const kernels::Patches p = fill();
            if (p.info.size() != in.patches) return fail(state, "patch count differs from the pipeline's");
            state.counters["patches"] = static_cast<double>(p.info.size());
        }
        for (auto _ : state) {
            const kernels::Patches p = fill();
            benchmark::DoNotOptimize(p.face_patch.data());
        }
    });
}

// The layout rounds' scan of the patches for concave corners and branch points; on the
// pipeline's final patches it finds none, so only the scan runs.
void BM_kernel_corner_transversals(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        const kernels::Patches patches = kernels::compute_patches(in.cut.mesh, in.cut.tau, in.border);
        const auto scan = [&] {
            return kernels::corner_transversals(in.regular.mesh, in.regular.tau, in.zero_vertices, in.cut_by, in.cut,
                                                in.border, patches);
        };
        if (!scan().empty()) return fail(state, "the pipeline's final patches still have corners to split");
        for (auto _ : state) {
            const std::vector<kernels::Trajectory> t = scan();
            benchmark::DoNotOptimize(t.data());
        }
    });
}

void BM_kernel_make_mesh_view(benchmark::State& state) {
    with_inputs(state, segmentation_inputs, [&](const SegmentationInputs& in) {
        const MeshView& m = in.cut.mesh;
        const auto make = [&] { return holoflow::make_mesh_view(m.V, m.F, m.twin); };
        {  // the same edges and vertex halfedges as the cut's own view
            const MeshView v = make();
            if (v.edge_halfedge != m.edge_halfedge || v.vertex_halfedge != m.vertex_halfedge)
                return fail(state, "mesh view differs from the cut's");
        }
        for (auto _ : state) {
            const MeshView v = make();
            benchmark::DoNotOptimize(v.vertex_halfedge.data());
        }
    });
}

// The cut of make_mesh_view and compute_patches above with its faces and vertices in a seeded
// random order: the order of decimated meshes such as shared/skull.obj, where 77 % of the
// neighbouring face pairs lie over 2000 faces apart (turbine's own order: 2 %). Whole-mesh walks
// then miss the cache at almost every step.
struct ScatteredCut {
    std::shared_ptr<const MeshView> mesh;
    Eigen::VectorXcd tau;
    std::vector<char> border;
};

const ScatteredCut& scattered_cut(int level) {
    static std::map<int, std::unique_ptr<ScatteredCut>> cache;
    if (auto it = cache.find(level); it != cache.end()) return *it->second;
    const SegmentationInputs& in = segmentation_inputs(level);
    const MeshView& m = in.cut.mesh;
    std::mt19937 rng(12345);
    std::vector<Index> face_at(m.n_faces()), vertex_to(m.n_vertices());  // new face -> old, old vertex -> new
    std::iota(face_at.begin(), face_at.end(), 0);
    std::iota(vertex_to.begin(), vertex_to.end(), 0);
    std::shuffle(face_at.begin(), face_at.end(), rng);
    std::shuffle(vertex_to.begin(), vertex_to.end(), rng);
    std::vector<Index> face_to(m.n_faces());
    for (Index f = 0; f < m.n_faces(); ++f) face_to[face_at[f]] = f;
    const auto moved = [&](Index h) { return h == holoflow::kNoHalfedge ? h : 3 * face_to[h / 3] + h % 3; };
    holoflow::PointMatrix V(m.n_vertices(), 3);
    for (Index v = 0; v < m.n_vertices(); ++v) V.row(vertex_to[v]) = m.V.row(v);
    holoflow::TriangleMatrix F(m.n_faces(), 3);
    std::vector<Index> twin(m.twin.size());
    for (Index f = 0; f < m.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) {
            F(f, k) = vertex_to[m.F(face_at[f], k)];
            twin[3 * f + k] = moved(m.twin[3 * face_at[f] + k]);
        }
    auto out = std::make_unique<ScatteredCut>();
    out->mesh =
        std::make_shared<const MeshView>(holoflow::make_mesh_view(std::move(V), std::move(F), std::move(twin)));
    // The form and border flags by the new edges, signed by the new edges' orientation.
    out->tau.resize(out->mesh->n_edges());
    out->border.resize(out->mesh->n_edges());
    for (Index e = 0; e < out->mesh->n_edges(); ++e) {
        const Index h_new = out->mesh->edge_halfedge[e];
        const Index h = 3 * face_at[h_new / 3] + h_new % 3;
        out->tau(e) = static_cast<double>(m.edge_sign(h)) * in.cut.tau(m.halfedge_edge[h]);
        out->border[e] = in.border[m.halfedge_edge[h]];
    }
    return *cache.emplace(level, std::move(out)).first->second;
}

void BM_kernel_make_mesh_view_scattered(benchmark::State& state) {
    with_inputs(state, scattered_cut, [&](const ScatteredCut& in) {
        for (auto _ : state) {
            const MeshView v = holoflow::make_mesh_view(in.mesh->V, in.mesh->F, in.mesh->twin);
            benchmark::DoNotOptimize(v.vertex_halfedge.data());
        }
    });
}

void BM_kernel_compute_patches_scattered(benchmark::State& state) {
    with_inputs(state, scattered_cut, [&](const ScatteredCut& in) {
        const auto fill = [&] { return kernels::compute_patches(*in.mesh, in.tau, in.border); };
        if (fill().info.size() != segmentation_inputs(static_cast<int>(state.range(0))).patches)
            return fail(state, "patch count differs from the cut's own order");
        for (auto _ : state) {
            const kernels::Patches p = fill();
            benchmark::DoNotOptimize(p.face_patch.data());
        }
    });
}

// Levels 0 and 1 run as long as --benchmark_min_time asks; level 2 a fixed few iterations.
// Wall time: several kernels run TBB loops, whose work the main thread's CPU time would miss.
void register_kernel(const char* name, void (*fn)(benchmark::State&)) {
    benchmark::RegisterBenchmark(name, fn)
        ->ArgName("loop")
        ->DenseRange(0, kMaxLevel - 1)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(name, fn)
        ->ArgName("loop")
        ->Arg(kMaxLevel)
        ->Iterations(kLargestLevelIterations)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
}

// `--write-subdivided=PATH,MESH,SCHEME,LEVEL`: returns true if the flag was given (and the
// file written).
bool write_subdivided_if_asked(int argc, char** argv) {
    const std::string flag = "--write-subdivided=";
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg.rfind(flag, 0) != 0) continue;
        std::vector<std::string> field;  // the last three fields; PATH keeps any other comma
        std::string rest = arg.substr(flag.size());
        for (int k = 0; k < 3; ++k) {
            const std::size_t comma = rest.rfind(',');
            if (comma == std::string::npos)
                throw std::invalid_argument("expected --write-subdivided=PATH,MESH,SCHEME,LEVEL");
            field.insert(field.begin(), rest.substr(comma + 1));
            rest.resize(comma);
        }
        const auto mesh = subdivided(field[0], field[1], std::stoi(field[2]));
        engine::write_file_atomic(rest, [&](std::ostream& out) { engine::write_off(out, *mesh); });
        std::cout << rest << ": " << mesh->n_vertices() << " vertices, " << mesh->n_faces()
                  << " faces\n";
        return true;
    }
    return false;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        if (write_subdivided_if_asked(argc, argv)) return 0;
    } catch (const std::exception& e) {
        std::cerr << "kernels_bench: " << e.what() << "\n";
        return 1;
    }
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    register_kernel("BM_kernel_laplacian_assembly", BM_kernel_laplacian_assembly);
    register_kernel("BM_kernel_intrinsic_delaunay", BM_kernel_intrinsic_delaunay);
    register_kernel("BM_kernel_carry_forms", BM_kernel_carry_forms);
    register_kernel("BM_kernel_cholesky_analyse", BM_kernel_cholesky_analyse);
    register_kernel("BM_kernel_cholesky_factorize", BM_kernel_cholesky_factorize);
    register_kernel("BM_kernel_cholesky_solve", BM_kernel_cholesky_solve);
    register_kernel("BM_kernel_homology_basis", BM_kernel_homology_basis);
    register_kernel("BM_kernel_hodge_star", BM_kernel_hodge_star);
    register_kernel("BM_kernel_integrate_form", BM_kernel_integrate_form);
    register_kernel("BM_kernel_find_zeros", BM_kernel_find_zeros);
    register_kernel("BM_kernel_regularise_zeros", BM_kernel_regularise_zeros);
    register_kernel("BM_kernel_trace_trajectories", BM_kernel_trace_trajectories);
    register_kernel("BM_kernel_cut_along_trajectories", BM_kernel_cut_along_trajectories);
    register_kernel("BM_kernel_compute_patches", BM_kernel_compute_patches);
    register_kernel("BM_kernel_corner_transversals", BM_kernel_corner_transversals);
    register_kernel("BM_kernel_make_mesh_view", BM_kernel_make_mesh_view);
    register_kernel("BM_kernel_make_mesh_view_scattered", BM_kernel_make_mesh_view_scattered);
    register_kernel("BM_kernel_compute_patches_scattered", BM_kernel_compute_patches_scattered);
    benchmark::AddCustomContext("mesh", "libcgal-demo turbine.off, Loop-subdivided");
    benchmark::AddCustomContext("tbb", TBB_VERSION_STRING);
    benchmark::AddCustomContext("tbb_max_concurrency",
                                std::to_string(oneapi::tbb::this_task_arena::max_concurrency()));
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
