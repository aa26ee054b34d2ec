#include "holoflow/kernels/patches.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/union_find.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr double kFlipTol = 1e-12;  // signed uv area below -tol * (longest edge)^2 is a flip

}  // namespace

Patches compute_patches(const MeshView& mesh, const Eigen::VectorXcd& tau, std::span<const char> border) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges() && static_cast<Index>(border.size()) == mesh.n_edges(),
                     "form and border flags must have one value per edge");
    const Index nf = mesh.n_faces();
    Patches p;
    p.face_patch.assign(nf, -1);
    p.corner_uv.assign(3 * static_cast<std::size_t>(nf), Complex(0));
    std::vector<Index> queue;
    queue.reserve(nf);
    for (Index seed = 0; seed < nf; ++seed) {
        if (p.face_patch[seed] >= 0) continue;
        const Index id = static_cast<Index>(p.info.size());
        p.info.emplace_back();
        p.face_patch[seed] = id;
        p.corner_uv[3 * seed] = 0;
        p.corner_uv[3 * seed + 1] = form_along(mesh, tau, 3 * seed);
        p.corner_uv[3 * seed + 2] = -form_along(mesh, tau, 3 * seed + 2);
        queue.assign(1, seed);
        for (std::size_t q = 0; q < queue.size(); ++q) {
            const Index f = queue[q];
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k, t = mesh.twin[h];
                if (t == kNoHalfedge || border[mesh.halfedge_edge[h]]) continue;
                const Index g = MeshView::face(t);
                if (p.face_patch[g] >= 0) continue;
                p.face_patch[g] = id;
                // t runs head(h) -> tail(h): its tail corner gets h's head uv.
                const Index kt = t % 3;
                const Complex base = p.corner_uv[3 * f + (k + 1) % 3];
                p.corner_uv[3 * g + kt] = base;
                p.corner_uv[3 * g + (kt + 1) % 3] = base + form_along(mesh, tau, t);
                p.corner_uv[3 * g + (kt + 2) % 3] = base - form_along(mesh, tau, MeshView::prev(t));
                queue.push_back(g);
            }
        }
    }

    const Index np = static_cast<Index>(p.info.size());
    const MapQuality quality = map_quality(mesh, edge_lengths(mesh), tau);
    std::vector<Complex> lo(np, Complex(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()));
    std::vector<Complex> hi(np, -lo[0]);
    std::vector<double> distortion_sum(np, 0);
    std::vector<Index> distortion_count(np, 0);
    std::vector<Index> interior_halfedges(np, 0), border_halfedges(np, 0);
    for (Index f = 0; f < nf; ++f) {
        PatchInfo& info = p.info[p.face_patch[f]];
        const Index id = p.face_patch[f];
        ++info.faces;
        const Complex a = p.corner_uv[3 * f], b = p.corner_uv[3 * f + 1], c = p.corner_uv[3 * f + 2];
        const double area = cross(b - a, c - a);
        const double scale = std::max({std::norm(b - a), std::norm(c - b), std::norm(a - c)});
        info.flipped_uv_triangles += area < -kFlipTol * scale;
        for (const Complex z : {a, b, c}) {
            lo[id] = {std::min(lo[id].real(), z.real()), std::min(lo[id].imag(), z.imag())};
            hi[id] = {std::max(hi[id].real(), z.real()), std::max(hi[id].imag(), z.imag())};
        }
        const double d = quality.face_distortion[f];
        if (std::isfinite(d)) {
            distortion_sum[id] += d;
            ++distortion_count[id];
            info.distortion_max = std::max(info.distortion_max, d);
        }
        for (int k = 0; k < 3; ++k) {
            const Index h = 3 * f + k, t = mesh.twin[h];
            const bool inner = t != kNoHalfedge && !border[mesh.halfedge_edge[h]];
            (inner ? interior_halfedges : border_halfedges)[id] += 1;
        }
    }
    // Vertices of each patch cut open: corners around a vertex joined across non-border edges.
    UnionFind wedges(mesh.n_halfedges());
    for (Index h = 0; h < mesh.n_halfedges(); ++h) {
        const Index p_edge = MeshView::prev(h), t = mesh.twin[p_edge];
        if (t == kNoHalfedge || border[mesh.halfedge_edge[p_edge]]) continue;
        wedges.unite(h, t);  // t leaves tail(h): the next corner around it
    }
    std::vector<Index> vertices(np, 0);
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (wedges.find(h) == h) ++vertices[p.face_patch[MeshView::face(h)]];

    // Border loops: follow border halfedges of the patch around its faces.
    std::vector<char> walked(mesh.n_halfedges(), 0);
    std::vector<int> loops(np, 0);
    const auto is_border = [&](Index h) {
        return mesh.twin[h] == kNoHalfedge || border[mesh.halfedge_edge[h]];
    };
    for (Index h0 = 0; h0 < mesh.n_halfedges(); ++h0) {
        if (walked[h0] || !is_border(h0)) continue;
        const Index id = p.face_patch[MeshView::face(h0)];
        ++loops[id];
        Index h = h0;
        while (!walked[h]) {
            walked[h] = 1;
            // Next border halfedge of this patch leaving head(h): turn around head(h) inside the patch.
            Index n = MeshView::next(h);
            while (!is_border(n)) n = MeshView::next(mesh.twin[n]);
            h = n;
        }
    }
    for (Index id = 0; id < np; ++id) {
        PatchInfo& info = p.info[id];
        const Index edges = interior_halfedges[id] / 2 + border_halfedges[id];
        info.euler_characteristic = static_cast<int>(vertices[id] - edges + info.faces);
        info.border_loops = loops[id];
        info.type = info.euler_characteristic == 1 && loops[id] == 1   ? PatchInfo::Type::Disk
                    : info.euler_characteristic == 0 && loops[id] == 2 ? PatchInfo::Type::Cylinder
                                                                        : PatchInfo::Type::Other;
        info.width = hi[id].real() - lo[id].real();
        info.height = hi[id].imag() - lo[id].imag();
        info.distortion_mean = distortion_count[id] ? distortion_sum[id] / distortion_count[id] : 0;
    }
    for (Index f = 0; f < nf; ++f)
        for (int k = 0; k < 3; ++k) p.corner_uv[3 * f + k] -= lo[p.face_patch[f]];
    // Rectangle fit: border corners against the nearest side.
    for (Index h = 0; h < mesh.n_halfedges(); ++h) {
        if (!is_border(h)) continue;
        const Index id = p.face_patch[MeshView::face(h)];
        PatchInfo& info = p.info[id];
        const Complex z = p.corner_uv[h];
        const double d = std::min({std::abs(z.real()), std::abs(info.width - z.real()), std::abs(z.imag()),
                                   std::abs(info.height - z.imag())});
        const double size = std::max(info.width, info.height);
        if (size > 0) info.rectangle_error = std::max(info.rectangle_error, d / size);
    }
    return p;
}

