#include "holoflow/kernels/flow_cut.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <complex>

#include <Eigen/Geometry>
#include <tbb/global_control.h>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/trajectories.h"

namespace holoflow::kernels {
namespace {

constexpr double kAreaTol = 1e-14;  // areas of a unit-size triangle, rounding only

// The unit square A B C D split along AC, in the plane, with the identity as its image.
struct Square {
    MeshView mesh;
    Eigen::VectorXcd tau;
    Square() {
        PointMatrix V(4, 3);
        V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
        TriangleMatrix F(2, 3);
        F << 0, 1, 2, 0, 2, 3;  // halfedge 1 runs B -> C, halfedge 3 runs A -> C
        mesh = make_mesh_view(V, F);
        tau.resize(mesh.n_edges());
        for (Index e = 0; e < mesh.n_edges(); ++e) {
            const Eigen::RowVector3d d = mesh.V.row(mesh.E(e, 1)) - mesh.V.row(mesh.E(e, 0));
            tau(e) = {d(0), d(1)};
        }
    }
};

// The cut mesh's triangles are counter-clockwise, not degenerate, and cover the unit square.
void expect_tiles_the_square(const CutMesh& cut) {
    double area = 0;
    for (Index f = 0; f < cut.mesh.n_faces(); ++f) {
        const Eigen::RowVector3d a = cut.mesh.V.row(cut.mesh.F(f, 0)), b = cut.mesh.V.row(cut.mesh.F(f, 1)),
                                 c = cut.mesh.V.row(cut.mesh.F(f, 2));
        const double z = (b - a).cross(c - a)(2) / 2;
        EXPECT_GT(z, kAreaTol);
        area += z;
    }
    EXPECT_NEAR(area, 1.0, kAreaTol);
}

// In face A B C: T0 runs from A to M, the middle of BC; T1 leaves C and stops on T0 at P; T2
// comes from D across AC at X and stops on T1 at Q, later than T1 stopped. Q exists only once
// T1 is cut in, although T1 stopped first: the cutter must still place all three.
std::vector<Trajectory> blocker_stops_first() {
    Trajectory t0;
    t0.start_vertex = 0;
    t0.first_face = 0;
    t0.family = TrajectoryFamily::Vertical;
    t0.crossings = {{1, 0.5, 1.1}};
    t0.end = Trajectory::End::Boundary;
    t0.length = 1.1;
    Trajectory t1;
    t1.start_vertex = 2;
    t1.first_face = 0;
    t1.family = TrajectoryFamily::Horizontal;
    t1.end = Trajectory::End::Collision;
    t1.end_barycentric = {0.5, 0.25, 0.25};  // P = (0.5, 0.25)
    t1.blocker = 0;
    t1.blocker_segment = 0;
    t1.blocker_length = 0.3;
    t1.length = 1.0;
    Trajectory t2;
    t2.start_vertex = 3;
    t2.first_face = 1;
    t2.family = TrajectoryFamily::Vertical;
    t2.crossings = {{3, 0.5, 0.7}};          // X = (0.5, 0.5)
    t2.end = Trajectory::End::Collision;
    t2.end_barycentric = {0.25, 0.125, 0.625};  // Q = (0.75, 0.625), between C and P
    t2.blocker = 1;
    t2.blocker_segment = 0;
    t2.blocker_length = 0.4;
    t2.length = 2.0;
    return {t0, t1, t2};
}

TEST(FlowCut, CurveStoppedOnACurveThatStoppedEarlierIsPlaced) {
    const Square square;
    const std::vector<Trajectory> ts = blocker_stops_first();
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, ts);
    EXPECT_EQ(cut.skipped_segments, 0);
    EXPECT_EQ(cut.mesh.n_vertices(), 8);  // A B C D, M, X, P and Q
    expect_tiles_the_square(cut);
    // Each curve is a border: T0 in two pieces (A-P, P-M), T1 in two (C-Q, Q-P), T2 in two
    // (D-X, X-Q).
    std::array<int, 3> edges{};
    for (Index e = 0; e < cut.mesh.n_edges(); ++e)
        if (cut.edge_trajectory[e] >= 0) ++edges[cut.edge_trajectory[e]];
    EXPECT_EQ(edges, (std::array<int, 3>{2, 2, 2}));
}

// A curve whose collision point lies on no piece (here its blocker segment does not exist; on
// real meshes, stops that depend on each other in a folded face) cannot be cut in: it is
// counted as skipped and its point dropped, and the rest is still a valid mesh (it threw
// "vertex is in no face" before).
TEST(FlowCut, CurveThatCannotBePlacedIsSkippedAndItsPointDropped) {
    const Square square;
    std::vector<Trajectory> ts = blocker_stops_first();
    ts[2].blocker_segment = 5;
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, ts);
    EXPECT_EQ(cut.skipped_segments, 1);
    EXPECT_EQ(cut.mesh.n_vertices(), 7);  // Q goes
    ASSERT_EQ(static_cast<Index>(cut.original_vertex.size()), cut.mesh.n_vertices());
    for (Index v = 0; v < 4; ++v) EXPECT_EQ(cut.original_vertex[v], v);
    expect_tiles_the_square(cut);
}

