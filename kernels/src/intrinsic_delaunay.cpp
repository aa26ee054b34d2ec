#include "holoflow/kernels/intrinsic_delaunay.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

// The cotangent test itself rounds with an absolute error of a few ulps times the triangle's
// cotangent scale (a^2 + b^2 + c^2) / (4 area); a margin of ~1e4 ulps keeps near-cocircular
// quads from flipping back and forth on rounding noise.
constexpr double kDelaunayTol = 1e-12;

// 16 area^2 of a triangle with side lengths x, y, z by Heron's formula in Kahan's stable form
// (sides sorted descending); not positive when the triangle inequality fails, NaN on NaN input.
double sixteen_area_squared(double x, double y, double z) {
    if (x < y) std::swap(x, y);
    if (x < z) std::swap(x, z);
    if (y < z) std::swap(y, z);
    return (x + (y + z)) * (z - (x - y)) * (z + (x - y)) * (x + (y - z));
}

bool is_proper_triangle(double x, double y, double z) {
    const double s = sixteen_area_squared(x, y, z);
    return s > 0 && std::isfinite(s);  // false on NaN too
}

// Flat halfedge state of the triangulation being flipped. Halfedge 3f+k runs from corner k to
// corner k+1 of face f; flips rewrite two faces in place, so slots keep their meaning.
class Flipper {
 public:
    explicit Flipper(const MeshView& mesh)
        : corner_(static_cast<std::size_t>(mesh.n_halfedges())),
          twin_(mesh.twin),
          edge_(mesh.halfedge_edge),
          ref_(mesh.edge_halfedge),
          length_(static_cast<std::size_t>(mesh.n_edges())) {
        for (Index h = 0; h < mesh.n_halfedges(); ++h) corner_[h] = mesh.tail(h);
        for (Index e = 0; e < mesh.n_edges(); ++e)
            length_[e] = (mesh.V.row(mesh.E(e, 1)) - mesh.V.row(mesh.E(e, 0))).norm();
    }

    Index n_edges() const { return static_cast<Index>(length_.size()); }
    Index n_halfedges() const { return static_cast<Index>(corner_.size()); }
    double length(Index e) const { return length_[e]; }
    Index edge(Index h) const { return edge_[h]; }
    Index twin(Index h) const { return twin_[h]; }
    Index ref(Index e) const { return ref_[e]; }
    Index corner(Index h) const { return corner_[h]; }

    //! An interior edge with distinct faces on its sides (only those can flip).
    bool is_flippable(Index e) const {
        const Index h = ref_[e], t = twin_[h];
        return t != kNoHalfedge && MeshView::face(h) != MeshView::face(t);
    }

    //! cot c + cot d < -tol * scale for the angles c, d opposite the flippable edge e.
    bool violates_delaunay(Index e) const {
        const Index h = ref_[e], t = twin_[h];
        const double ab = length_[e];
        const double bc = length_[edge_[MeshView::next(h)]], ca = length_[edge_[MeshView::prev(h)]];
        const double ad = length_[edge_[MeshView::next(t)]], db = length_[edge_[MeshView::prev(t)]];
        const double four_area_c = std::sqrt(sixteen_area_squared(ab, bc, ca));
        const double four_area_d = std::sqrt(sixteen_area_squared(ab, ad, db));
        const double ab2 = ab * ab, bc2 = bc * bc, ca2 = ca * ca, ad2 = ad * ad, db2 = db * db;
        const double cot_sum = (bc2 + ca2 - ab2) / four_area_c + (ad2 + db2 - ab2) / four_area_d;
        const double scale = (ab2 + bc2 + ca2) / four_area_c + (ab2 + ad2 + db2) / four_area_d;
        return cot_sum < -kDelaunayTol * scale;
    }

