// Hostile inputs through the whole reader path (bytes -> soup -> MeshView -> topology): absurd
// header counts, enormous lines, huge indices, lying binary lists, non-finite and collinear
// coordinates, and the legal but awkward cases (single triangle, thousands of components,
// 1e-6 degree needles and caps, coincident and intersecting geometry). Each gives a clean
// MeshError of the documented kind or a correct result. Inputs found while hardening (by the
// fuzzers in tests/fuzz or by review) are kept at the end as regressions.

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/mesh_reader.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/topology.h"
#include "support/generated_files.h"
#include "support/test_support.h"

namespace holoflow::engine {
namespace {

// 50 MB: far beyond any real line, small enough for a test (the readers scan it once).
constexpr std::size_t kEnormous = 50u << 20;
// Refusing a lying header must not depend on the claimed size: well under a second.
// Angles of 1e-6 degrees from double positions: rounding is ~1e-16 relative and the first-order
// formula for the apex angle errs by ~t^2 relative (t ~ 1e-8), so 1e-12 degrees is loose.
constexpr double kAngleTol = 1e-12;

struct Outcome {
    bool loaded = false;
    MeshErrorKind kind = MeshErrorKind::FileNotFound;  // a kind no parser produces
    std::string detail;
    LoadedMesh mesh;
    kernels::Topology topology;
};

//! The fuzzers' path on in-memory bytes. The buffer is sized exactly so that ASan sees any read
//! past the end. Only MeshError is caught: any other exception fails the test.
Outcome run(const std::string& bytes, MeshFormat format, const LoadOptions& options = {}) {
    const std::vector<char> buffer(bytes.begin(), bytes.end());
    Outcome o;
    try {
        const PolygonSoup soup = parse_polygon_soup(buffer.data(), buffer.size(), format);
        o.mesh = mesh_from_soup(soup, options);
    } catch (const MeshError& e) {
        o.kind = e.kind;
        o.detail = e.detail;
        return o;
    }
    o.loaded = true;
    o.topology = kernels::compute_topology(*o.mesh.mesh);
    return o;
}

::testing::AssertionResult refused_as(const Outcome& o, MeshErrorKind kind) {
    if (o.loaded) return ::testing::AssertionFailure() << "loaded, expected " << to_string(kind);
    if (o.kind != kind)
        return ::testing::AssertionFailure()
               << "refused as " << to_string(o.kind) << " (" << o.detail << "), expected "
               << to_string(kind);
    return ::testing::AssertionSuccess();
}

template <class T>
void put(std::string& out, T value, bool big_endian = false) {
    auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
    if (big_endian != (std::endian::native == std::endian::big))
        std::reverse(bytes.begin(), bytes.end());
    out.append(bytes.data(), bytes.size());
}

//! Binary little-endian PLY: float x y z, faces as `property list <count_type> int`. The face
//! records are appended raw by the caller so that list lengths can lie.
std::string ply_binary_header(std::size_t vertices, std::size_t faces, const char* count_type) {
    return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(vertices) +
           "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
           std::to_string(faces) + "\nproperty list " + count_type +
           " int vertex_indices\nend_header\n";
}

std::string tetra_vertices_binary() {
    std::string out;
    for (float x : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f}) put(out, x);
    return out;
}

std::string binary_stl(const std::vector<std::array<float, 9>>& triangles, std::uint32_t count) {
    std::string out(80, ' ');
    put(out, count);
    for (const auto& t : triangles) {
        for (int k = 0; k < 3; ++k) put(out, 0.f);
        for (float x : t) put(out, x);
        put(out, std::uint16_t{0});
    }
    return out;
}

//! Smallest interior angle of any face, in degrees.
double min_angle_degrees(const MeshView& m) {
    double smallest = 180;
    for (Index f = 0; f < m.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d a = m.V.row(m.F(f, k)), b = m.V.row(m.F(f, (k + 1) % 3)),
                                  c = m.V.row(m.F(f, (k + 2) % 3));
            const Eigen::Vector3d u = b - a, v = c - a;
            // atan2 of |u x v| and u.v stays accurate for tiny angles, unlike acos.
            const double angle = std::atan2(u.cross(v).norm(), u.dot(v));
            smallest = std::min(smallest, angle * 180 / std::numbers::pi);
        }
    return smallest;
}

// ---------------------------------------------------------------------------------------------
// Header counts far beyond the file size: refused before allocating, whatever the claim.

TEST(HostileInput, HeaderCountsBeyondFileSizeAreRefusedAtOnce) {
    EXPECT_TRUE(refused_as(run("OFF\n4000000000 8000000000 0\n0 0 0\n", MeshFormat::Off),
                           MeshErrorKind::HeaderMismatch));
    EXPECT_TRUE(refused_as(run("OFF\n9223372036854775807 9223372036854775807 0\n", MeshFormat::Off),
                           MeshErrorKind::HeaderMismatch));
    EXPECT_TRUE(refused_as(run("OFF\n99999999999999999999 1 0\n", MeshFormat::Off),
                           MeshErrorKind::HeaderMismatch));
    // Claims just too large: 5 vertices and 4 faces need at least 62 bytes, 32 follow.
    EXPECT_TRUE(refused_as(run("OFF\n5 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n",
                               MeshFormat::Off),
                           MeshErrorKind::HeaderMismatch));

    const std::string ply_ascii = "ply\nformat ascii 1.0\nelement vertex 1000000000000\n"
                                  "property float x\nproperty float y\nproperty float z\n"
                                  "element face 1\nproperty list uchar int vertex_indices\n"
                                  "end_header\n0 0 0\n3 0 0 0\n";
    EXPECT_TRUE(refused_as(run(ply_ascii, MeshFormat::Ply), MeshErrorKind::HeaderMismatch));
    // count x 24 bytes is 2^64 + 8: a wrapping product would claim only 8 bytes are needed.
    std::string wrap = "ply\nformat binary_little_endian 1.0\nelement vertex 768614336404564651\n"
                       "property double x\nproperty double y\nproperty double z\nend_header\n";
    wrap += tetra_vertices_binary();
    EXPECT_TRUE(refused_as(run(wrap, MeshFormat::Ply), MeshErrorKind::HeaderMismatch));
    std::string huge_faces = ply_binary_header(4, 4000000000u, "uchar") + tetra_vertices_binary();
    EXPECT_TRUE(refused_as(run(huge_faces, MeshFormat::Ply), MeshErrorKind::HeaderMismatch));

    // Binary STL claiming 2^32 - 1 triangles in a 134-byte file.
    std::string stl = binary_stl({{0, 0, 0, 1, 0, 0, 0, 1, 0}}, 0xffffffffu);
    EXPECT_TRUE(refused_as(run(stl, MeshFormat::Stl), MeshErrorKind::Truncated));
}

// ---------------------------------------------------------------------------------------------
// Enormous lines: a 50 MB comment is skipped, a 50 MB number is judged, nothing is quadratic.

TEST(HostileInput, FiftyMegabyteCommentLinesAreSkipped) {
    const std::string comment(kEnormous, 'x');
    const Outcome off = run("OFF\n#" + comment + "\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n# " + comment +
                                "\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n",
                            MeshFormat::Off);
    ASSERT_TRUE(off.loaded) << off.detail;
    EXPECT_EQ(off.topology.faces, 4);
    EXPECT_EQ(off.topology.genus, 0);

    const Outcome obj = run("#" + comment + "\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # " + comment,
                            MeshFormat::Obj);
    ASSERT_TRUE(obj.loaded) << obj.detail;
    EXPECT_EQ(obj.topology.boundary_loops, 1);

    const Outcome ply = run("ply\nformat ascii 1.0\ncomment " + comment +
                                "\nelement vertex 3\nproperty float x\nproperty float y\n"
                                "property float z\nelement face 1\n"
                                "property list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                            MeshFormat::Ply);
    ASSERT_TRUE(ply.loaded) << ply.detail;
    EXPECT_EQ(ply.topology.faces, 1);

    // ascii STL: the name after "solid" is free text.
    const Outcome stl = run("solid " + comment +
                                "\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                "vertex 0 1 0\nendloop\nendfacet\nendsolid\n",
                            MeshFormat::Stl);
    ASSERT_TRUE(stl.loaded) << stl.detail;
    EXPECT_EQ(stl.topology.faces, 1);
}

TEST(HostileInput, FiftyMegabyteNumbersAreJudgedNotTrusted) {
    // 1 followed by 50 M zeros overflows a double: inf, refused as non-finite.
    const std::string big = "1" + std::string(kEnormous, '0');
    EXPECT_TRUE(refused_as(
        run("OFF\n3 1 0\n" + big + " 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", MeshFormat::Off),
        MeshErrorKind::NonFiniteCoordinate));
    // 0.000...001 underflows to 0: the triangle becomes (0,0,0) (1,0,0) (0,1,0) and loads.
    const std::string tiny = "0." + std::string(kEnormous, '0') + "1";
    const Outcome under = run("v " + tiny + " 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", MeshFormat::Obj);
    ASSERT_TRUE(under.loaded) << under.detail;
    EXPECT_EQ(under.mesh.mesh->V(0, 0), 0.0);
    // 1.000...0 (50 M zeros) is exactly 1.
    const std::string one = "1." + std::string(kEnormous, '0');
    const Outcome exact = run("v " + one + " 0 0\nv 0 1 0\nv 0 0 0\nf 1 2 3\n", MeshFormat::Obj);
    ASSERT_TRUE(exact.loaded) << exact.detail;
    EXPECT_EQ(exact.mesh.mesh->V(0, 0), 1.0);
    // A 50 MB face index does not fit in 64 bits.
    EXPECT_TRUE(refused_as(run("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 " + big + "\n",
                               MeshFormat::Off),
                           MeshErrorKind::ParseError));
    // A 50 MB token where a keyword belongs.
    EXPECT_TRUE(refused_as(run(std::string(kEnormous, 'v') + " 0 0 0\n", MeshFormat::Obj),
                           MeshErrorKind::EmptyFile));  // unknown alphabetic statements are skipped
    EXPECT_TRUE(refused_as(run("solid x\nfacet normal 0 0 1\nouter loop\nvertex " + big +
                                   " 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n",
                               MeshFormat::Stl),
                           MeshErrorKind::NonFiniteCoordinate));
}

// ---------------------------------------------------------------------------------------------
// Indices at 2^31 and 2^63: out of range or unparseable, never wrapped into range.

TEST(HostileInput, IndicesAtTwoToThe31And63) {
    const std::string vertices = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n";
    for (const char* index : {"2147483648", "2147483647", "4294967296", "4294967297",
                              "9223372036854775807", "-9223372036854775808", "-1"}) {
        SCOPED_TRACE(index);
        EXPECT_TRUE(refused_as(run(vertices + "3 0 1 " + index + "\n", MeshFormat::Off),
                               MeshErrorKind::IndexOutOfRange));
    }
    EXPECT_TRUE(refused_as(run(vertices + "3 0 1 9223372036854775808\n", MeshFormat::Off),
                           MeshErrorKind::ParseError));
    EXPECT_TRUE(refused_as(run(vertices + "3 0 1 18446744073709551617\n", MeshFormat::Off),
                           MeshErrorKind::ParseError));

    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 ";
    for (const char* index : {"2147483649", "9223372036854775807", "-9223372036854775808",
                              "-2147483648"}) {
        SCOPED_TRACE(index);
        EXPECT_TRUE(refused_as(run(obj + index + "\n", MeshFormat::Obj),
                               MeshErrorKind::IndexOutOfRange));
    }
    EXPECT_TRUE(refused_as(run(obj + "9223372036854775808\n", MeshFormat::Obj),
                           MeshErrorKind::ParseError));

    // Binary PLY: uint32 2^31 and 2^32 - 1 stay large (no sign wrap to a valid index).
    for (std::uint32_t index : {0x80000000u, 0xffffffffu}) {
        std::string ply =
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\nelement face 1\n"
            "property list uchar uint vertex_indices\nend_header\n";
        for (float x : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(ply, x);
        put(ply, std::uint8_t{3});
        for (std::uint32_t i : {0u, 1u, index}) put(ply, i);
        EXPECT_TRUE(refused_as(run(ply, MeshFormat::Ply), MeshErrorKind::IndexOutOfRange));
    }
    // Indices stored as floats: 2^63 is not an int64, 2^31 is out of range.
    const std::string ply_float = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                  "property float y\nproperty float z\nelement face 1\n"
                                  "property list uchar float vertex_indices\nend_header\n"
                                  "0 0 0\n1 0 0\n0 1 0\n3 0 1 ";
    EXPECT_TRUE(refused_as(run(ply_float + "9.223372036854775808e18\n", MeshFormat::Ply),
                           MeshErrorKind::ParseError));
    EXPECT_TRUE(refused_as(run(ply_float + "2147483648\n", MeshFormat::Ply),
                           MeshErrorKind::IndexOutOfRange));
    EXPECT_TRUE(refused_as(run(ply_float + "nan\n", MeshFormat::Ply), MeshErrorKind::ParseError));
}

// ---------------------------------------------------------------------------------------------
// Binary PLY whose list lengths lie.

TEST(HostileInput, BinaryPlyWithWrongListLengths) {
    const std::string head = ply_binary_header(4, 4, "uchar") + tetra_vertices_binary();
    auto face = [](std::uint8_t count, std::vector<std::int32_t> items) {
        std::string out;
        put(out, count);
        for (std::int32_t i : items) put(out, i);
        return out;
    };
    const std::string good = face(3, {0, 2, 1}) + face(3, {0, 1, 3}) + face(3, {0, 3, 2});
    const std::string last = face(3, {1, 2, 3});
    const Outcome ok = run(head + good + last, MeshFormat::Ply);
    ASSERT_TRUE(ok.loaded) << ok.detail;
    EXPECT_EQ(ok.topology.genus, 0);
    EXPECT_EQ(ok.topology.boundary_loops, 0);

    // Length 255 at the last face: the items run past the end of the file.
    EXPECT_TRUE(refused_as(run(head + good + face(255, {1, 2, 3}), MeshFormat::Ply),
                           MeshErrorKind::Truncated));
    // One item too many: the last record ends short.
    EXPECT_TRUE(refused_as(run(head + good + face(4, {1, 2, 3}), MeshFormat::Ply),
                           MeshErrorKind::Truncated));
    // Wrong lengths inside the data: the records after it no longer line up, so what is found
    // first depends on the bytes; the outcome must be a clean refusal, whichever kind.
    EXPECT_FALSE(run(head + face(4, {0, 2, 1}) + good.substr(13) + last, MeshFormat::Ply).loaded);
    EXPECT_FALSE(run(head + face(0, {}) + good + last, MeshFormat::Ply).loaded);
    EXPECT_FALSE(run(head + face(2, {0, 2}) + good + last, MeshFormat::Ply).loaded);
    // A face of two corners with the rest intact is a degenerate face.
    EXPECT_TRUE(refused_as(run(head + good + face(2, {1, 2}), MeshFormat::Ply),
                           MeshErrorKind::DegenerateFace));
    // A signed count of -1.
    const std::string signed_head = ply_binary_header(4, 1, "char") + tetra_vertices_binary();
    std::string negative = signed_head;
    put(negative, std::int8_t{-1});
    put(negative, std::int32_t{0});
    EXPECT_TRUE(refused_as(run(negative, MeshFormat::Ply), MeshErrorKind::HeaderMismatch));
    // A uint32 count of 2^32 - 1 must be checked against the bytes left, not allocated.
    std::string huge = ply_binary_header(4, 1, "uint") + tetra_vertices_binary();
    put(huge, std::uint32_t{0xffffffffu});
    for (std::int32_t i : {0, 1, 2}) put(huge, i);
    EXPECT_TRUE(refused_as(run(huge, MeshFormat::Ply), MeshErrorKind::Truncated));
}

// ---------------------------------------------------------------------------------------------
// Non-finite and collinear coordinates.

TEST(HostileInput, NanAndInfinityAreRefusedInEveryFormat) {
    for (const char* value : {"nan", "NaN", "-nan", "inf", "-inf", "infinity", "1e400", "-1e999"}) {
        SCOPED_TRACE(value);
        const std::string v = value;
        EXPECT_TRUE(refused_as(run("OFF\n3 1 0\n0 0 0\n1 " + v + " 0\n0 1 0\n3 0 1 2\n",
                                   MeshFormat::Off),
                               MeshErrorKind::NonFiniteCoordinate));
        EXPECT_TRUE(refused_as(run("v 0 0 0\nv 1 0 " + v + "\nv 0 1 0\nf 1 2 3\n", MeshFormat::Obj),
                               MeshErrorKind::NonFiniteCoordinate));
    }
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                      -std::numeric_limits<float>::infinity()}) {
        std::string ply = ply_binary_header(3, 1, "uchar");
        for (float x : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, bad}) put(ply, x);
        put(ply, std::uint8_t{3});
        for (std::int32_t i : {0, 1, 2}) put(ply, i);
        EXPECT_TRUE(refused_as(run(ply, MeshFormat::Ply), MeshErrorKind::NonFiniteCoordinate));
        EXPECT_TRUE(refused_as(run(binary_stl({{0, 0, 0, bad, 0, 0, 0, 1, 0}}, 1), MeshFormat::Stl),
                               MeshErrorKind::NonFiniteCoordinate));
    }
}

