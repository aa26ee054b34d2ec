#include "holoflow/kernels/subdivision.h"

#include <array>
#include <algorithm>
#include <cmath>
#include <queue>
#include <tuple>

#include <Eigen/Geometry>

#include "holoflow/kernels/errors.h"

namespace holoflow::kernels {

namespace {

// The 1-to-4 split shared by every subdivision scheme here; only the positions V (#V + #E rows:
// input vertices, then one per input edge) differ between schemes.
//
// Input face f = (c0, c1, c2) with halfedge k running c_k -> c_{k+1} and midpoint m_k on it.
// Output face 4f + k = (c_k, m_k, m_{k+2}) has halfedges
//   12f + 3k     : c_k -> m_k        first half of input halfedge k
//   12f + 3k + 1 : m_k -> m_{k+2}    inner, opposite the middle face
//   12f + 3k + 2 : m_{k+2} -> c_k    second half of input halfedge k + 2
// and the middle face 4f + 3 = (m0, m1, m2) has halfedge 12f + 9 + j running m_j -> m_{j+1}.
MeshView split_faces(const MeshView& mesh, PointMatrix V) {
    const Index n_v = mesh.n_vertices(), n_f = mesh.n_faces();
    const Index n_h = mesh.n_halfedges();

    TriangleMatrix F(4 * n_f, 3);
    for (Index f = 0; f < n_f; ++f) {
        Index m[3];
        for (Index k = 0; k < 3; ++k) m[k] = n_v + mesh.halfedge_edge[3 * f + k];
        for (Index k = 0; k < 3; ++k) {
            F(4 * f + k, 0) = mesh.F(f, k);
            F(4 * f + k, 1) = m[k];
            F(4 * f + k, 2) = m[(k + 2) % 3];
            F(4 * f + 3, k) = m[k];
        }
    }

    // Halves of input halfedge h = 3f + k, in the output numbering above.
    auto first_half = [](Index h) { return 12 * (h / 3) + 3 * (h % 3); };
    auto second_half = [](Index h) { return 12 * (h / 3) + 3 * ((h % 3 + 1) % 3) + 2; };

    std::vector<Index> twin(12 * static_cast<std::size_t>(n_f), kNoHalfedge);
    for (Index h = 0; h < n_h; ++h) {
        const Index t = mesh.twin[h];
        if (t == kNoHalfedge) continue;
        twin[first_half(h)] = second_half(t);
        twin[second_half(h)] = first_half(t);
    }
    for (Index f = 0; f < n_f; ++f) {
        for (Index k = 0; k < 3; ++k) {
            const Index inner = 12 * f + 3 * k + 1;
            const Index middle = 12 * f + 9 + (k + 2) % 3;  // m_{k+2} -> m_k
            twin[inner] = middle;
            twin[middle] = inner;
        }
    }
    return make_mesh_view(std::move(V), std::move(F), std::move(twin));
}

// At least the faces bisect_long_edges makes (`inside`: #V flags), without splitting: every
// edge inside longer than max_length ends in 2^k pieces of at most max_length, each split of a
// face's side adds a face to it; and a face with its three corners inside ends tiled by
// triangles whose sides are at most max_length, none larger than the equilateral one. The
// length is taken a little longer, so that rounding in the midpoints cannot make it too high.
double bisected_faces_lower_bound(const MeshView& mesh, double max_length, const std::vector<char>& inside) {
    const double length = max_length * (1 + 1e-9);
    const double largest_area = std::sqrt(3.0) / 4 * length * length;
    double bound = 0;
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        double sides = 1;
        bool corners_inside = true;
        for (int k = 0; k < 3; ++k) {
            const Index a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3);
            corners_inside = corners_inside && inside[a];
            if (!inside[a] || !inside[b]) continue;
            const double l = (mesh.V.row(a) - mesh.V.row(b)).norm();
            if (l > length) sides += std::exp2(std::ceil(std::log2(l / length))) - 1;
        }
        double tiles = 0;
        if (corners_inside) {
            const Eigen::RowVector3d u = mesh.V.row(mesh.F(f, 1)) - mesh.V.row(mesh.F(f, 0));
            const Eigen::RowVector3d w = mesh.V.row(mesh.F(f, 2)) - mesh.V.row(mesh.F(f, 0));
            tiles = std::floor(0.5 * u.cross(w).norm() / largest_area);
        }
        bound += std::max(sides, tiles);
    }
    return bound;
}

}  // namespace

