#include "holoflow/kernels/subdivision.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::kernels {
namespace {

constexpr double kAreaRelTol = 1e-12;  // sums of O(#F) products of unit-size coordinates

Eigen::Vector3d corner(const MeshView& m, Index f, int k) { return m.V.row(m.F(f, k)).transpose(); }

Eigen::Vector3d area_vector(const MeshView& m, Index f) {
    return 0.5 * (corner(m, f, 1) - corner(m, f, 0)).cross(corner(m, f, 2) - corner(m, f, 0));
}

struct Case {
    std::string name;
    MeshView mesh;
};

std::vector<Case> cases() {
    std::vector<Case> c;
    c.push_back({"torus", shapes::torus(2.0, 0.7, 9, 6)});
    c.push_back({"icosphere", shapes::icosphere(1)});
    c.push_back({"flat_grid", shapes::flat_grid(4, 3)});
    c.push_back({"cylinder", shapes::cylinder(1.0, 1.0, 7, 2)});
    c.push_back({"genus_2", shapes::genus_surface(2, 1)});
    c.push_back({"perforated_sheet", shapes::perforated_sheet(3, 1)});
    // Every cylinder edge runs between the two rims, so its double cover has pairs of edges on
    // one vertex pair: the midpoints must go by edge index.
    c.push_back(
        {"double_cover_with_parallel_edges", double_cover(shapes::cylinder(1.0, 1.0, 5, 1)).mesh});
    return c;
}

// Both schemes share one connectivity (V + E vertices, 4 faces per face); only positions differ.
TEST(Subdivision, MidpointAndLoopKeepTopologyAndCounts) {
    for (const Case& c : cases())
        for (const auto& [scheme, subdivide] :
             {std::pair{"midpoint", &subdivide_midpoint}, std::pair{"loop", &subdivide_loop}}) {
            SCOPED_TRACE(c.name + " " + scheme);
            const MeshView& m = c.mesh;
            const MeshView s = subdivide(m);
            EXPECT_EQ(s.n_vertices(), m.n_vertices() + m.n_edges());
            EXPECT_EQ(s.n_edges(), 2 * m.n_edges() + 3 * m.n_faces());
            EXPECT_EQ(s.n_faces(), 4 * m.n_faces());
            const Topology before = compute_topology(m), after = compute_topology(s);
            EXPECT_EQ(after.genus, before.genus);
            EXPECT_EQ(after.euler_characteristic, before.euler_characteristic);
            EXPECT_EQ(after.components, before.components);
            ASSERT_EQ(after.boundary_loops, before.boundary_loops);
            for (int b = 0; b < before.boundary_loops; ++b)
                EXPECT_EQ(after.boundary_cycles[b].size(), 2 * before.boundary_cycles[b].size());
            EXPECT_EQ(s.is_closed(), m.is_closed());
        }
}

TEST(SubdivideMidpoint, KeepsGeometryAndOrientation) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        const MeshView& m = c.mesh;
        const MeshView s = subdivide_midpoint(m);
        // Original vertices keep their positions bit for bit; new ones sit at edge midpoints.
        EXPECT_EQ(s.V.topRows(m.n_vertices()), m.V);
        for (Index e = 0; e < m.n_edges(); ++e) {
            const Eigen::RowVector3d mid = 0.5 * (m.V.row(m.E(e, 0)) + m.V.row(m.E(e, 1)));
            EXPECT_EQ(s.V.row(m.n_vertices() + e), mid);
        }
        // Each face splits into four congruent quarters facing the same way, so areas add up.
        double area_before = 0.0, area_after = 0.0;
        for (Index f = 0; f < m.n_faces(); ++f) {
            const Eigen::Vector3d parent = area_vector(m, f);
            area_before += parent.norm();
            for (Index k = 0; k < 4; ++k) {
                const Eigen::Vector3d child = area_vector(s, 4 * f + k);
                EXPECT_NEAR((4.0 * child - parent).norm(), 0.0, kAreaRelTol * parent.norm());
                area_after += child.norm();
            }
        }
        EXPECT_NEAR(area_after, area_before, kAreaRelTol * area_before);
    }
}

