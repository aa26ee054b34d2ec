#include "holoflow/kernels/cotan_laplacian.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

constexpr std::size_t kGrain = 16384;  // below this a loop is cheaper than a TBB task split
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

//! Cotangent of the angle opposite halfedge h, NaN when the face has zero area.
double cot_opposite(const MeshView& mesh, Index h) {
    const Index f = h / 3, k = h % 3;
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, k)).transpose();
    const Eigen::Vector3d b = mesh.V.row(mesh.F(f, (k + 1) % 3)).transpose();
    const Eigen::Vector3d c = mesh.V.row(mesh.F(f, (k + 2) % 3)).transpose();
    const Eigen::Vector3d u = a - c, v = b - c;
    const double twice_area = u.cross(v).norm();
    return twice_area > 0 ? u.dot(v) / twice_area : kNaN;
}

//! Cotangents of the angles opposite sides l[0], l[1], l[2] of a triangle, NaN if degenerate.
void cot_from_lengths(const double l[3], double cot[3]) {
    double x = l[0], y = l[1], z = l[2];
    // Kahan's ordering x >= y >= z keeps Heron's formula accurate on needles.
    if (x < y) std::swap(x, y);
    if (x < z) std::swap(x, z);
    if (y < z) std::swap(y, z);
    const double sixteen_area_sq = (x + (y + z)) * (z - (x - y)) * (z + (x - y)) * (x + (y - z));
    if (!(sixteen_area_sq > 0)) {  // also catches NaN
        cot[0] = cot[1] = cot[2] = kNaN;
        return;
    }
    const double four_area = std::sqrt(sixteen_area_sq);
    for (int k = 0; k < 3; ++k) {
        const double a = l[k], b = l[(k + 1) % 3], c = l[(k + 2) % 3];
        cot[k] = (b * b + c * c - a * a) / four_area;
    }
}

}  // namespace

std::vector<double> cotan_weights(const MeshView& mesh) {
    const Index n_edges = mesh.n_edges();
    std::vector<double> w(static_cast<std::size_t>(n_edges));
    par::for_each_range(w.size(), kGrain, [&](std::size_t begin, std::size_t end) {
        for (std::size_t e = begin; e < end; ++e) {
            const Index h = mesh.edge_halfedge[e], t = mesh.twin[h];
            // Fixed order (representative halfedge first) keeps the sum bit-reproducible.
            double sum = cot_opposite(mesh, h);
            if (t != kNoHalfedge) sum += cot_opposite(mesh, t);
            w[e] = 0.5 * sum;
        }
    });
    for (Index e = 0; e < n_edges; ++e) {
        if (std::isfinite(w[e])) continue;
        const Index h = mesh.edge_halfedge[e], t = mesh.twin[h];
        const bool first = std::isfinite(cot_opposite(mesh, h));
        const Index f = first && t != kNoHalfedge ? t / 3 : h / 3;
        throw InvalidInput("cotan_weights: face " + std::to_string(f) +
                           " has zero area or non-finite positions (edge " + std::to_string(e) +
                           ")");
    }
    return w;
}

std::vector<double> cotan_weights_from_lengths(std::span<const Index> halfedge_edge,
                                               std::span<const double> edge_length, Index n_edges) {
    HOLOFLOW_REQUIRE(n_edges >= 0 && edge_length.size() == static_cast<std::size_t>(n_edges),
                     "need one length per edge");
    HOLOFLOW_REQUIRE(halfedge_edge.size() % 3 == 0, "need 3 halfedges per face");
    for (std::size_t h = 0; h < halfedge_edge.size(); ++h)
        HOLOFLOW_REQUIRE(halfedge_edge[h] >= 0 && halfedge_edge[h] < n_edges,
                         "halfedge " + std::to_string(h) + " has an edge out of range");
    for (Index e = 0; e < n_edges; ++e)
        HOLOFLOW_REQUIRE(std::isfinite(edge_length[e]) && edge_length[e] > 0,
                         "edge " + std::to_string(e) + " has a non-positive length");

    const std::size_t n_faces = halfedge_edge.size() / 3;
    std::vector<double> cot(halfedge_edge.size());
    par::for_each_range(n_faces, kGrain / 3, [&](std::size_t begin, std::size_t end) {
        for (std::size_t f = begin; f < end; ++f) {
            // Halfedge 3f+k is opposite corner k+2, i.e. it is side k of the triangle.
            const double l[3] = {edge_length[halfedge_edge[3 * f]],
                                 edge_length[halfedge_edge[3 * f + 1]],
                                 edge_length[halfedge_edge[3 * f + 2]]};
            cot_from_lengths(l, &cot[3 * f]);
        }
    });
    // Serial scatter in halfedge order: reproducible sums, first bad face reported.
    std::vector<double> w(static_cast<std::size_t>(n_edges), 0.0);
    for (std::size_t h = 0; h < cot.size(); ++h) {
        if (std::isnan(cot[h]))
            throw InvalidInput("cotan_weights_from_lengths: face " + std::to_string(h / 3) +
                               " violates the triangle inequality or is degenerate");
        w[halfedge_edge[h]] += 0.5 * cot[h];
    }
    return w;
}

