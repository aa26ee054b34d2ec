#include "holoflow/kernels/trajectories.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <functional>

#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/flow_cut.h"
#include "holoflow/kernels/patches.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/zero_fans.h"
#include "support/plane_zeros.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
using test::turned_grid;

// The grid with the simple zeros of f (at the given points) regularised into fan centres.
struct Regularised {
    RegularisedForm form;
    std::vector<Index> zeros;
};

Regularised regularise(const MeshView& m, const std::function<Complex(Complex)>& f, const std::vector<Complex>& at) {
    std::vector<Complex> values(m.n_vertices());
    for (Index v = 0; v < m.n_vertices(); ++v) values[v] = f(test::point(m, v));
    std::vector<ZeroRegion> regions;
    for (Complex z : at) regions.push_back(test::face_zero(m, z, 1, f));
    Regularised out{regularise_zeros(m, test::form_of(m, values), regions), {}};
    for (Index v : out.form.region_vertex) out.zeros.push_back(v);
    return out;
}

Index count(const std::vector<Trajectory>& ts, TrajectoryFamily family) {
    Index n = 0;
    for (const Trajectory& t : ts) n += t.family == family;
    return n;
}

const std::vector<TrajectoryFamily> kBoth{TrajectoryFamily::Vertical, TrajectoryFamily::Horizontal};

// z^2: a simple zero, so 2 (k + 1) = 4 curves of each family, all reaching the boundary.
TEST(Trajectories, SimpleZeroSendsFourCurvesOfEachFamily) {
    const Complex zero(0.013, -0.021);
    const Regularised r = regularise(turned_grid(14), [&](Complex z) { return (z - zero) * (z - zero); }, {zero});
    ASSERT_EQ(r.form.failed_regions, 0);
    const std::vector<Trajectory> ts = trace_trajectories(r.form.mesh, r.form.tau, r.zeros, kBoth);
    EXPECT_EQ(count(ts, TrajectoryFamily::Vertical), 4);
    EXPECT_EQ(count(ts, TrajectoryFamily::Horizontal), 4);
    for (const Trajectory& t : ts) EXPECT_EQ(t.end, Trajectory::End::Boundary);
}

// A zero listed twice (zeros the fans merged into one centre) starts its curves once.
TEST(Trajectories, ZeroListedTwiceStartsOnce) {
    const Complex zero(0.013, -0.021);
    const Regularised r = regularise(turned_grid(14), [&](Complex z) { return (z - zero) * (z - zero); }, {zero});
    ASSERT_EQ(r.form.failed_regions, 0);
    const std::vector<Index> twice{r.zeros[0], r.zeros[0]};
    for (bool motorcycle : {false, true}) {
        TraceOptions options;
        options.motorcycle = motorcycle;
        const auto once = trace_trajectories(r.form.mesh, r.form.tau, r.zeros, kBoth, options);
        const auto again = trace_trajectories(r.form.mesh, r.form.tau, twice, kBoth, options);
        ASSERT_EQ(once.size(), again.size());
        for (std::size_t i = 0; i < once.size(); ++i) EXPECT_EQ(once[i].crossings.size(), again[i].crossings.size());
    }
}

// f = z^3 / 3 - z: simple zeros at -1 and 1 on the level v = 0, so one horizontal curve joins
// them (a saddle connection). It is traced from both ends but kept once.
TEST(Trajectories, SaddleConnectionIsKeptOnce) {
    const auto f = [](Complex z) { return z * z * z / 3.0 - z; };
    const Regularised r = regularise(turned_grid(24), f, {Complex(-1, 0), Complex(1, 0)});
    ASSERT_EQ(r.form.failed_regions, 0);
    for (bool motorcycle : {false, true}) {
        SCOPED_TRACE(motorcycle);
        TraceOptions options;
        options.motorcycle = motorcycle;
        const auto ts = trace_trajectories(r.form.mesh, r.form.tau, r.zeros, kBoth, options);
        Index connections = 0;
        for (const Trajectory& t : ts)
            if (t.end == Trajectory::End::Zero) {
                ++connections;
                EXPECT_EQ(t.family, TrajectoryFamily::Horizontal);
                EXPECT_NE(t.start_vertex, t.end_vertex);
            }
        EXPECT_EQ(connections, 1);
        if (!motorcycle) {
            EXPECT_EQ(count(ts, TrajectoryFamily::Vertical), 8);
            EXPECT_EQ(count(ts, TrajectoryFamily::Horizontal), 7);
        }
        for (const Trajectory& t : ts)
            if (t.end == Trajectory::End::Collision) {
                ASSERT_GE(t.blocker, 0);
                ASSERT_LT(t.blocker, static_cast<Index>(ts.size()));
                EXPECT_LT(t.blocker_segment, ts[t.blocker].n_segments());
            }
    }
}

