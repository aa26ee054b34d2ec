#include "holoflow/engine/conformal_pipeline.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include <tbb/task_group.h>

#include "holoflow/engine/factorization_cache.h"
#include "holoflow/engine/stage_clock.h"
#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/harmonic.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/parallel.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::engine {
namespace {

using Complex = std::complex<double>;

constexpr double kNegativeWeightTol = 1e-12;
// The generic form's phases tried where the first one's image folds on more than this share of
// the triangles (ConformalResult::form_phase).
constexpr double kFoldedShare = 0.01;
constexpr int kFormPhases = 8;
// The chosen form alone (ConformalOptions::chosen_form_only) sums the potentials of this many
// groups of generators. Where the form falls under a potential's rounding (limbs it decays
// along, to 1e-16 of its largest values) one potential is flat to the last bit and the form
// exactly 0 there, degenerate image triangles the zero fans fail on (bull stretched 10 : 1: 9
// failed instead of 3); a sum of several keeps rounding noise there, as the 2g basis forms do.
constexpr Eigen::Index kPotentialGroups = 8;

//! Runs `first` here and `second` as a task beside it, then throws first's error, else second's:
//! the same error whichever finished first.
void side_by_side(const std::function<void()>& first, const std::function<void()>& second) {
    std::exception_ptr first_error, second_error;
    tbb::task_group group;
    group.run([&] {
        try {
            second();
        } catch (...) {
            second_error = std::current_exception();
        }
    });
    try {
        first();
    } catch (...) {
        first_error = std::current_exception();
    }
    group.wait();
    if (first_error) std::rethrow_exception(first_error);
    if (second_error) std::rethrow_exception(second_error);
}

// The values of tau = sum_i d_i (omega_i + i *omega_i) on the surface's edges and, with the
// intrinsic Laplacian, on the intrinsic triangulation's.
struct FormValues {
    Eigen::VectorXcd surface, laplace;
};

// FormValues from the closed forms eta alone (ConformalOptions::chosen_form_only). The real part
// is the harmonic form eta d + d f (one solve); the imaginary part the harmonic form of the
// coefficients C^T d = A^{-1} B d (kernels::hodge_star; `wedge` factors A), where B d = eta^T W (eta d + d f) needs
// no other form (B before hodge_star's symmetrisation, which changes rounding only): a second
// solve.
FormValues chosen_form_values(const ConformalWork& work, const Eigen::PartialPivLU<Eigen::MatrixXd>& wedge,
                              const Eigen::VectorXd& d) {
    const bool intrinsic = work.intrinsic_laplacian();
    const MeshView& laplace_mesh = work.laplace_mesh();
    const Eigen::SparseMatrix<double>& eta_surface = work.result.homology.sparse_closed_forms;
    const Eigen::SparseMatrix<double>& eta_laplace = intrinsic ? work.laplace_closed_forms : eta_surface;
    HOLOFLOW_REQUIRE(work.factor && d.size() == eta_laplace.cols(), "chosen form: factor and coefficients first");
    Eigen::MatrixXd on_laplace(eta_laplace.rows(), 2), on_surface(intrinsic ? eta_surface.rows() : 0, 2);
    // x split over kPotentialGroups groups of generators, each its own potential (columns of
    // one solve): see kPotentialGroups.
    const auto harmonic = [&](const Eigen::VectorXd& x, Eigen::Index column) {
        const Eigen::Index n = x.size(), groups = std::min<Eigen::Index>(kPotentialGroups, n);
        Eigen::MatrixXd parts = Eigen::MatrixXd::Zero(n, groups);
        for (Eigen::Index i = 0; i < n; ++i) parts(i, i % groups) = x[i];
        const Eigen::MatrixXd closed = eta_laplace * parts;
        const Eigen::MatrixXd potential =
            kernels::harmonic_potential(laplace_mesh.E, work.weights, *work.factor, closed, work.pinned);
        on_laplace.col(column) = kernels::plus_gradient(laplace_mesh.E, closed, potential).rowwise().sum();
        if (intrinsic)
            on_surface.col(column) =
                kernels::plus_gradient(work.result.surface->E, Eigen::MatrixXd(eta_surface * parts), potential)
                    .rowwise()
                    .sum();
    };
    harmonic(d, 0);
    const Eigen::Map<const Eigen::VectorXd> w(work.weights.data(), static_cast<Eigen::Index>(work.weights.size()));
    const Eigen::VectorXd inner = eta_laplace.transpose() * w.cwiseProduct(on_laplace.col(0));
    harmonic(wedge.solve(inner), 1);
    const auto complex = [](const Eigen::MatrixXd& two) -> Eigen::VectorXcd {
        return two.col(0).cast<Complex>() + Complex(0, 1) * two.col(1).cast<Complex>();
    };
    FormValues values;
    values.surface = complex(intrinsic ? on_surface : on_laplace);
    if (intrinsic) values.laplace = complex(on_laplace);
    return values;
}

}  // namespace

