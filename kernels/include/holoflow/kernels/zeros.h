#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Angle in [-pi, pi] turning `from` into `to`: an image corner's angle between its two edges.
inline double corner_angle(std::complex<double> from, std::complex<double> to) {
    const std::complex<double> r = std::conj(from) * to;
    return std::atan2(r.imag(), r.real());
}

//! An upper bound of std::atan2(y, x) within 4e-5 of it, without the call: a polynomial
//! arctangent (Abramowitz and Stegun 4.4.49, error 1.15e-5 at most on [0, 1]) plus 2e-5; +inf where
//! it cannot tell (both zero, or a non-finite input). Sums of it bound angle sums from above.
inline double atan2_above(double y, double x) {
    const double ax = std::abs(x), ay = std::abs(y);
    if (!(std::isfinite(ax) && std::isfinite(ay)) || (ax == 0 && ay == 0))
        return std::numeric_limits<double>::infinity();
    const double t = std::min(ax, ay) / std::max(ax, ay), t2 = t * t;
    double a = t * (0.9998660 + t2 * (-0.3302995 + t2 * (0.1801410 + t2 * (-0.0851330 + t2 * 0.0208351))));
    if (ay > ax) a = std::numbers::pi / 2 - a;
    if (x < 0) a = std::numbers::pi - a;
    return (std::signbit(y) ? -a : a) + 2e-5;
}

//! Flips of an image triangle from the sum of its three corner angles: 0 for pi
//! (counter-clockwise), 1 for -pi (flipped), -1 for 3 pi (all three angles pi).
inline int image_flips(double angle_sum) {
    return static_cast<int>(std::lround((std::numbers::pi - angle_sum) / (2 * std::numbers::pi)));
}

//! Image angle at the tail of halfedge h of triangles whose halfedge 3 f + k runs along
//! `along[3 f + k]`: between h and the reverse of the previous halfedge of its face.
inline double tail_angle(std::span<const std::complex<double>> along, Index h) {
    return corner_angle(along[h], -along[MeshView::prev(h)]);
}

//! image_flips of face f from its three tail angles.
inline int face_flips(std::span<const std::complex<double>> along, Index f) {
    return image_flips(tail_angle(along, 3 * f) + tail_angle(along, 3 * f + 1) + tail_angle(along, 3 * f + 2));
}

//! Flips per face and turns per vertex of a piecewise linear image.
struct ImageTurns {
    std::vector<int> face_flip;  //!< #F: image_flips of the face's angle sum
    std::vector<int> turns;      //!< #V: angle sum in whole turns, in half-turns where `half`
};

//! \brief The image bookkeeping of triangles F whose halfedge h = 3 f + k runs along `along[h]`
//! in the image: per face image_flips of its three corner angles (corner_angle of its two
//! edges), per vertex the sum of its corners' angles over 2 pi (over pi where half[v]),
//! rounded. Exactly these numbers, with no arctangent where none is needed: a face whose
//! corners are all clearly not straight flips by its orientation, and an inner vertex whose
//! corners are all so and whose link keeps clear of the ray from it towards +x turns as often
//! as the link crosses that ray (each corner's principal angle is the one its straight opposite
//! side sweeps); the other vertices sum their angles in ascending halfedge order.
//! \pre along has 3 #F values; half empty or #V flags.
ImageTurns image_turns(const TriangleMatrix& F, Index n_vertices, std::span<const std::complex<double>> along,
                       std::span<const char> half = {});

//! Special vertices that touch: saddles (saddle_order != 0), vertices with image winding != 1
//! and corners of flipped image triangles (DESIGN 2.5). A component holding several saddle
//! groups is split between them (each special vertex goes to its nearest group), so a cluster
//! holds at most one group of adjacent saddles.
struct ZeroCluster {
    int index = 0;                    //!< sum of saddle_order over its vertices: the zero's order if > 0
    std::vector<Index> vertices;      //!< ascending
    std::vector<Index> flipped_faces; //!< ascending
};

//! A zero's position refined inside the star of its saddle vertex (refine_zero).
struct ZeroPoint {
    Index face = -1;  //!< -1: not refined, the zero stays at its vertex
    std::array<double, 3> barycentric{};  //!< weights of the face's corners 0, 1, 2
    std::complex<double> image_offset{};  //!< image of the point minus image of corner 0
    std::array<double, 3> position{};     //!< the point in space
};

//! A zero point of the form: at a saddle vertex, and refined to a point of a face around it.
struct Zero {
    int order = 0;
    Index cluster = -1;  //!< in ZeroSet::clusters
    Index vertex = -1;   //!< the saddle vertex it sits at
    ZeroPoint point;     //!< where the form vanishes near it, when the fit places it
};