FlowComplex flow_complex(const MeshView& mesh, std::span<const Index> edge_label,
                         std::span<const Index> face_patch, std::span<const char> is_zero) {
    HOLOFLOW_REQUIRE(static_cast<Index>(edge_label.size()) == mesh.n_edges() &&
                         static_cast<Index>(face_patch.size()) == mesh.n_faces() &&
                         static_cast<Index>(is_zero.size()) == mesh.n_vertices(),
                     "labels, patches and zero flags must match the mesh");
    FlowComplex g;
    const Index ne = mesh.n_edges();
    std::vector<char> is_border(ne, 0);
    for (Index e = 0; e < ne; ++e) {
        const Index h = mesh.edge_halfedge[e];
        is_border[e] = edge_label[e] != kNoBorder || mesh.twin[h] == kNoHalfedge;
    }
    // Border edges around each vertex.
    std::vector<std::vector<Index>> vertex_border(mesh.n_vertices());
    for (Index e = 0; e < ne; ++e)
        if (is_border[e]) vertex_border[mesh.E(e, 0)].push_back(e), vertex_border[mesh.E(e, 1)].push_back(e);
    std::vector<Index> node_of(mesh.n_vertices(), -1);
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        const auto& b = vertex_border[v];
        const bool node = is_zero[v] || (!b.empty() && (b.size() != 2 || edge_label[b[0]] != edge_label[b[1]]));
        if (!node) continue;
        node_of[v] = static_cast<Index>(g.nodes.size());
        g.nodes.push_back({v, static_cast<bool>(is_zero[v])});
    }
    std::vector<char> used(ne, 0);
    const auto other_end = [&](Index e, Index v) { return mesh.E(e, 0) == v ? mesh.E(e, 1) : mesh.E(e, 0); };
    const auto sides = [&](Index e) {
        const Index h = mesh.edge_halfedge[e], t = mesh.twin[h];
        return std::array<Index, 2>{face_patch[MeshView::face(h)], t == kNoHalfedge ? -1 : face_patch[MeshView::face(t)]};
    };
    const auto walk = [&](Index start_vertex, Index e) {
        FlowComplex::Piece piece;
        piece.label = edge_label[e];
        piece.patches = sides(e);
        piece.from = node_of[start_vertex];
        piece.vertices.push_back(start_vertex);
        Index v = start_vertex;
        while (true) {
            used[e] = 1;
            v = other_end(e, v);
            piece.vertices.push_back(v);
            if (node_of[v] >= 0 || v == start_vertex) break;
            Index next = -1;
            for (Index c : vertex_border[v])
                if (!used[c]) next = c;
            if (next < 0) break;
            e = next;
        }
        piece.to = node_of[v];
        g.pieces.push_back(std::move(piece));
    };
    for (const FlowComplex::Node& n : g.nodes)
        for (Index e : vertex_border[n.vertex])
            if (!used[e]) walk(n.vertex, e);
    for (Index e = 0; e < ne; ++e)
        if (is_border[e] && !used[e]) walk(mesh.E(e, 0), e);  // loops without nodes
    Index np = 0;
    for (Index f : face_patch) np = std::max(np, f + 1);
    g.patch_pieces.resize(np);
    for (Index i = 0; i < static_cast<Index>(g.pieces.size()); ++i)
        for (Index side : g.pieces[i].patches)
            if (side >= 0 && (g.patch_pieces[side].empty() || g.patch_pieces[side].back() != i))
                g.patch_pieces[side].push_back(i);
    return g;
}

}  // namespace holoflow::kernels