void require_connected(const kernels::Topology& topology) {
    HOLOFLOW_REQUIRE(topology.components == 1, "the mesh has " + std::to_string(topology.components) +
                                                   " components; use --component largest");
}

Eigen::Index solve_block_width(Eigen::Index columns) {
    const Eigen::Index blocks = std::max<Eigen::Index>(1, (columns + kSolveBlockColumns - 1) / kSolveBlockColumns);
    return std::max<Eigen::Index>(1, (columns + blocks - 1) / blocks);
}

namespace conformal_stage {

ConformalWork prepare(std::shared_ptr<const MeshView> input_ptr, ConformalOptions options,
                      const kernels::Topology* known_topology) {
    HOLOFLOW_REQUIRE(input_ptr != nullptr, "no mesh");
    ConformalWork work;
    work.input = std::move(input_ptr);
    work.options = std::move(options);
    ConformalResult& r = work.result;
    StageClock clock(r.timings_ms);
    const MeshView& input = *work.input;

    const kernels::Topology topology = known_topology ? *known_topology : kernels::compute_topology(input);
    r.input_genus = topology.genus;
    require_connected(topology);
    if (topology.boundary_loops > 0) {
        HOLOFLOW_REQUIRE(topology.genus > 0 || topology.boundary_loops > 1,
                         "a topological disk has no holomorphic 1-form (`segment` slices holes at its "
                         "tips first)");
        r.cover = std::make_shared<const kernels::DoubleCover>(kernels::double_cover(input));
        r.surface = std::shared_ptr<const MeshView>(r.cover, &r.cover->mesh);
        r.double_covered = true;
        clock.lap("double_cover");
    } else {
        HOLOFLOW_REQUIRE(topology.genus > 0,
                         "a closed genus-0 surface has no holomorphic 1-form (`segment` "
                         "slices holes at its tips first)");
        r.surface = work.input;
    }
    return work;
}

void laplacian(ConformalWork& work) {
    ConformalResult& r = work.result;
    StageClock clock(r.timings_ms);
    const MeshView& surface = *r.surface;
    // The Laplacian lives on the intrinsic Delaunay triangulation (or the mesh itself); vertex
    // functions are shared by both, so the harmonic forms come back to the mesh's edges exactly.
    if (work.intrinsic_laplacian()) {
        work.intrinsic = kernels::intrinsic_delaunay(surface);
        r.intrinsic_flips = work.intrinsic.flips;
        clock.lap("intrinsic_delaunay");
        work.weights = kernels::cotan_weights_from_lengths(
            work.intrinsic.mesh.halfedge_edge, work.intrinsic.edge_length, work.intrinsic.mesh.n_edges());
    } else {
        work.weights = kernels::cotan_weights(surface);
    }
    {
        // Cocircular quads (rectangles in CAD meshes) give weights of -1e-15 by rounding.
        double scale = 0;
        for (double w : work.weights) scale = std::max(scale, std::abs(w));
        r.negative_weights = static_cast<Index>(std::count_if(
            work.weights.begin(), work.weights.end(),
            [&](double w) { return w < -kNegativeWeightTol * scale; }));
    }
    // Any one vertex would do (potentials are defined up to a constant): the default homology
    // root, which the homology stage then roots its tree at.
    work.pinned = {kernels::central_vertex(surface)};
    work.laplacian = kernels::assemble_laplacian(surface.n_vertices(), work.laplace_mesh().E,
                                                 work.weights, work.pinned);
    clock.lap("laplacian_assembly");
}

void homology(ConformalWork& work, StageTimes& times) {
    ConformalResult& r = work.result;
    StageClock clock(times);
    HOLOFLOW_REQUIRE(work.pinned.size() == 1, "homology: the laplacian stage comes first");
    kernels::HomologyOptions homology_options;
    homology_options.root = work.pinned.front();
    // The chosen form alone needs no dense forms: no harmonic forms are made of them in place.
    const bool sparse = work.options.chosen_form_only;
    homology_options.sparse_forms = sparse;
    r.homology = kernels::compute_homology_basis(*r.surface, homology_options);
    clock.lap("cut_graph_and_closed_forms");
    if (work.options.closed_forms) {
        HOLOFLOW_REQUIRE(!r.double_covered, "given closed forms need closed input");
        HOLOFLOW_REQUIRE(work.options.closed_forms->rows() == r.surface->n_edges() &&
                             work.options.closed_forms->cols() == 2 * r.homology.genus,
                         "given closed forms must be #E x 2g");
        if (sparse) r.homology.sparse_closed_forms = work.options.closed_forms->sparseView();
    }
    // A depends on the classes only: ready here, off the solves' path.
    work.wedge = sparse ? kernels::wedge_matrix(*r.surface, r.homology.sparse_closed_forms)
                        : kernels::wedge_matrix(*r.surface, work.closed_forms());
    // So does the cover's involution on them (the solves take the closed forms over).
    if (r.double_covered) work.involution = kernels::involution_matrix(*r.cover, r.homology);
    clock.lap("wedge_matrix");
    if (work.intrinsic_laplacian()) {
        HOLOFLOW_REQUIRE(work.intrinsic.form_slot.size() == static_cast<std::size_t>(r.surface->n_edges()),
                         "homology: the intrinsic triangulation comes first (laplacian stage)");
        if (sparse) {
            work.laplace_closed_forms = kernels::carry_forms(work.intrinsic, r.homology.sparse_closed_forms);
        } else {
            work.intrinsic.forms = kernels::carry_forms(work.intrinsic, work.closed_forms());
        }
        clock.lap("carry_forms");
    }
}

// Refuses (ResourceLimit) a model whose conformal stage would need more than the limit: the
// supernodal factor (0 before the analysis) and the dense forms, 2g columns each: the closed
// forms (which become the harmonic ones) and their carried copy on the edges, right-hand sides,
// potentials and the co-closedness residual on the vertices.
void check_memory(const ConformalWork& work, std::size_t factor_nonzeros) {
    if (work.options.max_solver_bytes == 0) return;
    // The chosen form alone holds sparse forms and its potentials' groups of dense columns:
    // closed parts and gradients on both triangulations and potentials, about four groups.
    const bool alone = work.options.chosen_form_only;
    const auto forms = std::max<Index>(work.form_count(), 0);
    const auto columns = static_cast<std::size_t>(alone ? 4 * kPotentialGroups : forms);
    const auto edges = static_cast<std::size_t>(work.result.surface->n_edges());
    const auto vertices = static_cast<std::size_t>(work.result.surface->n_vertices());
    const std::size_t bytes = 8 * (factor_nonzeros + columns * (2 * edges + 3 * vertices));
    if (bytes > work.options.max_solver_bytes)
        throw ResourceLimit("the conformal stage would need about " + std::to_string(bytes >> 20) +
                            " MiB (" + (alone ? "the chosen one of " : "") + std::to_string(forms) +
                            " forms), over the limit of " +
                            std::to_string(work.options.max_solver_bytes >> 20) + " MiB");
}

// Why a Laplacian may fail to factorise, from its off-diagonal (cotan) weights: where they span
// more than double precision resolves, the mesh's triangles are too thin for it.
std::string weight_spread(const kernels::LaplacianMatrix& L, bool intrinsic) {
    double smallest = std::numeric_limits<double>::infinity(), largest = 0;
    Index negative = 0;
    for (Index c = 0; c < L.n; ++c)
        for (Index k = L.col_start[static_cast<std::size_t>(c)]; k < L.col_start[static_cast<std::size_t>(c) + 1]; ++k) {
            const double w = -L.value[static_cast<std::size_t>(k)];  // off-diagonal entries are -w
            if (L.row[static_cast<std::size_t>(k)] == c || w == 0) continue;
            negative += w < 0;
            smallest = std::min(smallest, std::abs(w));
            largest = std::max(largest, std::abs(w));
        }
    if (largest == 0) return "";
    std::ostringstream note;
    note.precision(2);
    note << "; its cotan weights run from " << smallest << " to " << largest;
    if (negative > 0) note << ", " << negative << " of them negative" << (intrinsic ? "" : " (try --laplacian intrinsic)");
    if (largest > 1e8 * smallest) note << ": the mesh's triangles are too thin or stretched for double precision";
    return note.str();
}

void factorise(ConformalWork& work, FactorizationCache* cache, StageTimes& times) {
    StageClock clock(times);
    const auto symbolic = cache ? cache->analysis(work.laplacian)
                                : kernels::CholeskySymbolic::analyse(work.laplacian);
    clock.lap("analyse");
    check_memory(work, symbolic->factor_nonzeros());
    try {
        work.factor = kernels::CholeskyFactor::factorize(symbolic, work.laplacian);
    } catch (const SolverFailure& e) {
        throw SolverFailure(e.what() + weight_spread(work.laplacian, work.intrinsic_laplacian()));
    }
    work.laplacian = {};  // the factor holds what the solves need
    clock.lap("factorise");
}

void homology_and_factorise(ConformalWork& work, FactorizationCache* cache) {
    check_memory(work, 0);  // the dense forms alone, before the homology allocates them
    // The factorisation needs only the Laplacian, the cut graph only the surface: they run side
    // by side, write disjoint fields of `work` and time themselves into their own lists.
    const auto start = std::chrono::steady_clock::now();
    StageTimes homology_times, factor_times;
    side_by_side([&] { homology(work, homology_times); }, [&] { factorise(work, cache, factor_times); });
    StageTimes& times = work.result.timings_ms;
    double branches_ms = 0;
    for (const StageTimes* list : {&homology_times, &factor_times}) {
        for (const auto& entry : *list) branches_ms += entry.second;
        times.insert(times.end(), list->begin(), list->end());
    }
    // Negative by the time the branches overlapped, so that the stages still sum to wall time.
    times.emplace_back("overlap",
                       std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() -
                           branches_ms);
}

int begin_solves(ConformalWork& work) {
    work.solves_started = std::chrono::steady_clock::now();
    if (work.options.chosen_form_only) return 0;  // integrate solves for the form
    ConformalResult& r = work.result;
    const Eigen::MatrixXd& eta = work.intrinsic_laplacian() ? work.intrinsic.forms : work.closed_forms();
    work.laplace_closed_forms = eta.sparseView();
    const Eigen::Index columns = eta.cols(), width = solve_block_width(columns);
    // The harmonic forms are the closed ones plus a gradient, which each block adds to its
    // columns in place: the closed forms' storage becomes theirs (one #E x 2g matrix less to
    // allocate and fault in). Given forms stay the caller's, so they are copied.
    if (work.options.closed_forms) {
        r.harmonic = *work.options.closed_forms;
    } else {
        r.harmonic.swap(r.homology.closed_forms);
        r.homology.closed_forms.resize(0, 0);
    }
    return static_cast<int>((columns + width - 1) / width);
}

void solve_block(ConformalWork& work, int block) {
    ConformalResult& r = work.result;
    const bool intrinsic = work.intrinsic_laplacian();
    // Until this block adds its gradient, its columns of both still hold the closed forms.
    const Eigen::MatrixXd& eta = intrinsic ? work.intrinsic.forms : r.harmonic;
    const Eigen::Index width = solve_block_width(eta.cols()), first = block * width;
    HOLOFLOW_REQUIRE(block >= 0 && first < eta.cols(), "solve block out of range");
    const Eigen::Index count = std::min(width, eta.cols() - first);
    const MeshView& laplace_mesh = work.laplace_mesh();
    const Eigen::MatrixXd potential = kernels::harmonic_potential(laplace_mesh.E, work.weights, *work.factor,
                                                                  eta.middleCols(first, count), work.pinned);
    // The potential corrects the forms on both triangulations (it lives on the shared vertices);
    // on the intrinsic one its carried forms become the harmonic ones in place.
    kernels::plus_gradient_columns(r.surface->E, r.harmonic, potential, first, r.harmonic);
    if (intrinsic)
        kernels::plus_gradient_columns(laplace_mesh.E, work.intrinsic.forms, potential, first, work.intrinsic.forms);
}

void end_solves(ConformalWork& work) {
    if (work.options.chosen_form_only) return;
    ConformalResult& r = work.result;
    const MeshView& surface = *r.surface;
    const MeshView& laplace_mesh = work.laplace_mesh();
    work.factor.reset();
    const Eigen::MatrixXd& laplace_omega = work.intrinsic_laplacian() ? work.intrinsic.forms : r.harmonic;
    {
        // Divergence left at the vertices, relative to the largest flux w_e omega_e it sums.
        Eigen::MatrixXd residual =
            kernels::codifferential(surface.n_vertices(), laplace_mesh.E, work.weights, laplace_omega);
        for (Index p : work.pinned) residual.row(p).setZero();  // the pinned row carries the balance
        const Eigen::Map<const Eigen::VectorXd> w(work.weights.data(), laplace_omega.rows());
        const double scale = (laplace_omega.array().colwise() * w.array()).abs().maxCoeff();
        r.coclosedness_max = scale > 0 ? residual.cwiseAbs().maxCoeff() / scale : 0;
    }
    r.timings_ms.emplace_back(
        "solves",
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - work.solves_started).count());
}

