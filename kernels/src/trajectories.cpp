#include "holoflow/kernels/trajectories.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <tuple>

#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr double kLevelTol = 1e-9;        // a vertex this close to the level (relative) is on it
constexpr double kFirstRound = 1.0 / 32;  // first motorcycle round, in sqrt(image area)
constexpr std::size_t kSharedCrossings = 16;  // crossings of all curves together, per face
constexpr std::size_t kSharedClosedCrossings = 64;  // the same where every leaf closes

// Per-trace tracing state between rounds.
struct Walker {
    Index in = kNoHalfedge;  // halfedge of the current face we entered through
    double t_in = 0;         // entry point on `in`
    double d_tail = 0, d_head = 0;  // level offsets at in's tail and head
    bool done = false;
};

class Tracer {
 public:
    Tracer(const MeshView& mesh, const Eigen::VectorXcd& tau, std::span<const Index> zero_vertices,
           const TraceOptions& options)
        : mesh_(mesh), along_(forms_along(mesh, tau)), zero_(mesh.n_vertices(), 0), boundary_(mesh.n_vertices(), 0) {
        double area = 0;
        for (Index h = 0; h < mesh.n_halfedges(); ++h)
            if (mesh.twin[h] == kNoHalfedge) boundary_[mesh.tail(h)] = boundary_[mesh.head(h)] = 1;
        for (Index f = 0; f < mesh.n_faces(); ++f) {
            const Complex a = along_[3 * f], b = -along_[3 * f + 2];
            area += std::abs(cross(a, b)) / 2;
        }
        for (Index v : zero_vertices) zero_[v] = 1;
        unit_ = std::sqrt(area);
        n_faces_ = static_cast<std::size_t>(mesh.n_faces());
        cap_ = options.closed_leaves ? std::numeric_limits<double>::infinity() : options.length_cap * unit_;
        max_crossings_ = (options.closed_leaves ? 2 : 8) * n_faces_ + 64;
        shared_per_face_ = options.closed_leaves ? kSharedClosedCrossings : kSharedCrossings;
    }

    double unit() const { return unit_; }
    double cap() const { return cap_; }

    // The cut grows with every crossing: `curves` curves share 16 #F (64 #F with closed leaves)
    // + 64 per curve of them (generically dense vertical curves on a high-genus surface would
    // otherwise cut it into hundreds of faces per input face). Set before tracing, so it depends
    // on nothing else.
    void share_crossings(std::size_t curves) {
        if (curves > 0) max_crossings_ = std::min(max_crossings_, shared_per_face_ * n_faces_ / curves + 64);
    }

    double level(Complex z, TrajectoryFamily family) const {
        return family == TrajectoryFamily::Vertical ? z.real() : z.imag();
    }

    // Every direction leaving zero vertex v at its level, as started trajectories.
    void start(Index v, TrajectoryFamily family, std::vector<Trajectory>& out, std::vector<Walker>& walkers) const {
        Index h = mesh_.vertex_halfedge[v];
        if (h == kNoHalfedge) return;
        const Index first = h;
        do {
            const Index across = MeshView::next(h);
            const double db = level(along_[h], family), dc = -level(along_[MeshView::prev(h)], family);
            const double tol = kLevelTol * face_scale(MeshView::face(h));
            const bool along_boundary = (boundary_[mesh_.head(h)] && std::abs(db) <= tol) ||
                                        (boundary_[mesh_.head(across)] && std::abs(dc) <= tol);
            if ((db >= 0) != (dc >= 0) && !along_boundary) {
                Trajectory tr;
                tr.start_vertex = v;
                tr.first_face = MeshView::face(h);
                tr.family = family;
                const double t = db / (db - dc);
                tr.length = std::abs(level(along_[h] + t * along_[across], other(family)));
                Walker w;
                step_across(tr, w, across, t, db, dc);
                out.push_back(std::move(tr));
                walkers.push_back(w);
            } else if (std::abs(db) <= tol && boundary_[mesh_.head(h)] && mesh_.twin[h] != kNoHalfedge) {
                // The level runs along an inner edge to a boundary vertex (symmetric meshes): the
                // edge is the whole curve. Its other face sees it as its `dc` side and skips it.
                Trajectory tr;
                tr.start_vertex = v;
                tr.first_face = MeshView::face(h);
                tr.family = family;
                tr.end = Trajectory::End::Boundary;
                tr.end_vertex = mesh_.head(h);
                tr.length = std::abs(level(along_[h], other(family)));
                Walker w;
                w.done = true;
                out.push_back(std::move(tr));
                walkers.push_back(w);
            }
            h = mesh_.rotate(h);
        } while (h != kNoHalfedge && h != first);
    }

