#include "holoflow/engine/conformal_pipeline.h"

#include <algorithm>
#include <cmath>

#include "holoflow/engine/stage_clock.h"
#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/harmonic.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::engine {
namespace {

using Complex = std::complex<double>;

constexpr double kNegativeWeightTol = 1e-12;

}  // namespace

ConformalResult compute_conformal(const MeshView& input, const ConformalOptions& options) {
    ConformalResult r;
    StageClock clock(r.timings_ms);

    const kernels::Topology topology = kernels::compute_topology(input);
    r.input_genus = topology.genus;
    HOLOFLOW_REQUIRE(topology.components == 1,
                     "the mesh has " + std::to_string(topology.components) +
                         " components; use --component largest");
    if (topology.boundary_loops > 0) {
        HOLOFLOW_REQUIRE(topology.genus > 0 || topology.boundary_loops > 1,
                         "a topological disk has no holomorphic 1-form (tip slicing comes with "
                         "segmentation)");
        r.cover = std::make_shared<const kernels::DoubleCover>(kernels::double_cover(input));
        r.surface = std::shared_ptr<const MeshView>(r.cover, &r.cover->mesh);
        r.double_covered = true;
        clock.lap("double_cover");
    } else {
        HOLOFLOW_REQUIRE(topology.genus > 0,
                         "a closed genus-0 surface has no holomorphic 1-form (tip slicing "
                         "comes with segmentation)");
        r.surface = std::shared_ptr<const MeshView>(std::shared_ptr<const MeshView>{}, &input);
    }
    const MeshView& surface = *r.surface;

    r.homology = kernels::compute_homology_basis(surface);
    clock.lap("cut_graph_and_closed_forms");
    if (options.closed_forms) {
        HOLOFLOW_REQUIRE(!r.double_covered, "given closed forms need closed input");
        HOLOFLOW_REQUIRE(options.closed_forms->rows() == surface.n_edges() &&
                             options.closed_forms->cols() == r.homology.closed_forms.cols(),
                         "given closed forms must be #E x 2g");
    }
    const Eigen::MatrixXd& eta = options.closed_forms ? *options.closed_forms : r.homology.closed_forms;

    // The Laplacian lives on the intrinsic Delaunay triangulation (or the mesh itself); vertex
    // functions are shared by both, so the harmonic forms come back to the mesh's edges exactly.
    kernels::IntrinsicTriangulation intrinsic;
    const MeshView* laplace_mesh = &surface;
    const Eigen::MatrixXd* laplace_eta = &eta;  // the closed forms on the Laplacian's mesh
    std::vector<double> weights;
    if (options.laplacian == LaplacianKind::IntrinsicDelaunay) {
        intrinsic = kernels::intrinsic_delaunay(surface, eta);
        r.intrinsic_flips = intrinsic.flips;
        laplace_mesh = &intrinsic.mesh;
        laplace_eta = &intrinsic.forms;
        clock.lap("intrinsic_delaunay");
        weights = kernels::cotan_weights_from_lengths(intrinsic.mesh.halfedge_edge,
                                                      intrinsic.edge_length, intrinsic.mesh.n_edges());
    } else {
        weights = kernels::cotan_weights(surface);
    }
    {
        // Cocircular quads (rectangles in CAD meshes) give weights of -1e-15 by rounding.
        double scale = 0;
        for (double w : weights) scale = std::max(scale, std::abs(w));
        r.negative_weights = static_cast<Index>(std::count_if(
            weights.begin(), weights.end(), [&](double w) { return w < -kNegativeWeightTol * scale; }));
    }
    const std::vector<Index> pinned{r.homology.root};
    const kernels::LaplacianMatrix L =
        kernels::assemble_laplacian(surface.n_vertices(), laplace_mesh->E, weights, pinned);
    clock.lap("laplacian_assembly");
    const auto symbolic = kernels::CholeskySymbolic::analyse(L);
    clock.lap("analyse");
    const auto factor = kernels::CholeskyFactor::factorize(symbolic, L);
    clock.lap("factorise");

    // One solve for all 2g right-hand sides; the potential corrects the forms on both
    // triangulations (it lives on the shared vertices).
    const Eigen::MatrixXd potential =
        kernels::harmonic_potential(laplace_mesh->E, weights, *factor, *laplace_eta, pinned);
    r.harmonic = eta;
    kernels::add_gradient(surface.E, potential, r.harmonic);
    // On the intrinsic triangulation its carried forms become the harmonic ones in place.
    Eigen::MatrixXd& laplace_omega = laplace_mesh == &surface ? r.harmonic : intrinsic.forms;
    if (laplace_mesh != &surface) kernels::add_gradient(laplace_mesh->E, potential, laplace_omega);
    clock.lap("solves");
    {
        // Divergence left at the vertices, relative to the largest flux w_e omega_e it sums.
        Eigen::MatrixXd residual =
            kernels::codifferential(surface.n_vertices(), laplace_mesh->E, weights, laplace_omega);
        for (Index p : pinned) residual.row(p).setZero();  // the pinned row carries the balance
        const Eigen::Map<const Eigen::VectorXd> w(weights.data(), laplace_omega.rows());
        const double scale = (laplace_omega.array().colwise() * w.array()).abs().maxCoeff();
        r.coclosedness_max = scale > 0 ? residual.cwiseAbs().maxCoeff() / scale : 0;
    }

    r.star = kernels::hodge_star(weights, laplace_omega, kernels::wedge_matrix(surface, eta));
    clock.lap("hodge_star");
    r.basis = kernels::holomorphic_basis(r.star);
    r.closedness_max = kernels::closedness_error(surface, r.harmonic);
    clock.lap("holomorphic_basis");

    r.form_coefficients =
        r.double_covered
            ? kernels::even_form_coefficients(kernels::involution_matrix(*r.cover, r.homology))
            : kernels::generic_form_coefficients(r.harmonic.cols());
    // tau = sum_i d_i (omega_i + i *omega_i) with *omega_i = sum_j C(i, j) omega_j.
    const Eigen::VectorXd conjugate = r.star.star.transpose() * r.form_coefficients;
    const auto chosen_form = [&](const Eigen::MatrixXd& omega) -> Eigen::VectorXcd {
        return (omega * r.form_coefficients).cast<Complex>() +
               Complex(0, 1) * (omega * conjugate).cast<Complex>();
    };
    r.tau = chosen_form(r.harmonic);
    r.map = kernels::integrate_form(surface, r.homology, r.tau);
    r.input_mesh_quality = kernels::map_quality(surface, kernels::edge_lengths(surface), r.tau);
    if (laplace_mesh == &surface) {
        r.quality = r.input_mesh_quality;
    } else {
        r.quality =
            kernels::map_quality(*laplace_mesh, intrinsic.edge_length, chosen_form(laplace_omega));
    }
    clock.lap("integration");

    if (!r.harmonic.allFinite() || !r.tau.allFinite())
        throw SolverFailure("conformal: non-finite values in the harmonic forms");
    return r;
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