MeshView subdivide_midpoint(const MeshView& mesh) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges();
    PointMatrix V(n_v + n_e, 3);
    V.topRows(n_v) = mesh.V;
    for (Index e = 0; e < n_e; ++e)
        V.row(n_v + e) = 0.5 * (mesh.V.row(mesh.E(e, 0)) + mesh.V.row(mesh.E(e, 1)));
    return split_faces(mesh, std::move(V));
}

std::optional<MeshView> bisect_long_edges(const MeshView& mesh, double max_length, std::span<const char> zone,
                                          Index max_faces) {
    HOLOFLOW_REQUIRE(max_length > 0, "bisection needs a positive edge length");
    HOLOFLOW_REQUIRE(zone.empty() || static_cast<Index>(zone.size()) == mesh.n_vertices(),
                     "bisection zone must have one flag per vertex");
    std::vector<char> inside(zone.begin(), zone.end());
    if (zone.empty()) inside.assign(static_cast<std::size_t>(mesh.n_vertices()), 1);
    if (max_faces > 0 && bisected_faces_lower_bound(mesh, max_length, inside) > static_cast<double>(max_faces))
        return std::nullopt;
    std::vector<Eigen::RowVector3d> V(static_cast<std::size_t>(mesh.n_vertices()));
    for (Index v = 0; v < mesh.n_vertices(); ++v) V[v] = mesh.V.row(v);
    std::vector<std::array<Index, 3>> F(static_cast<std::size_t>(mesh.n_faces()));
    for (Index f = 0; f < mesh.n_faces(); ++f) F[f] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
    std::vector<Index> twin = mesh.twin;
    const auto tail = [&](Index h) { return F[h / 3][h % 3]; };
    const auto head = [&](Index h) { return F[h / 3][(h % 3 + 1) % 3]; };

    // Longest first, ties by the vertex pair: an entry is stale once its halfedge slot holds
    // another edge (faces are rewritten in place).
    using Entry = std::tuple<double, Index, Index, Index>;  // length, low vertex, high vertex, halfedge
    std::priority_queue<Entry> queue;
    const auto push = [&](Index h) {
        const Index a = tail(h), b = head(h);
        const double length = (V[a] - V[b]).norm();
        if (inside[a] && inside[b] && length > max_length) queue.emplace(length, std::min(a, b), std::max(a, b), h);
    };
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (twin[h] == kNoHalfedge || h < twin[h]) push(h);
    const auto link = [&](Index x, Index y) {
        twin[x] = y;
        if (y != kNoHalfedge) twin[y] = x;
    };
    // Face of halfedge h = (a, b, c) becomes (a, m, c) in place plus a new face (m, b, c);
    // returns the new face's halfedge m -> b.
    const auto split_side = [&](Index h, Index m) {
        const Index f = h / 3, k = h % 3;
        const Index b = head(h), c = F[f][(k + 2) % 3];
        const Index bc = 3 * f + (k + 1) % 3, outer_bc = twin[bc];
        const Index g = static_cast<Index>(F.size());
        F.push_back({m, b, c});
        twin.insert(twin.end(), 3, kNoHalfedge);
        F[f][(k + 1) % 3] = m;
        link(3 * g + 1, outer_bc);  // b -> c moves to the new face (queued again under its new slot)
        link(bc, 3 * g + 2);        // m -> c and c -> m
        push(3 * g + 1);
        return 3 * g;
    };
    const auto over_limit = [&] { return max_faces > 0 && static_cast<Index>(F.size()) > max_faces; };
    while (!queue.empty() && !over_limit()) {
        const auto [length, lo, hi, h] = queue.top();
        queue.pop();
        if (std::min(tail(h), head(h)) != lo || std::max(tail(h), head(h)) != hi) continue;
        const Index a = tail(h), b = head(h), t = twin[h];
        const Index m = static_cast<Index>(V.size());
        V.push_back(0.5 * (V[a] + V[b]));
        inside.push_back(1);
        const Index mb = split_side(h, m);  // h becomes a -> m
        if (t == kNoHalfedge) {
            for (Index x : {h, mb, Index(3 * (h / 3) + (h % 3 + 1) % 3)}) push(x);
            continue;
        }
        const Index ma = split_side(t, m);  // t becomes b -> m
        link(h, ma);
        link(t, mb);
        for (Index x : {h, t, Index(3 * (h / 3) + (h % 3 + 1) % 3), Index(3 * (t / 3) + (t % 3 + 1) % 3)}) push(x);
    }
    if (over_limit()) return std::nullopt;
    PointMatrix points(static_cast<Index>(V.size()), 3);
    for (std::size_t v = 0; v < V.size(); ++v) points.row(static_cast<Index>(v)) = V[v];
    TriangleMatrix triangles(static_cast<Index>(F.size()), 3);
    for (std::size_t f = 0; f < F.size(); ++f)
        for (int k = 0; k < 3; ++k) triangles(static_cast<Index>(f), k) = F[f][k];
    return make_mesh_view(std::move(points), std::move(triangles), std::move(twin));
}