struct ZeroSet {
    std::vector<int> winding;      //!< #V: turns of the image one-ring around the vertex's image
    std::vector<int> face_flip;    //!< #F: 1 for a flipped image triangle, else 0
    std::vector<ZeroCluster> clusters;  //!< ordered by smallest vertex
    std::vector<Zero> zeros;            //!< clusters of positive index, in cluster order
    int total_index = 0;  //!< sum (w_v - 1) + flips = 2g - 2 exactly on a closed surface
    int total_order = 0;  //!< sum of zero orders (= total_index when no cluster is negative)
    //! Clusters of index <= 0 that hold saddle-count defects (vertices with saddle_order != 0 away
    //! from any zero: a broken discrete maximum principle, e.g. negative weights; not the
    //! flat_clusters below), and positive ones the negatives merged into them cancelled.
    Index artifact_clusters = 0;
    //! Negative clusters merged into their nearest positive one (again if that one turned
    //! negative), so total_order = total_index whenever total_index >= 0.
    Index merged_negative_clusters = 0;
    Index nonpositive_winding_vertices = 0;  //!< w_v <= 0 anywhere
    //! #V: m_v = (sign changes of du around v) / 2 - 1 for u = Re of the integrated form, on the
    //! counting triangulation (Banchoff's index with the sign flipped); sum m_v = 2g - 2 exactly.
    std::vector<int> saddle_order;
    //! Clusters with no saddle: folds of the mesh's piecewise linear image only (flips and
    //! windings != 1 where the form has no zero), left for regularise_zeros to re-triangulate.
    Index fold_clusters = 0;
    //! Vertices of the counting triangulation where u is not resolved: the harmonicity residual
    //! of du there is not small against sum_e w_e |du_e| (the form is rounding noise: a thin
    //! fin, a spike, a neck far from every handle), so the signs of du and the saddles counted
    //! there are noise. Each one's saddles, with those of its one-ring and of the unresolved
    //! vertices it touches, make one group, so the noise cancels inside one cluster.
    Index unresolved_vertices = 0;
    //! Clusters of index 0 whose saddles all lie in such a region: noise that cancelled, not an
    //! artifact. Left for regularise_zeros like fold clusters.
    Index flat_clusters = 0;
    bool intrinsic = false;  //!< saddles counted on the intrinsic Delaunay triangulation
};

struct IntrinsicTriangulation;

struct ZeroOptions {
    //! Count saddles on the intrinsic Delaunay triangulation of the mesh, where a form harmonic
    //! for its cotan Laplacian obeys the discrete maximum principle (every m_v >= 0). False:
    //! on the mesh itself (right for a form harmonic for the mesh's own cotan weights).
    bool intrinsic_delaunay = true;
    //! That triangulation when the caller has it already (the conformal stage's, of this very
    //! mesh): its flips are replayed on tau instead of redone (carry_forms, the same bits).
    const IntrinsicTriangulation* triangulation = nullptr;
    //! The cotan weights of the counting triangulation (`triangulation`'s, or the mesh's with
    //! intrinsic_delaunay false) when the caller has them, the Laplacian's: the unresolved-vertex
    //! test reuses them instead of recomputing. Empty: computed here.
    std::span<const double> weights;
};

//! \brief Zero points of the closed complex 1-form `tau` (one value per edge, along
//! E(e,0) -> E(e,1)) on a closed mesh. Zeros are the saddles of u = Re(integral of tau): around
//! each vertex of the intrinsic Delaunay triangulation the sign of du along the edges changes
//! 2 (m_v + 1) times; each triangle has exactly one corner with a change, so
//! sum m_v = 2g - 2 is an integer identity (Banchoff), and with nonnegative cotan weights the
//! discrete maximum principle makes every m_v >= 0, so no artifact can appear. Ties (du = 0)
//! are broken by Im tau, then a generic linear function of the positions, then vertex ids
//! (symbolic perturbation); a vertex of intrinsic degree one (forced to its neighbour's value)
//! hands its m_v to that neighbour. The mesh's own image-winding bookkeeping (each corner's
//! principal image angle; sum (w_v - 1) + flips = 2g - 2 exactly) is kept for the folds of the
//! piecewise linear image, which join the clusters so that regularise_zeros removes them. A
//! zero sits at its cluster's saddle vertex (highest m_v, then smallest id). Where du is rounding
//! noise (ZeroSet::unresolved_vertices) the saddles of each such region group together, so
//! their noise cancels in one cluster instead of making artifacts. Deterministic.
//! \pre closed mesh, tau has #E finite values.  \throw InvalidInput.
ZeroSet find_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau, const ZeroOptions& options = {});

//! \brief Refines a zero of order `order` at an interior `vertex` to a point of its star: the
//! integral F of tau over the one-ring, in the cone's conformal chart zeta = (r e^{i phi})^s
//! (phi the angle around the vertex, s = 2 pi / total angle), is fitted by least squares with a
//! complex polynomial of degree order + 1 (exact for F = a (zeta - zeta0)^(order+1) + c); the
//! zero is the mean of the fit's critical points (the saddle found by counting can be a vertex
//! next to the true zero, so a point just beyond the star is reached by unfolding the faces on
//! the way). Returns face -1 when the vertex is on the boundary, has fewer than order + 2
//! neighbours, the fit is degenerate or the point lies more than 6 faces beyond the star. Pure
//! and cheap (one small dense fit).
ZeroPoint refine_zero(const MeshView& mesh, const Eigen::VectorXcd& tau, Index vertex, int order);

}  // namespace holoflow::kernels
