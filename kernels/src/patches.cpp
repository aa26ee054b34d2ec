#include "holoflow/kernels/patches.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <tuple>

#include <Eigen/Geometry>

#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/parallel.h"
#include "holoflow/kernels/union_find.h"
#include "holoflow/kernels/zeros.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr double kFlipTol = 1e-12;  // signed uv area below -tol * (longest edge)^2 is a flip

constexpr double kSideBulge = 1e-4;       // repaired borders: bulge of a side over its length
constexpr Index kCornerCandidates = 32;  // border points tried per rectangle corner
constexpr double kConcaveCorner = 1.25 * std::numbers::pi;  // a patch's angle between border edges above this
constexpr double kBranchTurn = 3 * std::numbers::pi;  // uv angle around an inner vertex above this: it turns twice
constexpr double kCornerGap = 1e-6;  // a concave corner at least this far off its rectangle's sides (over its size)
constexpr double kAxisTol = 1e-6;    // directions within this (radians, or relative) count as along
constexpr Index kOpeningCandidates = 64;  // start vertices tried per cylinder (each one short trace)
constexpr Index kParallelPatchFaces = 8000;  // from here the overlap pays (10k-20k faces: 5-10 % off the stages)
constexpr double kIsoLineTol = 1e-9;      // a repaired cylinder: loop spread across, period mismatch, over the period

bool flipped_uv(Complex a, Complex b, Complex c) {
    const double scale = std::max({std::norm(b - a), std::norm(c - b), std::norm(a - c)});
    return cross(b - a, c - a) < -kFlipTol * scale;
}

// Distance of a border point from the nearest side of its patch's rectangle [0, w] x [0, h],
// over the longer side (0 for a patch with no extent): what rectangle_error takes the max of.
double rectangle_gap(const PatchInfo& info, Complex z) {
    const double size = std::max(info.width, info.height);
    if (!(size > 0)) return 0;
    return std::min({std::abs(z.real()), std::abs(info.width - z.real()), std::abs(z.imag()),
                     std::abs(info.height - z.imag())}) /
           size;
}

bool on_border(const MeshView& mesh, std::span<const char> border, Index h) {
    return mesh.twin[h] == kNoHalfedge || border[mesh.halfedge_edge[h]];
}

// The border halfedge of the same patch that leaves head(h): turn around head(h) inside it.
Index next_on_border(const MeshView& mesh, std::span<const char> border, Index h) {
    Index n = MeshView::next(h);
    while (!on_border(mesh, border, n)) n = MeshView::next(mesh.twin[n]);
    return n;
}

// The border loops of the patches, each followed with its patch on the left: per halfedge its
// loop (-1 off the border), and each loop's first halfedge.
struct BorderLoops {
    std::vector<Index> loop_of;
    std::vector<Index> first;
};

BorderLoops border_loops(const MeshView& mesh, std::span<const char> border) {
    BorderLoops out{std::vector<Index>(mesh.n_halfedges(), -1), {}};
    for (Index h0 = 0; h0 < mesh.n_halfedges(); ++h0) {
        if (out.loop_of[h0] >= 0 || !on_border(mesh, border, h0)) continue;
        const Index id = static_cast<Index>(out.first.size());
        out.first.push_back(h0);
        for (Index h = h0; out.loop_of[h] < 0; h = next_on_border(mesh, border, h)) out.loop_of[h] = id;
    }
    return out;
}

// Corners (named by the halfedge leaving them) around a vertex joined across non-border edges:
// the points of the patches cut open.
UnionFind patch_points(const MeshView& mesh, std::span<const char> border) {
    UnionFind points(mesh.n_halfedges());
    for (Index h = 0; h < mesh.n_halfedges(); ++h) {
        const Index p_edge = MeshView::prev(h), t = mesh.twin[p_edge];
        if (t == kNoHalfedge || border[mesh.halfedge_edge[p_edge]]) continue;
        points.unite(h, t);  // t leaves tail(h): the next corner around it
    }
    return points;
}

// The points of one patch (the classes of patch_points its corners fall in), numbered 0, 1, ..
// in the order its faces meet them, through `local` (#H scratch, all -1, and left so when this
// goes).
class PatchPoints {
 public:
    PatchPoints(UnionFind& points, const std::vector<Index>& faces, std::vector<Index>& local)
        : points_(points), local_(local) {
        for (Index f : faces)
            for (int k = 0; k < 3; ++k) {
                const Index r = points.find(3 * f + k);
                if (local[r] < 0) local[r] = size(), roots_.push_back(r), first_corner_.push_back(3 * f + k);
            }
    }
    ~PatchPoints() {
        for (Index r : roots_) local_[r] = -1;
    }
    PatchPoints(const PatchPoints&) = delete;
    PatchPoints& operator=(const PatchPoints&) = delete;

    Index size() const { return static_cast<Index>(roots_.size()); }
    //! The point of a corner (halfedge leaving it).
    Index of(Index corner) const { return local_[points_.find(corner)]; }
    //! The first corner (in face order) at point q.
    Index first_corner(Index q) const { return first_corner_[q]; }

 private:
    UnionFind& points_;
    std::vector<Index>& local_;
    std::vector<Index> roots_, first_corner_;
};

// The edges between a patch's points, each with its cotangent weight from the 3D triangles,
// clamped positive. Computed here, not by cotan_weights: the cut can leave zero-area faces,
// which that refuses; they weigh 0 here.
struct PatchEdges {
    std::vector<std::pair<Index, Index>> pair;  // (smaller, larger) point, sorted
    std::vector<double> weight;
};

