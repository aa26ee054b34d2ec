#include "holoflow/kernels/conformal_map.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/shapes.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr double kExactTol = 1e-12;  // sums of a few exact edge differences

// tau = d(x + i y) on a mesh: the identity map of planar geometry.
Eigen::VectorXcd planar_identity_form(const MeshView& mesh) {
    Eigen::VectorXcd tau(mesh.n_edges());
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        const Eigen::RowVector3d d = mesh.V.row(mesh.E(e, 1)) - mesh.V.row(mesh.E(e, 0));
        tau(e) = Complex(d.x(), d.y());
    }
    return tau;
}

TEST(MapQuality, PlanarIdentityIsConformal) {
    const MeshView grid = shapes::flat_grid(6, 5);
    const MapQuality q = map_quality(grid, edge_lengths(grid), planar_identity_form(grid));
    EXPECT_EQ(q.flipped, 0);
    EXPECT_EQ(q.degenerate, 0);
    EXPECT_NEAR(q.distortion_max, 1.0, kExactTol);
    EXPECT_NEAR(q.distortion_mean, 1.0, kExactTol);
}

TEST(MapQuality, StretchAndFlipAreMeasured) {
    const MeshView grid = shapes::flat_grid(4, 4);
    Eigen::VectorXcd tau = planar_identity_form(grid);
    for (auto& t : tau) t = Complex(3 * t.real(), t.imag());  // x stretched 3 times
    const MapQuality stretched = map_quality(grid, edge_lengths(grid), tau);
    EXPECT_NEAR(stretched.distortion_max, 3.0, 1e-9);
    EXPECT_NEAR(stretched.distortion_mean, 3.0, 1e-9);
    for (auto& t : tau) t = std::conj(t);  // a reflection flips every image triangle
    EXPECT_EQ(map_quality(grid, edge_lengths(grid), tau).flipped, grid.n_faces());
    // The distortion alone is the same per face, flipped or not; a collapsed face has none.
    tau(0) = 0;
    const std::vector<double> alone = face_distortion(grid, edge_lengths(grid), tau);
    const MapQuality with_counts = map_quality(grid, edge_lengths(grid), tau);
    EXPECT_EQ(alone, with_counts.face_distortion);
    EXPECT_GT(with_counts.degenerate, 0);
    EXPECT_EQ(std::count(alone.begin(), alone.end(), std::numeric_limits<double>::infinity()), with_counts.degenerate);
}

TEST(ClosednessError, ExactFormsAreClosedAndNoiseIsNot) {
    const MeshView torus = shapes::torus(2, 1, 12, 8);
    Eigen::MatrixXd forms = compute_homology_basis(torus).closed_forms;
    EXPECT_EQ(closedness_error(torus, forms), 0.0);
    forms(0, 0) += 0.5;
    EXPECT_GT(closedness_error(torus, forms), 0.1);
}

TEST(IntegrateForm, CornersDifferByTheFormAndCutsByPeriods) {
    const MeshView torus = shapes::torus(2, 1, 16, 8);
    const HomologyBasis basis = compute_homology_basis(torus);
    const Eigen::VectorXcd tau = basis.closed_forms.col(0).cast<Complex>() +
                                 Complex(0, 1) * basis.closed_forms.col(1).cast<Complex>();
    const ConformalMap map = integrate_form(torus, basis, tau);
    for (Index f = 0; f < torus.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) {
            const Index a = 3 * f + k, b = MeshView::next(a);
            const Complex along = static_cast<double>(torus.edge_sign(a)) * tau(torus.halfedge_edge[a]);
            EXPECT_NEAR(std::abs(map.corner_uv(basis, b) - map.corner_uv(basis, a) - along), 0, kExactTol);
        }
    // Across an edge the two sides agree unless it is cut; then they differ by a period, an
    // integer combination of the periods 1 and i of this form.
    Index cut_sides = 0;
    for (Index h = 0; h < torus.n_halfedges(); ++h) {
        const Index t = torus.twin[h];  // tail(h) == head(t)
        const Complex jump = map.corner_uv(basis, h) - map.corner_uv(basis, MeshView::next(t));
        if (!basis.cut_edge[torus.halfedge_edge[h]]) {
            EXPECT_NEAR(std::abs(jump), 0, kExactTol);
            continue;
        }
        ++cut_sides;
        EXPECT_NEAR(jump.real(), std::round(jump.real()), kExactTol);
        EXPECT_NEAR(jump.imag(), std::round(jump.imag()), kExactTol);
    }
    EXPECT_GT(cut_sides, 0);
}

}  // namespace
}  // namespace holoflow::kernels