// homer (and oblong-shuffled) once failed in the cut stage with "non-manifold edge (a, b): 4
// faces share it": a critical curve traced from both of its zeros where one copy was stopped
// by a collision on the way. On f' = (z^2 - 1)((z - 0.3)^2 + 0.81) the real segment between -1
// and 1 is a horizontal saddle connection; the copy from 1 passes x ~ 0.44 first, the vertical
// curves from 0.3 +- 0.9i stop on it there, and the copy from -1 later stops on their ends.
// That partial copy runs a rounding error away from the whole one, its chords cannot be split
// apart from the whole one's, and the cutter then clipped collinear "triangles" in both faces
// along an edge. It must go like a whole copy, and the cut mesh must be manifold with every
// image triangle counter-clockwise.
TEST(Trajectories, CopyStoppedOnTheWayIsDropped) {
    // f'(z) = (z^2 - 1)(z - p)(z - q) with p q real, so that v = Im f takes one value at -1 and
    // 1 (the integral of f' over [-1, 1] is -4/15 - 4/3 p q); p and q are no mirror images, so
    // their curves reach the connection at different times. Shifted: no vertex on the curves.
    const Complex p(0.3, 0.9), q = 1.2 * std::conj(p), sum = p + q, product = p * q, shift(0.037, 0.023);
    const auto f = [=](Complex z) {
        z -= shift;
        const Complex z2 = z * z;
        return z2 * z2 * z / 5.0 - sum * z2 * z2 / 4.0 + (product - 1.0) * z2 * z / 3.0 + sum * z2 / 2.0 - product * z;
    };
    const Regularised r =
        regularise(turned_grid(24), f, {Complex(-1, 0) + shift, Complex(1, 0) + shift, p + shift, q + shift});
    ASSERT_EQ(r.form.failed_regions, 0);
    TraceOptions options;
    options.motorcycle = true;
    const auto ts = trace_trajectories(r.form.mesh, r.form.tau, r.zeros, kBoth, options);
    // The connection is kept once, whole; no horizontal curve from an end of it runs back
    // along its first crossing.
    Index connections = 0;
    for (const Trajectory& t : ts)
        if (t.end == Trajectory::End::Zero && t.family == TrajectoryFamily::Horizontal) {
            ++connections;
            ASSERT_FALSE(t.crossings.empty());
            for (const Trajectory& u : ts) {
                if (&u == &t || u.family != t.family || u.start_vertex != t.end_vertex || u.crossings.empty()) continue;
                EXPECT_NE(u.crossings.front().halfedge, r.form.mesh.twin[t.crossings.back().halfedge]);
            }
        }
    EXPECT_EQ(connections, 1);
    Index stopped = 0;  // the vertical curves from 0.3 +- 0.9i that end on the connection
    for (const Trajectory& t : ts) stopped += t.end == Trajectory::End::Collision && t.family == TrajectoryFamily::Vertical;
    EXPECT_GE(stopped, 2);
    const CutMesh cut = cut_along_trajectories(r.form.mesh, r.form.tau, ts);  // threw before
    EXPECT_EQ(cut.skipped_segments, 0);
    for (Index g = 0; g < cut.mesh.n_faces(); ++g) {
        const Complex a = form_along(cut.mesh, cut.tau, 3 * g), b = -form_along(cut.mesh, cut.tau, 3 * g + 2);
        EXPECT_GT(cross(a, b), 0) << "face " << g;
    }
}