    // Advances one trajectory until its length reaches `until` or it ends.
    void advance(Trajectory& tr, Walker& w, double until) const {
        const TrajectoryFamily fam = tr.family;
        while (!w.done && tr.length < until) {
            const Index in = w.in, f = MeshView::face(in);
            const Index a = mesh_.tail(in), b = mesh_.head(in), c = mesh_.head(MeshView::next(in));
            const double da = w.d_tail, db = w.d_head, dc = db + level(along_[MeshView::next(in)], fam);
            const double tol = kLevelTol * face_scale(f);
            // A zero or boundary vertex on the level ends the curve there.
            for (const auto& [v, d] : {std::pair{c, dc}, std::pair{a, da}, std::pair{b, db}}) {
                if (std::abs(d) > tol || !(zero_[v] || boundary_[v])) continue;
                tr.end = zero_[v] ? Trajectory::End::Zero : Trajectory::End::Boundary;
                tr.end_vertex = v;
                const Complex entry = w.t_in * along_[in];
                const Complex target = v == a ? Complex(0) : v == b ? along_[in] : along_[in] + along_[MeshView::next(in)];
                tr.length += std::abs(level(target - entry, other(fam)));
                w.done = true;
                return;
            }
            Index exit;
            double dt, dh;
            if ((dc >= 0) == (da >= 0)) exit = MeshView::next(in), dt = db, dh = dc;
            else exit = MeshView::prev(in), dt = dc, dh = da;
            const double t = dt / (dt - dh);
            const Complex entry = w.t_in * along_[in];
            const Complex exit_base = exit == MeshView::next(in) ? along_[in] : along_[in] + along_[MeshView::next(in)];
            const Complex exit_point = exit_base + t * along_[exit];
            tr.length += std::abs(level(exit_point - entry, other(fam)));
            step_across(tr, w, exit, t, dt, dh);
        }
    }

    // Records the crossing of `exit` at t (tr.length already counts the way there; d_tail and
    // d_head are the level offsets at exit's ends) and enters the next face, or ends the curve
    // at the boundary or the cap.
    void step_across(Trajectory& tr, Walker& w, Index exit, double t, double d_tail, double d_head) const {
        tr.crossings.push_back({exit, t, tr.length});
        if (mesh_.twin[exit] == kNoHalfedge) {
            tr.end = Trajectory::End::Boundary;
            w.done = true;
        } else if (tr.length > cap_ || tr.crossings.size() > max_crossings_) {
            tr.end = Trajectory::End::LengthCap;
            w.done = true;
        } else {
            w.in = mesh_.twin[exit];  // entered from its tail, which is exit's head
            w.t_in = 1 - t;
            w.d_tail = d_head;
            w.d_head = d_tail;
        }
    }

    // Image of a point of face f in its chart (corner 0 at 0).
    Complex corner_image(Index f, int k) const {
        return chart_corner(along_, f, k);
    }
    Complex crossing_image(Index f, const EdgeCrossing& c) const {
        // c.halfedge lies in face f, or is the twin of one of f's halfedges.
        Index h = c.halfedge;
        double t = c.t;
        if (MeshView::face(h) != f) h = mesh_.twin[h], t = 1 - t;
        return corner_image(f, h % 3) + t * along_[h];
    }

