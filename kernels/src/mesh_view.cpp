#include "holoflow/kernels/mesh_view.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow {
namespace {

constexpr Index kParallelHalfedges = 24000;  // below this, one thread: the split costs more
constexpr Index kBlock = 16384;              // halfedges or vertices per block of make_mesh_view

std::string edge_name(Index a, Index b) {
    return "edge (" + std::to_string(a) + ", " + std::to_string(b) + ")";
}

std::vector<Index> pair_halfedges(const TriangleMatrix& F, Index n_vertices) {
    const HalfedgeGroups groups = group_halfedges_by_vertex_pair(F, n_vertices);
    auto tail = [&](Index h) { return F(h / 3, h % 3); };
    auto head = [&](Index h) { return F(h / 3, (h % 3 + 1) % 3); };
    std::vector<Index> twin(3 * static_cast<std::size_t>(F.rows()), kNoHalfedge);
    for (Index g = 0; g < groups.n_groups(); ++g) {
        const Index begin = groups.group_start[g], size = groups.group_start[g + 1] - begin;
        const Index h = groups.halfedges[begin];
        const Index a = std::min(tail(h), head(h)), b = std::max(tail(h), head(h));
        if (size > 2)
            throw ConnectivityError(ConnectivityError::Kind::NonManifoldEdge, a, b,
                                    "non-manifold " + edge_name(a, b) + ": " +
                                        std::to_string(size) + " faces share it");
        if (size < 2) continue;
        const Index k = groups.halfedges[begin + 1];
        if (tail(h) == tail(k))
            throw ConnectivityError(ConnectivityError::Kind::InconsistentOrientation, a, b,
                                    "inconsistent orientation at " + edge_name(a, b) +
                                        ": both faces traverse it in the same direction");
        twin[h] = k;
        twin[k] = h;
    }
    return twin;
}

}  // namespace

HalfedgeGroups group_halfedges_by_vertex_pair(const TriangleMatrix& F, Index n_vertices) {
    const Index n_h = 3 * static_cast<Index>(F.rows());
    auto tail = [&](Index h) { return F(h / 3, h % 3); };
    auto head = [&](Index h) { return F(h / 3, (h % 3 + 1) % 3); };
    std::vector<Index> bucket_start(static_cast<std::size_t>(n_vertices) + 1, 0);
    for (Index h = 0; h < n_h; ++h) ++bucket_start[std::min(tail(h), head(h)) + 1];
    for (Index v = 0; v < n_vertices; ++v) bucket_start[v + 1] += bucket_start[v];
    // Per bucket, keys (larger vertex, halfedge) packed in one integer: sorting them orders by
    // the other vertex with ties by halfedge index, which keeps the grouping deterministic.
    std::vector<std::uint64_t> key(n_h);
    {
        std::vector<Index> fill(bucket_start.begin(), bucket_start.end() - 1);
        for (Index h = 0; h < n_h; ++h) {
            const Index a = tail(h), b = head(h);
            key[fill[std::min(a, b)]++] = static_cast<std::uint64_t>(std::max(a, b)) << 32 | static_cast<std::uint32_t>(h);
        }
    }
    HalfedgeGroups groups;
    groups.halfedges.resize(n_h);
    groups.group_start.reserve(static_cast<std::size_t>(n_h) / 2 + 2);
    for (Index v = 0; v < n_vertices; ++v) {
        const Index begin = bucket_start[v], end = bucket_start[v + 1];
        std::sort(key.begin() + begin, key.begin() + end);
        for (Index i = begin; i < end; ++i) {
            groups.halfedges[i] = static_cast<Index>(key[i] & 0xffffffffu);
            if (i == begin || key[i] >> 32 != key[i - 1] >> 32) groups.group_start.push_back(i);
        }
    }
    groups.group_start.push_back(n_h);
    return groups;
}

bool MeshView::is_closed() const {
    return std::none_of(twin.begin(), twin.end(), [](Index t) { return t == kNoHalfedge; });
}

MeshView make_mesh_view(PointMatrix V, TriangleMatrix F) {
    HOLOFLOW_REQUIRE(F.size() == 0 || (F.minCoeff() >= 0 && F.maxCoeff() < V.rows()),
                     "face index out of range");
    for (Index f = 0; f < F.rows(); ++f)
        HOLOFLOW_REQUIRE(F(f, 0) != F(f, 1) && F(f, 1) != F(f, 2) && F(f, 2) != F(f, 0),
                         "face " + std::to_string(f) + " repeats a vertex");
    std::vector<Index> twin = pair_halfedges(F, static_cast<Index>(V.rows()));
    return make_mesh_view(std::move(V), std::move(F), std::move(twin));
}