// A valid tetrahedron scaled far out of range is refused as such (it was called zero area,
// or failed later in the pipeline); within the range it loads.
TEST(HostileInput, CoordinatesOutOfRangeAreNamed) {
    const auto tetrahedron = [](const char* scale) {
        const std::string s(scale);
        return "OFF\n4 4 0\n0 0 0\n" + s + " 0 0\n0 " + s + " 0\n0 0 " + s + "\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    };
    for (const char* scale : {"1e100", "1e300", "1e-100", "1e-300"}) {
        SCOPED_TRACE(scale);
        EXPECT_TRUE(refused_as(run(tetrahedron(scale), MeshFormat::Off), MeshErrorKind::CoordinateRange));
    }
    for (const char* scale : {"1e50", "1e-50"}) {
        SCOPED_TRACE(scale);
        EXPECT_TRUE(run(tetrahedron(scale), MeshFormat::Off).loaded);
    }
}

TEST(HostileInput, AllCollinearPointsAreZeroArea) {
    EXPECT_TRUE(refused_as(run("OFF\n3 1 0\n0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n", MeshFormat::Off),
                           MeshErrorKind::ZeroAreaFace));
    // A quad and a hexagon on one line: whatever the triangulation, every piece is flat.
    EXPECT_TRUE(refused_as(run("OFF\n4 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n4 0 1 2 3\n",
                               MeshFormat::Off),
                           MeshErrorKind::ZeroAreaFace));
    EXPECT_TRUE(refused_as(run("OFF\n6 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 0\n4 0 0\n5 0 0\n"
                               "6 0 1 2 3 4 5\n",
                               MeshFormat::Off),
                           MeshErrorKind::ZeroAreaFace));
    // Three coincident points.
    EXPECT_TRUE(refused_as(run("v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n", MeshFormat::Obj),
                           MeshErrorKind::ZeroAreaFace));
    // Collinear in single precision after the STL float conversion.
    EXPECT_TRUE(refused_as(run(binary_stl({{0, 0, 0, 1, 1, 0, 2, 2, 0}}, 1), MeshFormat::Stl),
                           MeshErrorKind::ZeroAreaFace));
}

// ---------------------------------------------------------------------------------------------
// Legal but awkward meshes: correct results.

TEST(HostileInput, SingleTriangleIsADisk) {
    const Outcome o = run("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", MeshFormat::Off);
    ASSERT_TRUE(o.loaded) << o.detail;
    const kernels::Topology& t = o.topology;
    EXPECT_EQ(t.vertices, 3);
    EXPECT_EQ(t.edges, 3);
    EXPECT_EQ(t.faces, 1);
    EXPECT_EQ(t.components, 1);
    EXPECT_EQ(t.boundary_loops, 1);
    ASSERT_EQ(t.boundary_cycles.size(), 1u);
    EXPECT_EQ(t.boundary_cycles[0].size(), 3u);
    EXPECT_EQ(t.euler_characteristic, 1);
    EXPECT_EQ(t.genus, 0);
    // A disk has no holomorphic 1-form: a clean refusal, not a crash in the solver.
    EXPECT_THROW(compute_conformal(*o.mesh.mesh), InvalidInput);
}

TEST(HostileInput, FiveThousandSeparateTriangles) {
    constexpr int kTriangles = 5000;
    std::string off = "OFF\n" + std::to_string(3 * kTriangles) + " " + std::to_string(kTriangles) +
                      " 0\n";
    for (int i = 0; i < kTriangles; ++i) {
        const std::string x = std::to_string(2 * i);
        off += x + " 0 0\n" + x + ".5 0 0\n" + x + " 1 0\n";
    }
    for (int i = 0; i < kTriangles; ++i)
        off += "3 " + std::to_string(3 * i) + " " + std::to_string(3 * i + 1) + " " +
               std::to_string(3 * i + 2) + "\n";
    const Outcome o = run(off, MeshFormat::Off);
    ASSERT_TRUE(o.loaded) << o.detail;
    EXPECT_EQ(o.topology.components, kTriangles);
    EXPECT_EQ(o.topology.boundary_loops, kTriangles);
    EXPECT_EQ(o.topology.euler_characteristic, kTriangles);  // each a disk: chi = 1
    EXPECT_EQ(o.topology.genus, 0);
    EXPECT_EQ(o.mesh.report.components, static_cast<std::size_t>(kTriangles));
    EXPECT_THROW(compute_conformal(*o.mesh.mesh), InvalidInput);  // several components

    const Outcome largest = run(off, MeshFormat::Off, {ComponentPolicy::Largest, 0});
    ASSERT_TRUE(largest.loaded) << largest.detail;
    EXPECT_EQ(largest.topology.faces, 1);
    EXPECT_EQ(largest.mesh.report.dropped_components, static_cast<std::size_t>(kTriangles - 1));

    // The CLI's info on the file: exit 0 and the same counts.
    const test::TempDir dir;
    const auto r = test::run_cli("info --json '" + dir.write("many.off", off) + "'");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["components"], kTriangles);
    EXPECT_EQ(j["faces"], kTriangles);
    EXPECT_EQ(j["boundary_loops"], kTriangles);
    EXPECT_EQ(j["component_topology"].size(), static_cast<std::size_t>(kTriangles));
}