// Smallest corner angle over the faces.
double smallest_angle(const MeshView& m) {
    double smallest = std::numbers::pi;
    for (Index f = 0; f < m.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d u = corner(m, f, (k + 1) % 3) - corner(m, f, k), w = corner(m, f, (k + 2) % 3) - corner(m, f, k);
            smallest = std::min(smallest, std::atan2(u.cross(w).norm(), u.dot(w)));
        }
    return smallest;
}

TEST(BisectLongEdges, KeepsTopologyGeometryAndOrientation) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        const MeshView& m = c.mesh;
        double longest = 0;
        for (Index e = 0; e < m.n_edges(); ++e) longest = std::max(longest, (m.V.row(m.E(e, 0)) - m.V.row(m.E(e, 1))).norm());
        const double max_length = 0.3 * longest;
        const MeshView s = bisect_long_edges(m, max_length).value();
        const Topology before = compute_topology(m), after = compute_topology(s);
        EXPECT_EQ(after.genus, before.genus);
        EXPECT_EQ(after.euler_characteristic, before.euler_characteristic);
        EXPECT_EQ(after.boundary_loops, before.boundary_loops);
        EXPECT_EQ(s.is_closed(), m.is_closed());
        EXPECT_GT(s.n_faces(), m.n_faces());
        for (Index e = 0; e < s.n_edges(); ++e)
            EXPECT_LE((s.V.row(s.E(e, 0)) - s.V.row(s.E(e, 1))).norm(), max_length);
        ASSERT_GE(s.n_vertices(), m.n_vertices());
        EXPECT_EQ(s.V.topRows(m.n_vertices()), m.V);
        // Every face of the input is tiled by the faces its id and the new ids give it: the
        // oriented area vectors add up to the same total (no face lost, doubled or flipped).
        Eigen::Vector3d total_in = Eigen::Vector3d::Zero(), total_out = Eigen::Vector3d::Zero();
        double area_in = 0, area_out = 0;
        for (Index f = 0; f < m.n_faces(); ++f) total_in += area_vector(m, f), area_in += area_vector(m, f).norm();
        for (Index f = 0; f < s.n_faces(); ++f) total_out += area_vector(s, f), area_out += area_vector(s, f).norm();
        EXPECT_NEAR(area_out, area_in, kAreaRelTol * area_in);
        EXPECT_LE((total_out - total_in).norm(), kAreaRelTol * area_in);
    }
}

TEST(BisectLongEdges, NewVerticesAreEdgeMidpointsOnTheSurface) {
    const MeshView m = shapes::torus(2.0, 0.7, 9, 6);
    const MeshView s = bisect_long_edges(m, 0.2).value();
    // A new vertex sits halfway between two vertices it is joined to, on a straight line.
    for (Index v = m.n_vertices(); v < s.n_vertices(); ++v) {
        std::vector<Index> neighbours;
        for (Index h = 0; h < s.n_halfedges(); ++h)
            if (s.tail(h) == v) neighbours.push_back(s.head(h));
        bool midpoint = false;
        for (Index a : neighbours)
            for (Index b : neighbours)
                midpoint = midpoint || (a < b && (s.V.row(v) - 0.5 * (s.V.row(a) + s.V.row(b))).norm() < 1e-12);
        EXPECT_TRUE(midpoint) << "vertex " << v;
    }
}

TEST(BisectLongEdges, KeepsHalfTheSmallestAngle) {
    // Rivara: splitting the longest edge first at most halves the smallest angle, on needles
    // (one ring of a tall thin cylinder) and on a coarse torus refined far down.
    for (const MeshView& m : {shapes::cylinder(0.1, 4.0, 8, 1), shapes::torus(2.0, 0.7, 9, 6)}) {
        const MeshView s = bisect_long_edges(m, 0.05).value();
        EXPECT_GT(s.n_faces(), 20 * m.n_faces());
        EXPECT_GE(smallest_angle(s), 0.5 * smallest_angle(m) * (1 - 1e-9));
    }
}

// A length far below the edges' would refine the whole surface down to it (an icosphere to
// 1e-6: about 1e13 faces); with a face limit the bisection gives nothing, at once.
TEST(BisectLongEdges, GivesNothingPastTheFaceLimit) {
    const MeshView m = shapes::icosphere(1);
    EXPECT_FALSE(bisect_long_edges(m, 1e-6, {}, 5000).has_value());
    EXPECT_FALSE(bisect_long_edges(m, 1e-300, {}, 5000).has_value());
}

