#include "holoflow/kernels/zero_fans.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr int kMaxGrowth = 4;
constexpr double kOrientationTol = 1e-12;  // relative to the squared image edge lengths

// Faces around every vertex, CSR.
struct VertexFaces {
    std::vector<Index> start, faces;
    explicit VertexFaces(const MeshView& mesh) : start(mesh.n_vertices() + 1, 0) {
        for (Index h = 0; h < mesh.n_halfedges(); ++h) ++start[mesh.tail(h) + 1];
        for (Index v = 0; v < mesh.n_vertices(); ++v) start[v + 1] += start[v];
        faces.resize(mesh.n_halfedges());
        std::vector<Index> fill(start.begin(), start.end() - 1);
        for (Index h = 0; h < mesh.n_halfedges(); ++h) faces[fill[mesh.tail(h)]++] = MeshView::face(h);
    }
};

// One accepted fan: the star's faces go, the chain (the star's border, counter-clockwise) stays.
struct Fan {
    std::vector<Index> region_faces;
    std::vector<Index> chain;  // halfedges of removed faces along the star's border, in order
    bool open = false;         // chain runs boundary to boundary (centre on the mesh boundary)
    Index centre = -1;         // existing vertex, or -1 for a new point
    Eigen::RowVector3d centre_position = Eigen::RowVector3d::Zero();
    Complex centre_image;
    std::vector<Complex> chain_tail_image;  // image of each chain halfedge's tail, then its head
    Complex last_head_image;
};

struct Candidate {
    Index vertex;  // an existing vertex kept as the centre, or -1 for a new point
    Complex image;
    Eigen::RowVector3d position;
};

class FanBuilder {
 public:
    FanBuilder(const MeshView& mesh, const Eigen::VectorXcd& tau)
        : mesh_(mesh), tau_(tau), vf_(mesh), in_region_(mesh.n_faces(), 0), used_(mesh.n_faces(), 0),
          stamp_(mesh.n_vertices(), -1), image_(mesh.n_vertices()), is_boundary_vertex_(mesh.n_vertices(), 0) {
        for (Index h = 0; h < mesh.n_halfedges(); ++h)
            if (mesh.twin[h] == kNoHalfedge) is_boundary_vertex_[mesh.tail(h)] = is_boundary_vertex_[mesh.head(h)] = 1;
    }

    // The fan for one region; false when no star up to kMaxGrowth rings takes one.
    bool build(const ZeroRegion& region, Fan& fan) {
        std::vector<Index> seeds = region.vertices;
        if (region.vertex >= 0) seeds.push_back(region.vertex);
        if (region.face >= 0)
            for (int k = 0; k < 3; ++k) seeds.push_back(mesh_.F(region.face, k));
        std::sort(seeds.begin(), seeds.end());
        seeds.erase(std::unique(seeds.begin(), seeds.end()), seeds.end());
        for (int grown = 0; grown <= kMaxGrowth; ++grown) {
            if (try_region(region, seeds, fan)) return true;
            // Grow by one ring: every vertex of the current star becomes a seed.
            std::vector<Index> next;
            for (Index v : seeds)
                for (Index i = vf_.start[v]; i < vf_.start[v + 1]; ++i)
                    for (int k = 0; k < 3; ++k) next.push_back(mesh_.F(vf_.faces[i], k));
            std::sort(next.begin(), next.end());
            next.erase(std::unique(next.begin(), next.end()), next.end());
            seeds.swap(next);
        }
        return false;
    }

    void claim(const Fan& fan) {
        for (Index f : fan.region_faces) used_[f] = 1;
    }

 private:
    bool try_region(const ZeroRegion& region, const std::vector<Index>& seeds, Fan& fan) {
        fan = Fan{};
        for (Index v : seeds)
            for (Index i = vf_.start[v]; i < vf_.start[v + 1]; ++i) fan.region_faces.push_back(vf_.faces[i]);
        std::sort(fan.region_faces.begin(), fan.region_faces.end());
        fan.region_faces.erase(std::unique(fan.region_faces.begin(), fan.region_faces.end()), fan.region_faces.end());
        for (Index f : fan.region_faces)
            if (used_[f]) return false;  // overlaps an earlier fan
        for (Index f : fan.region_faces) in_region_[f] = 1;
        const bool ok = develop_and_fan(region, fan);
        for (Index f : fan.region_faces) in_region_[f] = 0;
        return ok;
    }