MeshView make_mesh_view(PointMatrix V, TriangleMatrix F, std::vector<Index> twin) {
    HOLOFLOW_REQUIRE(F.rows() > 0, "mesh has no faces");
    HOLOFLOW_REQUIRE(F.rows() < (Index{1} << 30) / 2, "too many faces for 32-bit halfedge indices");
    HOLOFLOW_REQUIRE(F.minCoeff() >= 0 && F.maxCoeff() < V.rows(), "face index out of range");
    MeshView m;
    m.V = std::move(V);
    m.F = std::move(F);
    m.twin = std::move(twin);
    const Index n_h = m.n_halfedges();
    HOLOFLOW_REQUIRE(static_cast<Index>(m.twin.size()) == n_h, "twin array has the wrong size");
    // The passes over halfedges and vertices run in blocks, in parallel on large meshes; each
    // block writes its own slots, and a failed check throws for the smallest offender, as a
    // serial pass would.
    const bool parallel = n_h >= kParallelHalfedges;
    const auto for_each_block = [&](Index n, const std::function<void(Index, Index)>& fn) {
        const Index blocks = (n + kBlock - 1) / kBlock;
        par::for_each_index(static_cast<std::size_t>(blocks), parallel, [&](std::size_t b) {
            const Index begin = static_cast<Index>(b) * kBlock;
            fn(begin, std::min(n, begin + kBlock));
        });
    };
    const Index halfedge_blocks = (n_h + kBlock - 1) / kBlock;
    // Why halfedge h's twin does not fit; null where it does.
    const auto twin_fault = [&](Index h) -> const char* {
        const Index t = m.twin[h];
        if (t == kNoHalfedge) return nullptr;
        if (!(t >= 0 && t < n_h && t != h && m.twin[t] == h)) return "twin is not an involution at halfedge ";
        if (!(m.tail(t) == m.head(h) && m.head(t) == m.tail(h))) return "twin halfedges are not opposite at halfedge ";
        return nullptr;
    };
    // The twins of a badly ordered mesh lie far apart: fetched kTwinsAhead halfedges early.
    constexpr Index kTwinsAhead = 32;
    std::vector<Index> misfit(halfedge_blocks, n_h);  // per block, its first halfedge with a fault
    for_each_block(n_h, [&](Index begin, Index end) {
        for (Index h = begin; h < end; ++h) {
            const Index ahead = h + kTwinsAhead < n_h ? m.twin[h + kTwinsAhead] : kNoHalfedge;
            if (ahead >= 0 && ahead < n_h) {
                __builtin_prefetch(&m.twin[ahead]);
                __builtin_prefetch(&m.F(ahead / 3, 0));
            }
            if (twin_fault(h) != nullptr) {
                misfit[begin / kBlock] = h;
                return;
            }
        }
    });
    const Index first_misfit = *std::min_element(misfit.begin(), misfit.end());
    HOLOFLOW_REQUIRE(first_misfit == n_h, twin_fault(first_misfit) + std::to_string(first_misfit));

    // Edges: one per halfedge pair, represented by the smaller halfedge index, numbered in
    // halfedge order (each block counts its edges, then numbers them from its offset).
    const auto owns_edge = [&](Index h) { return m.twin[h] == kNoHalfedge || m.twin[h] > h; };
    std::vector<Index> block_edges(halfedge_blocks + 1, 0);
    for_each_block(n_h, [&](Index begin, Index end) {
        Index count = 0;
        for (Index h = begin; h < end; ++h) count += owns_edge(h);
        block_edges[begin / kBlock + 1] = count;
    });
    for (std::size_t b = 1; b < block_edges.size(); ++b) block_edges[b] += block_edges[b - 1];
    m.halfedge_edge.assign(n_h, -1);
    m.edge_halfedge.resize(static_cast<std::size_t>(block_edges.back()));
    m.E.resize(static_cast<Eigen::Index>(m.edge_halfedge.size()), 2);
    for_each_block(n_h, [&](Index begin, Index end) {
        Index e = block_edges[begin / kBlock];
        for (Index h = begin; h < end; ++h) {
            if (!owns_edge(h)) continue;
            m.edge_halfedge[e] = h;
            m.halfedge_edge[h] = e;
            if (m.twin[h] != kNoHalfedge) m.halfedge_edge[m.twin[h]] = e;
            m.E(e, 0) = m.tail(h);
            m.E(e, 1) = m.head(h);
            ++e;
        }
    });

    // Outgoing halfedge per vertex, preferring the boundary one so that a counter-clockwise walk
    // from it covers the whole fan.
    const Index n_v = m.n_vertices();
    m.vertex_halfedge.assign(n_v, kNoHalfedge);
    std::vector<Index> outgoing(n_v, 0);
    for (Index h = 0; h < n_h; ++h) {
        const Index v = m.tail(h);
        ++outgoing[v];
        if (m.vertex_halfedge[v] == kNoHalfedge || m.twin[h] == kNoHalfedge) {
            if (m.twin[h] == kNoHalfedge && m.vertex_halfedge[v] != kNoHalfedge &&
                m.twin[m.vertex_halfedge[v]] == kNoHalfedge)
                throw ConnectivityError(ConnectivityError::Kind::NonManifoldVertex, v, -1,
                                        "non-manifold vertex " + std::to_string(v) +
                                            ": it joins several boundary fans");
            m.vertex_halfedge[v] = h;
        }
    }
    // Each fan walk is a chain of dependent loads (the twin of the previous halfedge): a cache
    // miss per step where the faces around a vertex lie far apart in memory, as decimated meshes
    // store them. kFanWalks vertices are walked side by side so that their misses overlap.
    constexpr Index kFanWalks = 16;
    std::vector<Index> visited(n_v, 0);  // halfedges of each vertex's fan
    for_each_block(n_v, [&](Index begin, Index end) {
        for (Index v0 = begin; v0 < end; v0 += kFanWalks) {
            const Index walks = std::min(kFanWalks, end - v0);
            std::array<Index, kFanWalks> h{}, steps{};
            for (Index w = 0; w < walks; ++w) h[w] = m.vertex_halfedge[v0 + w];
            for (bool walking = true; walking;) {
                walking = false;
                for (Index w = 0; w < walks; ++w) {
                    if (h[w] == kNoHalfedge) continue;
                    const Index v = v0 + w, r = m.rotate(h[w]);
                    ++steps[w];
                    h[w] = r == m.vertex_halfedge[v] || steps[w] > outgoing[v] ? kNoHalfedge : r;
                    walking = walking || h[w] != kNoHalfedge;
                }
            }
            std::copy_n(steps.begin(), walks, visited.begin() + v0);
        }
    });
    for (Index v = 0; v < n_v; ++v) {
        HOLOFLOW_REQUIRE(m.vertex_halfedge[v] != kNoHalfedge, "vertex " + std::to_string(v) + " is in no face");
        if (visited[v] != outgoing[v])
            throw ConnectivityError(ConnectivityError::Kind::NonManifoldVertex, v, -1,
                                    "non-manifold vertex " + std::to_string(v) + ": its faces form more than one fan");
    }
    return m;
}