MeshView flip_flat_edges_to_delaunay(const MeshView& mesh, double flatness) {
    HOLOFLOW_REQUIRE(flatness >= 0, "flatness must not be negative");
    TriangleMatrix F = mesh.F;
    std::vector<Index> twin = mesh.twin;
    const auto tail = [&](Index h) { return F(h / 3, h % 3); };
    const auto head = [&](Index h) { return F(h / 3, (h % 3 + 1) % 3); };
    const auto point = [&](Index v) -> Eigen::Vector3d { return mesh.V.row(v).transpose(); };
    // cot of the angle at p in triangle p q r, in 3D.
    const auto cot = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& r) {
        const Eigen::Vector3d u = q - p, w = r - p;
        return u.dot(w) / u.cross(w).norm();
    };
    std::vector<Index> queue;
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (twin[h] != kNoHalfedge && h < twin[h]) queue.push_back(h);
    // Flips only ever raise the smallest angle in the plane; a guard against rounding cycles.
    const std::size_t limit = 16 * queue.size() + 64;
    for (std::size_t q = 0; q < queue.size() && q < limit; ++q) {
        const Index h = queue[q], t = twin[h];
        if (t == kNoHalfedge || t / 3 == h / 3) continue;
        // Quad a -> d -> b -> c: h = a->b in (a, b, c), t = b->a in (b, a, d).
        const Index a = tail(h), b = head(h), c = head(MeshView::next(h)), d = head(MeshView::next(t));
        if (c == d) continue;
        const Eigen::Vector3d pa = point(a), pb = point(b), pc = point(c), pd = point(d);
        // Delaunay already (with a margin against near-cocircular quads flipping on noise). Most
        // edges stop here, so this test, the cheapest, comes first (the tests only skip: their
        // order changes no flip).
        const double cot_c = cot(pc, pa, pb), cot_d = cot(pd, pb, pa);
        if (!std::isfinite(cot_c) || !std::isfinite(cot_d) || cot_c + cot_d >= -1e-12 * (std::abs(cot_c) + std::abs(cot_d)))
            continue;
        const Eigen::Vector3d n = (pb - pa).cross(pc - pa);
        if (!(n.norm() > 0)) continue;
        const double side = std::max({(pb - pa).norm(), (pc - pa).norm(), (pd - pa).norm(), (pd - pb).norm()});
        if (std::abs(n.normalized().dot(pd - pa)) > flatness * side) continue;
        // Convex: both new triangles (c, a, d) and (d, b, c) turn the way the old ones did.
        if (!((pa - pc).cross(pd - pc).dot(n) > 0) || !((pb - pd).cross(pc - pd).dot(n) > 0)) continue;
        if (joins(F, twin, MeshView::prev(h), d)) continue;  // c -> a leaves c; the flip would double c-d
        flip_edge(F, twin, h);
        const Index f = h / 3, g = t / 3;
        for (Index x : {3 * f, 3 * f + 1, 3 * g, 3 * g + 1})
            if (twin[x] != kNoHalfedge) queue.push_back(x);
    }
    return make_mesh_view(mesh.V, std::move(F), std::move(twin));
}

}  // namespace holoflow::kernels