TEST(HostileInput, NeedlesAndCapsWithMicroDegreeAnglesLoad) {
    // tan(1e-6 degrees): the offset that makes an angle of 1e-6 degrees over a unit edge.
    const double t = std::tan(1e-6 * std::numbers::pi / 180);
    char buffer[512];
    // Needle: a tetrahedron whose base triangle has a 1e-6 degree angle at vertex 0.
    std::snprintf(buffer, sizeof buffer,
                  "OFF\n4 4 0\n0 0 0\n1 0 0\n1 %.17g 0\n0.5 0.5 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n"
                  "3 2 0 3\n",
                  t);
    const Outcome needle = run(buffer, MeshFormat::Off);
    ASSERT_TRUE(needle.loaded) << needle.detail;
    // The test's own geometry: the base has the 1e-6 degree angle, and the apex sees the short
    // edge (length tan(1e-6 deg), along y) from (0.5, -0.5, -1) away under an even smaller one,
    // 1e-6 degrees times sin(edge, sight line) / distance = sqrt(5/6) / sqrt(3/2) = sqrt(5) / 3.
    const double apex_angle = 1e-6 * std::sqrt(5.0) / 3;
    EXPECT_NEAR(min_angle_degrees(*needle.mesh.mesh), apex_angle, kAngleTol);
    EXPECT_EQ(needle.topology.genus, 0);
    EXPECT_EQ(needle.topology.boundary_loops, 0);
    EXPECT_EQ(needle.topology.euler_characteristic, 2);
    // Cap: the third corner near the middle of the opposite edge, two 1e-4 degree angles and one
    // of almost 180 degrees.
    const double t4 = std::tan(1e-4 * std::numbers::pi / 180);
    std::snprintf(buffer, sizeof buffer,
                  "OFF\n4 4 0\n0 0 0\n1 0 0\n0.5 %.17g 0\n0.5 0.5 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n"
                  "3 2 0 3\n",
                  t4 / 2);
    const Outcome cap = run(buffer, MeshFormat::Off);
    ASSERT_TRUE(cap.loaded) << cap.detail;
    EXPECT_NEAR(min_angle_degrees(*cap.mesh.mesh), 1e-4, kAngleTol);
    EXPECT_EQ(cap.topology.genus, 0);
    EXPECT_EQ(cap.topology.edges, 6);
    // With 1e-6 degree angles its short edges exceed the long one by 1e-16 of it: its edge
    // lengths lose its area, and on a tetrahedron no flip can remove it.
    std::snprintf(buffer, sizeof buffer,
                  "OFF\n4 4 0\n0 0 0\n1 0 0\n0.5 %.17g 0\n0.5 0.5 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n"
                  "3 2 0 3\n",
                  t / 2);
    EXPECT_TRUE(refused_as(run(buffer, MeshFormat::Off), MeshErrorKind::ZeroAreaFace));
    // The same needle in ascii STL: corners welded to 4 vertices, closed.
    std::snprintf(buffer, sizeof buffer, "%.9g", t);
    const std::string y = buffer;
    const std::string v[4] = {"0 0 0", "1 0 0", "1 " + y + " 0", "0.5 0.5 1"};
    std::string stl = "solid needle\n";
    for (const auto& f : {std::array{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}}) {
        stl += "facet normal 0 0 0\nouter loop\n";
        for (int k : f) stl += "vertex " + v[k] + "\n";
        stl += "endloop\nendfacet\n";
    }
    const Outcome welded = run(stl + "endsolid\n", MeshFormat::Stl);
    ASSERT_TRUE(welded.loaded) << welded.detail;
    EXPECT_EQ(welded.topology.vertices, 4);
    EXPECT_EQ(welded.topology.boundary_loops, 0);
    EXPECT_NEAR(min_angle_degrees(*welded.mesh.mesh), apex_angle, kAngleTol);  // t to 9 digits
}