    static TrajectoryFamily other(TrajectoryFamily f) {
        return f == TrajectoryFamily::Vertical ? TrajectoryFamily::Horizontal : TrajectoryFamily::Vertical;
    }

 private:
    double face_scale(Index f) const {
        return std::max({std::abs(along_[3 * f]), std::abs(along_[3 * f + 1]), std::abs(along_[3 * f + 2])});
    }

    const MeshView& mesh_;
    std::vector<Complex> along_;
    std::vector<char> zero_, boundary_;
    double unit_ = 0, cap_ = 0;
    std::size_t n_faces_ = 0, max_crossings_ = 0, shared_per_face_ = kSharedCrossings;
};

// One segment of a trajectory inside a face, in that face's chart, with arrival lengths.
struct Segment {
    Index trajectory, index, face;
    Complex from, to;
    double length_from;
    bool from_vertex, to_vertex;  // starts at its zero / ends at a vertex
};

// Segment j of trajectory `tr` (id i); a last segment ends at its vertex or collision point.
Segment trajectory_segment(const MeshView& mesh, const Tracer& tracer, const Trajectory& tr, Index i, Index j) {
    const auto corner_of = [&](Index f, Index v) {
        for (int k = 0; k < 3; ++k)
            if (mesh.F(f, k) == v) return k;
        return 0;
    };
    const Index f = tr.segment_face(mesh, j);
    Segment s{i, j, f, {}, {}, 0, j == 0, false};
    s.from = j == 0 ? tracer.corner_image(f, corner_of(f, tr.start_vertex)) : tracer.crossing_image(f, tr.crossings[j - 1]);
    s.length_from = j == 0 ? 0 : tr.crossings[j - 1].length;
    if (j < static_cast<Index>(tr.crossings.size())) {
        s.to = tracer.crossing_image(f, tr.crossings[j]);
    } else if (tr.end == Trajectory::End::Collision) {
        const auto& b = tr.end_barycentric;
        s.to = b[1] * tracer.corner_image(f, 1) + b[2] * tracer.corner_image(f, 2);
    } else {
        s.to = tracer.corner_image(f, corner_of(f, tr.end_vertex));
        s.to_vertex = true;
    }
    return s;
}

// Where segment p (of family `p_family`) meets segment q of the other family in their face, with
// the length each curve has travelled to get there.
struct Meeting {
    Complex point;
    double at_p, at_q;
};
std::optional<Meeting> meet(const Segment& p, const Segment& q, TrajectoryFamily p_family) {
    const bool p_vertical = p_family == TrajectoryFamily::Vertical;
    const Segment& vert = p_vertical ? p : q;
    const Segment& horz = p_vertical ? q : p;
    const double eps = 1e-12 * (std::abs(vert.to - vert.from) + std::abs(horz.to - horz.from) + std::abs(vert.from) +
                                std::abs(horz.from));
    const double u = vert.from.real(), v = horz.from.imag();
    if (v < std::min(vert.from.imag(), vert.to.imag()) - eps || v > std::max(vert.from.imag(), vert.to.imag()) + eps ||
        u < std::min(horz.from.real(), horz.to.real()) - eps || u > std::max(horz.from.real(), horz.to.real()) + eps)
        return std::nullopt;
    const Complex point(u, v);
    // Meeting at a zero (a shared start, or an end at a vertex) is not a collision.
    for (const Segment* s : {&vert, &horz})
        if ((s->from_vertex && std::abs(point - s->from) <= eps) || (s->to_vertex && std::abs(point - s->to) <= eps))
            return std::nullopt;
    const double at_vert = vert.length_from + std::abs(v - vert.from.imag());
    const double at_horz = horz.length_from + std::abs(u - horz.from.real());
    return Meeting{point, p_vertical ? at_vert : at_horz, p_vertical ? at_horz : at_vert};
}