PatchEdges patch_edges(const MeshView& mesh, const PatchPoints& points, const std::vector<Index>& faces) {
    std::vector<std::pair<std::pair<Index, Index>, double>> half;
    for (Index f : faces) {
        const Index v[3] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
        for (int k = 0; k < 3; ++k) {
            const Eigen::RowVector3d e1 = mesh.V.row(v[(k + 1) % 3]) - mesh.V.row(v[k]);
            const Eigen::RowVector3d e2 = mesh.V.row(v[(k + 2) % 3]) - mesh.V.row(v[k]);
            double cot = e1.dot(e2) / e1.cross(e2).norm();
            if (!std::isfinite(cot)) cot = 0;
            Index a = points.of(3 * f + (k + 1) % 3), b = points.of(3 * f + (k + 2) % 3);
            if (a > b) std::swap(a, b);
            half.push_back({{a, b}, 0.5 * cot});
        }
    }
    std::sort(half.begin(), half.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
    PatchEdges out;
    for (const auto& [pair, value] : half) {
        if (out.pair.empty() || out.pair.back() != pair) out.pair.push_back(pair), out.weight.push_back(0);
        out.weight.back() += value;
    }
    double mean = 0;
    for (double value : out.weight) mean += std::abs(value) / static_cast<double>(out.weight.size());
    const double floor = mean > 0 ? 1e-3 * mean : 1.0;
    for (double& value : out.weight) value = std::max(value, floor);
    return out;
}

// The layout system of one set of fixed points: each point not `fixed` the mean of its
// neighbours across `edges` (one sparse SPD solve). The Laplacian's pattern (fixed points pinned)
// and its analysis are made at the first try; a try with other weights refills and refactors it.
class InsideLayout {
 public:
    InsideLayout(const PatchEdges& edges, const std::vector<char>& fixed) : edges_(edges), fixed_(fixed) {}

    //! Moves the free rows of x with the edges' `weight`; fixed rows keep their place. lift[i]
    //! (empty: all 0) is where the second point of edge i lies seen from the first, minus its own
    //! x: a period across a cylinder's seam. False if the solver fails.
    bool solve(std::span<const double> weight, std::span<const Complex> lift, Eigen::MatrixXd& x) {
        const std::vector<char>& fixed = fixed_;
        if (std::all_of(fixed.begin(), fixed.end(), [](char f) { return f != 0; })) return true;
        if (L_.col_start.empty()) {
            std::vector<Index> pinned;
            for (Index q = 0; q < static_cast<Index>(fixed.size()); ++q)
                if (fixed[q]) pinned.push_back(q);
            EdgeMatrix E(static_cast<Index>(edges_.pair.size()), 2);
            for (Index i = 0; i < E.rows(); ++i) E(i, 0) = edges_.pair[i].first, E(i, 1) = edges_.pair[i].second;
            L_ = laplacian_pattern(static_cast<Index>(fixed.size()), E, std::move(pinned));
        }
        Eigen::MatrixXd b = x;  // fixed rows keep their place; the others sum their fixed neighbours
        for (Index q = 0; q < static_cast<Index>(x.rows()); ++q)
            if (!fixed[q]) b.row(q).setZero();
        for (std::size_t i = 0; i < edges_.pair.size(); ++i) {
            const auto [p, q] = edges_.pair[i];
            const double w = weight[i];
            if (!lift.empty()) {  // sum_q w (x_q + lift_pq - x_p) = 0 at p, and lift_qp = -lift_pq
                const Eigen::RowVector2d d(lift[i].real(), lift[i].imag());
                if (!fixed[p]) b.row(p) += w * d;
                if (!fixed[q]) b.row(q) -= w * d;
            }
            if (!fixed[p] && fixed[q]) b.row(p) += w * x.row(q);
            if (!fixed[q] && fixed[p]) b.row(q) += w * x.row(p);
        }
        fill_laplacian(L_, weight);
        try {
            if (!symbolic_) symbolic_ = CholeskySymbolic::analyse(L_);
            x = CholeskyFactor::factorize(symbolic_, L_)->solve(b);
        } catch (const SolverFailure&) {
            return false;
        }
        return true;
    }

 private:
    const PatchEdges& edges_;
    const std::vector<char>& fixed_;
    LaplacianMatrix L_;  // empty until the first try
    std::shared_ptr<const CholeskySymbolic> symbolic_;
};

// Flipped triangles of a layout (corner k of triangle i at uv[3 i + k]).
Index count_flips(std::span<const Complex> uv) {
    Index flips = 0;
    for (std::size_t i = 0; i + 2 < uv.size(); i += 3) flips += flipped_uv(uv[i], uv[i + 1], uv[i + 2]);
    return flips;
}

// A repair's layout with the clamped cotangent weights and, where rounding leaves flips there
// (sliver clusters with weights 1e6 apart collapse onto a point), with uniform ones (Tutte's)
// too: `solve(weight, uv)` makes one (false: none). The one with fewer flips goes to `uv` (the
// first on ties); returns its flips, -1 if neither could be made.
template <class Solve>
Index fewest_flips(const PatchEdges& edges, std::vector<Complex>& uv, const Solve& solve) {
    Index best = -1;
    std::vector<Complex> trial;
    std::vector<double> uniform;
    for (int attempt = 0; attempt < 2 && best != 0; ++attempt) {
        if (attempt == 1) uniform.assign(edges.weight.size(), 1.0);
        if (!solve(attempt == 0 ? std::span<const double>(edges.weight) : std::span<const double>(uniform), trial))
            continue;
        const Index flips = count_flips(trial);
        if (best < 0 || flips < best) best = flips, uv.swap(trial);
    }
    return best;
}

// One folded disk patch laid out again on its rectangle (see repair_folded_patches): the uv of
// corner k of faces[i] in uv[3 i + k]; returns its flips (see fewest_flips), -1 if the patch
// cannot be. `local` is #H scratch, all -1, and left so.
Index embed_on_rectangle(const MeshView& mesh, std::span<const char> border, UnionFind& patch_points,
                         const std::vector<Index>& faces, Index first_border, const PatchInfo& info,
                         std::span<const Complex> corner_uv, std::vector<Index>& local, std::vector<Complex>& uv) {
    const double w = info.width, h = info.height;
    if (!(w > 0 && h > 0)) return -1;
    const PatchPoints points(patch_points, faces, local);
    const Index n = points.size();
    // The border loop, counter-clockwise (the patch on its left); each point once.
    std::vector<Index> loop;
    std::vector<char> is_border(n, 0);
    for (Index e = first_border;;) {
        const Index q = points.of(e);
        if (is_border[q] || static_cast<Index>(loop.size()) >= n) return -1;
        is_border[q] = 1;
        loop.push_back(e);
        e = next_on_border(mesh, border, e);
        if (e == first_border) break;
    }
    const Index m = static_cast<Index>(loop.size());
    // The edges and their Laplacian pattern, made at the first layout and shared by a second
    // (the border at arc length: the same fixed points).
    std::optional<PatchEdges> edges;
    std::optional<InsideLayout> inside;
    const auto lay_out_inside = [&](const Eigen::MatrixXd& x) {
        if (!edges) {
            edges.emplace(patch_edges(mesh, points, faces));
            inside.emplace(*edges, is_border);
        }
        return fewest_flips(*edges, uv, [&](std::span<const double> weight, std::vector<Complex>& out) {
            Eigen::MatrixXd y = x;
            if (!inside->solve(weight, {}, y)) return false;
            out.resize(3 * faces.size());
            for (std::size_t i = 0; i < faces.size(); ++i)
                for (int k = 0; k < 3; ++k) {
                    const Index q = points.of(3 * faces[i] + k);
                    out[3 * i + k] = Complex(y(q, 0), y(q, 1));
                }
            return true;
        });
    };
    const std::array<Complex, 4> corner{Complex(0, 0), Complex(w, 0), Complex(w, h), Complex(0, h)};
    if (m == 3) {
        // A border of three points (a sliver between curves, often flat in the form's uv): on
        // three of the rectangle's corners, the assignment in border order nearest the form's.
        double best = std::numeric_limits<double>::infinity();
        std::array<Complex, 3> at{};
        for (int skipped = 0; skipped < 4; ++skipped)
            for (int shift = 0; shift < 3; ++shift) {
                std::array<Complex, 3> trial{};
                double cost = 0;
                for (int j = 0; j < 3; ++j) {
                    trial[(shift + j) % 3] = corner[(skipped + 1 + j) % 4];
                    cost += std::norm(corner_uv[loop[(shift + j) % 3]] - trial[(shift + j) % 3]);
                }
                if (cost < best) best = cost, at = trial;
            }
        Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, 2);
        for (Index i = 0; i < 3; ++i) x.row(points.of(loop[i])) << at[i].real(), at[i].imag();
        return lay_out_inside(x);
    }
    if (m < 4) return -1;
    // Corners: four border points in counter-clockwise order, nearest the rectangle's corners
    // (least sum of squared distances; first best on ties).
    std::array<Index, 4> at{};
    {
        const auto cost = [&](int c, Index i) { return std::norm(corner_uv[loop[i]] - corner[c]); };
        // Candidates: the points nearest each corner (all of them on short borders).
        std::vector<Index> candidates(m);
        std::iota(candidates.begin(), candidates.end(), Index{0});
        if (m > 4 * kCornerCandidates) {
            std::vector<Index> nearest, order = candidates;
            for (int c = 0; c < 4; ++c) {
                std::partial_sort(order.begin(), order.begin() + kCornerCandidates, order.end(), [&](Index i, Index j) {
                    return std::pair(cost(c, i), i) < std::pair(cost(c, j), j);
                });
                nearest.insert(nearest.end(), order.begin(), order.begin() + kCornerCandidates);
            }
            std::sort(nearest.begin(), nearest.end());
            nearest.erase(std::unique(nearest.begin(), nearest.end()), nearest.end());
            candidates.swap(nearest);
        }
        // For each first corner, one pass per later corner over the candidates after it,
        // keeping the best choice so far (a running minimum).
        constexpr double kNone = std::numeric_limits<double>::infinity();
        const Index nc = static_cast<Index>(candidates.size());
        double best = kNone;
        std::vector<double> previous(nc), next(nc);
        std::vector<std::array<Index, 4>> picks(nc), next_picks(nc);
        for (Index i0 = 0; i0 < nc; ++i0) {
            const auto position = [&](Index j) { return candidates[(i0 + j) % nc]; };
            std::fill(previous.begin(), previous.end(), kNone);
            previous[0] = cost(0, position(0));
            picks[0][0] = position(0);
            for (int c = 1; c < 4; ++c) {
                std::fill(next.begin(), next.end(), kNone);
                Index run = -1;  // best previous choice before j
                for (Index j = 1; j < nc; ++j) {
                    if (previous[j - 1] < (run < 0 ? kNone : previous[run])) run = j - 1;
                    if (run < 0) continue;
                    next[j] = previous[run] + cost(c, position(j));
                    next_picks[j] = picks[run];
                    next_picks[j][c] = position(j);
                }
                previous.swap(next);
                picks.swap(next_picks);
            }
            for (Index j = 0; j < nc; ++j)
                if (previous[j] < best) best = previous[j], at = picks[j];
        }
        if (!(best < kNone)) return -1;
    }
    // The border on the sides: by the form's uv projected on each side where that increases
    // (else 3D arc length), or by arc length throughout.
    const auto border_on_sides = [&](bool by_form) {
        Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, 2);
        const auto place = [&](Index i, Complex z) {
            const Index q = points.of(loop[i % m]);
            x(q, 0) = z.real();
            x(q, 1) = z.imag();
        };
        for (int c = 0; c < 4; ++c) {
            const Index begin = at[c], count = (at[(c + 1) % 4] - at[c] + m) % m;
            const Complex a = corner[c], b = corner[(c + 1) % 4];
            // Where along the side: the uv projected on it if that increases, else 3D arc
            // length (else the point count, for zero-length edges).
            std::vector<double> t(count + 1, 0), arc(count + 1, 0);
            bool increasing = by_form;
            for (Index j = 1; j < count; ++j) {
                const Complex z = corner_uv[loop[(begin + j) % m]];
                t[j] = ((z - a) * std::conj(b - a)).real() / std::norm(b - a);
                increasing = increasing && t[j] > t[j - 1] && t[j] < 1;
            }
            t[count] = 1;
            for (Index j = 1; j <= count; ++j) {
                const Index e = loop[(begin + j - 1) % m];
                arc[j] = arc[j - 1] + (mesh.V.row(mesh.head(e)) - mesh.V.row(mesh.tail(e))).norm();
                increasing = increasing && arc[j] > arc[j - 1];
            }
            // Bulged outwards a little: a strictly convex border, so that a triangle with its
            // three points on one side still has an area (Floater's theorem then holds for every
            // face).
            const Complex outward = (b - a) * Complex(0, -kSideBulge);
            for (Index j = 0; j < count; ++j) {
                const double s = increasing       ? t[j]
                                 : arc[count] > 0 ? arc[j] / arc[count]
                                                  : static_cast<double>(j) / static_cast<double>(count);
                place(begin + j, a + s * (b - a) + 4 * s * (1 - s) * outward);
            }
        }
        return x;
    };
    const Index flips = lay_out_inside(border_on_sides(true));
    if (flips == 0) return flips;
    // Where the form is nearly zero along the border (a failed zero's region, b9_mesh with its
    // faces split: 122 border points within 1e-5), its points crowd there and rounding flips
    // what they pull along; 3D arc length spaces them out.
    std::vector<Complex> form_border_uv = std::move(uv);
    const Index arc_flips = lay_out_inside(border_on_sides(false));
    if (arc_flips >= 0 && (flips < 0 || arc_flips < flips)) return arc_flips;
    uv = std::move(form_border_uv);
    return flips;
}