TEST(HostileInput, CoincidentVerticesAreDistinctUnlessOnASeam) {
    // Two tetrahedra touching at one point through two different vertex indices (3 and 7).
    const std::string off =
        "OFF\n8 8 0\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n2 2 2\n3 2 2\n2 3 2\n1 1 1\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 4 6 5\n3 4 5 7\n3 4 7 6\n3 5 6 7\n";
    const Outcome o = run(off, MeshFormat::Off);
    ASSERT_TRUE(o.loaded) << o.detail;
    EXPECT_EQ(o.topology.vertices, 8);
    EXPECT_EQ(o.topology.components, 2);
    EXPECT_EQ(o.topology.genus, 0);
    EXPECT_EQ(o.topology.euler_characteristic, 4);
    EXPECT_EQ(o.mesh.mesh->V.row(3), o.mesh.mesh->V.row(7));
    // A square annulus cut open along one radial edge whose two sides (0, 4 and 8, 9) lie at the
    // same positions: a seam, zipped into the annulus; kept open on request, a strip (a disk).
    const std::string cut_annulus = "OFF\n10 4 0\n-2 -2 0\n2 -2 0\n2 2 0\n-2 2 0\n-1 -1 0\n1 -1 0\n"
                                    "1 1 0\n-1 1 0\n-2 -2 0\n-1 -1 0\n"
                                    "4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 8 9 7\n";
    const Outcome annulus = run(cut_annulus, MeshFormat::Off);
    ASSERT_TRUE(annulus.loaded) << annulus.detail;
    EXPECT_EQ(annulus.topology.vertices, 8);
    EXPECT_EQ(annulus.topology.boundary_loops, 2);
    EXPECT_EQ(annulus.topology.euler_characteristic, 0);
    EXPECT_EQ(annulus.mesh.report.zipped_edges, 1u);
    EXPECT_EQ(annulus.mesh.report.zipped_vertices, 2u);
    LoadOptions keep;
    keep.seams = SeamPolicy::Keep;
    const Outcome strip = run(cut_annulus, MeshFormat::Off, keep);
    ASSERT_TRUE(strip.loaded) << strip.detail;
    EXPECT_EQ(strip.topology.vertices, 10);
    EXPECT_EQ(strip.topology.components, 1);
    EXPECT_EQ(strip.topology.boundary_loops, 1);
    EXPECT_EQ(strip.topology.euler_characteristic, 1);
    // STL welds by position, so the same touching tetrahedra meet in one non-manifold vertex.
    std::vector<std::array<float, 9>> tris;
    const float p[8][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 1},
                           {2, 2, 2}, {3, 2, 2}, {2, 3, 2}, {1, 1, 1}};
    for (const auto& f : {std::array{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {4, 6, 5},
                          {4, 5, 7}, {4, 7, 6}, {5, 6, 7}}) {
        std::array<float, 9> t{};
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d) t[3 * k + d] = p[f[k]][d];
        tris.push_back(t);
    }
    // By default the pinched vertex is split back into one per tetrahedron.
    const Outcome split = run(binary_stl(tris, 8), MeshFormat::Stl);
    ASSERT_TRUE(split.loaded) << split.detail;
    EXPECT_EQ(split.mesh.report.split_vertices, 1u);
    EXPECT_EQ(split.topology.vertices, 8);
    EXPECT_EQ(split.topology.components, 2);
    EXPECT_EQ(split.topology.euler_characteristic, 4);
    LoadOptions refuse;
    refuse.pinched_vertices = PinchedVertexPolicy::Refuse;
    EXPECT_TRUE(refused_as(run(binary_stl(tris, 8), MeshFormat::Stl, refuse), MeshErrorKind::NonManifoldVertex));
}