// f = (z - c)^2: from a vertex p with w = p - c in the first quadrant, the vertical transversal
// u = Re w^2 runs down onto the horizontal critical trajectory Im w = 0 (stopping there at
// w = sqrt(Re w^2)) and up to the boundary. It stops no earlier curve, and cutting along all
// of them splits one of the eight sectors in two.
TEST(Trajectories, TransversalStopsOnTheFirstCurveOfTheOtherFamily) {
    const Complex zero(0.013, -0.021);
    const Regularised r = regularise(turned_grid(14), [&](Complex z) { return (z - zero) * (z - zero); }, {zero});
    ASSERT_EQ(r.form.failed_regions, 0);
    TraceOptions options;
    options.motorcycle = true;
    const std::vector<Trajectory> ts = trace_trajectories(r.form.mesh, r.form.tau, r.zeros, kBoth, options);
    ASSERT_EQ(ts.size(), 8u);
    const MeshView& m = r.form.mesh;
    Index p = 0;
    for (Index v = 1; v < m.n_vertices(); ++v)
        if (std::abs(test::point(m, v) - zero - Complex(0.6, 0.25)) < std::abs(test::point(m, p) - zero - Complex(0.6, 0.25)))
            p = v;
    const Complex w = test::point(m, p) - zero;
    const std::vector<TransversalStart> starts{{p, TrajectoryFamily::Vertical}};
    const std::vector<Trajectory> cross_cut = trace_transversals(m, r.form.tau, r.zeros, starts, ts);
    ASSERT_EQ(cross_cut.size(), 2u);
    Index collisions = 0, boundary = 0;
    for (const Trajectory& t : cross_cut) {
        EXPECT_EQ(t.start_vertex, p);
        EXPECT_EQ(t.family, TrajectoryFamily::Vertical);
        if (t.end == Trajectory::End::Boundary) ++boundary;
        if (t.end != Trajectory::End::Collision) continue;
        ++collisions;
        ASSERT_GE(t.blocker, 0);
        ASSERT_LT(t.blocker, static_cast<Index>(ts.size()));
        EXPECT_EQ(ts[t.blocker].family, TrajectoryFamily::Horizontal);
        EXPECT_LT(t.blocker_segment, ts[t.blocker].n_segments());
        const Index f = t.segment_face(m, t.n_segments() - 1);
        Complex at = 0;
        for (int k = 0; k < 3; ++k) at += t.end_barycentric[k] * test::point(m, m.F(f, k));
        EXPECT_NEAR(std::abs(at - zero - std::sqrt((w * w).real())), 0, 0.02);  // PL level curves: ~0.01 here
    }
    EXPECT_EQ(collisions, 1);
    EXPECT_EQ(boundary, 1);

    std::vector<Trajectory> all = ts;
    all.insert(all.end(), cross_cut.begin(), cross_cut.end());
    const CutMesh cut = cut_along_trajectories(m, r.form.tau, all);
    EXPECT_EQ(cut.skipped_segments, 0);
    std::vector<char> border(cut.mesh.n_edges(), 0);
    for (Index e = 0; e < cut.mesh.n_edges(); ++e) border[e] = cut.edge_trajectory[e] != kNoBorder;
    const Patches patches = compute_patches(cut.mesh, cut.tau, border);
    EXPECT_EQ(patches.info.size(), 9u);
    for (const PatchInfo& info : patches.info) {
        EXPECT_EQ(info.type, PatchInfo::Type::Disk);
        EXPECT_EQ(info.flipped_uv_triangles, 0);
    }
}

// The form (du, dv) = ((di + slope dj) / 24, height dj / 24) on a 24 x 12 torus (vertex
// i * 12 + j), plus the exact form of `bump` sin(1.7 v): with a bump no two vertices share a
// level by symmetry (a vertex exactly on a level is passed on one side by rounding, the other
// side when traced the other way). Its periods are 1 and 12 slope / 24: for a rational slope
// every vertical leaf closes.
struct SlopedTorus {
    static constexpr int kAround = 24, kAcross = 12;
    MeshView mesh = shapes::torus(3, 1, kAround, kAcross);
    Eigen::VectorXcd tau;
    SlopedTorus(double slope, double height, double bump) : tau(mesh.n_edges()) {
        const auto wrapped = [](Index from, Index to, int n) {  // -1, 0 or 1 step around
            Index d = (to - from + n) % n;
            return static_cast<double>(d > n / 2 ? d - n : d);
        };
        const auto f = [bump](Index v) { return bump * std::sin(1.7 * static_cast<double>(v)); };
        for (Index e = 0; e < mesh.n_edges(); ++e) {
            const Index a = mesh.E(e, 0), b = mesh.E(e, 1);
            const double di = wrapped(a / kAcross, b / kAcross, kAround), dj = wrapped(a % kAcross, b % kAcross, kAcross);
            tau(e) = Complex(di + slope * dj + f(b) - f(a), height * dj) / Complex(kAround, 0);
        }
    }
};