// The form's coordinate along a loop (t[0] = 0 up to the period at t[m]) made strictly
// increasing: each stretch where it goes back (a fold touching the loop) is replaced, from the
// point before it to the first point beyond all of it, by 3D arc length between those two; the
// rest stays. Empty if that cannot be done (then the caller takes arc length all along).
std::vector<double> increasing_along(std::vector<double> t, const std::vector<double>& arc) {
    const std::size_t m = t.size() - 1;
    for (std::size_t i = 1; i <= m; ++i) {
        if (t[i] > t[i - 1]) continue;
        const std::size_t a = i - 1;
        std::size_t b = i;
        for (double top = t[a]; b < m && !(t[b] > top); ++b) top = std::max(top, t[b]);
        if (!(t[b] > t[a]) || !(arc[b] > arc[a])) return {};
        for (std::size_t k = a + 1; k < b; ++k) t[k] = t[a] + (t[b] - t[a]) * (arc[k] - arc[a]) / (arc[b] - arc[a]);
        i = b;
    }
    return t;
}

// One folded cylinder patch laid out again on its flat cylinder (see repair_folded_patches):
// the uv of corner k of faces[i] in uv[3 i + k]; returns its flips (see fewest_flips), -1 if
// the patch cannot be. `loops` are its two border loops' first halfedges; `local` is #H
// scratch, all -1, and left so.
Index embed_on_cylinder(const MeshView& mesh, std::span<const char> border, UnionFind& patch_points,
                        const std::vector<Index>& faces, std::array<Index, 2> loops,
                        std::span<const Complex> corner_uv, std::vector<Index>& local, std::vector<Complex>& uv) {
    const PatchPoints points(patch_points, faces, local);
    const Index n = points.size();
    // Each point's frame: the uv of its first corner.
    std::vector<Complex> frame(n);
    for (Index q = 0; q < n; ++q) frame[q] = corner_uv[points.first_corner(q)];
    // The period: the form along a border loop (the patch on its left). The integral of a closed
    // form, so exact whatever folds inside.
    std::array<std::vector<Index>, 2> loop;
    std::array<Complex, 2> period{};
    std::vector<char> is_border(n, 0);
    for (int l = 0; l < 2; ++l)
        for (Index e = loops[l];;) {
            const Index q = points.of(e);
            if (is_border[q] || static_cast<Index>(loop[l].size()) >= n) return -1;
            is_border[q] = 1;
            loop[l].push_back(e);
            period[l] += corner_uv[MeshView::next(e)] - corner_uv[e];
            e = next_on_border(mesh, border, e);
            if (e == loops[l]) break;
        }
    const Complex pi = period[1];
    if (!(std::abs(pi) > 0) || std::abs(period[0] + pi) > kIsoLineTol * std::abs(pi)) return -1;
    // A corner's uv is its point's frame plus a whole number of periods (the walk that
    // integrated the form went around the core that many times more).
    const auto turns = [&](Index corner) {
        const Complex d = corner_uv[corner] - frame[points.of(corner)];
        return std::round((d * std::conj(pi)).real() / std::norm(pi));
    };
    // In the frame turned so that the period is +i: across the core is real, around it imaginary.
    // Each loop must be an iso-line across (one real part), lower on the loop walked downwards.
    const Complex turn = Complex(0, std::abs(pi)) / pi;
    std::array<double, 2> level{};
    for (int l = 0; l < 2; ++l) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (Index e : loop[l]) {
            const double re = (corner_uv[e] * turn).real();
            lo = std::min(lo, re), hi = std::max(hi, re);
        }
        level[l] = 0.5 * (lo + hi);
        if (hi - lo > kIsoLineTol * std::abs(pi)) return -1;
    }
    // Loop 1 is walked along +period (the patch on its left lies towards lower levels).
    if (!(level[0] < level[1])) return -1;
    Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, 2);
    std::vector<char> moved(n, 0);  // loop points placed away from the form's uv
    for (int l = 0; l < 2; ++l) {
        // Around the loop: the form's own coordinate where it moves one way, else 3D arc length.
        std::vector<Index>& lp = loop[l];
        const Index m = static_cast<Index>(lp.size());
        const double sign = l == 1 ? 1 : -1, total = std::abs(pi);
        std::vector<double> along, arc;
        // A fold across the loop's first point leaves no increasing stretch to start from: then
        // from the point half way round.
        for (int attempt = 0; attempt < 2 && along.empty(); ++attempt) {
            if (attempt == 1) std::rotate(lp.begin(), lp.begin() + m / 2, lp.end());
            along.assign(m + 1, 0);
            arc.assign(m + 1, 0);
            for (Index j = 0; j < m; ++j) {
                const Index e = lp[j];
                along[j + 1] = along[j] + sign * ((corner_uv[MeshView::next(e)] - corner_uv[e]) * turn).imag();
                arc[j + 1] = arc[j] + (mesh.V.row(mesh.head(e)) - mesh.V.row(mesh.tail(e))).norm();
            }
            along = increasing_along(std::move(along), arc);
        }
        if (along.empty()) {
            if (!(arc[m] > 0)) return -1;
            along = arc;
        }
        // From where the form puts the loop's first point, one walk along the loop; `walk` is the
        // form's own position on it, a whole number of periods from each corner's uv.
        const Complex start = corner_uv[lp[0]] * turn;
        Complex walk = corner_uv[lp[0]];
        for (Index j = 0; j < m; ++j) {
            const Index e = lp[j];
            const double around = sign * total * along[j] / along[m];
            const Complex z = Complex(level[l], start.imag() + around) / turn;
            const double walked = std::round(((walk - corner_uv[e]) * std::conj(pi)).real() / std::norm(pi));
            const Complex placed = z - (walked + turns(e)) * pi;  // into its point's frame
            const Index q = points.of(e);
            x(q, 0) = placed.real();
            x(q, 1) = placed.imag();
            moved[q] = std::abs(placed - frame[q]) > kIsoLineTol * total;
            walk += corner_uv[MeshView::next(e)] - corner_uv[e];
        }
    }
    // Edges with their lift across the seam, from any face that has them (all agree: corners
    // of one face are in one walk).
    std::vector<double> corner_turns(3 * faces.size());  // turns(3 faces[i] + k) at 3 i + k
    for (std::size_t i = 0; i < faces.size(); ++i)
        for (int k = 0; k < 3; ++k) corner_turns[3 * i + k] = turns(3 * faces[i] + k);
    const PatchEdges edges = patch_edges(mesh, points, faces);
    std::vector<Complex> lift(edges.pair.size());
    for (std::size_t i = 0; i < faces.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            Index a = points.of(3 * faces[i] + k), b = points.of(3 * faces[i] + (k + 1) % 3);
            double da = corner_turns[3 * i + k], db = corner_turns[3 * i + (k + 1) % 3];
            if (a > b) std::swap(a, b), std::swap(da, db);
            const auto it = std::lower_bound(edges.pair.begin(), edges.pair.end(), std::pair(a, b));
            lift[it - edges.pair.begin()] = (db - da) * pi;
        }
    // Only around the folds first: the points within two rings of flipped faces and of loop
    // points placed away from the form's uv move; the rest keep the form's uv (and its
    // distortion: a layout of the whole patch squashes the cut's slivers). Where that still
    // flips (the free region is not convex, so nothing forbids it), every inside point moves:
    // with both loops on their lines and positive weights, no triangle flips, up to rounding.
    const auto layout = [&](const Eigen::MatrixXd& at, std::vector<Complex>& out) {
        out.resize(3 * faces.size());
        for (std::size_t i = 0; i < faces.size(); ++i)
            for (int k = 0; k < 3; ++k) {
                const Index q = points.of(3 * faces[i] + k);
                out[3 * i + k] = Complex(at(q, 0), at(q, 1)) + corner_turns[3 * i + k] * pi;
            }
        return count_flips(out);
    };
    std::vector<char> seed = moved, moves(n, 0);
    for (Index f : faces)
        if (flipped_uv(corner_uv[3 * f], corner_uv[3 * f + 1], corner_uv[3 * f + 2]))
            for (int k = 0; k < 3; ++k) seed[points.of(3 * f + k)] = 1;
    for (int ring = 0; ring < 2; ++ring) {
        for (Index f : faces) {
            const Index a = points.of(3 * f), b = points.of(3 * f + 1), c = points.of(3 * f + 2);
            if (seed[a] || seed[b] || seed[c]) moves[a] = moves[b] = moves[c] = 1;
        }
        seed = moves;
    }
    Eigen::MatrixXd form_x = x;  // the inside at the form's uv, each point in its frame
    std::vector<char> fixed(n);
    for (Index q = 0; q < n; ++q) {
        fixed[q] = is_border[q] || !moves[q];
        if (!is_border[q]) form_x(q, 0) = frame[q].real(), form_x(q, 1) = frame[q].imag();
    }
    InsideLayout around_folds(edges, fixed), whole(edges, is_border);
    return fewest_flips(edges, uv, [&](std::span<const double> weight, std::vector<Complex>& out) {
        Eigen::MatrixXd y = form_x;
        if (around_folds.solve(weight, lift, y) && layout(y, out) == 0) return true;
        y = x;
        if (!whole.solve(weight, lift, y)) return false;
        layout(y, out);
        return true;
    });
}