void flip_edge(TriangleMatrix& F, std::vector<Index>& twin, Index h) {
    const Index t = twin[h], f = MeshView::face(h), g = MeshView::face(t);
    const Index a = F(f, h % 3), b = F(g, t % 3), c = F(f, (h % 3 + 2) % 3), d = F(g, (t % 3 + 2) % 3);
    const Index o_ca = twin[MeshView::prev(h)], o_bc = twin[MeshView::next(h)];
    const Index o_ad = twin[MeshView::next(t)], o_db = twin[MeshView::prev(t)];
    F.row(f) << c, a, d;
    F.row(g) << d, b, c;
    const auto link = [&](Index x, Index y) {
        twin[x] = y;
        if (y != kNoHalfedge) twin[y] = x;
    };
    link(3 * f, o_ca), link(3 * f + 1, o_ad), link(3 * g, o_db), link(3 * g + 1, o_bc), link(3 * f + 2, 3 * g + 2);
}

bool joins(const TriangleMatrix& F, const std::vector<Index>& twin, Index h0, Index w) {
    const auto head = [&](Index h) { return F(h / 3, (h % 3 + 1) % 3); };
    for (Index h = h0;;) {  // counter-clockwise
        if (head(h) == w) return true;
        const Index t = twin[MeshView::prev(h)];
        if (t == kNoHalfedge) break;
        if ((h = t) == h0) return false;
    }
    for (Index h = h0;;) {  // clockwise
        const Index t = twin[h];
        if (t == kNoHalfedge) return false;
        h = MeshView::next(t);
        if (h == h0) return false;
        if (head(h) == w) return true;
    }
}

}  // namespace holoflow