namespace holoflow::kernels {

Eigen::MatrixXd subdivide_forms_midpoint(const MeshView& mesh, const MeshView& fine,
                                         const Eigen::MatrixXd& forms) {
    HOLOFLOW_REQUIRE(forms.rows() == mesh.n_edges(), "forms must have one row per edge");
    HOLOFLOW_REQUIRE(fine.n_faces() == 4 * mesh.n_faces() &&
                         fine.n_vertices() == mesh.n_vertices() + mesh.n_edges(),
                     "fine mesh is not the midpoint subdivision of mesh");
    const Eigen::Index k = forms.cols();
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(fine.n_edges(), k);
    Eigen::MatrixXd potential(fine.n_vertices(), k);  // per face, only its six vertices are used
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        // Potential at the corners by walking the face's halfedges.
        Eigen::RowVectorXd value = Eigen::RowVectorXd::Zero(k);
        for (int c = 0; c < 3; ++c) {
            const Index h = 3 * f + c;
            potential.row(mesh.tail(h)) = value;
            value += static_cast<double>(mesh.edge_sign(h)) * forms.row(mesh.halfedge_edge[h]);
        }
        for (int c = 0; c < 3; ++c) {
            const Index h = 3 * f + c;
            potential.row(mesh.n_vertices() + mesh.halfedge_edge[h]) =
                0.5 * (potential.row(mesh.tail(h)) + potential.row(mesh.head(h)));
        }
        for (Index child = 4 * f; child < 4 * f + 4; ++child)
            for (int c = 0; c < 3; ++c) {
                const Index h = 3 * child + c;
                // Both faces of an edge write the same value: the form is closed.
                out.row(fine.halfedge_edge[h]) = static_cast<double>(fine.edge_sign(h)) *
                             (potential.row(fine.head(h)) - potential.row(fine.tail(h)));
            }
    }
    return out;
}

}  // namespace holoflow::kernels

namespace holoflow::kernels {

MeshView subdivide_loop(const MeshView& mesh) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges();
    PointMatrix V(n_v + n_e, 3);

    // Moved input vertices: one-rings walked by halfedge, so an edge repeated on one vertex pair
    // counts once per edge, as the valence does.
    for (Index v = 0; v < n_v; ++v) {
        const Index start = mesh.vertex_halfedge[v];
        Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
        Index valence = 0, h = start, last = start;
        do {
            sum += mesh.V.row(mesh.head(h));
            ++valence;
            last = h;
            h = mesh.rotate(h);
        } while (h != kNoHalfedge && h != start);
        if (h == kNoHalfedge) {
            // The fan starts at the outgoing boundary halfedge (MeshView guarantees it) and ends
            // at the face whose incoming halfedge is on the boundary: the two boundary neighbours.
            const Eigen::RowVector3d ends =
                mesh.V.row(mesh.head(start)) + mesh.V.row(mesh.tail(MeshView::prev(last)));
            V.row(v) = 0.75 * mesh.V.row(v) + 0.125 * ends;
        } else {
            // Warren's weights: Loop's convergence to a C1 limit with plain rational weights.
            const double beta = valence > 3 ? 3.0 / (8.0 * valence) : 3.0 / 16.0;
            V.row(v) = (1.0 - valence * beta) * mesh.V.row(v) + beta * sum;
        }
    }

    // Edge vertices: the two ends and the two opposite corners, found through the halfedges.
    for (Index e = 0; e < n_e; ++e) {
        const Index h = mesh.edge_halfedge[e], t = mesh.twin[h];
        const Eigen::RowVector3d ends = mesh.V.row(mesh.tail(h)) + mesh.V.row(mesh.head(h));
        if (t == kNoHalfedge) {
            V.row(n_v + e) = 0.5 * ends;
        } else {
            const Eigen::RowVector3d opposite =
                mesh.V.row(mesh.tail(MeshView::prev(h))) + mesh.V.row(mesh.tail(MeshView::prev(t)));
            V.row(n_v + e) = 0.375 * ends + 0.125 * opposite;
        }
    }
    return split_faces(mesh, std::move(V));
}

}  // namespace holoflow::kernels