// A form on a torus whose vertical curves have an irrational slope: they never close and run
// to the cap. All curves together share 16 crossings per face (plus 64 each), so the cut stays
// a few times the mesh (dense curves on high-genus meshes cut it into millions of faces).
TEST(Trajectories, DenseCurvesShareACrossingBudget) {
    const SlopedTorus torus((std::sqrt(5.0) - 1) / 2, 1, 0);
    const MeshView& m = torus.mesh;
    std::vector<Index> starts;
    for (Index v = 0; v < m.n_vertices(); v += 29) starts.push_back(v);
    const std::vector<TrajectoryFamily> vertical{TrajectoryFamily::Vertical};
    const std::vector<Trajectory> ts = trace_trajectories(m, torus.tau, starts, vertical);
    ASSERT_EQ(ts.size(), 2 * starts.size());
    const std::size_t share = 16 * static_cast<std::size_t>(m.n_faces()) / ts.size() + 64;
    for (const Trajectory& t : ts) {
        EXPECT_EQ(t.end, Trajectory::End::LengthCap);
        EXPECT_LE(t.crossings.size(), share + 1);
    }
}

// With many starts a curve's share of crossings is less than its loop, so both copies of a
// loop (traced from its start each way) run into the cap; where they overlap they are one
// loop, joined whole and kept once (two overlapping copies broke the cutter).
TEST(Trajectories, CappedHalvesOfALoopAreJoined) {
    const SlopedTorus torus(0.25, 1, 1e-4);  // loops of 8 turns around the tube
    std::vector<Index> starts;
    for (Index k = 0; k < 45; ++k) starts.push_back((k % SlopedTorus::kAround) * SlopedTorus::kAcross + k / 9);
    const std::vector<TrajectoryFamily> vertical{TrajectoryFamily::Vertical};
    const std::vector<Trajectory> ts = trace_trajectories(torus.mesh, torus.tau, starts, vertical);
    const std::size_t share = 16 * static_cast<std::size_t>(torus.mesh.n_faces()) / (2 * starts.size()) + 64;
    Index joined = 0;
    for (const Trajectory& t : ts) {
        EXPECT_EQ(t.end, Trajectory::End::Zero);
        joined += t.crossings.size() > share;
    }
    EXPECT_GT(joined, 0);  // loops longer than a curve's share were traced whole
    const CutMesh cut = cut_along_trajectories(torus.mesh, torus.tau, ts, {});
    EXPECT_EQ(cut.skipped_segments, 0);
}

// Closed leaves (integer periods): no length cap, each curve may cross every face twice.
TEST(Trajectories, ClosedLeavesHaveNoLengthCap) {
    const SlopedTorus torus(1.0 / 12, 0.01, 1e-4);  // loops of 24 turns around a thin image
    const std::vector<Index> starts{1};
    const std::vector<TrajectoryFamily> vertical{TrajectoryFamily::Vertical};
    TraceOptions capped;
    capped.length_cap = 0.5;
    EXPECT_EQ(trace_trajectories(torus.mesh, torus.tau, starts, vertical, capped).front().end,
              Trajectory::End::LengthCap);
    TraceOptions closed = capped;
    closed.closed_leaves = true;
    const std::vector<Trajectory> ts = trace_trajectories(torus.mesh, torus.tau, starts, vertical, closed);
    ASSERT_EQ(ts.size(), 1u);  // the loop through the start, once
    EXPECT_EQ(ts[0].end, Trajectory::End::Zero);
    EXPECT_EQ(ts[0].end_vertex, 1);
    EXPECT_GT(ts[0].crossings.size(), static_cast<std::size_t>(torus.mesh.n_faces()) / 2);
}

// lion's zero on a closed critical loop: the loop is traced in both directions from its zero,
// and only one copy may stay (two copies cut a sliver patch and a segment the cutter skips).
TEST(Trajectories, ClosedLoopsAreNotDoubledOnTheCorpus) {
    for (const char* name : {"lion", "head"}) {
        SCOPED_TRACE(name);
        const engine::SegmentationResult r = engine::segment(*test::corpus_mesh(name));
        const auto& ts = r.trajectories;
        for (std::size_t i = 0; i < ts.size(); ++i)
            for (std::size_t j = i + 1; j < ts.size(); ++j) {
                const Trajectory &a = ts[i], &b = ts[j];
                const bool reversed = a.family == b.family && a.end == Trajectory::End::Zero &&
                                      b.end == Trajectory::End::Zero && a.start_vertex == b.end_vertex &&
                                      a.end_vertex == b.start_vertex && a.crossings.size() == b.crossings.size() &&
                                      !a.crossings.empty() &&
                                      r.regular.mesh.twin[a.crossings.front().halfedge] == b.crossings.back().halfedge;
                EXPECT_FALSE(reversed) << i << " and " << j;
            }
        EXPECT_EQ(r.cut.skipped_segments, 0);
    }
}

}  // namespace
}  // namespace holoflow::kernels