// The transversal kernels' inputs: a cut, its border flags and its patches.
void require_together(const CutMesh& cut, std::span<const char> border, const Patches& patches) {
    const MeshView& cm = cut.mesh;
    HOLOFLOW_REQUIRE(static_cast<Index>(border.size()) == cm.n_edges() &&
                         static_cast<Index>(patches.face_patch.size()) == cm.n_faces() &&
                         patches.corner_uv.size() == 3 * static_cast<std::size_t>(cm.n_faces()) &&
                         static_cast<Index>(cut.original_face.size()) == cm.n_faces() &&
                         static_cast<Index>(cut.original_vertex.size()) == cm.n_vertices(),
                     "cut, border flags and patches must belong together");
}

// A start vertex for a cylinder's transversal.
struct Opening {
    Index patch;
    double off_middle;  // distance of its uv from the middle of the patch across the core
    Index vertex;
    bool vertical;      // the core period is mostly real: iso-u lines cross it
    bool on_boundary;   // on the surface boundary (one curve leaves it into the patch)
};

// Per cylinder patch, the eligible vertices strictly inside it (every edge at it an interior,
// non-border edge of the patch), nearest the middle across the core first, ties to the smaller
// id; then those on the surface boundary with no trajectory at them (a cylinder of a
// double-covered or tip-sliced surface may have no inside vertex at all); kOpeningCandidates
// at most.
std::vector<Opening> cylinder_openings(const MeshView& mesh, const Eigen::VectorXcd& tau, std::span<const char> border,
                                       const BorderLoops& loops, const Patches& patches,
                                       std::span<const char> eligible) {
    const Index np = static_cast<Index>(patches.info.size());
    const auto is_cylinder = [&](Index id) { return patches.info[id].type == PatchInfo::Type::Cylinder; };
    // The core period of each cylinder: the form along its first border loop.
    std::vector<Complex> period(np, 0);
    std::vector<char> walked(np, 0);
    for (Index h0 : loops.first) {
        const Index id = patches.face_patch[MeshView::face(h0)];
        if (walked[id] || !is_cylinder(id)) continue;
        walked[id] = 1;
        Index h = h0;
        do {
            period[id] += form_along(mesh, tau, h);
            h = next_on_border(mesh, border, h);
        } while (h != h0);
    }
    std::vector<Opening> out;
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        const Index first = mesh.vertex_halfedge[v];
        if (!eligible[v] || first == kNoHalfedge) continue;
        const Index id = patches.face_patch[MeshView::face(first)];
        if (!is_cylinder(id)) continue;
        // Every face at v in the patch and no trajectory edge at v (surface boundary edges
        // are allowed: the fan then ends, h = kNoHalfedge).
        bool clean = true;
        Index h = first;
        do {
            clean = patches.face_patch[MeshView::face(h)] == id && !border[mesh.halfedge_edge[h]] &&
                    !border[mesh.halfedge_edge[MeshView::prev(h)]];
            h = mesh.rotate(h);
        } while (clean && h != first && h != kNoHalfedge);
        if (!clean) continue;
        const PatchInfo& info = patches.info[id];
        const bool vertical = std::abs(period[id].real()) >= std::abs(period[id].imag());
        const Complex uv = patches.corner_uv[first];
        const double off_middle = vertical ? std::abs(uv.imag() - info.height / 2) : std::abs(uv.real() - info.width / 2);
        out.push_back({id, off_middle, v, vertical, h == kNoHalfedge});
    }
    // The first kOpeningCandidates of each patch in this order (a total one: vertices differ),
    // selected per patch rather than sorting every vertex of every cylinder.
    const auto before = [](const Opening& a, const Opening& b) {
        return std::tie(a.patch, a.on_boundary, a.off_middle, a.vertex) <
               std::tie(b.patch, b.on_boundary, b.off_middle, b.vertex);
    };
    std::vector<std::size_t> start(np + 1, 0);  // by patch, a counting sort
    for (const Opening& o : out) ++start[o.patch + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<Opening> by_patch(out.size());
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    for (const Opening& o : out) by_patch[next[o.patch]++] = o;
    std::vector<Opening> kept;
    for (Index id = 0; id < np; ++id) {
        const auto first = by_patch.begin() + static_cast<std::ptrdiff_t>(start[id]);
        const auto last = by_patch.begin() + static_cast<std::ptrdiff_t>(start[id + 1]);
        const auto end = first + std::min<std::ptrdiff_t>(kOpeningCandidates, last - first);
        std::partial_sort(first, end, last, before);
        kept.insert(kept.end(), first, end);
    }
    return kept;
}

}  // namespace