void hodge_star(ConformalWork& work) {
    if (work.options.chosen_form_only) return;
    ConformalResult& r = work.result;
    StageClock clock(r.timings_ms);
    const Eigen::MatrixXd& laplace_omega = work.intrinsic_laplacian() ? work.intrinsic.forms : r.harmonic;
    side_by_side([&] { r.star = kernels::hodge_star(work.weights, work.laplace_closed_forms, laplace_omega, work.wedge); },
                 [&] { r.closedness_max = kernels::closedness_error(*r.surface, r.harmonic); });
    work.laplace_closed_forms = {};
    clock.lap("hodge_star");  // and the closedness check beside it
    r.basis = kernels::holomorphic_basis(r.star);
    clock.lap("holomorphic_basis");
}

void integrate(ConformalWork& work) {
    ConformalResult& r = work.result;
    StageClock clock(r.timings_ms);
    const MeshView& surface = *r.surface;
    r.form = work.options.form;
    const bool integer = r.form == FormChoice::IntegerPeriods;
    const auto generic = [&](int phase) {
        return r.double_covered ? kernels::even_form_coefficients(work.involution, phase)
                                : kernels::generic_form_coefficients(work.form_count(), phase);
    };
    if (integer) {
        r.form_coefficients = r.double_covered ? kernels::even_integer_form_coefficients(work.involution)
                                               : kernels::integer_form_coefficients(work.form_count());
    } else {
        r.form_coefficients = generic(1);
    }
    // tau = sum_i d_i (omega_i + i *omega_i) with *omega_i = sum_j C(i, j) omega_j.
    const auto form_of = [&](const Eigen::VectorXd& d, const Eigen::MatrixXd& omega) -> Eigen::VectorXcd {
        const Eigen::VectorXd conjugate = r.star.star.transpose() * d;
        return (omega * d).cast<Complex>() + Complex(0, 1) * (omega * conjugate).cast<Complex>();
    };
    const auto input_mesh_quality = [&](const Eigen::VectorXcd& tau) {
        return kernels::map_quality(surface, kernels::edge_lengths(surface), tau);
    };
    const bool intrinsic = work.intrinsic_laplacian();
    // The form with coefficients d: a combination of the harmonic basis, or its own solves. Its
    // values on the surface are needed only for the chosen form (`surface_too`).
    const bool own_solves = work.options.chosen_form_only;
    std::optional<Eigen::PartialPivLU<Eigen::MatrixXd>> wedge;  // factored once for every phase
    if (own_solves) {
        r.basis.genus = static_cast<int>(work.form_count() / 2);
        wedge = kernels::wedge_factor(work.wedge);
    }
    const auto values = [&](const Eigen::VectorXd& d, bool surface_too) {
        if (own_solves) return chosen_form_values(work, *wedge, d);
        FormValues v;
        if (surface_too || !intrinsic) v.surface = form_of(d, r.harmonic);
        if (intrinsic) v.laplace = form_of(d, work.intrinsic.forms);
        return v;
    };
    // Its quality where the Laplacian was built.
    const auto laplace_quality = [&](const FormValues& v) {
        return intrinsic ? kernels::map_quality(work.intrinsic.mesh, work.intrinsic.edge_length, v.laplace)
                         : input_mesh_quality(v.surface);
    };
    // The form of r.form_coefficients, from its values (where the Laplacian was built at least).
    const auto integrate_chosen = [&](const FormValues& v) {
        r.tau = v.surface.size() > 0 ? v.surface : form_of(r.form_coefficients, r.harmonic);
        // The map (a serial walk over the faces) and its quality checks are independent.
        side_by_side([&] { r.map = kernels::integrate_form(surface, r.homology, r.tau); },
                     [&] {
                         r.input_mesh_quality = input_mesh_quality(r.tau);
                         r.quality = intrinsic ? laplace_quality(v) : r.input_mesh_quality;
                     });
    };
    r.form_phase = 1;
    integrate_chosen(values(r.form_coefficients, true));
    // Where the discrete conjugate is far from a complex structure (pinholes of a mesh give the
    // star a square far from -1), whole regions of one generic form's image can fold while
    // another's do not: ChineseDragon-10kv with one tip hole, 35 % of the triangles for phase 1,
    // 1 % for phase 3. Past kFoldedShare, the next phases are tried, and the one with fewest
    // flips is kept where it has under half the first's (ties to the earlier phase).
    const Index faces = intrinsic ? work.intrinsic.mesh.n_faces() : surface.n_faces();
    if (!integer && static_cast<double>(r.quality.flipped) > kFoldedShare * static_cast<double>(faces)) {
        Index best = r.quality.flipped;
        int best_phase = 1;
        FormValues best_values;
        for (int phase = 2; phase <= kFormPhases; ++phase) {
            FormValues v = values(generic(phase), false);
            if (const Index flips = laplace_quality(v).flipped; flips < best)
                best = flips, best_phase = phase, best_values = std::move(v);
        }
        if (2 * best < r.quality.flipped) {
            r.form_phase = best_phase;
            r.form_coefficients = generic(best_phase);
            integrate_chosen(best_values);
        }
    }
    if (own_solves) {
        work.factor.reset();
        Eigen::MatrixXd parts(r.tau.size(), 2);
        parts << r.tau.real(), r.tau.imag();
        r.closedness_max = kernels::closedness_error(surface, parts);
        r.homology.sparse_closed_forms = {};
        work.laplace_closed_forms = {};
    }
    if (intrinsic) {
        work.intrinsic.forms = {};
        r.intrinsic = std::make_shared<const kernels::IntrinsicTriangulation>(std::move(work.intrinsic));
    }
    work.intrinsic = {};
    r.laplace_weights = std::move(work.weights);
    work.weights = {};
    clock.lap("integration");

    if (!r.harmonic.allFinite() || !r.tau.allFinite())
        throw SolverFailure("conformal: non-finite values in the harmonic forms");
}