    bool develop_and_fan(const ZeroRegion& region, Fan& fan) {
        ++generation_;
        // Develop the form over the star by a walk across its interior edges (in_region_ turns
        // from 1 to 2 on the faces reached).
        std::vector<Index> queue{fan.region_faces.front()};
        in_region_[queue[0]] = 2;
        set_image(mesh_.F(queue[0], 0), 0);
        Index vertices = 1, interior_halfedges = 0;
        for (std::size_t q = 0; q < queue.size(); ++q) {
            const Index f = queue[q];
            Index h = 3 * f;
            while (stamp_[mesh_.tail(h)] != generation_) h = MeshView::next(h);
            for (int s = 0; s < 2; ++s, h = MeshView::next(h)) {
                const Complex expected = image_[mesh_.tail(h)] + form_along(mesh_, tau_, h);
                if (stamp_[mesh_.head(h)] != generation_) {
                    set_image(mesh_.head(h), expected);
                    ++vertices;
                } else if (std::abs(image_[mesh_.head(h)] - expected) >
                           1e-8 * (std::abs(expected) + std::abs(form_along(mesh_, tau_, h)))) {
                    return false;  // the star is not simply connected (wraps around a handle)
                }
            }
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh_.twin[3 * f + k];
                if (t == kNoHalfedge || in_region_[MeshView::face(t)] != 1) continue;
                in_region_[MeshView::face(t)] = 2;
                queue.push_back(MeshView::face(t));
            }
        }
        if (queue.size() != fan.region_faces.size()) return false;  // not connected
        // Border of the star: halfedges whose twin is outside it (or on the mesh boundary).
        std::vector<Index> inner, outer;
        for (Index f : fan.region_faces)
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k, t = mesh_.twin[h];
                if (t == kNoHalfedge) outer.push_back(h);
                else if (!in_region_[MeshView::face(t)]) inner.push_back(h);
                else ++interior_halfedges;
            }
        const Index edges = interior_halfedges / 2 + static_cast<Index>(inner.size() + outer.size());
        if (vertices - edges + static_cast<Index>(fan.region_faces.size()) != 1) return false;  // not a disk
        if (inner.empty()) return false;

        // Chain the inner border: each tail must start exactly one inner halfedge.
        std::sort(inner.begin(), inner.end(), [&](Index a, Index b) { return mesh_.tail(a) < mesh_.tail(b); });
        for (std::size_t i = 1; i < inner.size(); ++i)
            if (mesh_.tail(inner[i]) == mesh_.tail(inner[i - 1])) return false;  // pinched
        auto starting_at = [&](Index v) -> Index {
            auto it = std::lower_bound(inner.begin(), inner.end(), v,
                                       [&](Index h, Index x) { return mesh_.tail(h) < x; });
            return it != inner.end() && mesh_.tail(*it) == v ? *it : kNoHalfedge;
        };
        fan.open = !outer.empty();
        Index first = inner.front();
        if (fan.open) {
            // The open chain starts where no inner halfedge ends.
            std::vector<Index> heads;
            for (Index h : inner) heads.push_back(mesh_.head(h));
            std::sort(heads.begin(), heads.end());
            first = kNoHalfedge;
            for (Index h : inner)
                if (!std::binary_search(heads.begin(), heads.end(), mesh_.tail(h))) {
                    if (first != kNoHalfedge) return false;  // several pieces
                    first = h;
                }
            if (first == kNoHalfedge) return false;
        }
        for (Index h = first;;) {
            fan.chain.push_back(h);
            if (fan.chain.size() > inner.size()) return false;
            h = starting_at(mesh_.head(h));
            if (h == kNoHalfedge) {
                if (!fan.open) return false;
                break;
            }
            if (h == first) {
                if (fan.open) return false;
                break;
            }
        }
        if (fan.chain.size() != inner.size()) return false;  // several loops

        // Centre candidates: the zero's estimate first, then (a poor estimate, an artifact)
        // the star's interior vertices and face centroids, whose images tile the star's image.
        std::vector<Candidate> candidates;
        if (fan.open) {
            // On the boundary: the region's boundary vertices, nearest the zero's point first.
            const Eigen::RowVector3d target = zero_point(region);
            std::vector<std::pair<double, Index>> order;
            for (Index h : outer) {
                const Index v = mesh_.tail(h);
                if (v == mesh_.tail(fan.chain.front()) || v == mesh_.head(fan.chain.back())) continue;
                order.emplace_back((mesh_.V.row(v) - target).squaredNorm(), v);
            }
            std::sort(order.begin(), order.end());
            for (const auto& [d, v] : order) candidates.push_back({v, image_[v], mesh_.V.row(v)});
        } else {
            if (region.face >= 0 && stamp_[mesh_.F(region.face, 0)] == generation_)
                candidates.push_back({-1, image_[mesh_.F(region.face, 0)] + region.image_offset, zero_point(region)});
            if (region.vertex >= 0) candidates.push_back({region.vertex, image_[region.vertex], mesh_.V.row(region.vertex)});
            for (Index f : fan.region_faces) {
                Complex p = 0;
                Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
                for (int k = 0; k < 3; ++k) {
                    const Index v = mesh_.F(f, k);
                    p += image_[v] / 3.0;
                    x += mesh_.V.row(v) / 3.0;
                    if (!is_boundary_vertex_[v]) candidates.push_back({v, image_[v], mesh_.V.row(v)});
                }
                candidates.push_back({-1, p, x});
            }
        }
        for (const Candidate& c : candidates) {
            if (!fan_is_valid(region, fan, c)) continue;
            fan.centre = c.vertex;
            fan.centre_image = c.image;
            fan.centre_position = c.position;
            for (Index h : fan.chain) fan.chain_tail_image.push_back(image_[mesh_.tail(h)]);
            fan.last_head_image = image_[mesh_.head(fan.chain.back())];
            return true;
        }
        return false;
    }

    bool fan_is_valid(const ZeroRegion& region, const Fan& fan, const Candidate& c) const {
        if (c.vertex >= 0)
            for (Index h : fan.chain)
                if (mesh_.tail(h) == c.vertex || mesh_.head(h) == c.vertex) return false;
        const Complex p = c.image;
        const Eigen::RowVector3d& x0 = c.position;
        double turning = 0;
        for (Index h : fan.chain) {
            const Complex a = image_[mesh_.tail(h)] - p, b = image_[mesh_.head(h)] - p;
            if (!(cross(a, b) > kOrientationTol * (std::norm(a) + std::norm(b)))) return false;
            turning += std::atan2(cross(a, b), (std::conj(a) * b).real());
            const Eigen::RowVector3d e1 = mesh_.V.row(mesh_.tail(h)) - x0, e2 = mesh_.V.row(mesh_.head(h)) - x0;
            if (!(e1.cross(e2).norm() > 1e-12 * (e1.squaredNorm() + e2.squaredNorm()))) return false;
        }
        // The centre must wind order + 1 times (half-turns on the boundary).
        const double turns = turning / (fan.open ? std::numbers::pi : 2 * std::numbers::pi);
        return std::lround(turns) == region.order + 1;
    }

    Eigen::RowVector3d zero_point(const ZeroRegion& region) const {
        if (region.face >= 0) {
            Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
            for (int k = 0; k < 3; ++k) x += region.barycentric[k] * mesh_.V.row(mesh_.F(region.face, k));
            return x;
        }
        if (region.vertex >= 0) return mesh_.V.row(region.vertex);
        Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
        for (Index v : region.vertices) x += mesh_.V.row(v);
        return x / static_cast<double>(std::max<std::size_t>(1, region.vertices.size()));
    }

    void set_image(Index v, Complex z) {
        stamp_[v] = generation_;
        image_[v] = z;
    }

    const MeshView& mesh_;
    const Eigen::VectorXcd& tau_;
    VertexFaces vf_;
    std::vector<char> in_region_, used_;
    std::vector<Index> stamp_;
    std::vector<Complex> image_;
    std::vector<char> is_boundary_vertex_;
    Index generation_ = 0;
};

}  // namespace