// Ends `tr` in its segment `segment` (face `face`) at `point`, reached at `length`, on segment
// `blocker_segment` of trajectory `blocker`, which got there at `blocker_length`.
void end_at_collision(const Tracer& tracer, Trajectory& tr, Index segment, double length, Index blocker,
                      Index blocker_segment, double blocker_length, Index face, Complex point) {
    tr.crossings.resize(segment);
    tr.end = Trajectory::End::Collision;
    tr.end_vertex = -1;
    tr.blocker = blocker;
    tr.blocker_segment = blocker_segment;
    tr.blocker_length = blocker_length;
    tr.length = length;
    const Complex c1 = tracer.corner_image(face, 1), c2 = tracer.corner_image(face, 2);
    const double area = cross(c1, c2);
    const double b1 = cross(point, c2) / area, b2 = cross(c1, point) / area;
    tr.end_barycentric = {1 - b1 - b2, b1, b2};
}

struct Event {
    double late, early;
    Index stopped, blocker, stopped_segment, blocker_segment, face;
    Complex point;
    bool operator<(const Event& o) const {
        return std::tie(late, early, stopped, blocker, face) < std::tie(o.late, o.early, o.stopped, o.blocker, o.face);
    }
};

// Crossing y is crossing x passed the other way (x's edge from the face beyond it, at the same place).
bool reverse_crossing(const MeshView& mesh, const EdgeCrossing& x, const EdgeCrossing& y) {
    return mesh.twin[x.halfedge] == y.halfedge && std::abs(x.t - (1 - y.t)) <= 1e-6;
}

// `b` runs back along `a` (same family, from a's end, the same edges crossed in opposite order
// at the same places): all of it (b ends at a's start), or a first part when b was stopped by
// a collision or the cap. Level curves of one family never cross, so such a b is the same curve.
bool retraces(const MeshView& mesh, const Trajectory& a, const Trajectory& b) {
    if (a.family != b.family || a.end != Trajectory::End::Zero || b.start_vertex != a.end_vertex) return false;
    const std::size_t n = a.crossings.size(), m = b.crossings.size();
    if (b.end == Trajectory::End::Zero) {
        if (b.end_vertex != a.start_vertex || m != n) return false;
    } else if ((b.end != Trajectory::End::Collision && b.end != Trajectory::End::LengthCap) || m > n) {
        return false;
    }
    if (m == 0) return b.first_face == a.segment_face(mesh, a.n_segments() - 1);
    for (std::size_t j = 0; j < m; ++j) {
        if (!reverse_crossing(mesh, a.crossings[n - 1 - j], b.crossings[j])) return false;
    }
    return true;
}

// A saddle connection (or a closed critical loop) is traced once from each end: the later
// copy goes. A copy stopped early by a collision goes too, whichever came first: cut in as
// well, its crossings would sit a rounding error away from the whole curve's, and two chords
// that close cannot be split apart (the cutter's pieces would overlap). Curves that stopped on
// a dropped copy stop on the kept curve (its segments in reverse).
void drop_reversed_duplicates(const MeshView& mesh, std::vector<Trajectory>& out) {
    const Index n = static_cast<Index>(out.size());
    std::vector<Index> copy_of(n, -1);
    for (Index j = 0; j < n; ++j) {
        if (out[j].end != Trajectory::End::Zero) continue;
        for (Index i = 0; i < j && copy_of[j] < 0; ++i)
            if (copy_of[i] < 0 && retraces(mesh, out[i], out[j])) copy_of[j] = i;
    }
    for (Index j = 0; j < n; ++j) {
        if (out[j].end != Trajectory::End::Collision && out[j].end != Trajectory::End::LengthCap) continue;
        for (Index i = 0; i < n && copy_of[j] < 0; ++i)
            if (copy_of[i] < 0 && retraces(mesh, out[i], out[j])) copy_of[j] = i;
    }
    std::vector<Index> new_id(n, -1);
    Index kept = 0;
    for (Index j = 0; j < n; ++j)
        if (copy_of[j] < 0) new_id[j] = kept++;
    if (kept == n) return;
    for (Trajectory& t : out) {
        if (t.end != Trajectory::End::Collision) continue;
        const Index b = t.blocker;
        if (copy_of[b] >= 0) {
            const Trajectory& whole = out[copy_of[b]];
            t.blocker_segment = whole.n_segments() - 1 - t.blocker_segment;
            t.blocker_length = whole.length - t.blocker_length;
            t.blocker = copy_of[b];
        }
        t.blocker = new_id[t.blocker];
    }
    for (Index j = 0; j < n; ++j)
        if (new_id[j] >= 0 && new_id[j] != j) out[new_id[j]] = std::move(out[j]);
    out.resize(kept);
}

