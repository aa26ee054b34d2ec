#include "holoflow/kernels/zero_fans.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>

#include <Eigen/Geometry>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"
#include "holoflow/kernels/union_find.h"
#include "holoflow/kernels/zeros.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr int kMaxSteps = 32;              // growth steps per region
constexpr int kMaxStarts = 4;              // first spokes tried per centre
constexpr int kMaxSearches = 8;            // centres given a sector search per attempt
constexpr Index kLongChain = 128;          // longer chains: one start, two centres
constexpr Index kMaxSectorChain = 384;     // longer still: fans only
constexpr double kOrientationTol = 1e-12;  // image cross product relative to squared lengths
constexpr double kDegenerateTol = 1e-12;   // 3D cross product relative to squared lengths
constexpr double kTouchTol = 1e-10;        // image distances relative to the region's extent
constexpr Index kCentre = -1;              // point id of the centre in a triangle
constexpr std::size_t kParallelKeptFaces = 8192;  // the new mesh's copy loops: blocks of this many

// Flipped image triangles of a mesh whose halfedge images are `along` (faces from first_face on).
Index count_flipped_images(const std::vector<Complex>& along, Index first_face = 0) {
    Index flipped = 0;
    for (Index f = first_face; f < static_cast<Index>(along.size()) / 3; ++f) flipped += face_flips(along, f) != 0;
    return flipped;
}

// The 3D triangle x y z is not degenerate.
bool solid(const Eigen::RowVector3d& x, const Eigen::RowVector3d& y, const Eigen::RowVector3d& z) {
    const Eigen::RowVector3d e1 = y - x, e2 = z - x;
    return e1.cross(e2).norm() > kDegenerateTol * (e1.squaredNorm() + e2.squaredNorm());
}

bool ccw(Complex a, Complex b, Complex c) {
    return cross(b - a, c - a) > kOrientationTol * (std::norm(b - a) + std::norm(c - a));
}

// Closed segments ab and cd meet, or come within tol of each other (tol: squared-length units).
bool segments_touch(Complex a, Complex b, Complex c, Complex d, double tol) {
    const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a);
    const double d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
    // sqrt of the norm, not std::abs (hypot): this test is the sector search's inner loop.
    const double ta = tol * std::max(1.0, std::sqrt(std::norm(b - a)));
    const double tc = tol * std::max(1.0, std::sqrt(std::norm(d - c)));
    if ((d1 > ta && d2 > ta) || (d1 < -ta && d2 < -ta)) return false;
    if ((d3 > tc && d4 > tc) || (d3 < -tc && d4 < -tc)) return false;
    if (std::abs(d1) <= ta && std::abs(d2) <= ta && std::abs(d3) <= tc && std::abs(d4) <= tc) {
        // Collinear: do their extents overlap along the line?
        const Complex dir = std::abs(b - a) >= std::abs(d - c) ? b - a : d - c;
        if (std::abs(dir) == 0) return std::abs(a - c) <= tol;
        const auto proj = [&](Complex p) { return (std::conj(dir) * p).real() / std::abs(dir); };
        const double lo1 = std::min(proj(a), proj(b)), hi1 = std::max(proj(a), proj(b));
        const double lo2 = std::min(proj(c), proj(d)), hi2 = std::max(proj(c), proj(d));
        return lo1 <= hi2 + tol && lo2 <= hi1 + tol;
    }
    return true;
}

// Winding number of the closed polygon p around z (not on it), from the signed crossings of
// the ray from z towards +x.
int winding_number(const std::vector<Complex>& p, Complex z) {
    int w = 0;
    if (p.empty()) return w;
    Complex a = p.back();  // edges (p[i - 1], p[i]): the same crossings, no modulo
    for (const Complex& b : p) {
        if (a.imag() <= z.imag()) {
            if (b.imag() > z.imag() && cross(b - a, z - a) > 0) ++w;
        } else if (b.imag() <= z.imag() && cross(b - a, z - a) < 0) {
            --w;
        }
        a = b;
    }
    return w;
}

// Ear clipping of a simple counter-clockwise polygon; false when no strict ear is left.
bool ear_clip(std::vector<Index> ids, const std::vector<Complex>& pos, std::vector<std::array<Index, 3>>& out) {
    std::vector<Complex> p(pos);
    while (ids.size() > 3) {
        const std::size_t m = ids.size();
        std::size_t ear = m;
        for (std::size_t i = 0; i < m && ear == m; ++i) {
            const std::size_t i0 = (i + m - 1) % m, i2 = (i + 1) % m;
            if (!ccw(p[i0], p[i], p[i2])) continue;
            bool empty = true;
            for (std::size_t j = 0; j < m && empty; ++j) {
                if (j == i || j == i0 || j == i2) continue;
                const Complex x = p[j];
                // Points on the ear's border count as inside: the diagonal must stay clear.
                empty = !(cross(p[i] - p[i0], x - p[i0]) >= 0 && cross(p[i2] - p[i], x - p[i]) >= 0 &&
                          cross(p[i0] - p[i2], x - p[i2]) >= 0);
            }
            if (empty) ear = i;
        }
        if (ear == m) return false;
        const std::size_t i0 = (ear + m - 1) % m, i2 = (ear + 1) % m;
        out.push_back({ids[i0], ids[ear], ids[i2]});
        ids.erase(ids.begin() + static_cast<std::ptrdiff_t>(ear));
        p.erase(p.begin() + static_cast<std::ptrdiff_t>(ear));
    }
    if (ids.size() == 3) {
        if (!ccw(p[0], p[1], p[2])) return false;
        out.push_back({ids[0], ids[1], ids[2]});
    }
    return true;
}

// The triangles the fans work on, with the form along each halfedge: the input's, or those
// after the edge flips, for which no MeshView is built (its edges and vertex fans are only
// needed for the result).
struct Triangles {
    const PointMatrix& V;
    const TriangleMatrix& F;
    const std::vector<Index>& twin;
    const std::vector<Complex>& along;

    Index n_vertices() const { return static_cast<Index>(V.rows()); }
    Index n_faces() const { return static_cast<Index>(F.rows()); }
    Index n_halfedges() const { return 3 * n_faces(); }
    Index tail(Index h) const { return F(h / 3, h % 3); }
    Index head(Index h) const { return F(h / 3, (h % 3 + 1) % 3); }
};

// Faces around every vertex, CSR, each vertex's in ascending halfedge order.
struct VertexFaces {
    std::vector<Index> start, faces;
    explicit VertexFaces(const Triangles& mesh) : start(mesh.n_vertices() + 1, 0) {
        for (Index h = 0; h < mesh.n_halfedges(); ++h) ++start[mesh.tail(h) + 1];
        for (Index v = 0; v < mesh.n_vertices(); ++v) start[v + 1] += start[v];
        faces.resize(mesh.n_halfedges());
        std::vector<Index> fill(start.begin(), start.end() - 1);
        for (Index h = 0; h < mesh.n_halfedges(); ++h) faces[fill[mesh.tail(h)]++] = MeshView::face(h);
    }
};

// One accepted re-triangulation: the region's faces go, its border chain stays, and new
// triangles join the chain's points (and a centre) in the image of the developed form.
struct Retriangulation {
    bool kept = false;          // already regular: faces claimed, left as they are
    std::vector<Index> faces;   // ascending
    std::vector<Index> chain;   // border halfedges of removed faces, counter-clockwise
    bool open = false;          // chain runs boundary to boundary (centre on the mesh boundary)
    bool has_centre = false;
    Index centre = -1;          // existing vertex kept as the centre, or -1 for a new point
    Eigen::RowVector3d centre_position = Eigen::RowVector3d::Zero();
    Complex centre_image;
    std::vector<Complex> point_image;  // chain tails, then (open) the last head
    std::vector<std::array<Index, 3>> triangles;  // point ids, kCentre for the centre