Patches compute_patches(const MeshView& mesh, const Eigen::VectorXcd& tau, std::span<const char> border) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges() && static_cast<Index>(border.size()) == mesh.n_edges(),
                     "form and border flags must have one value per edge");
    const Index nf = mesh.n_faces();
    Patches p;
    p.face_patch.assign(nf, -1);
    p.corner_uv.assign(3 * static_cast<std::size_t>(nf), Complex(0));
    // The flood fill, while other workers measure the faces and walk the border loops (neither
    // depends on the patches).
    std::vector<double> face_distortion;
    std::vector<Index> loop_starts;
    const auto flood_fill = [&] {
        // Per halfedge, in passes in memory order: the form along it, and its twin where the
        // flood crosses (-1 at borders). The flood then reads each face it reaches in one place.
        const std::vector<Complex> along = forms_along(mesh, tau);
        std::vector<Index> across(mesh.n_halfedges());
        for (Index h = 0; h < mesh.n_halfedges(); ++h)
            across[h] = on_border(mesh, border, h) ? kNoHalfedge : mesh.twin[h];
        std::vector<Index> queue;
        queue.reserve(nf);
        for (Index seed = 0; seed < nf; ++seed) {
            if (p.face_patch[seed] >= 0) continue;
            const Index id = static_cast<Index>(p.info.size());
            p.info.emplace_back();
            p.face_patch[seed] = id;
            p.corner_uv[3 * seed] = 0;
            p.corner_uv[3 * seed + 1] = along[3 * seed];
            p.corner_uv[3 * seed + 2] = -along[3 * seed + 2];
            queue.assign(1, seed);
            for (std::size_t q = 0; q < queue.size(); ++q) {
                const Index f = queue[q];
                for (int k = 0; k < 3; ++k) {
                    const Index t = across[3 * f + k];
                    if (t == kNoHalfedge) continue;
                    const Index g = MeshView::face(t);
                    if (p.face_patch[g] >= 0) continue;
                    p.face_patch[g] = id;
                    // t runs head(h) -> tail(h): its tail corner gets h's head uv.
                    const Index kt = t % 3;
                    const Complex base = p.corner_uv[3 * f + (k + 1) % 3];
                    p.corner_uv[3 * g + kt] = base;
                    p.corner_uv[3 * g + (kt + 1) % 3] = base + along[t];
                    p.corner_uv[3 * g + (kt + 2) % 3] = base - along[MeshView::prev(t)];
                    queue.push_back(g);
                }
            }
        }
    };
    par::run_together(nf >= kParallelPatchFaces,
                      {flood_fill, [&] { face_distortion = kernels::face_distortion(mesh, edge_lengths(mesh), tau); },
                       [&] { loop_starts = border_loops(mesh, border).first; }});

    const Index np = static_cast<Index>(p.info.size());
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
        info.flipped_uv_triangles += flipped_uv(a, b, c);
        for (const Complex z : {a, b, c}) {
            lo[id] = {std::min(lo[id].real(), z.real()), std::min(lo[id].imag(), z.imag())};
            hi[id] = {std::max(hi[id].real(), z.real()), std::max(hi[id].imag(), z.imag())};
        }
        const double d = face_distortion[f];
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
    // Vertices of each patch cut open (the classes of patch_points, counted without building
    // them): around a vertex, a fan of corners ends at each corner whose previous edge is on the
    // border, and a vertex with no such corner is one whole ring.
    std::vector<Index> vertices(np, 0);
    std::vector<char> fan_ends(mesh.n_vertices(), 0);
    for (Index h = 0; h < mesh.n_halfedges(); ++h)
        if (on_border(mesh, border, MeshView::prev(h))) {
            ++vertices[p.face_patch[MeshView::face(h)]];
            fan_ends[mesh.tail(h)] = 1;
        }
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        if (!fan_ends[v]) ++vertices[p.face_patch[MeshView::face(mesh.vertex_halfedge[v])]];

    std::vector<int> loops(np, 0);
    for (Index h0 : loop_starts) ++loops[p.face_patch[MeshView::face(h0)]];
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
        if (!on_border(mesh, border, h)) continue;
        PatchInfo& info = p.info[p.face_patch[MeshView::face(h)]];
        info.rectangle_error = std::max(info.rectangle_error, rectangle_gap(info, p.corner_uv[h]));
    }
    for (PatchInfo& info : p.info) info.form_flipped_uv_triangles = info.flipped_uv_triangles;
    return p;
}

