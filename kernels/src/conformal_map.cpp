#include "holoflow/kernels/conformal_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "holoflow/kernels/errors.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;

Complex form_along(const MeshView& mesh, const Eigen::VectorXcd& tau, Index h) {
    return static_cast<double>(mesh.edge_sign(h)) * tau(mesh.halfedge_edge[h]);
}

}  // namespace

ConformalMap integrate_form(const MeshView& mesh, const HomologyBasis& homology,
                            const Eigen::VectorXcd& tau) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    HOLOFLOW_REQUIRE(static_cast<Index>(homology.corner_wedge.size()) == mesh.n_halfedges(),
                     "homology basis belongs to another mesh");
    ConformalMap map;
    map.corner_wedge = homology.corner_wedge;
    map.wedge_uv.assign(homology.n_wedges, Complex(std::numeric_limits<double>::quiet_NaN(), 0));
    std::vector<char> placed(homology.n_wedges, 0);
    std::vector<char> visited(mesh.n_faces(), 0);
    std::vector<Index> queue;
    queue.reserve(mesh.n_faces());
    // Breadth-first over faces through uncut edges; each face gets its three corners from the
    // one already placed corner and the edge values (closedness makes the order irrelevant).
    for (Index seed = 0; seed < mesh.n_faces(); ++seed) {
        if (visited[seed]) continue;
        const Index w0 = map.corner_wedge[3 * seed];
        if (!placed[w0]) {
            map.wedge_uv[w0] = 0;
            placed[w0] = 1;
        }
        visited[seed] = 1;
        queue.push_back(seed);
        for (std::size_t q = queue.size() - 1; q < queue.size(); ++q) {
            const Index f = queue[q];
            Index known = -1;
            for (int k = 0; k < 3 && known < 0; ++k)
                if (placed[map.corner_wedge[3 * f + k]]) known = 3 * f + k;
            for (int step = 0; step < 2; ++step) {
                const Index next = MeshView::next(known);
                const Index w = map.corner_wedge[next];
                if (!placed[w]) {
                    map.wedge_uv[w] = map.wedge_uv[map.corner_wedge[known]] + form_along(mesh, tau, known);
                    placed[w] = 1;
                }
                known = next;
            }
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k, t = mesh.twin[h];
                if (t == kNoHalfedge || visited[MeshView::face(t)]) continue;
                if (homology.cut_edge.size() && homology.cut_edge[mesh.halfedge_edge[h]]) continue;
                visited[MeshView::face(t)] = 1;
                queue.push_back(MeshView::face(t));
            }
        }
    }

    // Conformal factor: mean of |tau(e)|^2 / |e|^2 over the edges at each vertex.
    map.conformal_factor.assign(mesh.n_vertices(), 0.0);
    std::vector<Index> count(mesh.n_vertices(), 0);
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        const double len2 = (mesh.V.row(mesh.E(e, 0)) - mesh.V.row(mesh.E(e, 1))).squaredNorm();
        const double ratio = std::norm(tau(e)) / len2;
        for (int s = 0; s < 2; ++s) {
            map.conformal_factor[mesh.E(e, s)] += ratio;
            ++count[mesh.E(e, s)];
        }
    }
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        if (count[v]) map.conformal_factor[v] /= count[v];
    return map;
}

MapQuality map_quality(const MeshView& mesh, const ConformalMap& map) {
    MapQuality q;
    q.face_distortion.assign(mesh.n_faces(), std::numeric_limits<double>::infinity());
    std::vector<double> finite;
    finite.reserve(mesh.n_faces());
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const Eigen::Vector3d p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)),
                              p2 = mesh.V.row(mesh.F(f, 2));
        // Triangle in its own orthonormal frame: p0 at 0, p1 on the x axis.
        const Eigen::Vector3d e1 = p1 - p0, e2 = p2 - p0;
        const double l1 = e1.norm();
        const Eigen::Vector3d x = e1 / l1;
        const Eigen::Vector3d n = e1.cross(e2);
        const Eigen::Vector3d y = n.cross(e1).normalized();
        Eigen::Matrix2d S;  // source edge vectors as columns
        S << l1, e2.dot(x), 0, e2.dot(y);
        const Complex z0 = map.corner_uv(3 * f), z1 = map.corner_uv(3 * f + 1),
                      z2 = map.corner_uv(3 * f + 2);
        Eigen::Matrix2d T;  // image edge vectors as columns
        T << (z1 - z0).real(), (z2 - z0).real(), (z1 - z0).imag(), (z2 - z0).imag();
        const double image_area = 0.5 * T.determinant();
        const double scale = std::max({std::norm(z1 - z0), std::norm(z2 - z0), std::norm(z2 - z1)});
        if (!(std::abs(image_area) > 1e-14 * scale)) {
            ++q.degenerate;
            continue;
        }
        if (image_area < 0) ++q.flipped;
        const Eigen::Matrix2d J = T * S.inverse();
        const Eigen::JacobiSVD<Eigen::Matrix2d> svd(J);
        const double d = svd.singularValues()(0) / svd.singularValues()(1);
        q.face_distortion[f] = d;
        finite.push_back(d);
    }
    if (!finite.empty()) {
        double sum = 0;
        for (double d : finite) sum += d;
        q.distortion_mean = sum / static_cast<double>(finite.size());
        q.distortion_max = *std::max_element(finite.begin(), finite.end());
        const std::size_t k = static_cast<std::size_t>(0.95 * static_cast<double>(finite.size() - 1));
        std::nth_element(finite.begin(), finite.begin() + static_cast<std::ptrdiff_t>(k), finite.end());
        q.distortion_p95 = finite[k];
    }
    return q;
}

double closedness_error(const MeshView& mesh, const Eigen::MatrixXcd& forms) {
    double worst = 0, scale = 0;
    for (Eigen::Index c = 0; c < forms.cols(); ++c) {
        const Eigen::VectorXcd col = forms.col(c);
        scale = std::max(scale, col.cwiseAbs().maxCoeff());
        for (Index f = 0; f < mesh.n_faces(); ++f) {
            Complex sum = 0;
            for (int k = 0; k < 3; ++k) sum += form_along(mesh, col, 3 * f + k);
            worst = std::max(worst, std::abs(sum));
        }
    }
    return scale > 0 ? worst / scale : 0;
}

}  // namespace holoflow::kernels
