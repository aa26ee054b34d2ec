#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Value of the 1-form `tau` (one value per edge, along E(e,0) -> E(e,1)) along halfedge h.
inline std::complex<double> form_along(const MeshView& mesh, const Eigen::VectorXcd& tau, Index h) {
    return static_cast<double>(mesh.edge_sign(h)) * tau(mesh.halfedge_edge[h]);
}

//! form_along of every halfedge, in halfedge order.
inline std::vector<std::complex<double>> forms_along(const MeshView& mesh, const Eigen::VectorXcd& tau) {
    std::vector<std::complex<double>> along(mesh.n_halfedges());
    for (Index h = 0; h < mesh.n_halfedges(); ++h) along[h] = form_along(mesh, tau, h);
    return along;
}

//! Image of corner k of face f in the face's own chart (corner 0 at the origin), from the form's
//! values along the halfedges (`along[h]` = form_along(mesh, tau, h)).
inline std::complex<double> chart_corner(std::span<const std::complex<double>> along, Index f, int k) {
    return k == 0 ? std::complex<double>(0) : k == 1 ? along[3 * f] : -along[3 * f + 2];
}

//! Cross product of two plane vectors given as complex numbers (twice their triangle's signed area).
inline double cross(std::complex<double> a, std::complex<double> b) {
    return a.real() * b.imag() - a.imag() * b.real();
}

//! Third corner of a triangle laid flat from its edge lengths: the base runs from 0 to `base` on
//! the real axis, the corner is `from_tail` from 0 and `from_head` from `base`, on the positive
//! side (on the axis when the lengths cannot close a triangle).
inline std::complex<double> apex_from_lengths(double base, double from_tail, double from_head) {
    const double x = (base * base + from_tail * from_tail - from_head * from_head) / (2 * base);
    return {x, std::sqrt(std::max(0.0, from_tail * from_tail - x * x))};
}

//! A holomorphic 1-form integrated over the fundamental domain.
struct ConformalMap {
    std::vector<std::complex<double>> wedge_uv;  //!< one complex coordinate per wedge
    std::vector<double> conformal_factor;        //!< #V: mean over the one-ring of |tau(e)|^2/|e|^2
    //! Coordinate of corner h (at tail(h)); wedges are the homology basis' corner_wedge.
    std::complex<double> corner_uv(const HomologyBasis& homology, Index h) const {
        return wedge_uv[homology.corner_wedge[h]];
    }
};

//! \brief Integrates the form `tau` (one complex value per edge, along E(e,0) -> E(e,1)) by a
//! walk over the faces of the fundamental domain from face 0 (uv 0 at its first corner); across
//! a cut edge the two sides differ by a period. \pre closed form, homology of this mesh.
//! \throw InvalidInput on size mismatch.
ConformalMap integrate_form(const MeshView& mesh, const HomologyBasis& homology,
                            const Eigen::VectorXcd& tau);

//! Quality of the piecewise-linear map whose edge vectors are a closed complex form `tau` on a
//! triangulation with the given edge lengths (intrinsic or from positions): image triangles need
//! no integration, so this works on any triangulation, cut or not.
struct MapQuality {
    Index flipped = 0;     //!< image triangles with negative signed area
    Index degenerate = 0;  //!< image triangles with zero area (relative to their edge lengths)
    //! Conformal distortion per face: ratio of the singular values of the affine map from the
    //! triangle (laid out from its lengths) to its image; 1 = conformal. Over non-degenerate faces.
    double distortion_mean = 0, distortion_p95 = 0, distortion_max = 0;
    std::vector<double> face_distortion;  //!< #F (infinity on degenerate faces)
};
MapQuality map_quality(const MeshView& mesh, std::span<const double> edge_length,
                       const Eigen::VectorXcd& tau);

//! MapQuality::face_distortion alone, without the counts and statistics.
std::vector<double> face_distortion(const MeshView& mesh, std::span<const double> edge_length,
                                    const Eigen::VectorXcd& tau);

//! Conformal distortion (as in MapQuality) of the affine map taking a triangle with edge lengths
//! a = |c0 c1|, b = |c1 c2|, c = |c2 c0| to the image with edge vectors c0 -> c1 = t0 and
//! c0 -> c2 = t2; infinity when the triangle or its image is degenerate.
double triangle_distortion(double a, double b, double c, std::complex<double> t0, std::complex<double> t2);

//! Euclidean length of every edge of a mesh from its positions.
std::vector<double> edge_lengths(const MeshView& mesh);

//! Closedness of 1-forms (#E x k): max over faces of |sum of the three edge values| divided by
//! the largest |value| on any edge. Holomorphic forms built from closed harmonic forms and their
//! stars (linear combinations) are closed exactly when these are.
double closedness_error(const MeshView& mesh, const Eigen::MatrixXd& forms);

}  // namespace holoflow::kernels