void run_after_prepare(ConformalWork& work, FactorizationCache* cache) {
    laplacian(work);
    homology_and_factorise(work, cache);
    const int blocks = begin_solves(work);
    par::for_each_index(static_cast<std::size_t>(blocks), blocks > 1,
                        [&](std::size_t b) { solve_block(work, static_cast<int>(b)); });
    end_solves(work);
    hodge_star(work);
    integrate(work);
}

}  // namespace conformal_stage

ConformalResult compute_conformal(const MeshView& input, const ConformalOptions& options,
                                  FactorizationCache* cache) {
    // The caller owns the mesh: a non-owning pointer to it.
    ConformalWork work = conformal_stage::prepare(
        std::shared_ptr<const MeshView>(std::shared_ptr<const MeshView>{}, &input), options);
    conformal_stage::run_after_prepare(work, cache);
    return std::move(work.result);
}

const char* form_name(FormChoice form) {
    return form == FormChoice::IntegerPeriods ? "integer_periods" : "generic";
}

nlohmann::json conformal_report(const ConformalResult& r) {
    const int g = r.basis.genus;
    nlohmann::json period = nlohmann::json::array();
    for (int i = 0; i < g; ++i) {
        nlohmann::json row = nlohmann::json::array();
        for (int j = 0; j < g; ++j)
            row.push_back({r.basis.period_matrix(i, j).real(), r.basis.period_matrix(i, j).imag()});
        period.push_back(row);
    }
    nlohmann::json j = {
        {"genus", r.input_genus},
        {"working_genus", g},
        {"double_covered", r.double_covered},
        {"vertices", r.surface->n_vertices()},
        {"faces", r.surface->n_faces()},
        {"period_matrix", period},
        {"form", form_name(r.form)},
        {"form_phase", r.form_phase},
        {"form_coefficients", std::vector<double>(r.form_coefficients.begin(), r.form_coefficients.end())},
        {"wedge_det", r.star.wedge_det},
        {"wedge_integrality_error", r.star.wedge_integrality_error},
        {"star_square_error", r.star.star_square_error},
        {"star_isometry_error", r.star.star_isometry_error},
        {"period_symmetry_error", r.basis.period_symmetry_error},
        {"period_im_min_eigenvalue", r.basis.period_im_min_eigenvalue},
        {"closedness_max", r.closedness_max},
        {"coclosedness_max", r.coclosedness_max},
        {"flipped_uv_triangles", r.quality.flipped},
        {"degenerate_uv_triangles", r.quality.degenerate},
        {"input_mesh_flipped_uv_triangles", r.input_mesh_quality.flipped},
        {"input_mesh_conformal_distortion",
         {{"mean", r.input_mesh_quality.distortion_mean},
          {"p95", r.input_mesh_quality.distortion_p95},
          {"max", r.input_mesh_quality.distortion_max}}},
        {"conformal_distortion",
         {{"mean", r.quality.distortion_mean},
          {"p95", r.quality.distortion_p95},
          {"max", r.quality.distortion_max}}},
        {"intrinsic_flips", r.intrinsic_flips},
        {"negative_cotan_weights", r.negative_weights},
        {"timings_ms", timings_report(r.timings_ms)},
    };
    if (g == 1) {
        const Complex m = kernels::reduce_modulus(r.basis.period_matrix(0, 0));
        j["reduced_modulus"] = {m.real(), m.imag()};
    }
    return j;
}

}  // namespace holoflow::engine
