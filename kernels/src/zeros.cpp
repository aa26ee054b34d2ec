#include "holoflow/kernels/zeros.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>

#include <Eigen/Geometry>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"
#include "holoflow/kernels/union_find.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr Index kParallelFaces = 20000;

// Image of halfedge h; an exactly zero image takes a generic linear image of the 3D edge vector
// (then of the edge's orientation), so no corner angle is atan2(0, 0).
Complex image_direction(const MeshView& mesh, const Eigen::VectorXcd& tau, Index h) {
    const Complex image = form_along(mesh, tau, h);
    if (image != Complex(0)) return image;
    const Index e = mesh.halfedge_edge[h];
    const double sign = mesh.edge_sign(h);
    const Eigen::RowVector3d d = mesh.V.row(mesh.E(e, 1)) - mesh.V.row(mesh.E(e, 0));
    const Complex generic(d(0) + 0.3719 * d(1) + 0.6113 * d(2), 0.5347 * d(0) - d(1) + 0.2953 * d(2));
    return sign * (generic != Complex(0) ? generic : Complex(1, 0));
}

double corner_angle(Complex from, Complex to) {
    const Complex r = std::conj(from) * to;
    return std::atan2(r.imag(), r.real());
}

// Critical point of the quadratic through the face's three images, laid out isometrically.
// Returns false when the images are (nearly) affine: no critical point to speak of.
bool quadratic_critical_point(const MeshView& mesh, const Eigen::VectorXcd& tau, Index f,
                              std::array<double, 3>& barycentric, Complex& image_offset) {
    const Eigen::RowVector3d p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)),
                             p2 = mesh.V.row(mesh.F(f, 2));
    const double a = (p1 - p0).norm();
    if (!(a > 0)) return false;
    const double x2 = (p2 - p0).dot(p1 - p0) / a;
    const double y2 = (p1 - p0).cross(p2 - p0).norm() / a;
    const Complex z1(a, 0), z2(x2, y2);
    const Complex w1 = image_direction(mesh, tau, 3 * f), w2 = -image_direction(mesh, tau, 3 * f + 2);
    // A z^2 + B z = w at z1, z2 (C = 0 at corner 0).
    const Complex det = z1 * z1 * z2 - z2 * z2 * z1;
    if (std::abs(det) == 0) return false;
    const Complex A = (w1 * z2 - w2 * z1) / det;
    const Complex B = (z1 * z1 * w2 - z2 * z2 * w1) / det;
    if (!(std::abs(A) * (a * a + std::norm(z2)) > 1e-9 * (std::abs(w1) + std::abs(w2)))) return false;
    const Complex z = -B / (2.0 * A);
    image_offset = -B * B / (4.0 * A);
    // Barycentric of z in (0, z1, z2).
    const double area2 = a * y2;
    const double b2 = z.imag() * a / area2;
    const double b1 = (z.real() * y2 - z.imag() * x2) / area2;
    barycentric = {1 - b1 - b2, b1, b2};
    return std::isfinite(b1) && std::isfinite(b2) && std::isfinite(image_offset.real()) &&
           std::isfinite(image_offset.imag());
}

Zero place_zero(const MeshView& mesh, const Eigen::VectorXcd& tau, const ZeroCluster& cluster,
                const std::vector<int>& winding) {
    Zero zero;
    zero.order = cluster.index;
    // A lone vertex winding k + 1 times is the zero itself.
    if (cluster.flipped_faces.empty()) {
        Index best = cluster.vertices.front();
        for (Index v : cluster.vertices)
            if (winding[v] > winding[best]) best = v;
        zero.vertex = best;
        return zero;
    }
    // Otherwise the flipped face whose quadratic critical point lies deepest inside it.
    double best_depth = -std::numeric_limits<double>::infinity();
    for (Index f : cluster.flipped_faces) {
        std::array<double, 3> bary;
        Complex offset;
        if (!quadratic_critical_point(mesh, tau, f, bary, offset)) continue;
        const double depth = std::min({bary[0], bary[1], bary[2]});
        if (depth > best_depth) {
            best_depth = depth;
            zero.face = f;
            zero.barycentric = bary;
            zero.image_offset = offset;
        }
    }
    if (zero.face >= 0 && best_depth >= -1e-9) {
        for (double& b : zero.barycentric) b = std::max(b, 0.0);
        const double sum = zero.barycentric[0] + zero.barycentric[1] + zero.barycentric[2];
        for (double& b : zero.barycentric) b /= sum;
        return zero;
    }
    // No fit inside its face: the first flipped face's centroid, image by linear interpolation.
    const Index f = cluster.flipped_faces.front();
    zero = Zero{};
    zero.order = cluster.index;
    zero.face = f;
    zero.barycentric = {1.0 / 3, 1.0 / 3, 1.0 / 3};
    zero.image_offset = (image_direction(mesh, tau, 3 * f) - image_direction(mesh, tau, 3 * f + 2)) / 3.0;
    return zero;
}

}  // namespace