CollapsedArea collapsed_area(const MeshView& mesh, std::span<const Complex> corner_uv, double ratio) {
    const Index nf = mesh.n_faces();
    HOLOFLOW_REQUIRE(corner_uv.size() == 3 * static_cast<std::size_t>(nf), "uv must have three corners per face");
    HOLOFLOW_REQUIRE(ratio > 0, "the collapse ratio must be positive");
    std::vector<double> area(nf), uv_area(nf);
    double total_uv = 0;
    CollapsedArea out;
    for (Index f = 0; f < nf; ++f) {
        const auto p0 = mesh.V.row(mesh.F(f, 0)), p1 = mesh.V.row(mesh.F(f, 1)), p2 = mesh.V.row(mesh.F(f, 2));
        area[f] = 0.5 * (p1 - p0).cross(p2 - p0).norm();
        const Complex a = corner_uv[3 * f], b = corner_uv[3 * f + 1], c = corner_uv[3 * f + 2];
        uv_area[f] = 0.5 * std::abs(cross(b - a, c - a));
        out.total += area[f];
        total_uv += uv_area[f];
    }
    // scale_f < ratio * mean  <=>  uv_area_f / area_f < ratio^2 * total_uv / total; a uv that
    // is one point (total_uv 0) is collapsed everywhere.
    const double limit = ratio * ratio * total_uv / out.total;
    out.faces.resize(nf);
    for (Index f = 0; f < nf; ++f) {
        out.faces[f] = !(total_uv > 0) || uv_area[f] < limit * area[f];
        if (out.faces[f]) out.collapsed += area[f];
    }
    return out;
}

Patches repair_folded_patches(const MeshView& mesh, std::span<const char> border, Patches p) {
    HOLOFLOW_REQUIRE(static_cast<Index>(border.size()) == mesh.n_edges() &&
                         static_cast<Index>(p.face_patch.size()) == mesh.n_faces() &&
                         p.corner_uv.size() == 3 * static_cast<std::size_t>(mesh.n_faces()),
                     "patches and border flags must belong to this mesh");
    const Index np = static_cast<Index>(p.info.size());
    std::vector<std::vector<Index>> faces(np);
    std::vector<Index> first_border(np, kNoHalfedge);
    const auto folded = [](const PatchInfo& info) {
        return (info.type == PatchInfo::Type::Disk || info.type == PatchInfo::Type::Cylinder) &&
               info.flipped_uv_triangles > 0;
    };
    if (std::none_of(p.info.begin(), p.info.end(), folded)) return p;
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const Index id = p.face_patch[f];
        HOLOFLOW_REQUIRE(id >= 0 && id < np, "face " + std::to_string(f) + " has no patch");
        if (!folded(p.info[id])) continue;
        faces[id].push_back(f);
        for (int k = 0; k < 3; ++k)
            if (first_border[id] == kNoHalfedge && on_border(mesh, border, 3 * f + k)) first_border[id] = 3 * f + k;
    }
    // A cylinder's two border loops.
    std::vector<std::array<Index, 2>> loops(np, {kNoHalfedge, kNoHalfedge});
    if (std::any_of(p.info.begin(), p.info.end(),
                    [&](const PatchInfo& info) { return folded(info) && info.type == PatchInfo::Type::Cylinder; }))
        for (Index h0 : border_loops(mesh, border).first) {
            std::array<Index, 2>& two = loops[p.face_patch[MeshView::face(h0)]];
            two[two[0] == kNoHalfedge ? 0 : 1] = h0;
        }
    UnionFind points = patch_points(mesh, border);
    std::vector<Index> local(mesh.n_halfedges(), -1);
    std::vector<Complex> uv;
    const std::vector<double> length = edge_lengths(mesh);
    for (Index id = 0; id < np; ++id) {
        PatchInfo& info = p.info[id];
        if (faces[id].empty() || first_border[id] == kNoHalfedge) continue;
        const Index flips =
            info.type == PatchInfo::Type::Disk
                ? embed_on_rectangle(mesh, border, points, faces[id], first_border[id], info, p.corner_uv, local, uv)
            : loops[id][1] != kNoHalfedge
                ? embed_on_cylinder(mesh, border, points, faces[id], loops[id], p.corner_uv, local, uv)
                : -1;
        if (flips < 0 || flips >= info.flipped_uv_triangles) continue;  // rounding beat the theorem: the form's uv stays
        for (std::size_t i = 0; i < faces[id].size(); ++i) std::copy_n(&uv[3 * i], 3, &p.corner_uv[3 * faces[id][i]]);
        info.flipped_uv_triangles = flips;
        info.distortion_max = info.distortion_mean = info.rectangle_error = 0;
        Index finite = 0;
        for (Index f : faces[id]) {
            const Complex a = p.corner_uv[3 * f], b = p.corner_uv[3 * f + 1], c = p.corner_uv[3 * f + 2];
            const double d = triangle_distortion(length[mesh.halfedge_edge[3 * f]], length[mesh.halfedge_edge[3 * f + 1]],
                                                 length[mesh.halfedge_edge[3 * f + 2]], b - a, c - a);
            if (std::isfinite(d)) info.distortion_mean += d, info.distortion_max = std::max(info.distortion_max, d), ++finite;
            for (int k = 0; k < 3; ++k)
                if (on_border(mesh, border, 3 * f + k))
                    info.rectangle_error = std::max(info.rectangle_error, rectangle_gap(info, p.corner_uv[3 * f + k]));
        }
        if (finite > 0) info.distortion_mean /= static_cast<double>(finite);
    }
    return p;
}