// The limit refuses exactly the results with more faces than it allows: the lower bound that
// refuses without splitting never exceeds the count the splits reach. On needles, a coarse
// torus, a zone, an open sheet and a mesh of very uneven edges, from barely split to finely.
TEST(BisectLongEdges, FaceLimitRefusesExactlyTheLargerResults) {
    std::vector<Case> meshes = cases();
    meshes.push_back({"needles", shapes::cylinder(0.1, 4.0, 8, 1)});
    MeshView uneven = shapes::torus(2.0, 0.7, 9, 6);
    for (Index v = 0; v < uneven.n_vertices(); ++v) uneven.V.row(v).x() *= v % 3 == 0 ? 4.0 : 0.5;
    meshes.push_back({"uneven", make_mesh_view(uneven.V, uneven.F)});
    for (const Case& c : meshes) {
        const MeshView& m = c.mesh;
        std::vector<char> zone(static_cast<std::size_t>(m.n_vertices()), 0);
        for (Index v = 0; v < m.n_vertices(); v += 2) zone[v] = 1;
        double longest = 0;
        for (Index e = 0; e < m.n_edges(); ++e) longest = std::max(longest, (m.V.row(m.E(e, 0)) - m.V.row(m.E(e, 1))).norm());
        for (const double fraction : {0.9, 0.4, 0.15, 0.06})
            for (const bool zoned : {false, true}) {
                SCOPED_TRACE(c.name + " at " + std::to_string(fraction) + (zoned ? " in a zone" : ""));
                const std::span<const char> where = zoned ? std::span<const char>(zone) : std::span<const char>();
                const MeshView all = bisect_long_edges(m, fraction * longest, where).value();
                const std::optional<MeshView> at_limit = bisect_long_edges(m, fraction * longest, where, all.n_faces());
                ASSERT_TRUE(at_limit.has_value());
                EXPECT_EQ(at_limit->F, all.F);
                EXPECT_EQ(at_limit->V, all.V);
                if (all.n_faces() > m.n_faces()) {
                    EXPECT_FALSE(bisect_long_edges(m, fraction * longest, where, all.n_faces() - 1).has_value());
                }
            }
    }
}

TEST(BisectLongEdges, LeavesShortEdgesAloneAndRejectsNonPositiveLengths) {
    const MeshView m = shapes::icosphere(1);
    const MeshView s = bisect_long_edges(m, 10.0).value();
    EXPECT_EQ(s.F, m.F);
    EXPECT_EQ(s.V, m.V);
    EXPECT_THROW(bisect_long_edges(m, 0.0), InvalidInput);
    EXPECT_THROW(bisect_long_edges(m, -1.0), InvalidInput);
}

// Interior edges whose opposite angles add up to more than pi (cotangents summing below 0).
Index non_delaunay_edges(const MeshView& m) {
    Index count = 0;
    const auto cot_at = [&](Index h) {  // angle opposite halfedge h, in its face
        const Index f = MeshView::face(h), k = h % 3;
        const Eigen::Vector3d p = corner(m, f, (k + 2) % 3), a = corner(m, f, k) - p, b = corner(m, f, (k + 1) % 3) - p;
        return a.dot(b) / a.cross(b).norm();
    };
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Index h = m.edge_halfedge[e];
        if (m.twin[h] != kNoHalfedge && cot_at(h) + cot_at(m.twin[h]) < -1e-9) ++count;
    }
    return count;
}

// A sheared grid: every cell a parallelogram whose grid diagonal is the long one.
MeshView sheared_grid(int n, double lift) {
    MeshView m = shapes::flat_grid(n, n);
    PointMatrix V = m.V;
    for (Index v = 0; v < V.rows(); ++v) {
        V(v, 0) += 3 * V(v, 1);
        V(v, 2) = lift * std::max(0.0, V(v, 1) - 0.5);  // lift > 0: a crease along y = 0.5
    }
    return make_mesh_view(std::move(V), m.F);
}