    Complex image(Index p) const { return p == kCentre ? centre_image : point_image[p]; }
    // Input vertex of chain point p (not the centre).
    Index vertex(const Triangles& mesh, Index p) const {
        const Index n = static_cast<Index>(chain.size());
        return open && p == n ? mesh.head(chain.back()) : mesh.tail(chain[p % n]);
    }
    // Points a then b along the chain: chain halfedge a.
    bool chain_edge(Index a, Index b) const {
        return a != kCentre && b != kCentre && b == (open ? a + 1 : (a + 1) % static_cast<Index>(point_image.size()));
    }
};

// What a region left unresolved weighs (RegularisedForm::failed_weight).
Index region_weight(const ZeroRegion& r) { return std::max(r.order, 1); }

struct Group {
    std::vector<Index> members;  // input regions (none for a leftover fold)
    std::vector<Index> seed_faces;
    int order = 0;
    bool accepted = false;
    Index absorbed_into = -1;
    Retriangulation result;
};

struct Candidate {
    Index vertex;  // an existing vertex kept as the centre, or -1 for a new point
    Complex image;
    Eigen::RowVector3d position;
};

// Why a region failed, to steer its growth.
struct Diagnosis {
    std::vector<Index> bad_vertices;  // border vertices next to a bad spoke or a wrong winding
};

class Builder {
 public:
    Builder(const Triangles& mesh, std::span<const ZeroRegion> regions, const FanOptions& options)
        : mesh_(mesh), regions_(regions), options_(options), vf_(mesh), along_(mesh.along),
          zero_vertex_(mesh.n_vertices(), 0), boundary_(mesh.n_vertices(), 0),
          owner_(mesh.n_faces(), -1), mark_(mesh.n_faces(), 0), stamp_(mesh.n_vertices(), -1),
          chain_stamp_(mesh.n_vertices(), -1), candidate_stamp_(mesh.n_vertices(), -1), image_(mesh.n_vertices()), origin_(mesh.n_faces()),
          cut_(mesh.n_halfedges(), 0) {
        for (Index h = 0; h < mesh.n_halfedges(); ++h)
            if (mesh.twin[h] == kNoHalfedge) boundary_[mesh.tail(h)] = boundary_[mesh.head(h)] = 1;
        // Half-turns on the mesh boundary, where the double cover sees whole ones (turns()).
        ImageTurns image = image_turns(mesh.F, mesh.n_vertices(), along_, boundary_);
        flip_ = std::move(image.face_flip);
        winding_ = std::move(image.turns);
        face_cap_ = std::max<Index>(512, mesh.n_faces() / 32);
        for (const ZeroRegion& r : regions)
            if (r.order > 0 && r.vertex >= 0) zero_vertex_[r.vertex] = 1;
    }

    std::vector<Group> run() {
        std::vector<Group> groups(regions_.size());
        for (std::size_t r = 0; r < regions_.size(); ++r) {
            groups[r].members = {static_cast<Index>(r)};
            groups[r].order = regions_[r].order;
        }
        // Zeros first, each on its own; then folds (one next to a zero joins the zero's region);
        // then zeros that failed may take in the zeros of their tangle (one centre for zeros
        // the mesh cannot separate); then folds again, and flips no region holds.
        const std::size_t n_regions = regions_.size();
        for (int pass = 0; pass < 5; ++pass) {
            if (pass == 4) add_leftovers(groups);
            for (std::size_t r = 0; r < groups.size(); ++r) {
                // The leftovers (after the regions) change no region's outcome: skipped where
                // the caller does not want them at this many failed regions.
                if (r == n_regions && pass == 4 && failed_weight(groups) >= options_.leftover_folds_below_failed_weight)
                    break;
                const bool zeros_pass = pass == 0 || pass == 2;
                if ((groups[r].order > 0) != zeros_pass || groups[r].absorbed_into >= 0 || groups[r].accepted)
                    continue;
                // A failed region may grow once more from its irregular vertices only.
                const Index g = static_cast<Index>(r);
                if (!solve_or_undo(groups, g, pass == 2, false) && has_regular_seeds(groups[g])) {
                    ++regrowable_;
                    if (options_.regrow_failed) solve_or_undo(groups, g, pass == 2, true);
                }
            }
        }
        return groups;
    }

    const std::vector<int>& flips() const { return flip_; }
    Index regrowable_failures() const { return regrowable_; }

    // Regions whose group was not accepted, in itself or within another one, by their weight.
    Index failed_weight(const std::vector<Group>& groups) const {
        Index failed = 0;
        for (const ZeroRegion& r : regions_) failed += region_weight(r);
        for (const Group& g : groups)
            if (g.accepted)
                for (Index m : g.members) failed -= region_weight(regions_[m]);
        return failed;
    }

 private:
    // Image angle of face f at its corner v.
    double corner_angle_at(Index f, Index v) const {
        const int k = mesh_.F(f, 0) == v ? 0 : mesh_.F(f, 1) == v ? 1 : 2;
        return tail_angle(along_, 3 * f + k);
    }

    // Flips no region took in (and windings != 1 inside no region) become folds of their own.
    void add_leftovers(std::vector<Group>& groups) {
        std::vector<Index> seeds;
        for (Index f = 0; f < mesh_.n_faces(); ++f)
            if (flip_[f] && owner_[f] < 0) seeds.push_back(f);
        for (Index v = 0; v < mesh_.n_vertices(); ++v) {
            if (boundary_[v] || winding_[v] == 1) continue;
            bool free = true;
            for (Index i = vf_.start[v]; i < vf_.start[v + 1]; ++i) free = free && owner_[vf_.faces[i]] < 0;
            if (free) seeds.push_back(vf_.faces[vf_.start[v]]);
        }
        // One fold per connected piece (seeds sharing a vertex).
        std::vector<Index> piece(mesh_.n_vertices(), -1);
        UnionFind pieces(static_cast<Index>(seeds.size()));
        for (Index i = 0; i < static_cast<Index>(seeds.size()); ++i)
            for (int k = 0; k < 3; ++k) {
                Index& p = piece[mesh_.F(seeds[i], k)];
                if (p >= 0) pieces.unite(p, i);
                else p = i;
            }
        std::vector<Index> group_of(seeds.size(), -1);
        for (Index i = 0; i < static_cast<Index>(seeds.size()); ++i) {
            Index& g = group_of[pieces.find(i)];
            if (g < 0) g = static_cast<Index>(groups.size()), groups.emplace_back();
            for (int k = 0; k < 3; ++k) star(mesh_.F(seeds[i], k), groups[g].seed_faces);
        }
        for (std::size_t g = 0; g < groups.size(); ++g) normalise(groups[g].seed_faces);
    }

    // A region that fails leaves the others as they were (it may have taken some in): it and
    // the groups it absorbed get their state and faces back.
    bool solve_or_undo(std::vector<Group>& groups, Index g, bool merge_zeros, bool special_seeds) {
        undo_.assign(1, {g, groups[g]});
        if (solve(groups, g, merge_zeros, special_seeds)) return true;
        for (auto& [o, saved] : undo_) {
            groups[o] = std::move(saved);
            for (Index f : groups[o].result.faces) owner_[f] = o;
        }
        return false;
    }

    bool solve(std::vector<Group>& groups, Index g, bool merge_zeros, bool special_seeds) {
        std::vector<Index> faces = groups[g].seed_faces;
        for (Index r : groups[g].members) add_seeds(regions_[r], special_seeds, faces);
        normalise(faces);
        if (!merge_zeros && already_regular(groups, g, faces)) return true;
        if (merge_zeros) take_tangle(groups, g, faces);
        std::vector<Index> previous;
        for (int step = 0; step <= kMaxSteps; ++step) {
            absorb_or_block(groups, g, faces, merge_zeros);
            fill_holes(faces);
            if (faces.empty() || static_cast<Index>(faces.size()) > face_cap_ || faces == previous) return false;
            previous = faces;
            Diagnosis diagnosis;
            const bool accepted = try_region(groups[g], faces, diagnosis);
            if (accepted) {
                groups[g].accepted = true;
                for (Index f : faces) owner_[f] = g;
                return true;
            }
            if (!grow(faces, diagnosis)) return false;
        }
        return false;
    }

