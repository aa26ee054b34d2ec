#pragma once

#include <array>
#include <cmath>
#include <complex>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/zero_fans.h"

//! Planar test meshes with zeros of an analytic function placed inside faces (zero fans,
//! trajectories).
namespace holoflow::test {

//! Flat grid over [-1.5, 1.5]^2 turned by a generic angle (no edge along an axis).
inline MeshView turned_grid(int n) {
    MeshView m = shapes::flat_grid(n, n);
    const double c = std::cos(0.3), s = std::sin(0.3);
    for (Index v = 0; v < m.n_vertices(); ++v) {
        const double x = 3 * m.V(v, 0) - 1.5, y = 3 * m.V(v, 1) - 1.5;
        m.V(v, 0) = c * x - s * y;
        m.V(v, 1) = s * x + c * y;
    }
    return m;
}

//! Vertex v of a planar mesh as a complex number.
inline std::complex<double> point(const MeshView& m, Index v) { return {m.V(v, 0), m.V(v, 1)}; }

//! The exact form d f (one value per edge, along E(e,0) -> E(e,1)) for f given at the vertices.
inline Eigen::VectorXcd form_of(const MeshView& m, const std::vector<std::complex<double>>& f) {
    Eigen::VectorXcd tau(m.n_edges());
    for (Index e = 0; e < m.n_edges(); ++e) tau(e) = f[m.E(e, 1)] - f[m.E(e, 0)];
    return tau;
}

//! The first face whose 2D triangle holds z strictly inside, with its barycentric coordinates;
//! -1 if none.
inline Index face_containing(const MeshView& m, std::complex<double> z, std::array<double, 3>& bary) {
    for (Index f = 0; f < m.n_faces(); ++f) {
        const std::complex<double> a = point(m, m.F(f, 0)), b = point(m, m.F(f, 1)), c = point(m, m.F(f, 2));
        const double area = kernels::cross(b - a, c - a);
        const double b1 = kernels::cross(z - a, c - a) / area, b2 = kernels::cross(b - a, z - a) / area;
        if (b1 > 0 && b2 > 0 && b1 + b2 < 1) {
            bary = {1 - b1 - b2, b1, b2};
            return f;
        }
    }
    return -1;
}

//! A region for a zero of order `order` of f at z inside a face of m.
inline kernels::ZeroRegion face_zero(const MeshView& m, std::complex<double> z, int order,
                                     const std::function<std::complex<double>(std::complex<double>)>& f) {
    kernels::ZeroRegion r;
    r.order = order;
    r.face = face_containing(m, z, r.barycentric);
    for (int k = 0; k < 3; ++k) r.vertices.push_back(m.F(r.face, k));
    r.image_offset = f(z) - f(point(m, m.F(r.face, 0)));
    return r;
}

}  // namespace holoflow::test