TEST(FlipFlatEdgesToDelaunay, MakesAFlatSheetDelaunayWithTheSameGeometry) {
    const MeshView m = sheared_grid(8, 0.0);
    ASSERT_GT(non_delaunay_edges(m), 20);
    const MeshView s = flip_flat_edges_to_delaunay(m);
    EXPECT_EQ(non_delaunay_edges(s), 0);
    EXPECT_EQ(s.V, m.V);
    EXPECT_EQ(s.n_faces(), m.n_faces());
    EXPECT_EQ(compute_topology(s).boundary_loops, 1);
    double area_in = 0, area_out = 0;
    Eigen::Vector3d total_in = Eigen::Vector3d::Zero(), total_out = Eigen::Vector3d::Zero();
    for (Index f = 0; f < m.n_faces(); ++f) total_in += area_vector(m, f), area_in += area_vector(m, f).norm();
    for (Index f = 0; f < s.n_faces(); ++f) total_out += area_vector(s, f), area_out += area_vector(s, f).norm();
    EXPECT_NEAR(area_out, area_in, kAreaRelTol * area_in);
    EXPECT_LE((total_out - total_in).norm(), kAreaRelTol * area_in);
    EXPECT_GT(smallest_angle(s), smallest_angle(m));
}

TEST(FlipFlatEdgesToDelaunay, KeepsCreasesAndCurvedParts) {
    // Creased: both flat halves are made Delaunay, the crease's edges stay (a flip across
    // them would cut the corner off the fold).
    const MeshView creased = sheared_grid(8, 1.0);
    const MeshView s = flip_flat_edges_to_delaunay(creased);
    EXPECT_LT(non_delaunay_edges(s), non_delaunay_edges(creased));
    for (Index e = 0; e < creased.n_edges(); ++e) {
        const Index a = creased.E(e, 0), b = creased.E(e, 1);
        if (creased.V(a, 1) != 0.5 || creased.V(b, 1) != 0.5) continue;
        bool kept = false;
        for (Index x = 0; x < s.n_edges() && !kept; ++x) kept = std::minmax(s.E(x, 0), s.E(x, 1)) == std::minmax(a, b);
        EXPECT_TRUE(kept) << "crease edge " << a << "-" << b;
    }
    for (const MeshView& curved : {shapes::icosphere(2), shapes::torus(2.0, 0.7, 9, 6)})
        EXPECT_EQ(flip_flat_edges_to_delaunay(curved).F, curved.F);
    EXPECT_THROW(flip_flat_edges_to_delaunay(creased, -1.0), InvalidInput);
}

TEST(SubdivideMidpoint, ChildCornersLieOnTheParentFace) {
    const MeshView m = shapes::genus_surface(1, 2);
    const MeshView s = subdivide_midpoint(m);
    for (Index f = 0; f < m.n_faces(); ++f) {
        for (Index k = 0; k < 3; ++k) {
            // Corner triangle 4f + k starts at the parent's corner k.
            EXPECT_EQ(s.F(4 * f + k, 0), m.F(f, k));
            // Every child vertex is a parent corner or the midpoint of one of the parent's edges.
            for (Index j = 0; j < 3; ++j) {
                const Index v = s.F(4 * f + k, j);
                const bool is_corner = v == m.F(f, 0) || v == m.F(f, 1) || v == m.F(f, 2);
                bool is_midpoint = false;
                for (Index i = 0; i < 3; ++i)
                    is_midpoint |= v == m.n_vertices() + m.halfedge_edge[3 * f + i];
                EXPECT_TRUE(is_corner || is_midpoint);
            }
        }
    }
}

TEST(SubdivideMidpoint, TwiceOnAnIcosahedronGivesTheIcosphereConnectivity) {
    const MeshView ico = shapes::icosphere(0);
    const MeshView twice = subdivide_midpoint(subdivide_midpoint(ico));
    const MeshView level2 = shapes::icosphere(2);
    EXPECT_EQ(twice.F, level2.F);  // icosphere is built by the same split, then projected
    EXPECT_EQ(compute_topology(twice).euler_characteristic, 2);
}