// A saddle connection (or a closed critical loop) longer than a curve's crossing budget is
// stopped at the cap from both of its zeros. Where the two stopped halves overlap they are one
// curve: the earlier is completed by the later run backwards to its zero (the later then
// retraces it and drop_reversed_duplicates drops it). Overlap is mutual, so looking up each
// curve's last crossing among the earlier curves' crossings finds every pair.
void join_overlapping_halves(const MeshView& mesh, std::vector<Trajectory>& out) {
    struct Passage {
        Index halfedge, trajectory, index;
        bool operator<(const Passage& o) const {
            return std::tie(halfedge, trajectory, index) < std::tie(o.halfedge, o.trajectory, o.index);
        }
    };
    const Index n = static_cast<Index>(out.size());
    std::vector<Passage> passages;
    for (Index i = 0; i < n; ++i)
        if (out[i].end == Trajectory::End::LengthCap)
            for (Index k = 0; k < static_cast<Index>(out[i].crossings.size()); ++k)
                passages.push_back({out[i].crossings[k].halfedge, i, k});
    if (passages.empty()) return;
    std::sort(passages.begin(), passages.end());
    for (Index j = 0; j < n; ++j) {
        const Trajectory& b = out[j];
        if (b.end != Trajectory::End::LengthCap || b.crossings.empty()) continue;
        const std::size_t m = b.crossings.size();
        const EdgeCrossing& last = b.crossings.back();
        const Index h = mesh.twin[last.halfedge];
        for (auto it = std::lower_bound(passages.begin(), passages.end(), Passage{h, 0, 0});
             it != passages.end() && it->halfedge == h && it->trajectory < j; ++it) {
            Trajectory& a = out[it->trajectory];
            const std::size_t p = static_cast<std::size_t>(it->index);
            if (a.end != Trajectory::End::LengthCap || a.family != b.family) continue;
            // a from crossing p on must run back along b, and end inside it (a stops at b's zero).
            const std::size_t rest = a.crossings.size() - p;
            bool overlap = rest <= m;
            for (std::size_t q = 0; q < rest && overlap; ++q)
                overlap = reverse_crossing(mesh, b.crossings[m - 1 - q], a.crossings[p + q]);
            if (!overlap) continue;
            const double at_p = a.crossings[p].length;
            a.crossings.resize(p);
            for (std::size_t q = 0; q < m; ++q) {
                const EdgeCrossing& x = b.crossings[m - 1 - q];
                a.crossings.push_back({mesh.twin[x.halfedge], 1 - x.t, at_p + (last.length - x.length)});
            }
            a.length = at_p + last.length;
            a.end = Trajectory::End::Zero;
            a.end_vertex = b.start_vertex;
            break;
        }
    }
}

}  // namespace

Index Trajectory::segment_face(const MeshView& mesh, Index j) const {
    if (j < static_cast<Index>(crossings.size())) return MeshView::face(crossings[j].halfedge);
    return crossings.empty() ? first_face : MeshView::face(mesh.twin[crossings.back().halfedge]);
}