// A pinwheel in face A B C: T0 from A stops on T1, T1 from B on T2, T2 from C on T3, and T3,
// which comes from D across AC at X = (0.5, 0.5), stops on T0 (families alternate, as the
// motorcycle rule makes them). Each stop lies on a segment that itself waits for another, so no
// order of chords places them; the face is split as the plane graph they make instead: four
// pieces around the quadrilateral of the four stops, and that quadrilateral.
TEST(FlowCut, PinwheelOfCurvesStoppingOnEachOtherIsPlaced) {
    const Square square;
    const std::array<std::array<double, 3>, 4> stop{{{0.0667, 0.7792, 0.1541},    // (0.9333, 0.1541)
                                                     {0.2923, 0.0327, 0.6750},    // (0.7077, 0.6750)
                                                     {0.4775, 0.0535, 0.4690},    // (0.5225, 0.4690)
                                                     {0.2297, 0.6431, 0.1272}}};  // (0.7703, 0.1272)
    std::vector<Trajectory> ts(4);
    for (Index i = 0; i < 4; ++i) {
        Trajectory& t = ts[i];
        t.start_vertex = i < 3 ? i : 3;
        t.first_face = i < 3 ? 0 : 1;
        t.family = i % 2 == 0 ? TrajectoryFamily::Vertical : TrajectoryFamily::Horizontal;
        if (i == 3) t.crossings = {{3, 0.5, 0.7}};
        t.end = Trajectory::End::Collision;
        t.end_barycentric = stop[i];
        t.blocker = (i + 1) % 4;
        t.blocker_segment = i == 2 ? 1 : 0;  // T3's second segment lies in A B C
        t.blocker_length = 0.5;
        t.length = 1.0 + 0.1 * static_cast<double>(i);
    }
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, ts);
    EXPECT_EQ(cut.skipped_segments, 0);
    EXPECT_EQ(cut.mesh.n_vertices(), 9);  // A B C D, X and the four stops
    expect_tiles_the_square(cut);
    // Each curve is a border up to its stop, in pieces split where the one before it stops on it:
    // T3 also has its piece D-X in A C D.
    std::array<int, 4> edges{};
    for (Index e = 0; e < cut.mesh.n_edges(); ++e)
        if (cut.edge_trajectory[e] >= 0) ++edges[cut.edge_trajectory[e]];
    EXPECT_EQ(edges, (std::array<int, 4>{2, 2, 2, 3}));
    EXPECT_EQ(cut.mesh.twin, make_mesh_view(cut.mesh.V, cut.mesh.F).twin);
}

