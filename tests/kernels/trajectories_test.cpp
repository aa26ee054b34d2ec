#include "holoflow/kernels/trajectories.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <functional>

#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/zero_fans.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;

// Flat grid over [-1.5, 1.5]^2 turned by a generic angle (no edge along an axis).
MeshView turned_grid(int n) {
    MeshView m = shapes::flat_grid(n, n);
    const double c = std::cos(0.3), s = std::sin(0.3);
    for (Index v = 0; v < m.n_vertices(); ++v) {
        const double x = 3 * m.V(v, 0) - 1.5, y = 3 * m.V(v, 1) - 1.5;
        m.V(v, 0) = c * x - s * y;
        m.V(v, 1) = s * x + c * y;
    }
    return m;
}

Complex point(const MeshView& m, Index v) { return {m.V(v, 0), m.V(v, 1)}; }

// The grid with the simple zeros of f (at the given points) regularised into fan centres.
struct Regularised {
    RegularisedForm form;
    std::vector<Index> zeros;
};

Regularised regularise(const MeshView& m, const std::function<Complex(Complex)>& f, std::vector<Complex> at) {
    Eigen::VectorXcd tau(m.n_edges());
    for (Index e = 0; e < m.n_edges(); ++e) tau(e) = f(point(m, m.E(e, 1))) - f(point(m, m.E(e, 0)));
    std::vector<ZeroRegion> regions;
    for (Complex z : at) {
        ZeroRegion r;
        r.order = 1;
        for (Index g = 0; g < m.n_faces() && r.face < 0; ++g) {
            const Complex a = point(m, m.F(g, 0)), b = point(m, m.F(g, 1)), c = point(m, m.F(g, 2));
            const double area = cross(b - a, c - a);
            const double b1 = cross(z - a, c - a) / area, b2 = cross(b - a, z - a) / area;
            if (b1 > 0 && b2 > 0 && b1 + b2 < 1) r.face = g, r.barycentric = {1 - b1 - b2, b1, b2};
        }
        for (int k = 0; k < 3; ++k) r.vertices.push_back(m.F(r.face, k));
        r.image_offset = f(z) - f(point(m, m.F(r.face, 0)));
        regions.push_back(r);
    }
    Regularised out{regularise_zeros(m, tau, regions), {}};
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