std::vector<Trajectory> trace_trajectories(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                           std::span<const Index> zero_vertices,
                                           std::span<const TrajectoryFamily> families,
                                           const TraceOptions& options) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    for (Index v : zero_vertices) HOLOFLOW_REQUIRE(v >= 0 && v < mesh.n_vertices(), "zero vertex out of range");
    Tracer tracer(mesh, tau, zero_vertices, options);
    std::vector<Trajectory> out;
    std::vector<Walker> walkers;
    // A vertex listed twice (zeros the fans merged into one centre) starts its curves once.
    std::vector<char> started(mesh.n_vertices(), 0);
    for (Index v : zero_vertices) {
        if (started[v]) continue;
        started[v] = 1;
        for (TrajectoryFamily fam : families) tracer.start(v, fam, out, walkers);
    }
    const Index n = static_cast<Index>(out.size());
    if (!(tracer.unit() > 0)) return out;
    tracer.share_crossings(out.size());

    if (!options.motorcycle) {
        par::for_each_index(out.size(), true, [&](std::size_t i) { tracer.advance(out[i], walkers[i], tracer.cap() * 2); });
        join_overlapping_halves(mesh, out);
        drop_reversed_duplicates(mesh, out);
        return out;
    }

    // Motorcycle rounds: everything advances to length T, then collisions up to T are decided in
    // order of the later arrival; the others wait for a later round.
    std::vector<std::vector<Segment>> bucket(mesh.n_faces());
    std::vector<Event> pending;
    std::vector<double> stop(n, std::numeric_limits<double>::infinity());
    std::vector<Index> next_segment(n, 0);
    const auto intersect = [&](const Segment& p, const Segment& q, std::vector<Event>& events) {
        const std::optional<Meeting> m = meet(p, q, out[p.trajectory].family);
        if (!m) return;
        const bool p_later = m->at_p > m->at_q || (m->at_p == m->at_q && p.trajectory > q.trajectory);
        const Segment& late = p_later ? p : q;
        const Segment& early = p_later ? q : p;
        events.push_back({std::max(m->at_p, m->at_q), std::min(m->at_p, m->at_q), late.trajectory, early.trajectory,
                          late.index, early.index, late.face, m->point});
    };
    const auto decide = [&](double until) {
        std::sort(pending.begin(), pending.end());
        std::vector<Event> later;
        for (const Event& e : pending) {
            if (e.late > until) {
                later.push_back(e);
                continue;
            }
            if (!(stop[e.stopped] > e.late) || !(stop[e.blocker] > e.early)) continue;
            Trajectory& tr = out[e.stopped];
            if (e.late > tr.length) continue;  // ended (zero, boundary) before getting there
            stop[e.stopped] = e.late;
            end_at_collision(tracer, tr, e.stopped_segment, e.late, e.blocker, e.blocker_segment, e.early, e.face,
                             e.point);
            walkers[e.stopped].done = true;
        }
        pending.swap(later);
    };
    for (double T = kFirstRound * tracer.unit();; T *= 2) {
        const double until = std::min(T, tracer.cap() * 2);
        par::for_each_index(out.size(), true, [&](std::size_t i) {
            if (stop[i] == std::numeric_limits<double>::infinity()) tracer.advance(out[i], walkers[i], until);
        });
        for (Index i = 0; i < n; ++i) {
            if (stop[i] < std::numeric_limits<double>::infinity()) continue;
            const Index segments = out[i].n_segments();
            for (Index j = next_segment[i]; j < segments; ++j) {
                const Segment s = trajectory_segment(mesh, tracer, out[i], i, j);
                for (const Segment& q : bucket[s.face])
                    if (out[q.trajectory].family != out[i].family) intersect(s, q, pending);
                bucket[s.face].push_back(s);
            }
            next_segment[i] = segments;
        }
        bool all_done = true;
        for (Index i = 0; i < n; ++i) all_done = all_done && walkers[i].done;
        const bool last = all_done || until >= tracer.cap() * 2;
        decide(last ? std::numeric_limits<double>::infinity() : until);
        if (last) break;
    }
    join_overlapping_halves(mesh, out);
    drop_reversed_duplicates(mesh, out);
    return out;
}