// Two curves of one family crossing in a face (only a face folded in the image lets them): no
// plane graph splits it, so the later one is still skipped, and the mesh stays valid.
TEST(FlowCut, CurvesCrossingInAFaceAreSkipped) {
    const Square square;
    std::vector<Trajectory> ts(2);
    ts[0].start_vertex = 0;  // A to the middle of BC
    ts[0].crossings = {{1, 0.5, 1.1}};
    ts[0].length = 1.1;
    ts[1].start_vertex = 2;  // C to the middle of AB, across the first at (2/3, 1/3)
    ts[1].crossings = {{0, 0.5, 1.2}};
    ts[1].length = 1.2;
    for (Trajectory& t : ts) {
        t.first_face = 0;
        t.end = Trajectory::End::Boundary;
    }
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, ts);
    EXPECT_EQ(cut.skipped_segments, 1);
    EXPECT_EQ(cut.mesh.twin, make_mesh_view(cut.mesh.V, cut.mesh.F).twin);
}

// Curves crossing in face A B C (only a face folded in its chart lets traced curves do so):
// T0 runs from A to M on BC; T1 leaves C close along CA and stops on T0 near A; T2 leaves C
// and stops on T0; T3 comes from D across AC, crosses T1 and stops on T0; T4 comes from D
// across AC and stops on T1. The pieces the placeable curves split the face into then
// triangulate with one diagonal twice, which no mesh can hold: the face keeps
// only its border (all five of its segments skipped), and the cut mesh stays a valid tiling (it
// was refused as non-manifold before). The configuration hangs on rounding, hence the digits;
// the cutter's arithmetic is plain doubles, the same on every machine.
TEST(FlowCut, CrossingCurvesWhosePiecesShareADiagonalLeaveTheFaceWhole) {
    const Square square;
    using Point = std::array<double, 3>;  // barycentric of A B C
    const auto along = [](const Point& from, const Point& to, double s) {
        return Point{from[0] + s * (to[0] - from[0]), from[1] + s * (to[1] - from[1]), from[2] + s * (to[2] - from[2])};
    };
    const Point a{1, 0, 0}, c{0, 0, 1}, m{0, 1 - 0.6019186653459272, 0.6019186653459272};
    std::vector<Trajectory> ts(5);
    ts[0].start_vertex = 0;
    ts[0].crossings = {{1, 0.6019186653459272, 1.167}};
    ts[0].end = Trajectory::End::Boundary;
    ts[0].length = 1.167;
    // T stops on the blocker's first segment (from `from` to `to`) at s, where the blocker has
    // come `blocker_length` far, after T has come `length`.
    const auto stop = [&](Index t, Index blocker, const Point& from, const Point& to, double s, double blocker_length,
                          double length) {
        ts[t].end = Trajectory::End::Collision;
        ts[t].end_barycentric = along(from, to, s);
        ts[t].blocker = blocker;
        ts[t].blocker_segment = 0;
        ts[t].blocker_length = blocker_length;
        ts[t].length = length;
    };
    ts[1].start_vertex = 2;
    stop(1, 0, a, m, 0.062917483984265513, 0.0734, 1.343);
    ts[2].start_vertex = 2;
    stop(2, 0, a, m, 0.5864304006019323, 0.684, 0.768);
    ts[3].start_vertex = 3;
    ts[3].crossings = {{3, 0.074265173269746104, 0.9}};
    stop(3, 0, a, m, 0.27105204218065482, 0.316, 1.145);
    ts[4].start_vertex = 3;
    ts[4].crossings = {{3, 0.52076505367503723, 0.7}};
    stop(4, 1, c, ts[1].end_barycentric, 0.22207774587298207, 0.298, 1.087);
    for (Index i = 0; i < 5; ++i) {
        ts[i].first_face = i < 3 ? 0 : 1;
        ts[i].family = i == 2 || i == 3 ? TrajectoryFamily::Horizontal : TrajectoryFamily::Vertical;
    }
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, ts);
    EXPECT_EQ(cut.skipped_segments, 5);
    expect_tiles_the_square(cut);
    EXPECT_EQ(cut.mesh.twin, make_mesh_view(cut.mesh.V, cut.mesh.F).twin);
}

// The cutter pairs halfedges by construction (pieces of input edges, chords inside a face); it
// must find the pairing that matching vertex pairs over the whole cut mesh gives.
TEST(FlowCut, PairingIsTheOneByVertexPairs) {
    const Square square;
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, blocker_stops_first());
    EXPECT_EQ(cut.mesh.twin, make_mesh_view(cut.mesh.V, cut.mesh.F).twin);
}