TEST(HostileInput, IntersectingSeparateMeshesAreFine) {
    // Two tetrahedra passing through each other, and two coplanar overlapping triangles.
    const Outcome o = run("OFF\n8 8 0\n0 0 0\n2 0 0\n0 2 0\n0 0 2\n0.5 0.5 0.5\n2.5 0.5 0.5\n"
                          "0.5 2.5 0.5\n0.5 0.5 2.5\n"
                          "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n3 4 6 5\n3 4 5 7\n3 4 7 6\n"
                          "3 5 6 7\n",
                          MeshFormat::Off);
    ASSERT_TRUE(o.loaded) << o.detail;
    EXPECT_EQ(o.topology.components, 2);
    EXPECT_EQ(o.topology.boundary_loops, 0);
    EXPECT_EQ(o.topology.euler_characteristic, 4);
    const Outcome flat = run("v 0 0 0\nv 2 0 0\nv 0 2 0\nv 0.5 0.5 0\nv 2.5 0.5 0\nv 0.5 2.5 0\n"
                             "f 1 2 3\nf 4 5 6\n",
                             MeshFormat::Obj);
    ASSERT_TRUE(flat.loaded) << flat.detail;
    EXPECT_EQ(flat.topology.components, 2);
    EXPECT_EQ(flat.topology.boundary_loops, 2);
}