ZeroSet find_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    HOLOFLOW_REQUIRE(tau.allFinite(), "form has non-finite values");
    HOLOFLOW_REQUIRE(mesh.is_closed(), "zero bookkeeping needs a closed surface");
    const Index nv = mesh.n_vertices(), nf = mesh.n_faces();
    ZeroSet z;
    z.face_flip.assign(nf, 0);
    std::vector<double> angle(3 * static_cast<std::size_t>(nf));
    par::for_each_range(static_cast<std::size_t>(nf), kParallelFaces, [&](std::size_t begin, std::size_t end) {
        for (Index f = static_cast<Index>(begin); f < static_cast<Index>(end); ++f) {
            double sum = 0;
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k;
                const double a = corner_angle(image_direction(mesh, tau, h),
                                              -image_direction(mesh, tau, MeshView::prev(h)));
                angle[h] = a;
                sum += a;
            }
            // sum is pi (counter-clockwise image), -pi (flipped) or 3 pi (all three angles pi);
            // the count below keeps the identity exact for any of them.
            z.face_flip[f] = static_cast<int>(std::lround((std::numbers::pi - sum) / (2 * std::numbers::pi)));
        }
    });
    std::vector<double> vertex_angle(nv, 0.0);
    for (Index h = 0; h < mesh.n_halfedges(); ++h) vertex_angle[mesh.tail(h)] += angle[h];
    z.winding.resize(nv);
    for (Index v = 0; v < nv; ++v)
        z.winding[v] = static_cast<int>(std::lround(vertex_angle[v] / (2 * std::numbers::pi)));

    // Cluster vertices with w != 1 and the corners of flipped faces.
    std::vector<char> special(nv, 0);
    UnionFind uf(nv);
    for (Index v = 0; v < nv; ++v) {
        special[v] = z.winding[v] != 1;
        z.total_index += z.winding[v] - 1;
        z.nonpositive_winding_vertices += z.winding[v] <= 0;
    }
    for (Index f = 0; f < nf; ++f) {
        if (!z.face_flip[f]) continue;
        z.total_index += z.face_flip[f];
        for (int k = 0; k < 3; ++k) {
            special[mesh.F(f, k)] = 1;
            uf.unite(mesh.F(f, k), mesh.F(f, (k + 1) % 3));
        }
    }
    for (Index e = 0; e < mesh.n_edges(); ++e)
        if (special[mesh.E(e, 0)] && special[mesh.E(e, 1)]) uf.unite(mesh.E(e, 0), mesh.E(e, 1));

    std::vector<Index> cluster_of(nv, -1);
    for (Index v = 0; v < nv; ++v) {
        if (!special[v]) continue;
        const Index root = uf.find(v);
        if (cluster_of[root] < 0) {  // roots are smallest members: clusters come out ordered
            cluster_of[root] = static_cast<Index>(z.clusters.size());
            z.clusters.emplace_back();
        }
        cluster_of[v] = cluster_of[root];
        ZeroCluster& c = z.clusters[cluster_of[v]];
        c.vertices.push_back(v);
        c.index += z.winding[v] - 1;
    }
    for (Index f = 0; f < nf; ++f) {
        if (!z.face_flip[f]) continue;
        ZeroCluster& c = z.clusters[cluster_of[mesh.F(f, 0)]];
        c.flipped_faces.push_back(f);
        c.index += z.face_flip[f];
    }

    // Negative clusters join the nearest positive one (breadth-first over edges), so the
    // reported orders add up to the exact total.
    std::vector<Index> nearest(nv, -1), queue;
    for (Index c = 0; c < static_cast<Index>(z.clusters.size()); ++c)
        if (z.clusters[c].index > 0)
            for (Index v : z.clusters[c].vertices) nearest[v] = c, queue.push_back(v);
    for (std::size_t q = 0; q < queue.size(); ++q) {
        const Index v = queue[q];
        Index h = mesh.vertex_halfedge[v];
        const Index start = h;
        do {
            const Index w = mesh.head(h);
            if (nearest[w] < 0) nearest[w] = nearest[v], queue.push_back(w);
            h = mesh.rotate(h);
        } while (h != start && h != kNoHalfedge);
    }
    for (ZeroCluster& c : z.clusters) {
        if (c.index > 0) continue;
        ++z.artifact_clusters;
        if (c.index == 0 || nearest[c.vertices.front()] < 0) continue;
        ZeroCluster& target = z.clusters[nearest[c.vertices.front()]];
        target.index += c.index;
        target.vertices.insert(target.vertices.end(), c.vertices.begin(), c.vertices.end());
        target.flipped_faces.insert(target.flipped_faces.end(), c.flipped_faces.begin(), c.flipped_faces.end());
        std::sort(target.vertices.begin(), target.vertices.end());
        std::sort(target.flipped_faces.begin(), target.flipped_faces.end());
        c = ZeroCluster{};
        ++z.merged_negative_clusters;
    }
    for (Index c = 0; c < static_cast<Index>(z.clusters.size()); ++c) {
        if (z.clusters[c].index <= 0) continue;
        Zero zero = place_zero(mesh, tau, z.clusters[c], z.winding);
        zero.cluster = c;
        z.total_order += zero.order;
        z.zeros.push_back(zero);
    }
    return z;
}

}  // namespace holoflow::kernels