TEST(SubdivideFormsMidpoint, CarriedFormsStayClosedWithTheSameWedgeMatrix) {
    for (const MeshView& m : {shapes::torus(2.0, 0.7, 9, 6), shapes::genus_surface(2, 1)}) {
        const HomologyBasis h = compute_homology_basis(m);
        const MeshView fine = subdivide_midpoint(m);
        const Eigen::MatrixXd forms = subdivide_forms_midpoint(m, fine, h.closed_forms);
        ASSERT_EQ(forms.rows(), fine.n_edges());
        // Integer forms become halves of integers: every face sum is exactly 0.
        for (Index f = 0; f < fine.n_faces(); ++f) {
            Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(forms.cols());
            for (Index k = 3 * f; k < 3 * f + 3; ++k)
                sum += fine.edge_sign(k) * forms.row(fine.halfedge_edge[k]);
            ASSERT_EQ(sum.cwiseAbs().maxCoeff(), 0.0) << "face " << f;
        }
        // Same cohomology classes: the wedge (cup product) matrix is unchanged, exactly.
        EXPECT_EQ(wedge_matrix(fine, forms), wedge_matrix(m, h.closed_forms));
    }
    const MeshView m = shapes::torus(2.0, 0.7, 9, 6);
    EXPECT_THROW(subdivide_forms_midpoint(m, m, compute_homology_basis(m).closed_forms),
                 InvalidInput);
}

// ---- Loop subdivision: positions.


constexpr double kAffineTol = 1e-12;    // a few roundings of O(1) coordinates, O(1) map entries
constexpr double kAnalyticTol = 1e-14;  // closed-form positions, unit-size coordinates
constexpr double kPlaneTol = 1e-14;     // affine combinations of points on a tilted plane


// Regular tetrahedron inscribed in the unit sphere (every vertex has valence 3).
MeshView regular_tetrahedron() {
    PointMatrix V(4, 3);
    V << 1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1;
    V /= std::sqrt(3.0);
    TriangleMatrix F(4, 3);
    F << 0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2;
    return make_mesh_view(std::move(V), std::move(F));
}

// Unit square in z = 0 cut into n x n cells, every cell split along the same diagonal: valence 6
// inside, the stencils symmetric about every interior vertex and edge (shapes::flat_grid flips
// its diagonals across the centre lines, which breaks that symmetry there).
MeshView regular_grid(int n) {
    auto id = [n](int i, int j) { return static_cast<Index>(j * (n + 1) + i); };
    PointMatrix V((n + 1) * (n + 1), 3);
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) V.row(id(i, j)) << double(i) / n, double(j) / n, 0.0;
    TriangleMatrix F(2 * n * n, 3);
    Index f = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            F.row(f++) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
            F.row(f++) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
        }
    return make_mesh_view(std::move(V), std::move(F));
}

double enclosed_volume(const MeshView& m) {
    double six_v = 0.0;
    for (Index f = 0; f < m.n_faces(); ++f) {
        const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)),
                              c = m.V.row(m.F(f, 2));
        six_v += a.dot(b.cross(c));
    }
    return six_v / 6.0;
}

PointMatrix apply(const Eigen::Matrix3d& A, const Eigen::RowVector3d& t, const PointMatrix& V) {
    PointMatrix out = V * A.transpose();
    out.rowwise() += t;
    return out;
}


TEST(SubdivideLoop, SharesTheMidpointLayout) {
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        const MeshView loop = subdivide_loop(c.mesh), mid = subdivide_midpoint(c.mesh);
        EXPECT_EQ(loop.F, mid.F);
        EXPECT_EQ(loop.twin, mid.twin);
        EXPECT_EQ(loop.halfedge_edge, mid.halfedge_edge);
    }
}