std::vector<Trajectory> cylinder_transversals(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                              std::span<const Index> zero_vertices,
                                              std::span<const Trajectory> trajectories, const CutMesh& cut,
                                              std::span<const char> border, const Patches& patches) {
    require_together(cut, border, patches);
    // Openings are vertices inside cylinders: none without one (and no border loops to walk).
    if (std::none_of(patches.info.begin(), patches.info.end(),
                     [](const PatchInfo& info) { return info.type == PatchInfo::Type::Cylinder; }))
        return {};
    const MeshView& cm = cut.mesh;
    std::vector<char> eligible(cm.n_vertices(), 0);
    for (Index v = 0; v < cm.n_vertices(); ++v) eligible[v] = cut.original_vertex[v] >= 0;
    for (Index z : zero_vertices)
        if (z >= 0 && z < cm.n_vertices()) eligible[z] = 0;  // the cut keeps the traced vertex ids
    const BorderLoops loops = border_loops(cm, border);
    const std::vector<Opening> openings = cylinder_openings(cm, cut.tau, border, loops, patches, eligible);
    if (openings.empty()) return {};

    // The cylinders' border halfedges by traced face and by tail vertex.
    const std::vector<Index>& loop_of = loops.loop_of;
    std::vector<std::pair<Index, Index>> by_face, by_tail;
    for (Index h = 0; h < cm.n_halfedges(); ++h) {
        if (loop_of[h] < 0 || patches.info[patches.face_patch[MeshView::face(h)]].type != PatchInfo::Type::Cylinder)
            continue;
        by_face.emplace_back(cut.original_face[MeshView::face(h)], h);
        by_tail.emplace_back(cm.tail(h), h);
    }
    std::sort(by_face.begin(), by_face.end());
    std::sort(by_tail.begin(), by_tail.end());
    // The border loop of `patch` a curve ends on; -1 if none or not one alone.
    const auto end_loop = [&](const Trajectory& t, Index patch) {
        Index found = -1;
        bool unique = true;
        const auto consider = [&](Index h) {
            if (patches.face_patch[MeshView::face(h)] != patch) return;
            if (found >= 0 && found != loop_of[h]) unique = false;
            found = loop_of[h];
        };
        const auto range = [](const std::vector<std::pair<Index, Index>>& list, Index key) {
            return std::equal_range(list.begin(), list.end(), std::pair{key, Index{-1}},
                                    [](const auto& a, const auto& b) { return a.first < b.first; });
        };
        if (t.end_vertex >= 0) {
            for (auto [it, end] = range(by_tail, t.end_vertex); it != end; ++it) consider(it->second);
        } else if (t.end == Trajectory::End::Collision) {
            for (auto [it, end] = range(by_face, t.segment_face(mesh, t.n_segments() - 1)); it != end; ++it)
                if (cut.edge_trajectory[cm.halfedge_edge[it->second]] == t.blocker) consider(it->second);
        } else if (t.end == Trajectory::End::Boundary && !t.crossings.empty()) {
            for (auto [it, end] = range(by_face, MeshView::face(t.crossings.back().halfedge)); it != end; ++it)
                if (cm.twin[it->second] == kNoHalfedge) consider(it->second);
        }
        return unique ? found : Index{-1};
    };

    // The curves of each opening, traced in two rounds: every cylinder's first few starts, then
    // the others of the cylinders those did not open across (most open at their first start).
    // A start's curves do not depend on the other starts traced with it, so the rounds choose
    // what tracing all at once would.
    constexpr std::size_t kFirstRoundStarts = 4;
    std::vector<std::vector<Trajectory>> curves_of(openings.size());
    const auto trace_openings = [&](const std::vector<std::size_t>& which) {
        std::vector<TransversalStart> starts;
        std::vector<std::pair<Index, std::size_t>> by_vertex;  // start vertex -> opening
        for (std::size_t i : which) {
            const Index v = cut.original_vertex[openings[i].vertex];
            starts.push_back({v, openings[i].vertical ? TrajectoryFamily::Vertical : TrajectoryFamily::Horizontal});
            by_vertex.emplace_back(v, i);
        }
        std::sort(by_vertex.begin(), by_vertex.end());
        // Openings are distinct vertices of the traced mesh (original_vertex is its ids).
        for (Trajectory& t : trace_transversals(mesh, tau, zero_vertices, starts, trajectories)) {
            const auto it = std::lower_bound(by_vertex.begin(), by_vertex.end(), std::pair{t.start_vertex, std::size_t{0}});
            if (it != by_vertex.end() && it->first == t.start_vertex) curves_of[it->second].push_back(std::move(t));
        }
    };
    // Per cylinder, the first start with two curves that run from one border loop to the
    // other, else the first with two that end on one loop (they cut a disk off the cylinder).
    // A start at a fold of the form sends more than two; a pair of them is a cut as well. A
    // start on the surface boundary counts as a curve of its own (no curve) ending on its loop.
    // (Among the openings [first, end) of one cylinder.)
    struct Choice {
        std::array<const Trajectory*, 2> across{}, off{};
    };
    const auto filled = [](const std::array<const Trajectory*, 2>& pair) { return pair[0] || pair[1]; };
    const auto choose = [&](std::size_t first, std::size_t end) {
        Choice c;
        const Index patch = openings[first].patch;
        for (std::size_t i = first; i < end; ++i) {
            std::vector<std::pair<const Trajectory*, Index>> curves;  // with the loop each ends on
            if (openings[i].on_boundary) curves.emplace_back(nullptr, loop_of[cm.vertex_halfedge[openings[i].vertex]]);
            for (const Trajectory& t : curves_of[i]) curves.emplace_back(&t, end_loop(t, patch));
            for (std::size_t a = 0; a < curves.size(); ++a)
                for (std::size_t b = a + 1; b < curves.size(); ++b) {
                    if (curves[a].second < 0 || curves[b].second < 0) continue;
                    auto& slot = curves[a].second != curves[b].second ? c.across : c.off;
                    if (!filled(slot)) slot = {curves[a].first, curves[b].first};
                }
            if (filled(c.across)) break;
        }
        return c;
    };
    std::vector<std::pair<std::size_t, std::size_t>> cylinders;  // openings [first, last) of each
    for (std::size_t i = 0; i < openings.size();) {
        const std::size_t first = i;
        while (i < openings.size() && openings[i].patch == openings[first].patch) ++i;
        cylinders.emplace_back(first, i);
    }
    std::vector<std::size_t> which;
    for (const auto& [first, last] : cylinders)
        for (std::size_t i = first; i < std::min(last, first + kFirstRoundStarts); ++i) which.push_back(i);
    trace_openings(which);
    which.clear();
    for (const auto& [first, last] : cylinders)
        if (!filled(choose(first, std::min(last, first + kFirstRoundStarts)).across))
            for (std::size_t i = first + kFirstRoundStarts; i < last; ++i) which.push_back(i);
    if (!which.empty()) trace_openings(which);
    std::vector<Trajectory> out;
    for (const auto& [first, last] : cylinders) {
        const Choice c = choose(first, last);
        for (const Trajectory* t : filled(c.across) ? c.across : c.off)
            if (t) out.push_back(*t);
    }
    return out;
}

namespace {

// Where a curve's first segment goes from its start, in the form's image (in its first face's
// chart, chart_corner).
Complex first_step(const MeshView& mesh, const Eigen::VectorXcd& tau, const Trajectory& t) {
    const Index f = t.first_face;
    int from = 0;
    while (from < 3 && mesh.F(f, from) != t.start_vertex) ++from;
    if (from == 3) return 0;
    std::array<double, 3> b{};
    if (!t.crossings.empty()) {
        const Index h = t.crossings[0].halfedge;
        if (MeshView::face(h) != f) return 0;
        b[h % 3] = 1 - t.crossings[0].t;
        b[(h % 3 + 1) % 3] = t.crossings[0].t;
    } else if (t.end_vertex >= 0) {
        for (int k = 0; k < 3; ++k) b[k] = mesh.F(f, k) == t.end_vertex;
    } else if (t.end == Trajectory::End::Collision) {
        b = t.end_barycentric;
    } else {
        return 0;
    }
    const std::array<Complex, 3> along{form_along(mesh, tau, 3 * f), form_along(mesh, tau, 3 * f + 1),
                                       form_along(mesh, tau, 3 * f + 2)};
    Complex step = -chart_corner(along, 0, from);  // the barycentric weights sum to 1
    for (int k = 0; k < 3; ++k) step += b[k] * chart_corner(along, 0, k);
    return step;
}

}  // namespace

