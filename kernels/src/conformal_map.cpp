#include "holoflow/kernels/conformal_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Geometry>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;

constexpr Index kParallelFaces = 20000;  // below this, threads cost more than they save

}  // namespace

ConformalMap integrate_form(const MeshView& mesh, const HomologyBasis& homology,
                            const Eigen::VectorXcd& tau) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    HOLOFLOW_REQUIRE(static_cast<Index>(homology.corner_wedge.size()) == mesh.n_halfedges(),
                     "homology basis belongs to another mesh");
    ConformalMap map;
    const std::vector<Index>& corner_wedge = homology.corner_wedge;
    map.wedge_uv.assign(homology.n_wedges, Complex(std::numeric_limits<double>::quiet_NaN(), 0));
    std::vector<char> placed(homology.n_wedges, 0);
    std::vector<char> visited(mesh.n_faces(), 0);
    std::vector<Index> queue;
    queue.reserve(mesh.n_faces());
    // Breadth-first over faces through uncut edges; each face gets its three corners from the
    // one already placed corner and the edge values (closedness makes the order irrelevant).
    for (Index seed = 0; seed < mesh.n_faces(); ++seed) {
        if (visited[seed]) continue;
        const Index w0 = corner_wedge[3 * seed];
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
                if (placed[corner_wedge[3 * f + k]]) known = 3 * f + k;
            for (int step = 0; step < 2; ++step) {
                const Index next = MeshView::next(known);
                const Index w = corner_wedge[next];
                if (!placed[w]) {
                    map.wedge_uv[w] = map.wedge_uv[corner_wedge[known]] + form_along(mesh, tau, known);
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

std::vector<double> edge_lengths(const MeshView& mesh) {
    std::vector<double> length(mesh.n_edges());
    for (Index e = 0; e < mesh.n_edges(); ++e)
        length[e] = (mesh.V.row(mesh.E(e, 0)) - mesh.V.row(mesh.E(e, 1))).norm();
    return length;
}

double triangle_distortion(double a, double b, double c, Complex t0, Complex t2) {
    // Source triangle laid out from its lengths: corner 0 at 0, corner 1 on the x axis.
    const Complex corner2 = apex_from_lengths(a, c, b);
    const double x2 = corner2.real(), y2 = corner2.imag();
    const double scale = std::max({std::norm(t0), std::norm(t2 - t0), std::norm(t2)});
    if (!(std::abs(0.5 * cross(t0, t2)) > 1e-14 * scale) || !(y2 > 0)) return std::numeric_limits<double>::infinity();
    Eigen::Matrix2d S;  // source edge vectors corner0->corner1, corner0->corner2 as columns
    S << a, x2, 0, y2;
    Eigen::Matrix2d T;  // their images
    T << t0.real(), t2.real(), t0.imag(), t2.imag();
    // Singular values of the 2x2 Jacobian from its conformal and anti-conformal parts
    // (|q| +- |p|): exact 1 for a similarity, no cancellation. sqrt, not std::hypot: this runs
    // per face of every cut mesh, and Jacobian entries are far from overflow (an overflow gives
    // a non-finite distortion, counted as degenerate).
    const Eigen::Matrix2d J = T * S.inverse();
    const double q0 = J(0, 0) + J(1, 1), q1 = J(1, 0) - J(0, 1), p0 = J(0, 0) - J(1, 1), p1 = J(1, 0) + J(0, 1);
    const double conformal = std::sqrt(q0 * q0 + q1 * q1);
    const double anticonformal = std::sqrt(p0 * p0 + p1 * p1);
    return (conformal + anticonformal) / std::abs(conformal - anticonformal);
}

namespace {

enum FaceState : char { kGood, kFlipped, kDegenerate };

struct FaceMeasures {
    std::vector<double> distortion;  // infinity where degenerate
    std::vector<char> state;         // FaceState
};

// Per face in parallel (each face writes its own slots).
FaceMeasures measure_faces(const MeshView& mesh, std::span<const double> edge_length, const Eigen::VectorXcd& tau) {
    HOLOFLOW_REQUIRE(static_cast<Index>(edge_length.size()) == mesh.n_edges() &&
                         tau.size() == mesh.n_edges(),
                     "lengths and form must have one value per edge");
    FaceMeasures m{std::vector<double>(mesh.n_faces(), std::numeric_limits<double>::infinity()),
                   std::vector<char>(mesh.n_faces(), kGood)};
    par::for_each_range(static_cast<std::size_t>(mesh.n_faces()), kParallelFaces, [&](std::size_t begin, std::size_t end) {
        for (Index f = static_cast<Index>(begin); f < static_cast<Index>(end); ++f) {
            const Index h0 = 3 * f, h1 = 3 * f + 1, h2 = 3 * f + 2;
            const Complex t0 = form_along(mesh, tau, h0), t2 = -form_along(mesh, tau, h2);
            const double d = triangle_distortion(edge_length[mesh.halfedge_edge[h0]], edge_length[mesh.halfedge_edge[h1]],
                                                 edge_length[mesh.halfedge_edge[h2]], t0, t2);
            if (!std::isfinite(d)) {
                m.state[f] = kDegenerate;
                continue;
            }
            if (cross(t0, t2) < 0) m.state[f] = kFlipped;
            m.distortion[f] = d;
        }
    });
    return m;
}

}  // namespace

std::vector<double> face_distortion(const MeshView& mesh, std::span<const double> edge_length,
                                    const Eigen::VectorXcd& tau) {
    return measure_faces(mesh, edge_length, tau).distortion;
}

MapQuality map_quality(const MeshView& mesh, std::span<const double> edge_length,
                       const Eigen::VectorXcd& tau) {
    MapQuality q;
    FaceMeasures measured = measure_faces(mesh, edge_length, tau);
    q.face_distortion = std::move(measured.distortion);
    const std::vector<char>& state = measured.state;
    std::vector<double> finite;
    finite.reserve(mesh.n_faces());
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        q.flipped += state[f] == kFlipped;
        q.degenerate += state[f] == kDegenerate;
        if (state[f] != kDegenerate) finite.push_back(q.face_distortion[f]);
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

double closedness_error(const MeshView& mesh, const Eigen::MatrixXd& forms) {
    // Signed edge of every halfedge once, then one flat pass per column (columns in parallel).
    const Index n_h = mesh.n_halfedges();
    std::vector<Index> edge(n_h);
    std::vector<double> sign(n_h);
    for (Index h = 0; h < n_h; ++h) {
        edge[h] = mesh.halfedge_edge[h];
        sign[h] = mesh.edge_sign(h);
    }
    const auto cols = static_cast<std::size_t>(forms.cols());
    std::vector<double> worst(cols, 0.0), scale(cols, 0.0);
    par::for_each_index(cols, mesh.n_faces() > kParallelFaces, [&](std::size_t c) {
        const double* value = forms.col(static_cast<Eigen::Index>(c)).data();
        for (Index e = 0; e < mesh.n_edges(); ++e) scale[c] = std::max(scale[c], std::abs(value[e]));
        for (Index h = 0; h < n_h; h += 3) {
            const double sum = sign[h] * value[edge[h]] + sign[h + 1] * value[edge[h + 1]] +
                               sign[h + 2] * value[edge[h + 2]];
            worst[c] = std::max(worst[c], std::abs(sum));
        }
    });
    const double s = cols ? *std::max_element(scale.begin(), scale.end()) : 0.0;
    return s > 0 ? *std::max_element(worst.begin(), worst.end()) / s : 0.0;
}

}  // namespace holoflow::kernels