    // A lone region with nothing to repair (no flip around its vertices, every winding 1, a
    // zero's vertex winding order + 1) keeps its faces; they are claimed so that no other
    // region takes its centre away.
    bool already_regular(std::vector<Group>& groups, Index g, const std::vector<Index>& faces) {
        Group& group = groups[g];
        if (group.members.size() != 1) return false;
        const ZeroRegion& region = regions_[group.members.front()];
        if (group.order > 0 && (region.vertex < 0 || boundary_[region.vertex])) return false;
        for (Index f : faces)
            if (flip_[f] || owner_[f] >= 0) return false;
        std::vector<Index> vertices = region.vertices;
        if (region.vertex >= 0) vertices.push_back(region.vertex);
        for (Index v : vertices)
            if (winding_[v] != (v == region.vertex ? group.order + 1 : 1)) return false;
        group.accepted = true;
        group.result = Retriangulation{};
        group.result.kept = true;
        group.result.faces = faces;
        group.result.centre = region.vertex >= 0 ? region.vertex : vertices.front();
        for (Index f : faces) owner_[f] = g;
        return true;
    }

    // The whole tangle around the region: the connected flips and windings != 1 (over mesh
    // edges) that touch it, with every zero inside, whose separate regions failed.
    void take_tangle(std::vector<Group>& groups, Index g, std::vector<Index>& faces) {
        std::vector<Index> queue;
        ++generation_;
        for (Index f : faces)
            for (int k = 0; k < 3; ++k) {
                const Index v = mesh_.F(f, k);
                if (stamp_[v] != generation_ && special(v)) stamp_[v] = generation_, queue.push_back(v);
            }
        for (std::size_t q = 0; q < queue.size(); ++q) {
            const Index v = queue[q];
            for (Index i = vf_.start[v]; i < vf_.start[v + 1]; ++i)
                for (int k = 0; k < 3; ++k) {
                    const Index w = mesh_.F(vf_.faces[i], k);
                    if (stamp_[w] != generation_ && special(w)) stamp_[w] = generation_, queue.push_back(w);
                }
        }
        for (Index v : queue) star(v, faces);
        for (Index o = 0; o < static_cast<Index>(groups.size()); ++o) {
            if (o == g || !unplaced_zero(groups[o])) continue;
            bool inside = false;
            for (Index r : groups[o].members)
                inside = inside || (regions_[r].vertex >= 0 && stamp_[regions_[r].vertex] == generation_);
            if (inside) absorb(groups, g, o, faces);
        }
        normalise(faces);
    }

    // Some member's cluster has a vertex where the image is regular.
    bool has_regular_seeds(const Group& group) const {
        for (Index r : group.members)
            for (Index v : regions_[r].vertices)
                if (v != regions_[r].vertex && !irregular(v)) return true;
        return false;
    }

    // A flip around v, or a winding other than 1 (half-turns on the boundary).
    bool irregular(Index v) const { return winding_[v] != 1 || special(v); }

    // A flip around v, or (inside the mesh) a winding other than 1.
    bool special(Index v) const {
        if (!boundary_[v] && winding_[v] != 1) return true;
        for (Index i = vf_.start[v]; i < vf_.start[v + 1]; ++i)
            if (flip_[vf_.faces[i]]) return true;
        return false;
    }

    // A zero neither placed nor taken in by another region yet.
    static bool unplaced_zero(const Group& group) {
        return !group.accepted && group.absorbed_into < 0 && group.order > 0;
    }

    // Group o joins group g: its regions and order, and its faces (freed) are added to `faces`.
    void absorb(std::vector<Group>& groups, Index g, Index o, std::vector<Index>& faces) {
        Group& other = groups[o];
        undo_.emplace_back(o, other);
        other.accepted = false;
        other.absorbed_into = g;
        groups[g].order += other.order;
        groups[g].members.insert(groups[g].members.end(), other.members.begin(), other.members.end());
        for (Index x : other.result.faces) owner_[x] = -1, faces.push_back(x);
        other.result = Retriangulation{};
    }

    // The stars of the region's vertices (its zero, its cluster) and its face; with
    // `special_seeds`, of only the cluster vertices where the image is not regular.
    void add_seeds(const ZeroRegion& region, bool special_seeds, std::vector<Index>& faces) const {
        std::vector<Index> seeds;
        for (Index v : region.vertices)
            if (!special_seeds || irregular(v)) seeds.push_back(v);
        if (region.vertex >= 0) seeds.push_back(region.vertex);
        if (region.face >= 0)
            for (int k = 0; k < 3; ++k) seeds.push_back(mesh_.F(region.face, k));
        for (Index v : seeds) star(v, faces);
        if (region.face >= 0) faces.push_back(region.face);
    }

    void star(Index v, std::vector<Index>& faces) const {
        for (Index i = vf_.start[v]; i < vf_.start[v + 1]; ++i) faces.push_back(vf_.faces[i]);
    }

    // Sorted, each face once. Where the first `sorted` entries are so already (a region and what
    // a step adds to it), only the rest is sorted, then merged in.
    static void normalise(std::vector<Index>& faces, std::size_t sorted = 0) {
        const auto middle = faces.begin() + static_cast<std::ptrdiff_t>(sorted);
        std::sort(middle, faces.end());
        std::inplace_merge(faces.begin(), middle, faces.end());
        faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
    }

    // Faces of accepted regions: a fold (order 0) on either side joins this region; two zeros
    // never merge (each keeps its own centre), so the other zero's faces are left out.
    void absorb_or_block(std::vector<Group>& groups, Index g, std::vector<Index>& faces, bool merge_zeros) {
        for (bool changed = true; changed;) {
            changed = false;
            std::vector<Index> kept;
            for (Index f : faces) {
                const Index o = owner_[f];
                if (o < 0 || o == g) {
                    kept.push_back(f);
                    continue;
                }
                if (groups[o].order > 0 && groups[g].order > 0 && !merge_zeros) continue;  // blocked
                absorb(groups, g, o, kept);
                changed = true;
            }
            if (merge_zeros) {
                // Zeros not placed yet whose point the region covers.
                for (Index f : faces) mark_[f] = 1;
                for (Index o = 0; o < static_cast<Index>(groups.size()); ++o) {
                    if (o == g || !unplaced_zero(groups[o])) continue;
                    bool inside = false;
                    for (Index r : groups[o].members) {
                        const ZeroRegion& region = regions_[r];
                        if (region.face >= 0) inside = inside || mark_[region.face];
                        if (region.vertex >= 0)
                            for (Index i = vf_.start[region.vertex]; i < vf_.start[region.vertex + 1]; ++i)
                                inside = inside || mark_[vf_.faces[i]];
                    }
                    if (inside) absorb(groups, g, o, kept), changed = true;
                }
                for (Index f : faces) mark_[f] = 0;
            }
            faces.swap(kept);
            if (changed) normalise(faces);  // else a part of the sorted list it was
        }
    }