// ---------------------------------------------------------------------------------------------
// Found while hardening (review of the loader, then kept as regressions).

// Polygons that double back over coincident corners have no ear: ear clipping used to clip
// "anyway" one corner at a time, a failed O(n^2) search per corner, O(n^3) per polygon (3 s for
// 200 such 256-gons in a Release build). Now the rest is fanned at once; the cost comparison
// with convex polygons is BM_engine_load_polygons in bench/mesh_io_bench.cpp. Here: the outcome.
TEST(HostileInput, PolygonsWithoutEarsAreTriangulatedAndRefusedCleanly) {
    // The convex copies triangulate alike: all but the first are dropped as duplicates (or the
    // mesh refused, when asked); the fan over the doubled circle meets a corner's twin (a
    // zero-area triangle) and is refused.
    const Outcome copies = run(test::polygon_stack_off(256, 50, false), MeshFormat::Off);
    ASSERT_TRUE(copies.loaded) << copies.detail;
    EXPECT_EQ(copies.mesh.report.duplicate_faces, 49u * 254u);
    EXPECT_EQ(copies.topology.faces, 254);
    LoadOptions refuse;
    refuse.duplicate_faces = DuplicateFacePolicy::Refuse;
    EXPECT_TRUE(refused_as(run(test::polygon_stack_off(256, 50, false), MeshFormat::Off, refuse),
                           MeshErrorKind::DuplicateFace));
    EXPECT_TRUE(refused_as(run(test::polygon_stack_off(256, 50, true), MeshFormat::Off),
                           MeshErrorKind::ZeroAreaFace));
}

}  // namespace
}  // namespace holoflow::engine