// Icosahedron: every vertex has valence 5 and its neighbours sum to 5 cos(theta) v, cos(theta) =
// 1/sqrt(5); an edge's opposite corners sum to (4/sqrt 5) (a+b)/|a+b|^2 by symmetry. So the
// interior rules give closed-form radii for both kinds of vertex.
TEST(SubdivideLoop, IcosahedronMatchesTheInteriorRules) {
    const MeshView m = shapes::icosphere(0);
    const MeshView s = subdivide_loop(m);
    const double beta = 3.0 / 40.0;  // Warren, n = 5
    const double vertex_radius = 1.0 - 5.0 * beta * (1.0 - 1.0 / std::sqrt(5.0));
    const double ab = std::sqrt(2.0 + 2.0 / std::sqrt(5.0));  // |a + b| for adjacent a, b
    const double edge_radius = 0.375 * ab + 0.125 * (4.0 / std::sqrt(5.0)) / ab;
    for (Index v = 0; v < m.n_vertices(); ++v) {
        EXPECT_NEAR(s.V.row(v).norm(), vertex_radius, kAnalyticTol);
        EXPECT_NEAR(s.V.row(v).normalized().dot(m.V.row(v)), 1.0, kAnalyticTol);
    }
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Eigen::RowVector3d p = s.V.row(m.n_vertices() + e);
        const Eigen::RowVector3d axis = m.V.row(m.E(e, 0)) + m.V.row(m.E(e, 1));
        EXPECT_NEAR(p.norm(), edge_radius, kAnalyticTol);
        EXPECT_NEAR(p.normalized().dot(axis.normalized()), 1.0, kAnalyticTol);
    }
}

// Tetrahedron: valence 3 (beta = 3/16) and the neighbours of v sum to -v, so v goes to v/4; an
// edge's opposite corners are the other two, summing to -(a+b), so its vertex lands at (a+b)/4.
TEST(SubdivideLoop, TetrahedronMatchesTheValenceThreeRule) {
    const MeshView m = regular_tetrahedron();
    const MeshView s = subdivide_loop(m);
    for (Index v = 0; v < m.n_vertices(); ++v)
        EXPECT_LT((s.V.row(v) - 0.25 * m.V.row(v)).norm(), kAnalyticTol);
    for (Index e = 0; e < m.n_edges(); ++e) {
        const Eigen::RowVector3d expected = 0.25 * (m.V.row(m.E(e, 0)) + m.V.row(m.E(e, 1)));
        EXPECT_LT((s.V.row(m.n_vertices() + e) - expected).norm(), kAnalyticTol);
    }
}

// Flat grid: the boundary is a cubic B-spline, so straight sides stay put and a corner (boundary
// neighbours at distance h along x and y) moves to (h/8, h/8); boundary edges split at midpoints.
TEST(SubdivideLoop, GridBoundaryFollowsTheCurveRules) {
    const int nx = 4, ny = 3;
    const MeshView m = shapes::flat_grid(nx, ny);
    const MeshView s = subdivide_loop(m);
    for (Index v = 0; v < m.n_vertices(); ++v) {
        const Eigen::RowVector3d p = m.V.row(v), q = s.V.row(v);
        const bool on_x_side = p.x() == 0.0 || p.x() == 1.0;
        const bool on_y_side = p.y() == 0.0 || p.y() == 1.0;
        if (on_x_side && on_y_side) {
            const Eigen::RowVector3d inward(p.x() == 0.0 ? 1.0 : -1.0, p.y() == 0.0 ? 1.0 : -1.0,
                                            0);
            const Eigen::RowVector3d expected =
                p + 0.125 * Eigen::RowVector3d(inward.x() / nx, inward.y() / ny, 0.0);
            EXPECT_LT((q - expected).norm(), kAnalyticTol);
        } else if (on_x_side || on_y_side) {
            EXPECT_LT((q - p).norm(), kAnalyticTol);
        }
    }
    for (Index e = 0; e < m.n_edges(); ++e) {
        if (!m.is_boundary_halfedge(m.edge_halfedge[e])) continue;
        const Eigen::RowVector3d mid = 0.5 * (m.V.row(m.E(e, 0)) + m.V.row(m.E(e, 1)));
        EXPECT_EQ(s.V.row(m.n_vertices() + e), mid);
    }
}