    // Closes small holes (complement pieces bounded by the region, not touching the mesh
    // boundary or another region), so that growth around a cluster leaves a disk. The outside
    // pieces flooded first stay marked until the end, so a later flood stops at them too: a
    // pocket between the region and such a piece (a notch along the border) is closed as a
    // hole. That rounds the region off; stopping there instead (the strict definition) gave
    // the 872 unseen variants 420 failed fans instead of 410 for a fifth less fan time
    // (bench/README, "Hole filling in the fan regions"), so the rounding stays.
    void fill_holes(std::vector<Index>& faces) {
        for (Index f : faces) mark_[f] = 1;
        const std::size_t region = faces.size(), rest = static_cast<std::size_t>(mesh_.n_faces()) - region;
        std::vector<Index> added;
        flooded_.clear();  // every piece, each flooded_[first, end): its marks are undone at the end
        for (Index f : faces)
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh_.twin[3 * f + k];
                if (t == kNoHalfedge || mark_[MeshView::face(t)]) continue;
                // Flood the outside piece, up to the region's size.
                const std::size_t first = flooded_.size();
                flooded_.push_back(MeshView::face(t));
                mark_[flooded_[first]] = 2;
                bool hole = true;
                for (std::size_t q = first; q < flooded_.size() && hole; ++q) {
                    const Index x = flooded_[q];
                    // A hole is smaller than the region and than the rest of the surface.
                    const std::size_t size = flooded_.size() - first;
                    if (owner_[x] >= 0 || size > region || 2 * size > rest) hole = false;
                    for (int j = 0; j < 3 && hole; ++j) {
                        const Index u = mesh_.twin[3 * x + j];
                        if (u == kNoHalfedge) hole = false;
                        else if (const Index y = MeshView::face(u); !mark_[y]) mark_[y] = 2, flooded_.push_back(y);
                    }
                }
                // Outside pieces stay marked 2 until done.
                if (hole)
                    for (std::size_t q = first; q < flooded_.size(); ++q)
                        mark_[flooded_[q]] = 1, added.push_back(flooded_[q]);
            }
        for (Index x : flooded_) mark_[x] = 0;
        for (Index f : faces) mark_[f] = 0;
        faces.insert(faces.end(), added.begin(), added.end());
        normalise(faces, region);
    }

    // Grows towards what broke: flipped faces touching the region, stars of border vertices
    // whose winding is not 1 or that saw a bad spoke; else one ring.
    bool grow(std::vector<Index>& faces, const Diagnosis& diagnosis) {
        const std::size_t before = faces.size();
        for (Index f : faces) mark_[f] = 1;
        std::vector<Index> border;
        for (Index f : faces)
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh_.twin[3 * f + k];
                if (t != kNoHalfedge && !mark_[MeshView::face(t)]) border.push_back(mesh_.tail(3 * f + k));
            }
        normalise(border);
        std::vector<Index> add;
        for (Index v : border)
            if (special(v)) star(v, add);
        for (Index v : diagnosis.bad_vertices) star(v, add);
        bool grew = false;
        for (Index f : add) grew = grew || !mark_[f];
        if (!grew)
            for (Index v : border) star(v, add);
        for (Index f : faces) mark_[f] = 0;
        faces.insert(faces.end(), add.begin(), add.end());
        normalise(faces, before);
        return faces.size() > before;
    }

    bool try_region(Group& group, const std::vector<Index>& faces, Diagnosis& diagnosis) {
        Retriangulation& out = group.result;
        out = Retriangulation{};
        out.faces = faces;
        for (Index f : faces) mark_[f] = 1;
        const bool ok = develop(group, out, diagnosis);
        for (Index f : faces) mark_[f] = 0;
        return ok;
    }

    Complex corner_image(Index f, int k) const {
        return origin_[f] + chart_corner(along_, f, k);
    }
    // The two developed images of an edge's tail differ by more than 1e-8 (|mine| + |edge|).
    // Squared norms settle almost every edge (no hypot): |d| <= 1e-8 max(|mine|, |edge|) passes.
    static bool sides_disagree(Complex mine, Complex theirs, Complex edge) {
        const double gap2 = std::norm(mine - theirs);
        if (gap2 <= 1e-16 * std::max(std::norm(mine), std::norm(edge))) return false;
        return std::abs(mine - theirs) > 1e-8 * (std::abs(mine) + std::abs(edge));
    }
    bool is_chain(Index v) const { return chain_stamp_[v] == generation_; }

    // Turns of the image around v for its angle sum: whole turns inside, half-turns on the mesh
    // boundary (where the double cover sees whole ones), so that 1 is regular everywhere.
    int turns(Index v, double angle) const {
        return static_cast<int>(std::lround(angle / ((boundary_[v] ? 1 : 2) * std::numbers::pi)));
    }

    bool develop(Group& group, Retriangulation& out, Diagnosis& diagnosis) {
        ++generation_;
        // Develop the form over a breadth-first tree of the region's faces (mark_ turns from 1
        // to 2 on the faces reached). Interior edges whose two sides then disagree (the region
        // goes around a handle) are cuts: the region is handled as the disk it is once cut
        // there, both sides of a cut on its border.
        const Index f0 = out.faces.front();
        std::vector<Index> queue{f0};
        mark_[f0] = 2;
        origin_[f0] = 0;
        for (std::size_t q = 0; q < queue.size(); ++q) {
            const Index f = queue[q];
            for (int k = 0; k < 3; ++k) {
                const Index t = mesh_.twin[3 * f + k];
                if (t == kNoHalfedge || mark_[MeshView::face(t)] != 1) continue;
                const Index g = MeshView::face(t);
                mark_[g] = 2;
                origin_[g] = 0;
                origin_[g] = corner_image(f, (k + 1) % 3) - corner_image(g, t % 3);
                queue.push_back(g);
            }
        }
        for (Index f : out.faces) mark_[f] = 1;
        if (queue.size() != out.faces.size()) return false;
        std::vector<Index> border;
        Index interior_halfedges = 0, cuts = 0;
        for (Index f : out.faces)
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k, t = mesh_.twin[h];
                cut_[h] = 0;
                if (t == kNoHalfedge || !mark_[MeshView::face(t)]) {
                    border.push_back(h);
                    continue;
                }
                const Complex mine = corner_image(f, k), theirs = corner_image(MeshView::face(t), (t % 3 + 1) % 3);
                if (sides_disagree(mine, theirs, along_[h])) {
                    cut_[h] = 1;
                    ++cuts;
                    border.push_back(h);
                } else {
                    ++interior_halfedges;
                }
            }
        bool touches_boundary = false;
        for (Index h : border) touches_boundary = touches_boundary || mesh_.twin[h] == kNoHalfedge;
        if (touches_boundary && cuts > 0) return false;
        out.open = touches_boundary;
        if (!out.open) {
            // One border loop, walked around each head inside the region.
            const auto on_border = [&](Index h) { return cut_[h] || !mark_[MeshView::face(mesh_.twin[h])]; };
            const Index first = *std::min_element(border.begin(), border.end());
            for (Index h = first;;) {
                out.chain.push_back(h);
                if (out.chain.size() > border.size()) return false;
                // Around h's head inside the region to the next border halfedge; a whole turn
                // without one (a cut seen from one side only) means no loop.
                const Index start = MeshView::next(h);
                Index n = start;
                while (!on_border(n)) {
                    n = MeshView::next(mesh_.twin[n]);
                    if (n == start) return false;
                }
                h = n;
                if (h == first) break;
            }
            if (out.chain.size() != border.size()) return false;
        } else {
            // Open: the inner border runs from the mesh boundary to the mesh boundary.
            std::vector<Index> inner;
            for (Index h : border)
                if (mesh_.twin[h] != kNoHalfedge) inner.push_back(h);
            if (inner.empty()) return false;
            std::sort(inner.begin(), inner.end(), [&](Index a, Index b) { return mesh_.tail(a) < mesh_.tail(b); });
            for (std::size_t i = 1; i < inner.size(); ++i)
                if (mesh_.tail(inner[i]) == mesh_.tail(inner[i - 1])) return false;
            const auto starting_at = [&](Index v) -> Index {
                auto it = std::lower_bound(inner.begin(), inner.end(), v,
                                           [&](Index h, Index x) { return mesh_.tail(h) < x; });
                return it != inner.end() && mesh_.tail(*it) == v ? *it : kNoHalfedge;
            };
            std::vector<Index> heads;
            for (Index h : inner) heads.push_back(mesh_.head(h));
            std::sort(heads.begin(), heads.end());
            Index first = kNoHalfedge;
            for (Index h : inner)
                if (!std::binary_search(heads.begin(), heads.end(), mesh_.tail(h))) {
                    if (first != kNoHalfedge) return false;
                    first = h;
                }
            if (first == kNoHalfedge) return false;
            for (Index h = first; h != kNoHalfedge; h = starting_at(mesh_.head(h))) {
                out.chain.push_back(h);
                if (out.chain.size() > inner.size()) return false;
            }
            if (out.chain.size() != inner.size()) return false;
        }
        for (Index h : out.chain) {
            out.point_image.push_back(corner_image(MeshView::face(h), h % 3));
            chain_stamp_[mesh_.tail(h)] = generation_;
        }
        if (out.open) {
            const Index last = out.chain.back();
            out.point_image.push_back(corner_image(MeshView::face(last), (last % 3 + 1) % 3));
            chain_stamp_[mesh_.head(last)] = generation_;
        }
        // Interior vertices (their images agree on every face around them); a disk has
        // V - E + F = 1, counted on the cut-open region (the border contributes L - L).
        std::vector<Index> interior;
        for (Index f : out.faces)
            for (int k = 0; k < 3; ++k) {
                const Index v = mesh_.F(f, k);
                if (is_chain(v)) continue;
                if (stamp_[v] != generation_) interior.push_back(v);
                set_image(v, corner_image(f, k));
            }
        const Index outer_edges = out.open ? static_cast<Index>(border.size() - out.chain.size()) : 0;
        {
            // Disk test: interior vertices - interior edges + faces = 1 (closed; the border
            // loop adds as many points as edges). Open: the boundary path's vertices and
            // edges count too, with one point more than edges on the chain.
            Index chi = static_cast<Index>(interior.size()) - interior_halfedges / 2 + static_cast<Index>(out.faces.size());
            if (out.open) chi += 1 - outer_edges;  // chain: L + 1 points, L edges; boundary path: its own
            if (chi != 1) return false;
        }

        // Closed: the chain turns 1 + (index inside) times, which must be order + 1.
        if (!out.open) {
            int index = 0;
            for (Index f : out.faces) index += flip_[f];
            for (Index v : interior) index += winding_[v] - 1;
            if (index != group.order) return false;
        }

        // A fold needs no centre: its border is then a simple polygon to clip.
        if (!out.open && group.order == 0) {
            std::vector<Index> ids(out.point_image.size());
            for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<Index>(i);
            if (polygon_is_simple(out.point_image) && ear_clip(ids, out.point_image, out.triangles) &&
                triangles_are_valid(out, diagnosis))
                return true;
        }
        const std::vector<Candidate> candidates = centre_candidates(group, out);
        int searches = 0;  // sector searches are the costly part: a few centres only
        for (std::size_t c = 0; c < candidates.size(); ++c) {
            out.triangles.clear();
            if (!triangulate_around(candidates[c], group.order, out, c == 0 ? &diagnosis : nullptr, searches))
                continue;
            out.centre = candidates[c].vertex;
            out.centre_image = candidates[c].image;
            out.centre_position = candidates[c].position;
            if (triangles_are_valid(out, diagnosis)) return out.has_centre = true;
        }
        return false;
    }

    static bool polygon_is_simple(const std::vector<Complex>& p) {
        const std::size_t n = p.size();
        if (n < 3) return false;
        double extent = 0, area = 0;
        for (std::size_t i = 0; i < n; ++i) {
            extent = std::max(extent, std::abs(p[i] - p[0]));
            area += cross(p[i], p[(i + 1) % n]);
        }
        if (!(area > 0)) return false;
        const double tol = kTouchTol * extent;
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = i + 2; j < n; ++j) {
                if (i == 0 && j == n - 1) continue;  // adjacent through the wrap
                if (segments_touch(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n], tol)) return false;
            }
        return true;
    }

    std::vector<Candidate> centre_candidates(const Group& group, const Retriangulation& out) const {
        std::vector<Candidate> candidates;
        Eigen::RowVector3d target = Eigen::RowVector3d::Zero();
        int zero_members = 0;
        for (Index r : group.members) {
            const ZeroRegion& region = regions_[r];
            if (region.order <= 0 && group.order > 0) continue;
            target += zero_point(region);
            ++zero_members;
            if (out.open) continue;
            if (region.vertex >= 0 && stamp_[region.vertex] == generation_)
                candidates.push_back({region.vertex, image_[region.vertex], mesh_.V.row(region.vertex)});
            if (region.face >= 0 && mark_[region.face])
                candidates.push_back({-1, corner_image(region.face, 0) + region.image_offset, zero_point(region)});
        }
        if (zero_members > 0) {
            target /= zero_members;
        } else {
            for (Index f : out.faces)
                for (int k = 0; k < 3; ++k) target += mesh_.V.row(mesh_.F(f, k));
            target /= 3.0 * static_cast<double>(out.faces.size());
        }
        std::vector<std::pair<double, Candidate>> rest;
        if (out.open) {
            // On the boundary: the region's boundary vertices other than the chain's ends.
            for (Index f : out.faces)
                for (int k = 0; k < 3; ++k) {
                    const Index h = 3 * f + k;
                    if (mesh_.twin[h] != kNoHalfedge) continue;
                    const Index v = mesh_.tail(h);
                    if (v == mesh_.tail(out.chain.front()) || v == mesh_.head(out.chain.back())) continue;
                    rest.push_back({(mesh_.V.row(v) - target).squaredNorm(), {v, image_[v], mesh_.V.row(v)}});
                }
        } else {
            // Interior vertices and face centroids, nearest the zero first.
            for (Index f : out.faces) {
                Complex p = 0;
                Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
                for (int k = 0; k < 3; ++k) {
                    const Index v = mesh_.F(f, k);
                    p += image_[v] / 3.0;
                    x += mesh_.V.row(v) / 3.0;
                    if (!boundary_[v] && !is_chain(v))
                        rest.push_back({(mesh_.V.row(v) - target).squaredNorm(), {v, image_[v], mesh_.V.row(v)}});
                }
                rest.push_back({(x - target).squaredNorm(), {-1, p, x}});
            }
        }
        std::stable_sort(rest.begin(), rest.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        // Each vertex once (its first entry): a stamp, not a scan of the list.
        const auto fresh = [&](const Candidate& c) {
            if (c.vertex < 0) return true;
            if (candidate_stamp_[c.vertex] == generation_) return false;
            return (candidate_stamp_[c.vertex] = generation_), true;
        };
        for (const Candidate& c : candidates) fresh(c);
        for (const auto& entry : rest)
            if (fresh(entry.second)) candidates.push_back(entry.second);
        return candidates;
    }

    // Triangles joining the chain's points and the centre: a fan where the chain is
    // star-shaped around it, else sectors between spokes (each a simple counter-clockwise
    // polygon, clipped into ears) found by a longest-path search over the spokes. The centre
    // then winds order + 1 times (half-turns on the boundary).
    bool triangulate_around(const Candidate& c, int order, Retriangulation& out, Diagnosis* diagnosis,
                            int& searches) const {
        const std::vector<Complex>& pts = out.point_image;
        const Index np = static_cast<Index>(pts.size());
        const Index n = static_cast<Index>(out.chain.size());  // arc edges; point i + 1 follows i
        // Most candidates fail: cheap tests first (no hypot, no atan2 until a fan or a sector
        // search can still follow).
        if (c.vertex >= 0 && is_chain(c.vertex)) return false;
        // A candidate that is no fan's centre once the sector searches are spent fails here,
        // before any full pass over the chain (the tests below return false the same way).
        const auto point = [&](Index i) { return pts[out.open ? i : i % np]; };
        bool fan = true;  // point(i + 1) without a division: only a closed chain's last wraps
        for (Index i = 0; i < n && fan; ++i) fan = ccw(c.image, pts[i], pts[i + 1 < np ? i + 1 : 0]);
        const int search_cap = n > kLongChain ? 2 : kMaxSearches;
        if (!fan && !diagnosis && (n > kMaxSectorChain || searches >= search_cap)) return false;
        double extent2 = 0, nearest2 = std::numeric_limits<double>::infinity();
        for (const Complex& p : pts) {
            const double d2 = std::norm(p - c.image);
            extent2 = std::max(extent2, d2);
            nearest2 = std::min(nearest2, d2);
        }
        if (!(extent2 > 0)) return false;
        const double tol = kTouchTol * std::sqrt(extent2);
        if (nearest2 <= tol * tol) return false;
        // A closed chain must wind order + 1 times around the centre: counted with the signed
        // crossings of a ray first (no atan2), so most candidates fail before the angles below.
        if (!out.open && winding_number(pts, c.image) != order + 1) return false;
        // Unwrapped angles of the points around the centre.
        std::vector<double> theta(n + 1);
        theta[0] = 0;
        for (Index i = 0; i < n; ++i) theta[i + 1] = theta[i] + corner_angle(point(i) - c.image, point(i + 1) - c.image);
        const double turns = theta[n] / (out.open ? std::numbers::pi : 2 * std::numbers::pi);
        if (std::lround(turns) != order + 1 || std::abs(turns - (order + 1)) > 0.25) return false;

        if (fan) {
            for (Index i = 0; i < n; ++i) out.triangles.push_back({kCentre, i % np, (i + 1) % np});
            return true;
        }
        if (diagnosis)
            for (Index i = 0; i < n; ++i)
                if (!ccw(c.image, point(i), point(i + 1))) {
                    diagnosis->bad_vertices.push_back(out.vertex(mesh_, i));
                    diagnosis->bad_vertices.push_back(out.vertex(mesh_, i + 1));
                }

        if (n > kMaxSectorChain || ++searches > search_cap) return false;
        // Starts: the open chain's first point; on a closed chain the points nearest the centre.
        std::vector<Index> starts;
        if (out.open) {
            starts.push_back(0);
        } else {
            std::vector<std::pair<double, Index>> near;
            for (Index i = 0; i < np; ++i) near.push_back({std::abs(pts[i] - c.image), i});
            std::sort(near.begin(), near.end());
            for (Index i = 0; i < std::min<Index>(np, n > kLongChain ? 1 : kMaxStarts); ++i) starts.push_back(near[i].second);
        }
        // Per start: the chain's points from it, and per arc edge e (per point j) whether an
        // earlier arc edge t in [i, e - 2] touches it (touches the spoke from j, t in [i, j - 2]).
        // Sectors from i are tried with i rising, so each list is tested downwards once, only as
        // far as some sector reaches back: linear in the chain times a sector's length.
        struct Hits {
            Index lowest_tested, hit;  // tests done down to lowest_tested; the highest hit, or -1
        };
        std::vector<Complex> rel(n + 1);
        std::vector<Hits> arc(n), spoke(n + 1);
        std::vector<Index> best(n + 1), from(n + 1);
        for (Index s : starts) {
            // Sector (i, j) is valid when polygon (centre, point s+i, ..., point s+j) is simple and
            // counter-clockwise; best[j]: most spokes from 0 to j (closest to a fan), rows taken
            // in order so each is final before it extends, and rows 0 cannot reach are skipped.
            for (Index i = 0; i <= n; ++i) rel[i] = point(out.open ? i : (s + i) % np);
            const auto at = [&](Index i) { return rel[i]; };
            const auto ang = [&](Index i) { return out.open ? theta[i] : theta_from(theta, s, i, n); };
            for (Index e = 0; e < n; ++e) arc[e] = {e - 1, -1};
            for (Index j = 0; j <= n; ++j) spoke[j] = {j - 1, -1};
            std::fill(best.begin(), best.end(), -1);
            std::fill(from.begin(), from.end(), -1);
            best[0] = 0;
            // Is there a t in [i, top] with touches(t)? Tests go downwards and stop at the first hit.
            const auto hit_from = [&](Hits& h, Index i, const auto& touches) {
                if (h.hit >= 0) return h.hit >= i;
                while (h.lowest_tested > i) {
                    const Index t = --h.lowest_tested;
                    if (touches(t)) {
                        h.hit = t;
                        return true;
                    }
                }
                return false;
            };
            const auto arc_hit = [&](Index e, Index i) {
                return hit_from(arc[e], i, [&](Index t) { return segments_touch(at(t), at(t + 1), at(e), at(e + 1), tol); });
            };
            const auto spoke_hit = [&](Index j, Index i) {
                return hit_from(spoke[j], i, [&](Index t) { return segments_touch(at(t), at(t + 1), at(j), c.image, tol); });
            };
            for (Index i = 0; i < n; ++i) {
                if (best[i] < 0) continue;
                const Complex a = at(i);
                double arc_area = 0;
                for (Index j = i + 1; j <= n; ++j) {
                    const Complex p = at(j - 1), q = at(j);
                    arc_area += cross(p, q);
                    // The new arc edge p q against the earlier ones and the first spoke.
                    if (arc_hit(j - 1, i)) break;
                    if (j - 1 > i && segments_touch(c.image, a, p, q, tol)) break;
                    const double alpha = ang(j) - ang(i);
                    if (alpha >= 2 * std::numbers::pi - 1e-9) break;
                    if (alpha <= 1e-9) continue;
                    // The closing spoke q -> centre against the arc's other edges.
                    if (spoke_hit(j, i)) continue;
                    if (cross(c.image, a) + cross(q, c.image) + arc_area > 0 && best[i] + 1 > best[j])
                        best[j] = best[i] + 1, from[j] = i;
                }
            }
            if (best[n] < 0) continue;
            std::vector<Index> spokes{n};
            while (spokes.back() != 0) spokes.push_back(from[spokes.back()]);
            std::reverse(spokes.begin(), spokes.end());
            bool clipped = true;
            for (std::size_t k = 0; k + 1 < spokes.size() && clipped; ++k) {
                std::vector<Index> ids{kCentre};
                std::vector<Complex> pos{c.image};
                for (Index t = spokes[k]; t <= spokes[k + 1]; ++t) {
                    ids.push_back(out.open ? t : (s + t) % np);
                    pos.push_back(at(t));
                }
                clipped = ear_clip(ids, pos, out.triangles);
            }
            if (clipped) return true;
            out.triangles.clear();
        }
        return false;
    }

    static double theta_from(const std::vector<double>& theta, Index s, Index i, Index n) {
        // Angle of point s + i relative to point s, continuing past the chain's end.
        const Index k = s + i;
        return k <= n ? theta[k] - theta[s] : theta[n] + theta[k - n] - theta[s];
    }

    // New triangles: counter-clockwise images, non-degenerate in 3D, and every chain point
    // still winding once (its outside angles plus its new inside angles make 2 pi; pi on the
    // mesh boundary, where a point turning 2 pi would be a zero nobody counted).
    bool triangles_are_valid(const Retriangulation& out, Diagnosis& diagnosis) const {
        const auto image = [&](Index p) { return out.image(p); };
        const auto position = [&](Index p) -> Eigen::RowVector3d {
            return p == kCentre ? out.centre_position : Eigen::RowVector3d(mesh_.V.row(out.vertex(mesh_, p)));
        };
        std::vector<std::pair<Index, double>> inside;  // per chain point: its vertex, new angles
        for (const auto& t : out.triangles) {
            if (!ccw(image(t[0]), image(t[1]), image(t[2]))) return false;
            if (!solid(position(t[0]), position(t[1]), position(t[2]))) return false;
            for (int k = 0; k < 3; ++k)
                if (t[k] != kCentre)
                    inside.emplace_back(out.vertex(mesh_, t[k]), corner_angle(image(t[(k + 1) % 3]) - image(t[k]),
                                                                          image(t[(k + 2) % 3]) - image(t[k])));
        }
        // No new edge may double an edge outside the region (or another new one): the mesh
        // keeps one edge per vertex pair wherever its input had.
        std::vector<std::pair<Index, Index>> pairs;
        for (const auto& t : out.triangles)
            for (int k = 0; k < 3; ++k) {
                const Index a = t[k], b = t[(k + 1) % 3];
                if (out.chain_edge(a, b)) continue;
                const Index va = a == kCentre ? out.centre : out.vertex(mesh_, a), vb = b == kCentre ? out.centre : out.vertex(mesh_, b);
                if (va == vb) return false;
                pairs.emplace_back(std::min(va, vb), std::max(va, vb));  // -1: a new centre
                if (va < 0 || vb < 0) continue;  // a new centre has no edges outside
                for (Index j = vf_.start[va]; j < vf_.start[va + 1]; ++j) {
                    const Index f = vf_.faces[j];
                    if (std::binary_search(out.faces.begin(), out.faces.end(), f)) continue;
                    for (int i = 0; i < 3; ++i)
                        if (mesh_.F(f, i) == vb) return false;
                }
            }
        std::sort(pairs.begin(), pairs.end());
        for (std::size_t i = 0; i + 2 < pairs.size(); ++i)
            if (pairs[i] == pairs[i + 2]) return false;  // each inner edge shows up twice, once per side
        // A vertex on a cut shows up twice: its angles add up over both.
        std::sort(inside.begin(), inside.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        bool ok = true;
        for (std::size_t i = 0; i < inside.size();) {
            const Index v = inside[i].first;
            double total = 0;
            for (; i < inside.size() && inside[i].first == v; ++i) total += inside[i].second;
            for (Index j = vf_.start[v]; j < vf_.start[v + 1]; ++j) {
                const Index f = vf_.faces[j];
                if (std::binary_search(out.faces.begin(), out.faces.end(), f)) continue;
                total += corner_angle_at(f, v);
            }
            // A zero's own point may keep its turns where an open region's boundary stretch
            // reaches it: its own region places it (inside, a zero's point is in its region).
            const int t = turns(v, total);
            if (t != 1 && !(boundary_[v] && zero_vertex_[v] && t == winding_[v])) {
                diagnosis.bad_vertices.push_back(v);
                ok = false;
            }
        }
        return ok;
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

    const Triangles& mesh_;
    std::span<const ZeroRegion> regions_;
    const FanOptions options_;
    VertexFaces vf_;
    const std::vector<Complex>& along_;
    std::vector<int> flip_, winding_;
    std::vector<char> zero_vertex_;  // a zero's region sits at this vertex
    std::vector<char> boundary_;
    std::vector<Index> owner_;
    std::vector<char> mark_;
    std::vector<Index> stamp_, chain_stamp_;
    mutable std::vector<Index> candidate_stamp_;
    std::vector<Complex> image_, origin_;
    std::vector<char> cut_;
    std::vector<Index> flooded_;  // fill_holes' scratch, kept for its capacity
    Index regrowable_ = 0;        // failed solves whose region could grow again (run())
    Index generation_ = 0;
    Index face_cap_ = 0;
    std::vector<std::pair<Index, Group>> undo_;  // groups as they were before the current solve
};

// Flipped image triangles that one edge flip repairs: where the image of the two faces across
// an edge is a simple quadrilateral with the other diagonal inside, that diagonal gives two
// counter-clockwise image triangles (the 3D triangles must stay non-degenerate and the new
// edge must not double one). Vertices stay; flipped faces lose their input face (-1); faces
// marked `keep` stay.
struct Flipped {
    std::vector<Complex> along;  // the form along each halfedge
    // Only where some image triangle was flipped (the caller reads them when flips > 0):
    TriangleMatrix F;
    std::vector<Index> twin;
    std::vector<Index> original_face;
    Index flips = 0;
};

Flipped flip_folds(const MeshView& mesh, std::vector<Complex> along, const std::vector<char>& keep) {
    const Index nf = mesh.n_faces();
    Flipped out;
    const auto flipped = [&](Index f) {
        return !ccw(Complex(0), along[3 * f], -along[3 * f + 2]);
    };
    std::vector<Index> queue;
    for (Index f = 0; f < nf; ++f)
        if (flipped(f)) queue.push_back(f);
    if (queue.empty()) {  // nothing to flip: the caller keeps the input's triangles
        out.along = std::move(along);
        return out;
    }
    out.F = mesh.F;
    out.twin = mesh.twin;
    TriangleMatrix& F = out.F;
    std::vector<Index>& twin = out.twin;
    out.original_face.resize(nf);
    for (Index f = 0; f < nf; ++f) out.original_face[f] = f;
    const auto tail = [&](Index h) { return F(h / 3, h % 3); };
    const auto head = [&](Index h) { return F(h / 3, (h % 3 + 1) % 3); };
    std::vector<char> queued(nf, 0);
    for (Index f : queue) queued[f] = 1;
    const std::size_t limit = 16 * queue.size() + 64;  // flips only ever get fewer; a guard
    for (std::size_t q = 0; q < queue.size() && q < limit; ++q) {
        const Index f = queue[q];
        queued[f] = 0;
        if (!flipped(f) || keep[f]) continue;
        for (int k = 0; k < 3; ++k) {
            const Index h = 3 * f + k, t = twin[h];
            if (t == kNoHalfedge) continue;
            const Index g = t / 3;
            if (keep[g]) continue;
            // Quad a -> d -> b -> c: h = a->b in (a, b, c), t = b->a in (b, a, d).
            const Index a = tail(h), b = head(h), c = head(MeshView::next(h)), d = head(MeshView::next(t));
            if (c == d || a == b || joins(F, twin, MeshView::prev(h), d)) continue;
            const Complex ia = 0, ib = along[h], ic = ib + along[MeshView::next(h)], id = along[MeshView::next(t)];
            // New faces (c, a, d) and (d, b, c).
            if (!ccw(ic, ia, id) || !ccw(id, ib, ic)) continue;
            if (!solid(mesh.V.row(c), mesh.V.row(a), mesh.V.row(d)) ||
                !solid(mesh.V.row(d), mesh.V.row(b), mesh.V.row(c)))
                continue;
            // The outer halfedges keep their twins and values: c->a, a->d, d->b, b->c.
            const Index ca = MeshView::prev(h), bc = MeshView::next(h), ad = MeshView::next(t), db = MeshView::prev(t);
            const Index o_ca = twin[ca], o_bc = twin[bc], o_ad = twin[ad], o_db = twin[db];
            const Complex v_ca = along[ca], v_bc = along[bc], v_ad = along[ad], v_db = along[db];
            flip_edge(F, twin, h);
            along[3 * f] = v_ca, along[3 * f + 1] = v_ad, along[3 * g] = v_db, along[3 * g + 1] = v_bc;
            along[3 * f + 2] = ic - id, along[3 * g + 2] = id - ic;  // d -> c, c -> d
            out.original_face[f] = out.original_face[g] = -1;
            ++out.flips;
            for (Index x : {o_ca, o_ad, o_db, o_bc})
                if (x != kNoHalfedge && !queued[x / 3] && flipped(x / 3)) queued[x / 3] = 1, queue.push_back(x / 3);
            break;
        }
    }
    out.along = std::move(along);
    return out;
}

RegularisedForm regularise_on(const Triangles& mesh, std::span<const ZeroRegion> regions, const FanOptions& options) {
    RegularisedForm out;
    Builder builder(mesh, regions, options);
    const std::vector<Group> groups = builder.run();
    out.regrowable_failures = builder.regrowable_failures();
    const std::vector<Complex>& along = mesh.along;
    std::vector<Index> accepted;
    for (std::size_t g = 0; g < groups.size(); ++g)
        if (groups[g].accepted && !groups[g].result.kept) accepted.push_back(static_cast<Index>(g));

    // Faces and vertices that go: every region's faces; vertices not on a chain or a centre.
    std::vector<char> face_removed(mesh.n_faces(), 0), vertex_kept(mesh.n_vertices(), 1);
    for (Index g : accepted)
        for (Index f : groups[g].result.faces) {
            face_removed[f] = 1;
            for (int k = 0; k < 3; ++k) vertex_kept[mesh.F(f, k)] = 0;
        }
    for (Index g : accepted) {
        const Retriangulation& r = groups[g].result;
        for (Index h : r.chain) vertex_kept[mesh.tail(h)] = vertex_kept[mesh.head(h)] = 1;
        if (r.centre >= 0) vertex_kept[r.centre] = 1;
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
    std::vector<Index> centre_vertex(groups.size(), -1);
    for (Index g : accepted) {
        const Retriangulation& r = groups[g].result;
        if (!r.has_centre) continue;
        if (r.centre >= 0) {
            centre_vertex[g] = new_vertex[r.centre];
        } else {
            centre_vertex[g] = static_cast<Index>(out.original_vertex.size());
            out.original_vertex.push_back(-1);
        }
    }
    const Index nv = static_cast<Index>(out.original_vertex.size());
    PointMatrix V(nv, 3);
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        if (new_vertex[v] >= 0) V.row(new_vertex[v]) = mesh.V.row(v);
    for (Index g : accepted)
        if (groups[g].result.has_centre) V.row(centre_vertex[g]) = groups[g].result.centre_position;

    // Kept faces first (in order), then each region's triangles; twins through the old pairing
    // on the chains, through shared point pairs inside a region.
    Index nf = 0;
    std::vector<Index> new_face(mesh.n_faces(), -1);
    for (Index f = 0; f < mesh.n_faces(); ++f)
        if (!face_removed[f]) new_face[f] = nf++;
    Index region_faces = 0;
    for (Index g : accepted) region_faces += static_cast<Index>(groups[g].result.triangles.size());
    TriangleMatrix F(nf + region_faces, 3);
    std::vector<Index> twin(3 * static_cast<std::size_t>(nf + region_faces), kNoHalfedge);
    std::vector<Complex> along_new(twin.size());
    std::vector<Index> chain_owner(mesh.n_halfedges(), -1);  // old chain halfedge -> new halfedge
    out.original_face.assign(nf + region_faces, -1);
    Index next_face = nf;
    for (Index g : accepted) {
        const Retriangulation& r = groups[g].result;
        const auto vertex = [&](Index p) { return p == kCentre ? centre_vertex[g] : new_vertex[r.vertex(mesh, p)]; };
        const auto image = [&](Index p) { return r.image(p); };
        std::map<std::pair<Index, Index>, Index> open_edges;  // (from, to) point ids -> halfedge
        for (const auto& t : r.triangles) {
            const Index f = next_face++;
            for (int k = 0; k < 3; ++k) {
                const Index a = t[k], b = t[(k + 1) % 3], h = 3 * f + k;
                F(f, k) = vertex(a);
                // Point a then b along the chain is chain halfedge a.
                if (r.chain_edge(a, b)) {
                    along_new[h] = along[r.chain[a]];
                    chain_owner[r.chain[a]] = h;
                    continue;
                }
                along_new[h] = image(b) - image(a);
                if (auto it = open_edges.find({b, a}); it != open_edges.end()) {
                    twin[h] = it->second;
                    twin[it->second] = h;
                    open_edges.erase(it);
                } else {
                    open_edges[{a, b}] = h;
                }
            }
        }
        // What is left open are the spokes to the mesh boundary (open chains).
        for (const auto& [key, h] : open_edges)
            HOLOFLOW_REQUIRE(r.open && (key.first == kCentre || key.second == kCentre),
                             "re-triangulated region is not closed");
    }
    // Kept faces in parallel blocks: each writes its own rows, and the one region halfedge that
    // owns the chain halfedge across from it (each has one kept face across).
    const auto n_faces = static_cast<std::size_t>(mesh.n_faces());
    par::for_each_range(n_faces, kParallelKeptFaces, [&](std::size_t begin, std::size_t end) {
        for (Index f = static_cast<Index>(begin); f < static_cast<Index>(end); ++f) {
            if (face_removed[f]) continue;
            const Index g = new_face[f];
            out.original_face[g] = f;
            for (int k = 0; k < 3; ++k) {
                const Index h = 3 * f + k;
                F(g, k) = new_vertex[mesh.F(f, k)];
                along_new[3 * g + k] = along[h];
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
    });
    // Two regions touching along an edge: their chain halfedges pair up directly.
    for (Index g : accepted)
        for (Index h : groups[g].result.chain) {
            const Index t = mesh.twin[h];
            if (t != kNoHalfedge && chain_owner[t] >= 0) twin[chain_owner[h]] = chain_owner[t];
        }

    // An accepted group lists every region it took in (absorbed groups' members included).
    out.region_vertex.assign(regions.size(), -1);
    for (std::size_t g = 0; g < groups.size(); ++g) {
        if (!groups[g].accepted) continue;
        const Retriangulation& r = groups[g].result;
        const Index v = r.kept         ? new_vertex[r.centre]
                        : r.has_centre ? centre_vertex[g]
                                       : new_vertex[mesh.tail(r.chain.front())];
        for (Index member : groups[g].members) out.region_vertex[member] = v;
    }
    for (std::size_t r = 0; r < regions.size(); ++r) {
        if (out.region_vertex[r] < 0) ++out.failed_regions, out.failed_weight += region_weight(regions[r]);
        else if (groups[r].absorbed_into >= 0) ++out.merged_regions;
    }

    out.mesh = make_mesh_view(std::move(V), std::move(F), std::move(twin));
    out.tau.resize(out.mesh.n_edges());
    const auto n_edges = static_cast<std::size_t>(out.mesh.n_edges());
    par::for_each_range(n_edges, kParallelKeptFaces, [&](std::size_t begin, std::size_t end) {
        for (Index e = static_cast<Index>(begin); e < static_cast<Index>(end); ++e)
            out.tau(e) = along_new[out.mesh.edge_halfedge[e]];
    });

    // What is left: failed regions, or none. Kept faces keep their images, so their flips.
    for (Index f = 0; f < mesh.n_faces(); ++f) out.flipped_faces += !face_removed[f] && builder.flips()[f] != 0;
    out.flipped_faces += count_flipped_images(along_new, nf);
    return out;
}

}  // namespace

RegularisedForm regularise_zeros(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                 std::span<const ZeroRegion> regions, const FanOptions& options) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    for (const ZeroRegion& r : regions) {
        for (Index v : r.vertices) HOLOFLOW_REQUIRE(v >= 0 && v < mesh.n_vertices(), "region vertex out of range");
        HOLOFLOW_REQUIRE(r.vertex < mesh.n_vertices() && r.face < mesh.n_faces(), "region position out of range");
        HOLOFLOW_REQUIRE(!r.vertices.empty() || r.vertex >= 0 || r.face >= 0, "empty region");
    }
    // Edge flips first: they repair what they can without losing a vertex. A face holding a
    // zero's point stays, the point is placed in it.
    std::vector<char> keep(mesh.n_faces(), 0);
    for (const ZeroRegion& r : regions)
        if (r.face >= 0) keep[r.face] = 1;
    const Flipped flipped = flip_folds(mesh, forms_along(mesh, tau), keep);
    if (flipped.flips == 0) return regularise_on(Triangles{mesh.V, mesh.F, mesh.twin, flipped.along}, regions, options);
    // Flips keep vertex and face ids and never touch a kept face: the regions hold as given.
    RegularisedForm out = regularise_on(Triangles{mesh.V, flipped.F, flipped.twin, flipped.along}, regions, options);
    for (Index& f : out.original_face)
        if (f >= 0) f = flipped.original_face[f];
    out.edge_flips = flipped.flips;
    return out;
}

}  // namespace holoflow::kernels