LaplacianMatrix laplacian_pattern(Index n_vertices, const EdgeMatrix& E,
                                  std::vector<Index> pinned) {
    HOLOFLOW_REQUIRE(n_vertices >= 0, "negative vertex count");
    const Index n_edges = static_cast<Index>(E.rows());
    HOLOFLOW_REQUIRE(E.size() == 0 || (E.minCoeff() >= 0 && E.maxCoeff() < n_vertices),
                     "edge vertex index out of range");
    for (Index p : pinned)
        HOLOFLOW_REQUIRE(p >= 0 && p < n_vertices,
                         "pinned vertex " + std::to_string(p) + " out of range");
    const auto n = static_cast<std::size_t>(n_vertices);

    // Two counting sorts (by row, then stably by column) leave every column's rows sorted in
    // O(V + E); repeated pairs become neighbours and merge into one slot.
    std::vector<Index> row_start(n + 1, 0), col_count(n + 1, 0);
    for (Index e = 0; e < n_edges; ++e) {
        const Index a = std::min(E(e, 0), E(e, 1)), b = std::max(E(e, 0), E(e, 1));
        if (a == b) continue;
        ++row_start[a + 1];
        ++col_count[b + 1];
    }
    for (std::size_t v = 0; v < n; ++v) {
        row_start[v + 1] += row_start[v];
        col_count[v + 1] += col_count[v];
    }
    const Index n_off = row_start[n];
    std::vector<Index> by_row(static_cast<std::size_t>(n_off));
    {
        std::vector<Index> next(row_start.begin(), row_start.end() - 1);
        for (Index e = 0; e < n_edges; ++e) {
            const Index a = std::min(E(e, 0), E(e, 1));
            if (a != std::max(E(e, 0), E(e, 1))) by_row[next[a]++] = e;
        }
    }
    std::vector<Index> by_col(static_cast<std::size_t>(n_off));
    {
        std::vector<Index> next(col_count.begin(), col_count.end() - 1);
        for (Index e : by_row) by_col[next[std::max(E(e, 0), E(e, 1))]++] = e;
    }

    LaplacianMatrix L;
    L.n = n_vertices;
    L.col_start.resize(n + 1);
    L.row.reserve(static_cast<std::size_t>(n_off) + n);
    L.edge_slot.assign(static_cast<std::size_t>(n_edges), -1);
    L.diagonal_slot.resize(n);
    L.col_start[0] = 0;
    for (std::size_t j = 0; j < n; ++j) {
        Index previous_row = -1;
        for (Index k = col_count[j]; k < col_count[j + 1]; ++k) {
            const Index e = by_col[k];
            const Index a = std::min(E(e, 0), E(e, 1));
            if (a != previous_row) {
                L.row.push_back(a);
                previous_row = a;
            }
            L.edge_slot[e] = static_cast<Index>(L.row.size()) - 1;
        }
        L.diagonal_slot[j] = static_cast<Index>(L.row.size());
        L.row.push_back(static_cast<Index>(j));
        L.col_start[j + 1] = static_cast<Index>(L.row.size());
    }
    L.value.assign(L.row.size(), 0.0);
    L.pinned = std::move(pinned);
    return L;
}

void fill_laplacian(LaplacianMatrix& L, std::span<const double> edge_weight) {
    HOLOFLOW_REQUIRE(edge_weight.size() == L.edge_slot.size(), "need one weight per edge");
    HOLOFLOW_REQUIRE(
        L.diagonal_slot.size() == static_cast<std::size_t>(L.n) && L.value.size() == L.row.size(),
        "matrix has no pattern");
    std::fill(L.value.begin(), L.value.end(), 0.0);
    const std::size_t n_edges = edge_weight.size();
    // An edge adds -w to its slot and +w to the diagonal of its smaller vertex (the slot's row);
    // the larger vertex (the slot's column) gets its share from the column sums below.
    for (std::size_t e = 0; e < n_edges; ++e) {
        const Index s = L.edge_slot[e];
        if (s < 0) continue;
        const double w = edge_weight[e];
        L.value[s] -= w;
        L.value[L.diagonal_slot[L.row[s]]] += w;
    }
    // Sequential slots of column j: no search for the column of an entry is needed.
    for (Index j = 0; j < L.n; ++j) {
        const Index d = L.diagonal_slot[j];
        double sum = 0;
        for (Index s = L.col_start[j]; s < d; ++s) sum -= L.value[s];
        L.value[d] += sum;
    }
    if (L.pinned.empty()) return;
    std::vector<char> is_pinned(static_cast<std::size_t>(L.n), 0);
    for (Index p : L.pinned) is_pinned[p] = 1;
    for (Index j = 0; j < L.n; ++j) {
        const Index d = L.diagonal_slot[j];
        for (Index s = L.col_start[j]; s < d; ++s)
            if (is_pinned[j] || is_pinned[L.row[s]]) L.value[s] = 0.0;
        if (is_pinned[j]) L.value[d] = 1.0;
    }
}

LaplacianMatrix assemble_laplacian(Index n_vertices, const EdgeMatrix& E,
                                   std::span<const double> edge_weight, std::vector<Index> pinned) {
    LaplacianMatrix L = laplacian_pattern(n_vertices, E, std::move(pinned));
    fill_laplacian(L, edge_weight);
    return L;
}

}  // namespace holoflow::kernels