    //! Flips edge e (abc, bad -> dca, cdb) and appends how its form values follow to `log`.
    //! Returns false, changing nothing, if the new diagonal or one of the new triangles comes out
    //! degenerate in floating point.
    bool flip(Index e, Index outer_edges[4], std::vector<FormFlip>& log) {
        const Index h = ref_[e], t = twin_[h];
        const Index hn = MeshView::next(h), hp = MeshView::prev(h);
        const Index tn = MeshView::next(t), tp = MeshView::prev(t);
        const Index a = corner_[h], b = corner_[hn], c = corner_[hp], d = corner_[tp];
        const double ab = length_[e], bc = length_[edge_[hn]], ca = length_[edge_[hp]];
        const double ad = length_[edge_[tn]], db = length_[edge_[tp]];

        // Lay out a = (0, 0), b = (ab, 0), c above and d below the x axis.
        const double four_area_c = std::sqrt(sixteen_area_squared(ab, bc, ca));
        const double four_area_d = std::sqrt(sixteen_area_squared(ab, ad, db));
        const double dx = ((ca * ca - bc * bc) - (ad * ad - db * db)) / (2 * ab);
        const double dy = (four_area_c + four_area_d) / (2 * ab);
        const double cd = std::hypot(dx, dy);
        if (!(cd > 0) || !std::isfinite(cd) || !is_proper_triangle(cd, ca, ad) ||
            !is_proper_triangle(cd, db, bc))
            return false;

        // eta(c->d) = eta(c->a) + eta(a->d), read before any slot moves. Slot h becomes d->c and
        // t becomes c->d; the edge keeps its index and its reference halfedge.
        const double sign_e = ref_[e] == t ? 1.0 : -1.0;
        log.push_back({e, edge_[hp], edge_[tn], sign_e * along(hp), sign_e * along(tn)});
        length_[e] = cd;

        // The outer halfedges keep their direction and rotate one slot: c->a from hp to hn,
        // a->d from tn to hp, d->b from tp to tn, b->c from hn to tp. They may be twins of each
        // other (a vertex of degree 2), so map twins through the move before writing.
        const Index from[4] = {hp, tn, tp, hn};
        const Index to[4] = {hn, hp, tn, tp};
        auto moved = [&](Index s) {
            for (int i = 0; i < 4; ++i)
                if (from[i] == s) return to[i];
            return s;
        };
        Index old_edge[4], old_twin[4];
        bool was_ref[4];
        for (int i = 0; i < 4; ++i) {
            old_edge[i] = edge_[from[i]];
            old_twin[i] = twin_[from[i]];
            was_ref[i] = ref_[old_edge[i]] == from[i];
        }
        for (int i = 0; i < 4; ++i) {
            edge_[to[i]] = old_edge[i];
            if (was_ref[i]) ref_[old_edge[i]] = to[i];
            const Index o = old_twin[i] == kNoHalfedge ? kNoHalfedge : moved(old_twin[i]);
            twin_[to[i]] = o;
            if (o != kNoHalfedge) twin_[o] = to[i];
            outer_edges[i] = old_edge[i];
        }
        corner_[h] = d;
        corner_[hn] = c;
        corner_[hp] = a;
        corner_[t] = c;
        corner_[tn] = d;
        corner_[tp] = b;
        return true;
    }

 private:
    //! +1 if halfedge h runs along its edge's reference direction, -1 otherwise.
    double along(Index h) const { return ref_[edge_[h]] == h ? 1.0 : -1.0; }

    std::vector<Index> corner_;  // #H: tail vertex of each halfedge
    std::vector<Index> twin_;    // #H
    std::vector<Index> edge_;    // #H: edge of each halfedge
    std::vector<Index> ref_;     // #E: halfedge along which the edge's form values are measured
    std::vector<double> length_;
};

}  // namespace

IntrinsicTriangulation intrinsic_delaunay(const MeshView& mesh, const IntrinsicDelaunayOptions& options) {
    const Index n_edges = mesh.n_edges();
    HOLOFLOW_REQUIRE(options.max_flips >= -1, "max_flips must be -1 or nonnegative");

    Flipper flipper(mesh);
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const double x = flipper.length(flipper.edge(3 * f)),
                     y = flipper.length(flipper.edge(3 * f + 1)),
                     z = flipper.length(flipper.edge(3 * f + 2));
        HOLOFLOW_REQUIRE(is_proper_triangle(x, y, z),
                         "face " + std::to_string(f) + " has zero area or non-finite positions");
    }

    // Ever-growing bound: Delaunay flipping terminates, so only a cycling bug could reach it.
    const std::int64_t safety_bound = 100 * static_cast<std::int64_t>(n_edges) + 1000;
    const std::int64_t limit = options.max_flips >= 0
                                   ? std::min<std::int64_t>(options.max_flips, safety_bound)
                                   : safety_bound;

    IntrinsicTriangulation result;
    // FIFO of edges to check, each at most once in it (in_queue), seeded in index order.
    std::vector<Index> queue(static_cast<std::size_t>(std::max<Index>(n_edges, 1)));
    std::vector<char> in_queue(static_cast<std::size_t>(n_edges), 0);
    std::size_t head = 0, count = 0;
    auto push = [&](Index e) {
        if (in_queue[e] || !flipper.is_flippable(e)) return;
        in_queue[e] = 1;
        queue[(head + count) % queue.size()] = e;
        ++count;
    };
    for (Index e = 0; e < n_edges; ++e) push(e);
    std::int64_t flips = 0;
    while (count > 0) {
        const Index e = queue[head];
        head = (head + 1) % queue.size();
        --count;
        in_queue[e] = 0;
        if (!flipper.is_flippable(e) || !flipper.violates_delaunay(e)) continue;
        if (flips == limit) {
            result.hit_flip_limit = true;
            break;
        }
        Index outer[4];
        if (!flipper.flip(e, outer, result.form_flips)) continue;  // counted by the final pass below
        ++flips;
        for (Index o : outer) push(o);
    }
    result.flips = static_cast<Index>(flips);
    for (Index e = 0; e < n_edges; ++e)
        if (flipper.is_flippable(e) && flipper.violates_delaunay(e)) ++result.non_delaunay_edges;

    TriangleMatrix F(mesh.n_faces(), 3);
    std::vector<Index> twin(static_cast<std::size_t>(flipper.n_halfedges()));
    for (Index h = 0; h < flipper.n_halfedges(); ++h) {
        F(h / 3, h % 3) = flipper.corner(h);
        twin[h] = flipper.twin(h);
    }
    result.mesh = make_mesh_view(mesh.V, std::move(F), std::move(twin));

    // make_mesh_view numbers edges by their smaller halfedge and orients them along it: move
    // lengths over and note where form values go, with a sign where our reference halfedge differs.
    result.edge_length.assign(static_cast<std::size_t>(n_edges), 0.0);
    result.form_slot.assign(static_cast<std::size_t>(n_edges), 0);
    result.form_sign.assign(static_cast<std::size_t>(n_edges), 1.0);
    for (Index e = 0; e < n_edges; ++e) {
        const Index r = flipper.ref(e), out = result.mesh.halfedge_edge[r];
        result.edge_length[out] = flipper.length(e);
        result.form_slot[out] = e;
        if (result.mesh.edge_halfedge[out] != r) result.form_sign[out] = -1.0;
    }
    return result;
}