RegularisedForm regularise_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                 std::span<const ZeroRegion> regions) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    for (const ZeroRegion& r : regions) {
        for (Index v : r.vertices) HOLOFLOW_REQUIRE(v >= 0 && v < mesh.n_vertices(), "region vertex out of range");
        HOLOFLOW_REQUIRE(r.vertex < mesh.n_vertices() && r.face < mesh.n_faces(), "region position out of range");
        HOLOFLOW_REQUIRE(!r.vertices.empty() || r.vertex >= 0 || r.face >= 0, "empty region");
    }
    RegularisedForm out;
    FanBuilder builder(mesh, tau);
    std::vector<Fan> fans;
    out.region_vertex.assign(regions.size(), -1);
    std::vector<Index> fan_of_region(regions.size(), -1);
    for (std::size_t r = 0; r < regions.size(); ++r) {
        Fan fan;
        if (builder.build(regions[r], fan)) {
            builder.claim(fan);
            fan_of_region[r] = static_cast<Index>(fans.size());
            fans.push_back(std::move(fan));
        } else {
            ++out.failed_regions;
        }
    }

    // Faces and vertices that go: every star's faces; vertices not on a chain or a centre.
    std::vector<char> face_removed(mesh.n_faces(), 0), vertex_kept(mesh.n_vertices(), 1);
    for (const Fan& fan : fans)
        for (Index f : fan.region_faces) {
            face_removed[f] = 1;
            for (int k = 0; k < 3; ++k) vertex_kept[mesh.F(f, k)] = 0;
        }
    for (const Fan& fan : fans) {
        for (Index h : fan.chain) vertex_kept[mesh.tail(h)] = vertex_kept[mesh.head(h)] = 1;
        if (fan.centre >= 0) vertex_kept[fan.centre] = 1;
    }
    std::vector<Index> new_vertex(mesh.n_vertices(), -1);
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        if (!vertex_kept[v]) {
            ++out.removed_vertices;
            continue;
        }
        new_vertex[v] = static_cast<Index>(out.original_vertex.size());
        out.original_vertex.push_back(v);
    }
    std::vector<Index> centre_vertex(fans.size());
    for (std::size_t i = 0; i < fans.size(); ++i) {
        if (fans[i].centre >= 0) {
            centre_vertex[i] = new_vertex[fans[i].centre];
        } else {
            centre_vertex[i] = static_cast<Index>(out.original_vertex.size());
            out.original_vertex.push_back(-1);
        }
    }
    const Index nv = static_cast<Index>(out.original_vertex.size());
    PointMatrix V(nv, 3);
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        if (new_vertex[v] >= 0) V.row(new_vertex[v]) = mesh.V.row(v);
    for (std::size_t i = 0; i < fans.size(); ++i) V.row(centre_vertex[i]) = fans[i].centre_position;

    // Kept faces first (in order), then the fans; twins rebuilt through the old pairing.
    Index nf = 0;
    std::vector<Index> new_face(mesh.n_faces(), -1);
    for (Index f = 0; f < mesh.n_faces(); ++f)
        if (!face_removed[f]) new_face[f] = nf++;
    Index fan_faces = 0;
    for (const Fan& fan : fans) fan_faces += static_cast<Index>(fan.chain.size());
    TriangleMatrix F(nf + fan_faces, 3);
    std::vector<Index> twin(3 * static_cast<std::size_t>(nf + fan_faces), kNoHalfedge);
    std::vector<Complex> along_new(twin.size());
    std::vector<Index> chain_owner(mesh.n_halfedges(), -1);  // old chain halfedge -> new fan halfedge
    out.original_face.assign(nf + fan_faces, -1);
    Index next_face = nf;
    for (std::size_t i = 0; i < fans.size(); ++i) {
        const Fan& fan = fans[i];
        const Index c = centre_vertex[i];
        const Index first_face = next_face;
        const std::size_t n = fan.chain.size();
        for (std::size_t j = 0; j < n; ++j) {
            const Index h = fan.chain[j], f = next_face++;
            F.row(f) << c, new_vertex[mesh.tail(h)], new_vertex[mesh.head(h)];
            const Complex a = fan.chain_tail_image[j];
            const Complex b = j + 1 < n ? fan.chain_tail_image[j + 1] : fan.last_head_image;
            along_new[3 * f] = a - fan.centre_image;
            along_new[3 * f + 1] = form_along(mesh, tau, h);
            along_new[3 * f + 2] = fan.centre_image - b;
            chain_owner[h] = 3 * f + 1;
            if (j > 0) {
                twin[3 * f] = 3 * (f - 1) + 2;
                twin[3 * (f - 1) + 2] = 3 * f;
            }
        }
        if (!fan.open) {
            const Index last = next_face - 1;
            twin[3 * first_face] = 3 * last + 2;
            twin[3 * last + 2] = 3 * first_face;
        }
    }
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        if (face_removed[f]) continue;
        const Index g = new_face[f];
        out.original_face[g] = f;
        for (int k = 0; k < 3; ++k) {
            const Index h = 3 * f + k;
            F(g, k) = new_vertex[mesh.F(f, k)];
            along_new[3 * g + k] = form_along(mesh, tau, h);
            const Index t = mesh.twin[h];
            if (t == kNoHalfedge) continue;
            if (!face_removed[MeshView::face(t)]) {
                twin[3 * g + k] = 3 * new_face[MeshView::face(t)] + t % 3;
            } else {
                const Index owner = chain_owner[t];
                twin[3 * g + k] = owner;
                twin[owner] = 3 * g + k;
            }
        }
    }
    // Two fans whose stars touch along an edge: their chain halfedges pair up directly.
    for (const Fan& fan : fans)
        for (Index h : fan.chain) {
            const Index t = mesh.twin[h];
            if (t != kNoHalfedge && chain_owner[t] >= 0) twin[chain_owner[h]] = chain_owner[t];
        }
    for (std::size_t r = 0; r < regions.size(); ++r)
        if (fan_of_region[r] >= 0) out.region_vertex[r] = centre_vertex[fan_of_region[r]];

    out.mesh = make_mesh_view(std::move(V), std::move(F), std::move(twin));
    out.tau.resize(out.mesh.n_edges());
    for (Index e = 0; e < out.mesh.n_edges(); ++e) out.tau(e) = along_new[out.mesh.edge_halfedge[e]];
    return out;
}

}  // namespace holoflow::kernels