// A capped curve ends on the edge it last crossed (AC here, at X), in no segment of the face
// behind it (A C D). That face is split at X too: the cut mesh keeps the square's four border
// edges, with no slit along A-X-C.
TEST(FlowCut, PointOnTheEdgeOfAFaceNoCurveEntersSplitsThatFace) {
    const Square square;
    Trajectory t;
    t.start_vertex = 1;  // B
    t.first_face = 0;
    t.crossings = {{2, 0.5, 0.7}};  // halfedge 2 runs C -> A
    t.end = Trajectory::End::LengthCap;
    t.length = 0.7;
    const CutMesh cut = cut_along_trajectories(square.mesh, square.tau, std::vector<Trajectory>{t});
    EXPECT_EQ(cut.mesh.n_vertices(), 5);
    EXPECT_EQ(cut.mesh.n_faces(), 4);
    EXPECT_EQ(std::count(cut.mesh.twin.begin(), cut.mesh.twin.end(), kNoHalfedge), 4);
    EXPECT_EQ(cut.mesh.twin, make_mesh_view(cut.mesh.V, cut.mesh.F).twin);
}

// Large cuts are assembled in parallel blocks (every face, halfedge and edge writes its own
// slots): the same cut mesh, form and labels with one thread.
TEST(FlowCut, LargeCutIsTheSameWithAnyThreadCount) {
    const MeshView grid = shapes::flat_grid(90, 80);  // 14400 faces
    Eigen::VectorXcd tau(grid.n_edges());
    const std::complex<double> turn = std::polar(1.0, 0.3);  // curves cross the faces obliquely
    for (Index e = 0; e < grid.n_edges(); ++e) {
        const Eigen::RowVector3d d = grid.V.row(grid.E(e, 1)) - grid.V.row(grid.E(e, 0));
        tau(e) = turn * std::complex<double>(d(0), d(1));
    }
    std::vector<Index> starts;
    for (int row = 10; row < 80; row += 17)
        for (int column = 7; column < 90; column += 23) starts.push_back(row * 91 + column);
    const std::vector<TrajectoryFamily> families{TrajectoryFamily::Vertical, TrajectoryFamily::Horizontal};
    TraceOptions options;
    options.motorcycle = true;
    const std::vector<Trajectory> curves = trace_trajectories(grid, tau, starts, families, options);
    std::vector<Index> labels(grid.n_edges(), kNoBorder);
    for (Index e = 0; e < grid.n_edges(); e += 7) labels[e] = e % 11;
    const auto cut_with = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return cut_along_trajectories(grid, tau, curves, labels);
    };
    const CutMesh one = cut_with(1), two = cut_with(2);
    EXPECT_GT(one.mesh.n_faces(), grid.n_faces() + 1000);
    EXPECT_EQ(one.skipped_segments, 0);
    EXPECT_EQ(one.mesh.twin, make_mesh_view(one.mesh.V, one.mesh.F).twin);
    EXPECT_EQ(one.mesh.V, two.mesh.V);
    EXPECT_EQ(one.mesh.F, two.mesh.F);
    EXPECT_EQ(one.mesh.twin, two.mesh.twin);
    EXPECT_EQ(one.tau, two.tau);
    EXPECT_EQ(one.edge_trajectory, two.edge_trajectory);
    EXPECT_EQ(one.original_face, two.original_face);
    EXPECT_EQ(one.original_vertex, two.original_vertex);
    // Every input label is kept on the pieces of its edge; the curves' own edges carry theirs.
    Index labelled = 0;
    for (Index e = 0; e < one.mesh.n_edges(); ++e) labelled += one.edge_trajectory[e] != kNoBorder;
    EXPECT_GT(labelled, grid.n_edges() / 7);
}

TEST(FlowCut, LabelsMustMatchTheEdges) {
    const Square square;
    const std::vector<Index> labels(square.mesh.n_edges() + 1, kNoBorder);
    EXPECT_THROW(cut_along_trajectories(square.mesh, square.tau, blocker_stops_first(), labels), InvalidInput);
}

}  // namespace
}  // namespace holoflow::kernels