Eigen::MatrixXd carry_forms(const IntrinsicTriangulation& triangulation, const Eigen::MatrixXd& forms) {
    const auto n_edges = static_cast<Eigen::Index>(triangulation.form_slot.size());
    HOLOFLOW_REQUIRE(forms.rows() == n_edges,
                     "forms needs one row per edge (" + std::to_string(n_edges) + ")");
    HOLOFLOW_REQUIRE(forms.allFinite(), "forms has non-finite values");
    Eigen::MatrixXd carried(n_edges, forms.cols());
    // Columns are independent: replay the flips on each in turn (in place, in flip order).
    par::for_each_index(static_cast<std::size_t>(forms.cols()), n_edges >= par::kParallelColumnRows, [&](std::size_t c) {
        const auto j = static_cast<Eigen::Index>(c);
        Eigen::VectorXd eta = forms.col(j);
        for (const FormFlip& f : triangulation.form_flips)
            eta[f.edge] = f.sign_a * eta[f.from_a] + f.sign_b * eta[f.from_b];
        double* out = carried.col(j).data();
        for (Eigen::Index e = 0; e < n_edges; ++e)
            out[e] = triangulation.form_sign[e] * eta[triangulation.form_slot[e]];
    });
    return carried;
}

Eigen::SparseMatrix<double> carry_forms(const IntrinsicTriangulation& triangulation,
                                        const Eigen::SparseMatrix<double>& forms) {
    const auto n_edges = static_cast<Eigen::Index>(triangulation.form_slot.size());
    HOLOFLOW_REQUIRE(forms.rows() == n_edges,
                     "forms needs one row per edge (" + std::to_string(n_edges) + ")");
    // Each column replayed as the dense overload does, in a scratch column of its thread's.
    return par::sparse_from_columns(
        n_edges, forms.cols(), n_edges >= par::kParallelColumnRows, [&](Eigen::Index j, double* out) {
            thread_local std::vector<double> eta;
            eta.assign(static_cast<std::size_t>(n_edges), 0.0);
            for (Eigen::SparseMatrix<double>::InnerIterator it(forms, j); it; ++it) {
                HOLOFLOW_REQUIRE(std::isfinite(it.value()), "forms has non-finite values");
                eta[static_cast<std::size_t>(it.row())] = it.value();
            }
            for (const FormFlip& f : triangulation.form_flips)
                eta[f.edge] = f.sign_a * eta[f.from_a] + f.sign_b * eta[f.from_b];
            for (Eigen::Index e = 0; e < n_edges; ++e) out[e] = triangulation.form_sign[e] * eta[triangulation.form_slot[e]];
        });
}

IntrinsicTriangulation intrinsic_delaunay(const MeshView& mesh, const Eigen::MatrixXd& forms,
                                          const IntrinsicDelaunayOptions& options) {
    IntrinsicTriangulation result = intrinsic_delaunay(mesh, options);
    result.forms = carry_forms(result, forms);
    return result;
}

}  // namespace holoflow::kernels