std::vector<Trajectory> corner_transversals(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                            std::span<const Index> zero_vertices,
                                            std::span<const Trajectory> trajectories, const CutMesh& cut,
                                            std::span<const char> border, const Patches& patches) {
    require_together(cut, border, patches);
    const MeshView& cm = cut.mesh;
    std::vector<char> is_zero(cm.n_vertices(), 0);
    for (Index z : zero_vertices)
        if (z >= 0 && z < cm.n_vertices()) is_zero[z] = 1;  // the cut keeps the traced vertex ids
    struct Candidate {
        double angle;
        Index vertex;
        Complex direction;
    };
    std::vector<Candidate> best(patches.info.size(), {0, -1, 0});
    const std::array<Complex, 4> axes{Complex(1, 0), Complex(0, 1), Complex(-1, 0), Complex(0, -1)};
    // uv from corner h to corner `to` of the same face
    const auto uv_from = [&](Index h, Index to) { return patches.corner_uv[to] - patches.corner_uv[h]; };
    // The uv angle of face(h) at the tail of h is atan2 of these (sine and cosine, scaled).
    const auto corner_sides = [&](Index h) {
        const Complex e1 = uv_from(h, MeshView::next(h)), e2 = uv_from(h, MeshView::prev(h));
        return std::pair{cross(e1, e2), (e1 * std::conj(e2)).real()};
    };
    const auto corner_angle = [&](Index h) {
        const auto [y, x] = corner_sides(h);
        return std::atan2(y, x);
    };
    std::vector<Index> sector;
    // Each border halfedge out of a vertex starts one sector of its patch there: the faces
    // from it around the vertex, inside the patch, to the next border edge. Where the border
    // passes straight the sector has 180 degrees, at a rectangle's corner 90; at an L's
    // concave corner 270, at the end of a slit 360.
    for (Index h0 = 0; h0 < cm.n_halfedges(); ++h0) {
        const Index v = cm.tail(h0), id = patches.face_patch[MeshView::face(h0)];
        const PatchInfo& info = patches.info[id];
        // Disks only (a cylinder is opened by cylinder_transversals), not folded ones (the
        // repair's), and the corner off the rectangle's sides.
        if (!on_border(cm, border, h0) || cut.original_vertex[v] < 0 || is_zero[v] ||
            info.type != PatchInfo::Type::Disk || info.flipped_uv_triangles > 0 ||
            !(rectangle_gap(info, patches.corner_uv[h0]) > kCornerGap))
            continue;
        sector.clear();
        double angle = 0;
        for (Index h = h0; h != kNoHalfedge && static_cast<Index>(sector.size()) < cm.n_faces();) {
            angle += corner_angle(h);
            sector.push_back(h);
            if (on_border(cm, border, MeshView::prev(h))) break;
            h = cm.rotate(h);
        }
        if (!(angle > kConcaveCorner) || (best[id].vertex >= 0 && !(angle > best[id].angle + kAxisTol))) continue;
        // The axis direction into the sector farthest from its two sides.
        const Complex first_side = uv_from(h0, MeshView::next(h0));
        const Complex last_side = uv_from(sector.back(), MeshView::prev(sector.back()));
        double widest = 0;
        Complex direction = 0;
        for (const Complex d : axes) {
            const bool inside = std::any_of(sector.begin(), sector.end(), [&](Index h) {
                const Complex e1 = uv_from(h, MeshView::next(h)), e2 = uv_from(h, MeshView::prev(h));
                return cross(e1, e2) > 0 && cross(e1, d) >= -kAxisTol * std::abs(e1) &&
                       cross(d, e2) >= -kAxisTol * std::abs(e2);
            });
            const double nearest = std::min(std::abs(std::arg(d / first_side)), std::abs(std::arg(d / last_side)));
            if (inside && nearest > widest + kAxisTol) widest = nearest, direction = d;
        }
        if (direction != Complex(0)) best[id] = {angle, v, direction};
    }
    // Branch points: inner vertices of a disk around which its uv turns twice or more (angles
    // summing above 3 pi), where a zero whose fan failed (traced from another vertex) sent no
    // curve. One takes its patch's turn before any corner; the patch's corners come after it is
    // split. A bound of each sum comes first, from a polynomial arctangent; only a vertex whose
    // bound passes 3 pi is summed exactly (in halfedge order, as always).
    std::vector<char> inner(cm.n_vertices(), 1);
    for (Index h = 0; h < cm.n_halfedges(); ++h)
        if (on_border(cm, border, h)) inner[cm.tail(h)] = inner[cm.head(h)] = 0;
    const auto in_disk = [&](Index h) {  // face(h) in a disk without flips
        const PatchInfo& info = patches.info[patches.face_patch[MeshView::face(h)]];
        return info.type == PatchInfo::Type::Disk && info.flipped_uv_triangles == 0;
    };
    // Each corner's bound first, in parallel; then their sums (adding the 0 of a corner that
    // does not count changes no sum).
    std::vector<double> corner_bound(cm.n_halfedges(), 0);
    par::for_each_range(static_cast<std::size_t>(cm.n_halfedges()), 3 * kParallelPatchFaces,
                        [&](std::size_t begin, std::size_t end) {
                            for (Index h = static_cast<Index>(begin); h < static_cast<Index>(end); ++h)
                                if (inner[cm.tail(h)] && in_disk(h)) {
                                    const auto [y, x] = corner_sides(h);
                                    corner_bound[h] = atan2_above(y, x);
                                }
                        });
    std::vector<double> bound(cm.n_vertices(), 0);  // no smaller than the exact sum
    for (Index h = 0; h < cm.n_halfedges(); ++h) bound[cm.tail(h)] += corner_bound[h];
    std::vector<Index> branch(patches.info.size(), -1);
    if (std::any_of(bound.begin(), bound.end(), [](double b) { return b > kBranchTurn; })) {
        std::vector<double> turn(cm.n_vertices(), 0);
        for (Index h = 0; h < cm.n_halfedges(); ++h)
            if (bound[cm.tail(h)] > kBranchTurn && in_disk(h)) turn[cm.tail(h)] += corner_angle(h);
        for (Index h = 0; h < cm.n_halfedges(); ++h) {
            const Index v = cm.tail(h), id = patches.face_patch[MeshView::face(h)];
            if (inner[v] && turn[v] > kBranchTurn && !is_zero[v] && cut.original_vertex[v] >= 0 &&
                (branch[id] < 0 || turn[v] > turn[branch[id]] + kAxisTol))
                branch[id] = v;
        }
    }
    std::vector<TransversalStart> starts;
    std::vector<const Candidate*> chosen;  // per start: the corner, or null for a branch point
    for (std::size_t id = 0; id < best.size(); ++id)
        if (branch[id] >= 0) {
            starts.push_back({cut.original_vertex[branch[id]], TrajectoryFamily::Vertical});
            chosen.push_back(nullptr);
        } else if (best[id].vertex >= 0) {
            const Candidate& c = best[id];
            starts.push_back({cut.original_vertex[c.vertex],
                              c.direction.real() == 0 ? TrajectoryFamily::Vertical : TrajectoryFamily::Horizontal});
            chosen.push_back(&c);
        }
    if (starts.empty()) return {};
    const std::vector<Trajectory> traced = trace_transversals(mesh, tau, zero_vertices, starts, trajectories);
    // A curve already among `trajectories` (its corner was not split by it) is not sent again.
    const auto is_new = [&](const Trajectory& c) {
        return std::none_of(trajectories.begin(), trajectories.end(), [&](const Trajectory& t) {
            return t.start_vertex == c.start_vertex && t.family == c.family && t.first_face == c.first_face;
        });
    };
    std::vector<Trajectory> out;
    for (std::size_t k = 0; k < chosen.size(); ++k)
        for (const Trajectory& t : traced) {
            if (t.start_vertex != starts[k].vertex || t.family != starts[k].family || !is_new(t)) continue;
            // A branch point sends all its curves; a corner the one along its direction.
            if (chosen[k] != nullptr) {
                const Complex step = first_step(mesh, tau, t);
                if (!((step * std::conj(chosen[k]->direction)).real() > kAxisTol * std::abs(step))) continue;
            }
            out.push_back(t);
            if (chosen[k] != nullptr) break;
        }
    return out;
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