// On a regular grid the stencils are symmetric: interior vertices do not move and interior edge
// vertices are midpoints (c + d = a + b), so positions, hence every linear function of them, are
// reproduced exactly up to rounding; z stays exactly 0 everywhere.
TEST(SubdivideLoop, FlatGridInteriorStaysInPlace) {
    const MeshView m = regular_grid(6);
    const MeshView s = subdivide_loop(m);
    EXPECT_TRUE((s.V.col(2).array() == 0.0).all());
    std::vector<bool> boundary(m.n_vertices(), false);
    for (Index h = 0; h < m.n_halfedges(); ++h)
        if (m.is_boundary_halfedge(h)) boundary[m.tail(h)] = true;
    for (Index v = 0; v < m.n_vertices(); ++v) {
        if (boundary[v]) continue;
        EXPECT_LT((s.V.row(v) - m.V.row(v)).norm(), kAnalyticTol);
    }
    for (Index e = 0; e < m.n_edges(); ++e) {
        if (m.is_boundary_halfedge(m.edge_halfedge[e])) continue;
        const Eigen::RowVector3d mid = 0.5 * (m.V.row(m.E(e, 0)) + m.V.row(m.E(e, 1)));
        EXPECT_LT((s.V.row(m.n_vertices() + e) - mid).norm(), kAnalyticTol);
    }
}

// Any planar mesh (irregular valences, holes) stays in its plane: every rule is an affine
// combination. The plane is tilted so that rounding is actually exercised.
TEST(SubdivideLoop, PlanarMeshStaysPlanar) {
    const Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
    const Eigen::Matrix3d R =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), normal).toRotationMatrix();
    const Eigen::RowVector3d origin(0.25, -1.5, 0.75);
    const double offset = origin.dot(normal.transpose());
    for (const MeshView& flat : {shapes::perforated_sheet(3, 2), shapes::flat_grid(5, 4)}) {
        MeshView m = make_mesh_view(apply(R, origin, flat.V), flat.F);
        for (int level = 0; level < 3; ++level) {
            m = subdivide_loop(m);
            const Eigen::VectorXd height = (m.V * normal).array() - offset;
            EXPECT_LT(height.cwiseAbs().maxCoeff(), kPlaneTol) << "level " << level + 1;
        }
    }
}

// Affine invariance: subdividing A(m) equals A applied to the subdivided mesh, on closed, open and
// parallel-edge meshes alike; with planar input this is exact reproduction of linear functions.
TEST(SubdivideLoop, CommutesWithAffineMaps) {
    Eigen::Matrix3d A;
    A << 1.3, -0.4, 0.2, 0.5, 0.9, -0.7, -0.1, 0.6, 1.1;  // invertible, not a similarity
    const Eigen::RowVector3d t(0.7, -1.2, 2.5);
    for (const Case& c : cases()) {
        SCOPED_TRACE(c.name);
        const MeshView mapped = make_mesh_view(apply(A, t, c.mesh.V), c.mesh.F, c.mesh.twin);
        const PointMatrix subdivided_then_mapped = apply(A, t, subdivide_loop(c.mesh).V);
        const PointMatrix mapped_then_subdivided = subdivide_loop(mapped).V;
        EXPECT_LT((subdivided_then_mapped - mapped_then_subdivided).cwiseAbs().maxCoeff(),
                  kAffineTol);
    }
}

// Loop surfaces converge: the volume changes between successive levels of an icosahedron shrink
// geometrically (the distance between levels is O(h^2), h halving each time), and the volume
// decreases since new vertices are convex combinations of a convex polyhedron's vertices.
TEST(SubdivideLoop, IcosphereConvergesToASmoothLimit) {
    MeshView m = shapes::icosphere(0);
    std::vector<double> volume{enclosed_volume(m)};
    for (int level = 1; level <= 5; ++level) {
        m = subdivide_loop(m);
        volume.push_back(enclosed_volume(m));
    }
    for (std::size_t k = 1; k < volume.size(); ++k) EXPECT_LT(volume[k], volume[k - 1]);
    for (std::size_t k = 2; k < volume.size(); ++k) {
        const double previous = volume[k - 2] - volume[k - 1], change = volume[k - 1] - volume[k];
        SCOPED_TRACE("level " + std::to_string(k));
        EXPECT_LT(change, 0.3 * previous);  // O(h^2): ratio -> 1/4 (0.20, 0.24, 0.25 measured)
    }
}

// Positive enclosed volume before and after on a closed surface: the faces still face outward.
TEST(SubdivideLoop, KeepsOrientation) {
    const MeshView t = shapes::torus(2.0, 0.7, 12, 8);
    EXPECT_GT(enclosed_volume(t), 0.0);
    EXPECT_GT(enclosed_volume(subdivide_loop(t)), 0.0);
}

}  // namespace
}  // namespace holoflow::kernels