std::vector<Trajectory> trace_transversals(const MeshView& mesh, const Eigen::VectorXcd& tau,
                                           std::span<const Index> zero_vertices,
                                           std::span<const TransversalStart> starts,
                                           std::span<const Trajectory> earlier, const TraceOptions& options) {
    HOLOFLOW_REQUIRE(tau.size() == mesh.n_edges(), "form must have one value per edge");
    for (Index v : zero_vertices) HOLOFLOW_REQUIRE(v >= 0 && v < mesh.n_vertices(), "zero vertex out of range");
    for (const TransversalStart& s : starts)
        HOLOFLOW_REQUIRE(s.vertex >= 0 && s.vertex < mesh.n_vertices(), "transversal start out of range");
    const Tracer tracer(mesh, tau, zero_vertices, options);
    std::vector<Trajectory> out;
    std::vector<Walker> walkers;
    for (const TransversalStart& s : starts) tracer.start(s.vertex, s.family, out, walkers);
    if (!(tracer.unit() > 0)) return {};

    // The earlier curves' segments, by face.
    std::vector<std::vector<Segment>> bucket(mesh.n_faces());
    for (Index i = 0; i < static_cast<Index>(earlier.size()); ++i)
        for (Index j = 0; j < earlier[i].n_segments(); ++j) {
            const Segment s = trajectory_segment(mesh, tracer, earlier[i], i, j);
            bucket[s.face].push_back(s);
        }
    // Each new curve stops at its first meeting with an earlier one of the other family. It
    // advances in rounds of doubling length, so nothing is traced far past that meeting.
    std::vector<Index> next_segment(out.size(), 0);
    const auto advance_and_stop = [&](std::size_t k, double until) {
        Trajectory& tr = out[k];
        tracer.advance(tr, walkers[k], until);
        const Index segments = tr.n_segments();
        for (Index j = next_segment[k]; j < segments; ++j) {
            const Segment s = trajectory_segment(mesh, tracer, tr, static_cast<Index>(k), j);
            std::optional<Meeting> first;
            const Segment* blocker = nullptr;
            for (const Segment& q : bucket[s.face]) {
                if (earlier[q.trajectory].family == tr.family) continue;
                const std::optional<Meeting> m = meet(s, q, tr.family);
                if (m && (!first || std::tie(m->at_p, q.trajectory) < std::tie(first->at_p, blocker->trajectory)))
                    first = m, blocker = &q;
            }
            if (first) {
                end_at_collision(tracer, tr, j, first->at_p, blocker->trajectory, blocker->index, first->at_q, s.face,
                                 first->point);
                walkers[k].done = true;
                break;
            }
        }
        next_segment[k] = tr.n_segments();
    };
    for (double T = kFirstRound * tracer.unit();; T *= 2) {
        const double until = std::min(T, tracer.cap() * 2);
        par::for_each_index(out.size(), true, [&](std::size_t k) {
            // (A curve can end in its first step, at the boundary: its segment is checked too.)
            if (!walkers[k].done || next_segment[k] < out[k].n_segments()) advance_and_stop(k, until);
        });
        if (until >= tracer.cap() * 2 ||
            std::all_of(walkers.begin(), walkers.end(), [](const Walker& w) { return w.done; }))
            break;
    }
    // A start is kept with all its curves or not at all: a slit from one side opens nothing.
    std::vector<char> unfinished(mesh.n_vertices(), 0);
    for (const Trajectory& tr : out)
        if (tr.end == Trajectory::End::LengthCap) unfinished[tr.start_vertex] = 1;
    std::vector<Trajectory> kept;
    for (Trajectory& tr : out)
        if (!unfinished[tr.start_vertex]) kept.push_back(std::move(tr));
    return kept;
}

}  // namespace holoflow::kernels
