#include "holoflow/engine/mesh_reader.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <gtest/gtest.h>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

#include "support/test_support.h"

namespace holoflow::engine {
namespace {

using Polygons = std::vector<std::vector<std::int64_t>>;
using test::slurp;

// OpenMesh stores float coordinates: a decimal read into float and into double agree to a few
// float ulps (relative 2^-23 each; 1e-6 leaves room for the decimal -> float double rounding).
constexpr double kFloatTol = 1e-6;

Polygons polygons_of(const PolygonSoup& s) {
    Polygons out;
    for (std::size_t p = 0; p < s.n_polygons(); ++p)
        out.emplace_back(s.indices.begin() + static_cast<std::ptrdiff_t>(s.offsets[p]),
                         s.indices.begin() + static_cast<std::ptrdiff_t>(s.offsets[p + 1]));
    return out;
}

// Regular-ish tetrahedron used by every format; positions chosen to be exact in binary.
const std::vector<double> kTetraPositions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
const Polygons kTetraFaces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

MeshErrorKind read_kind(const std::string& path) {
    try {
        read_polygon_soup(path);
    } catch (const MeshError& e) {
        return e.kind;
    }
    ADD_FAILURE() << "expected a MeshError reading " << path;
    return MeshErrorKind::TooLarge;  // a kind the reader never produces
}

//! The error parsing `bytes` gives (kind and detail); a failure where it gives none.
MeshError parse_error(const std::string& bytes, MeshFormat format) {
    try {
        parse_polygon_soup(bytes.data(), bytes.size(), format);
    } catch (const MeshError& e) {
        return e;
    }
    ADD_FAILURE() << "expected a MeshError parsing:\n" << bytes.substr(0, 200);
    return MeshError(MeshErrorKind::TooLarge, "");  // a kind the reader never produces
}

MeshErrorKind parse_kind(const std::string& bytes, MeshFormat format) { return parse_error(bytes, format).kind; }

//! Binary writer for PLY/STL test files with a chosen byte order.
class Bytes {
  public:
    explicit Bytes(bool big_endian) : big_(big_endian) {}
    Bytes& text(const std::string& s) {
        data_ += s;
        return *this;
    }
    template <class T>
    Bytes& put(T value) {
        char b[sizeof(T)];
        std::memcpy(b, &value, sizeof(T));
        if (big_ != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
        data_.append(b, sizeof(T));
        return *this;
    }
    const std::string& str() const { return data_; }

  private:
    bool big_;
    std::string data_;
};

// ---------------------------------------------------------------------------------------------
// Error kinds

TEST(MeshError, NamesAndExitStatusesAreDistinct) {
    std::set<std::string> names;
    std::set<int> statuses;
    for (int k = 0; k <= static_cast<int>(MeshErrorKind::CoordinateRange); ++k) {
        const auto kind = static_cast<MeshErrorKind>(k);
        names.insert(to_string(kind));
        statuses.insert(exit_status(kind));
        EXPECT_EQ(exit_status(kind), 10 + k);
    }
    EXPECT_EQ(names.size(), 18u);
    EXPECT_EQ(statuses.size(), 18u);
    EXPECT_STREQ(to_string(MeshErrorKind::FileNotFound), "file_not_found");
    EXPECT_STREQ(to_string(MeshErrorKind::NonFiniteCoordinate), "non_finite_coordinate");
    EXPECT_STREQ(to_string(MeshErrorKind::TooLarge), "too_large");
    const MeshError e(MeshErrorKind::Truncated, "file ends after 2 of 4 vertices");
    EXPECT_STREQ(e.what(), "truncated: file ends after 2 of 4 vertices");
}

TEST(MeshReader, FormatFromExtensionIgnoresCase) {
    EXPECT_EQ(format_from_path("a/b.OFF"), MeshFormat::Off);
    EXPECT_EQ(format_from_path("x.obj"), MeshFormat::Obj);
    EXPECT_EQ(format_from_path("x.Ply"), MeshFormat::Ply);
    EXPECT_EQ(format_from_path("x.stl"), MeshFormat::Stl);
    EXPECT_THROW(format_from_path("x.xyz"), MeshError);
    EXPECT_THROW(format_from_path("noextension"), MeshError);
}

// ---------------------------------------------------------------------------------------------
// OFF

TEST(OffReader, Tetrahedron) {
    const test::TempDir dir;
    const std::string path = dir.write("tetra.off",
                                       "OFF\n# a comment\n4 4 6\n"
                                       "0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                                       "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
    const PolygonSoup s = read_polygon_soup(path);
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
    EXPECT_EQ(s.welded_vertices, 0u);
}

TEST(OffReader, ColouredQuadWithCountsOnKeywordLineAndComments) {
    const test::TempDir dir;
    const std::string path = dir.write("quad.off",
                                       "# leading comment\r\n\r\nCOFF 4 1 0 # counts here\r\n"
                                       "-1.5 +2 3e-1 255 0 0 255\r\n"
                                       "  1 0 0 #red\r\n"
                                       "1 1 0\r\n"
                                       "0 1 0.25\r\n"
                                       "4  0 1 2 3  0.5 0.5 0.5\r\n");
    const PolygonSoup s = read_polygon_soup(path);
    EXPECT_EQ(s.positions, (std::vector<double>{-1.5, 2, 0.3, 1, 0, 0, 1, 1, 0, 0, 1, 0.25}));
    EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 2, 3}}));
}

// Geomview's OFF is free-format: tokens may share or span lines. Such a file is read as one
// stream when it holds exactly the announced elements; colours after an element need the line
// layout, and a file that fits neither keeps the line reader's error.
TEST(OffReader, FreeLayoutIsReadAsATokenStream) {
    for (const std::string& off : {std::string("OFF\n4 4 6\n0 0 0 1 0 0 0 1 0 0 0 1\n3 0 2 1 3 0 1 3 3 0 3 2 3 1 2 3\n"),
                                  std::string("OFF\t4 4 6\t0 0 0\t1 0 0\t0 1 0\t0 0 1\t3 0 2 1\t3 0 1 3\t3 0 3 2\t3 1 2 3"),
                                  std::string("OFF\n4 4\n0 0\n0 1 0 0 # x y z may wrap\n0 1 0\n0 0 1\n3\n0 2 1\n"
                                              "3 0 1 3 3 0 3 2\n3 1 2 3\n# end\n")}) {
        SCOPED_TRACE(off);
        const PolygonSoup s = parse_polygon_soup(off.data(), off.size(), MeshFormat::Off);
        EXPECT_EQ(s.positions, kTetraPositions);
        EXPECT_EQ(polygons_of(s), kTetraFaces);
    }
    // One token too many or too few: the line reader's errors.
    const std::string extra = "OFF\n3 1 0\n0 0 0 1 0 0 0 1 0\n3 0 1 2 7\n";
    const std::string missing = "OFF\n3 1 0\n# padding for the size check\n0 0 0 1 0 0 0 1\n3 0 1 2\n";
    EXPECT_EQ(parse_kind(extra, MeshFormat::Off), MeshErrorKind::Truncated);
    EXPECT_EQ(parse_kind(missing, MeshFormat::Off), MeshErrorKind::Truncated);
}

TEST(OffReader, PrefixedKeywordsAccepted) {
    for (const std::string keyword : {"OFF", "COFF", "NOFF", "CNOFF", "STOFF", "STCNOFF"}) {
        SCOPED_TRACE(keyword);
        const std::string off = keyword + "\n3 1 0\n0 0 0 9 9 9\n1 0 0\n0 1 0\n3 0 1 2\n";
        const PolygonSoup s = parse_polygon_soup(off.data(), off.size(), MeshFormat::Off);
        EXPECT_EQ(s.n_vertices(), 3u);
        EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 2}}));
    }
}

TEST(OffReader, KeepsValuesTheLoaderMustJudge) {
    // NaN, infinity, overflow to infinity, out-of-range, negative and > 2^31 indices, and a
    // two-corner face are all kept as written: validating them is the loader's job.
    const std::string off =
        "OFF\n3 3 0\nnan 0 inf\n1e400 -1e400 1e-400\n0 0 0\n3 0 1 3000000000\n3 -1 0 7\n2 0 1\n";
    const PolygonSoup s = parse_polygon_soup(off.data(), off.size(), MeshFormat::Off);
    ASSERT_EQ(s.n_vertices(), 3u);
    EXPECT_TRUE(std::isnan(s.positions[0]));
    EXPECT_TRUE(std::isinf(s.positions[2]) && s.positions[2] > 0);
    EXPECT_TRUE(std::isinf(s.positions[3]) && s.positions[3] > 0);
    EXPECT_TRUE(std::isinf(s.positions[4]) && s.positions[4] < 0);
    EXPECT_EQ(s.positions[5], 0.0);
    EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 3000000000LL}, {-1, 0, 7}, {0, 1}}));
}

TEST(OffReader, RefusesFourDimensionalNdimAndBinary) {
    const std::string four = "4OFF\n1 0 0\n0 0 0 0\n";
    const std::string ndim = "nOFF\n3\n1 0 0\n0 0 0\n";
    const std::string binary = "OFF BINARY\n1 0 0\n";
    EXPECT_EQ(parse_kind(four, MeshFormat::Off), MeshErrorKind::ParseError);
    EXPECT_EQ(parse_kind(ndim, MeshFormat::Off), MeshErrorKind::ParseError);
    EXPECT_EQ(parse_kind(binary, MeshFormat::Off), MeshErrorKind::ParseError);
    try {  // named, not read as a vertex count
        parse_polygon_soup(four.data(), four.size(), MeshFormat::Off);
    } catch (const MeshError& e) {
        EXPECT_NE(std::string(e.what()).find("4D"), std::string::npos) << e.what();
    }
    try {
        parse_polygon_soup(binary.data(), binary.size(), MeshFormat::Off);
    } catch (const MeshError& e) {
        EXPECT_NE(e.detail.find("binary"), std::string::npos) << e.detail;
    }
}

TEST(OffReader, FewerVerticesThanAnnouncedIsTruncated) {
    const test::TempDir dir;
    const std::string path = dir.write("short.off",
                                       "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
                                       "                                         \n");
    // The face line is read as vertex 3 ("3 0 1 2" has three numbers), then faces run out.
    EXPECT_EQ(read_kind(path), MeshErrorKind::Truncated);
    const std::string cut = "OFF\n4 1 0\n0 0 0\n1 0 0\n                              \n";
    const MeshError short_error = parse_error(cut, MeshFormat::Off);
    EXPECT_EQ(short_error.kind, MeshErrorKind::Truncated);
    EXPECT_NE(short_error.detail.find("2 of 4 vertices"), std::string::npos) << short_error.detail;
    // Comment padding keeps the header size check satisfied so that the cut itself is found.
    const std::string face_cut = "OFF\n3 1 0\n# padding\n0 0 0\n1 0 0\n0 1 0\n3 0 1";
    EXPECT_EQ(parse_kind(face_cut, MeshFormat::Off), MeshErrorKind::Truncated);
}

// CGAL's prim.off lists one face more than its header says; like other readers we stop at the
// announced count, and count what was left out.
TEST(OffReader, LinesAfterTheAnnouncedFacesAreCountedNotRead) {
    const std::string extra = "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n# comment\n3 0 1 3\n\n3 1 2 3\n";
    const PolygonSoup s = parse_polygon_soup(extra.data(), extra.size(), MeshFormat::Off);
    EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 2}}));
    EXPECT_EQ(s.ignored_lines, 2u);
}

TEST(OffReader, HugeHeaderCountIsRefusedQuickly) {
    const test::TempDir dir;
    const std::string path =
        dir.write("huge.off", "OFF\n1000000000000 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n");
    try {
        read_polygon_soup(path);  // would need 24 TB if the count were believed
        ADD_FAILURE() << "expected header_mismatch";
    } catch (const MeshError& e) {
        EXPECT_EQ(e.kind, MeshErrorKind::HeaderMismatch);
        EXPECT_NE(e.detail.find("1000000000000 vertices"), std::string::npos) << e.detail;
    }
    // Counts at the edge of 64 bits must not overflow the size check.
    const std::string edge = "OFF\n3074457345618258603 0 0\n0 0 0\n";
    EXPECT_EQ(parse_kind(edge, MeshFormat::Off), MeshErrorKind::HeaderMismatch);
    const std::string negative = "OFF\n-3 1 0\n0 0 0\n";
    EXPECT_EQ(parse_kind(negative, MeshFormat::Off), MeshErrorKind::HeaderMismatch);
}

TEST(OffReader, GarbageTokenIsParseErrorWithLine) {
    const test::TempDir dir;
    const std::string path = dir.write("bad.off", "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n");
    EXPECT_EQ(read_kind(path), MeshErrorKind::ParseError);
    const std::string bad = "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n";
    try {
        parse_polygon_soup(bad.data(), bad.size(), MeshFormat::Off);
    } catch (const MeshError& e) {
        EXPECT_NE(e.detail.find("line 4"), std::string::npos) << e.detail;
        EXPECT_NE(e.detail.find("'zero'"), std::string::npos) << e.detail;
    }
    const std::string bad_index = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n";
    EXPECT_EQ(parse_kind(bad_index, MeshFormat::Off), MeshErrorKind::ParseError);
    const std::string bad_keyword = "OFX\n3 1 0\n";
    EXPECT_EQ(parse_kind(bad_keyword, MeshFormat::Off), MeshErrorKind::ParseError);
}

// ---------------------------------------------------------------------------------------------
// OBJ

TEST(ObjReader, TetrahedronWithAllCornerForms) {
    const test::TempDir dir;
    const std::string path =
        dir.write("tetra.obj",
                  "# tetra\nmtllib x.mtl\no tetra\n"
                  "v 0 0 0\nv 1 0 0 1.0\nv 0 1 0 0.5 0.5 0.5\nv 0 0 1\n"
                  "vt 0 0\nvt 1 0\nvn 0 0 1\ng group\ns off\nusemtl m\n"
                  "f 1 3 2\nf 1/1 2/2 4/1\nf 1//1 4//1 3//1\nf 2/1/1 3/2/1 4/1/1\n"
                  "l 1 2\np 3\n");
    const PolygonSoup s = read_polygon_soup(path);
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
}

TEST(ObjReader, NegativeIndicesAreRelativeToVerticesReadSoFar) {
    const std::string obj =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -1 -2\n"
        "v 0 0 1\nf -4/-1 -3/-2 -1/-1\nf -4//-1 -1//-1 -2//-1\nf -3 -2 -1\n";
    const PolygonSoup s = parse_polygon_soup(obj.data(), obj.size(), MeshFormat::Obj);
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
}

TEST(ObjReader, QuadWithLineContinuation) {
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 1 1 \\\n 0\nv 0 1 0\nf 1 2 \\\r\n3 4\n";
    const PolygonSoup s = parse_polygon_soup(obj.data(), obj.size(), MeshFormat::Obj);
    EXPECT_EQ(s.positions, (std::vector<double>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}));
    EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 2, 3}}));
}

TEST(ObjReader, Errors) {
    const std::string zero = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n";
    EXPECT_EQ(parse_kind(zero, MeshFormat::Obj), MeshErrorKind::ParseError);
    const std::string garbage = "v 0 0 0\nv 1 0 x\n";
    EXPECT_EQ(parse_kind(garbage, MeshFormat::Obj), MeshErrorKind::ParseError);
    const std::string bad_corner = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3a\n";
    EXPECT_EQ(parse_kind(bad_corner, MeshFormat::Obj), MeshErrorKind::ParseError);
    const std::string comments_only = "# nothing\n\ng empty\n";
    EXPECT_EQ(parse_kind(comments_only, MeshFormat::Obj), MeshErrorKind::EmptyFile);
}

// ---------------------------------------------------------------------------------------------
// PLY

const char* kPlyTetraAscii =
    "ply\nformat ascii 1.0\ncomment made by hand\nobj_info none\n"
    "element vertex 4\nproperty float x\nproperty double y\nproperty uchar red\nproperty int z\n"
    "property list uchar float texcoord\n"
    "element face 4\nproperty int flags\nproperty list uchar int vertex_indices\n"
    "property list int int other_list\n"
    "element edge 2\nproperty list uint8 uint32 ends\nproperty float weight\n"
    "end_header\n"
    "0 0 9 0 2 0.5 0.5\n1 0 9 0 0\n0 1 9 0 1 7\n0 0 9 1 0\n"
    "7 3 0 2 1 0\n7 3 0 1 3 2 5 5\n7 3 0 3 2 1 9\n7 3 1 2 3 0\n"
    "2 0 1 0.5\n2 2 3 0.5\n";

TEST(PlyReader, AsciiWithExtraPropertiesAndUnknownElement) {
    const test::TempDir dir;
    const PolygonSoup s = read_polygon_soup(dir.write("tetra.ply", kPlyTetraAscii));
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
}

// Blender 2.4 wrote a "Created by ..." line without the comment keyword after the format line.
// Before the first element a line of no known keyword cannot change how the data reads: it is
// skipped. Among the elements it could be a property misspelt, and is refused.
TEST(PlyReader, UnknownLinesBeforeTheFirstElementAreComments) {
    std::string blender = kPlyTetraAscii;
    blender.insert(blender.find("comment"), "Created by Blender3D 247 - www.blender.org, source file: \n");
    const PolygonSoup s = parse_polygon_soup(blender.data(), blender.size(), MeshFormat::Ply);
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
    std::string misspelt = kPlyTetraAscii;
    misspelt.replace(misspelt.find("property double y"), 8, "propery");
    EXPECT_EQ(parse_kind(misspelt, MeshFormat::Ply), MeshErrorKind::ParseError);
}

// The tetrahedron in binary with mixed types, an extra list and an unknown element between.
std::string binary_tetra_ply(bool big_endian) {
    Bytes b(big_endian);
    b.text(std::string("ply\nformat ") +
           (big_endian ? "binary_big_endian" : "binary_little_endian") +
           " 1.0\nelement vertex 4\nproperty float x\nproperty double y\nproperty short red\n"
           "property int z\nproperty list uchar float texcoord\n"
           "element material 2\nproperty uchar r\nproperty float shininess\n"
           "element face 4\nproperty list uchar int vertex_index\nproperty uint16 flags\n"
           "element edge 1\nproperty list int uint ends\n"
           "end_header\n");
    for (int v = 0; v < 4; ++v) {
        b.put(static_cast<float>(kTetraPositions[3 * v]));
        b.put(static_cast<double>(kTetraPositions[3 * v + 1]));
        b.put(static_cast<std::int16_t>(-7));
        b.put(static_cast<std::int32_t>(kTetraPositions[3 * v + 2]));
        b.put(static_cast<std::uint8_t>(v % 2 == 0 ? 2 : 0));
        if (v % 2 == 0) b.put(0.25f).put(0.75f);
    }
    for (int m = 0; m < 2; ++m) b.put(static_cast<std::uint8_t>(m)).put(1.5f);
    for (const auto& f : kTetraFaces) {
        b.put(static_cast<std::uint8_t>(f.size()));
        for (auto i : f) b.put(static_cast<std::int32_t>(i));
        b.put(static_cast<std::uint16_t>(0xabcd));
    }
    b.put(static_cast<std::int32_t>(2)).put(std::uint32_t{0}).put(std::uint32_t{1});
    return b.str();
}

TEST(PlyReader, BinaryLittleEndian) {
    const test::TempDir dir;
    const PolygonSoup s = read_polygon_soup(dir.write("tetra.ply", binary_tetra_ply(false)));
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
}

TEST(PlyReader, BinaryBigEndian) {
    const test::TempDir dir;
    const PolygonSoup s = read_polygon_soup(dir.write("tetra.ply", binary_tetra_ply(true)));
    EXPECT_EQ(s.positions, kTetraPositions);
    EXPECT_EQ(polygons_of(s), kTetraFaces);
}

TEST(PlyReader, LargeUnsignedIndicesKeptAsInt64) {
    Bytes b(false);
    b.text(
        "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar uint vertex_indices\nend_header\n");
    b.put(1.0f).put(2.0f).put(3.0f);
    b.put(std::uint8_t{3})
        .put(std::uint32_t{0})
        .put(std::uint32_t{4000000000u})
        .put(std::uint32_t{1});
    const PolygonSoup s = parse_polygon_soup(b.str().data(), b.str().size(), MeshFormat::Ply);
    EXPECT_EQ(s.positions, (std::vector<double>{1, 2, 3}));
    EXPECT_EQ(polygons_of(s), (Polygons{{0, 4000000000LL, 1}}));
}

// Strip 0 1 2 3 4 gives (0 1 2) (2 1 3) (2 3 4); after a -1 restart the parity starts again;
// the repeated vertices of a joined strip give degenerate triangles that are skipped.
// The second strip joins [5 6 7] and [8 9 10]; 7 is repeated twice so that [8 9 10] starts at an
// even position and keeps its winding.
const std::vector<std::int32_t> kStrips = {0, 1, 2, 3, 4, -1, 5, 6, 7, 7, 7, 8, 8, 9, 10};
const Polygons kStripTriangles = {{0, 1, 2}, {2, 1, 3}, {2, 3, 4}, {5, 6, 7}, {8, 9, 10}};

TEST(PlyReader, TristripsAsciiDecodeWithAlternatingWinding) {
    std::string ply =
        "ply\nformat ascii 1.0\nelement vertex 11\nproperty float x\nproperty float y\n"
        "property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n";
    for (int v = 0; v < 11; ++v) ply += std::to_string(v) + " 0 0\n";
    ply += std::to_string(kStrips.size());
    for (auto i : kStrips) ply.append(" ").append(std::to_string(i));
    ply += "\n";
    const PolygonSoup s = parse_polygon_soup(ply.data(), ply.size(), MeshFormat::Ply);
    EXPECT_EQ(s.n_vertices(), 11u);
    EXPECT_EQ(polygons_of(s), kStripTriangles);
}

TEST(PlyReader, TristripsBinaryDecodeWithAlternatingWinding) {
    for (const bool big : {false, true}) {
        SCOPED_TRACE(big ? "big endian" : "little endian");
        Bytes b(big);
        b.text(std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
               " 1.0\nelement vertex 11\nproperty float x\nproperty float y\nproperty float z\n"
               "element tristrips 2\nproperty list int int vertex_indices\nend_header\n");
        for (int v = 0; v < 11; ++v) b.put(static_cast<float>(v)).put(0.0f).put(0.0f);
        // Split the strips over two records: the first five indices, then the rest.
        b.put(std::int32_t{5});
        for (std::size_t k = 0; k < 5; ++k) b.put(kStrips[k]);
        b.put(static_cast<std::int32_t>(kStrips.size() - 6));
        for (std::size_t k = 6; k < kStrips.size(); ++k) b.put(kStrips[k]);
        const PolygonSoup s = parse_polygon_soup(b.str().data(), b.str().size(), MeshFormat::Ply);
        EXPECT_EQ(s.n_vertices(), 11u);
        EXPECT_EQ(s.positions[3 * 10], 10.0);
        EXPECT_EQ(polygons_of(s), kStripTriangles);
    }
}

TEST(PlyReader, BinaryCutShortIsTruncated) {
    const std::string full = binary_tetra_ply(false);
    const test::TempDir dir;
    // Cut inside the face lists (the fixed-size header check still passes).
    const std::string path = dir.write("cut.ply", full.substr(0, full.size() - 20));
    EXPECT_EQ(read_kind(path), MeshErrorKind::Truncated);
}

TEST(PlyReader, HeaderCountsBeyondFileSizeAreRefusedBeforeReading) {
    Bytes b(false);
    b.text(
        "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000000\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n");
    b.put(1.0f).put(2.0f).put(3.0f);
    EXPECT_EQ(parse_kind(b.str(), MeshFormat::Ply), MeshErrorKind::HeaderMismatch);
    // A list count larger than the remaining bytes.
    Bytes l(false);
    l.text(
        "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uint int vertex_indices\nend_header\n");
    l.put(std::uint32_t{4000000000u}).put(std::int32_t{0});
    EXPECT_EQ(parse_kind(l.str(), MeshFormat::Ply), MeshErrorKind::Truncated);
    Bytes n(false);
    n.text(
        "ply\nformat binary_little_endian 1.0\nelement face 1\n"
        "property list int int vertex_indices\nend_header\n");
    n.put(std::int32_t{-2}).put(std::int32_t{0});
    EXPECT_EQ(parse_kind(n.str(), MeshFormat::Ply), MeshErrorKind::HeaderMismatch);
    const std::string negative = "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n";
    EXPECT_EQ(parse_kind(negative, MeshFormat::Ply), MeshErrorKind::HeaderMismatch);
}

TEST(PlyReader, HeaderErrors) {
    const std::string no_z =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nend_header\n0 0\n";
    EXPECT_EQ(parse_kind(no_z, MeshFormat::Ply), MeshErrorKind::ParseError);
    const std::string no_list =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property int a\nend_header\n0 0 0\n1\n";
    EXPECT_EQ(parse_kind(no_list, MeshFormat::Ply), MeshErrorKind::ParseError);
    const std::string bad_type =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n"
        "end_header\n0\n";
    EXPECT_EQ(parse_kind(bad_type, MeshFormat::Ply), MeshErrorKind::ParseError);
    const std::string twice_x =
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n0 1 2 3\n";
    EXPECT_EQ(parse_kind(twice_x, MeshFormat::Ply), MeshErrorKind::ParseError);
    const std::string no_end = "ply\nformat ascii 1.0\nelement vertex 1\n";
    EXPECT_EQ(parse_kind(no_end, MeshFormat::Ply), MeshErrorKind::Truncated);
    const std::string not_ply = "plx\nformat ascii 1.0\nend_header\n";
    EXPECT_EQ(parse_kind(not_ply, MeshFormat::Ply), MeshErrorKind::ParseError);
    const std::string ascii_short =
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n0 0 0\n1 1\n   \n";
    EXPECT_EQ(parse_kind(ascii_short, MeshFormat::Ply), MeshErrorKind::Truncated);
}

// ---------------------------------------------------------------------------------------------
// STL

std::string ascii_stl_tetra() {
    std::string s = "solid tetra\n";
    for (const auto& f : kTetraFaces) {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for (auto i : f) {
            s += "      vertex";
            for (int d = 0; d < 3; ++d) {
                const double x = kTetraPositions[static_cast<std::size_t>(3 * i + d)];
                // Write one corner's zero as -0: welding must treat it as 0.
                s += ' ';
                s += (x == 0.0 && i == 3 && f[0] == 1) ? std::string("-0") : std::to_string(x);
            }
            s += "\n";
        }
        s += "    endloop\n  endfacet\n";
    }
    return s + "endsolid tetra\n";
}

std::string binary_stl_tetra(const std::string& header80) {
    Bytes b(false);
    std::string header = header80;
    header.resize(80, ' ');
    b.text(header).put(static_cast<std::uint32_t>(kTetraFaces.size()));
    for (const auto& f : kTetraFaces) {
        b.put(0.0f).put(0.0f).put(1.0f);
        for (auto i : f)
            for (int d = 0; d < 3; ++d)
                b.put(static_cast<float>(kTetraPositions[static_cast<std::size_t>(3 * i + d)]));
        b.put(std::uint16_t{0});
    }
    return b.str();
}

TEST(StlReader, AsciiTetrahedronIsWelded) {
    const test::TempDir dir;
    const PolygonSoup s = read_polygon_soup(dir.write("tetra.stl", ascii_stl_tetra()));
    // First appearance order: 0, 2, 1 from the first facet, then 3.
    EXPECT_EQ(s.positions, (std::vector<double>{0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1}));
    EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {2, 1, 3}}));
    EXPECT_EQ(s.welded_vertices, 12u - 4u);
    EXPECT_FALSE(std::signbit(s.positions[9]));  // -0 merged into +0
}

TEST(StlReader, BinaryTetrahedronIsWeldedEvenWithSolidHeader) {
    const test::TempDir dir;
    for (const std::string header : {"binary tetra", "solid but binary"}) {
        SCOPED_TRACE(header);
        const PolygonSoup s = read_polygon_soup(dir.write("tetra.stl", binary_stl_tetra(header)));
        EXPECT_EQ(s.positions, (std::vector<double>{0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1}));
        EXPECT_EQ(polygons_of(s), (Polygons{{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {2, 1, 3}}));
        EXPECT_EQ(s.welded_vertices, 8u);
    }
}

// Some exporters write the whole file on one line, or the first facet on the solid's line; the
// solid's name then stops before the keyword that starts the next item.
TEST(StlReader, AsciiFacetsOnTheSolidLineAreRead) {
    std::string one_line = ascii_stl_tetra();
    std::replace(one_line.begin(), one_line.end(), '\n', ' ');
    EXPECT_EQ(polygons_of(parse_polygon_soup(one_line.data(), one_line.size(), MeshFormat::Stl)),
              (Polygons{{0, 1, 2}, {0, 2, 3}, {0, 3, 1}, {2, 1, 3}}));
    const std::string two_solids = "solid a facet normal 0 0 1 outer loop vertex 0 0 0 "
                                   "vertex 1 0 0 vertex 0 1 0 endloop endfacet endsolid a "
                                   "solid b facet outer loop vertex 0 0 0 vertex 0 1 0 "
                                   "vertex 0 0 1 endloop endfacet endsolid b";
    EXPECT_EQ(polygons_of(parse_polygon_soup(two_solids.data(), two_solids.size(), MeshFormat::Stl)),
              (Polygons{{0, 1, 2}, {0, 2, 3}}));
    // NUL padding after the last endsolid is not data (and does not make the file binary).
    const std::string padded = ascii_stl_tetra() + std::string(37, '\0');
    EXPECT_EQ(parse_polygon_soup(padded.data(), padded.size(), MeshFormat::Stl).n_polygons(), 4u);
}

TEST(StlReader, Errors) {
    const test::TempDir dir;
    const std::string full = binary_stl_tetra("binary");
    EXPECT_EQ(read_kind(dir.write("cut.stl", full.substr(0, full.size() - 7))),
              MeshErrorKind::Truncated);
    const std::string solid_cut = binary_stl_tetra("solid x");
    EXPECT_EQ(parse_kind(solid_cut.substr(0, solid_cut.size() - 50), MeshFormat::Stl),
              MeshErrorKind::Truncated);
    EXPECT_EQ(parse_kind(full + std::string(10, '\0'), MeshFormat::Stl),
              MeshErrorKind::HeaderMismatch);
    EXPECT_EQ(parse_kind(std::string("\x01\x02\x03", 3), MeshFormat::Stl),
              MeshErrorKind::Truncated);
    const std::string four_vertices =
        "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n"
        "vertex 0 1 0\nendloop\nendfacet\nendsolid q\n";
    EXPECT_EQ(parse_kind(four_vertices, MeshFormat::Stl), MeshErrorKind::ParseError);
    const std::string ascii_cut = "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n";
    EXPECT_EQ(parse_kind(ascii_cut, MeshFormat::Stl), MeshErrorKind::Truncated);
    // Bytes after endsolid that are not another solid are named, even binary ones.
    const std::string trailing = ascii_stl_tetra() + std::string("\x01\x00junk", 6);
    const MeshError after_end = parse_error(trailing, MeshFormat::Stl);
    EXPECT_EQ(after_end.kind, MeshErrorKind::ParseError);
    EXPECT_NE(after_end.detail.find("expected 'facet' or 'endsolid'"), std::string::npos) << after_end.detail;
    std::string empty_binary(80, ' ');
    empty_binary += std::string(4, '\0');
    EXPECT_EQ(parse_kind(empty_binary, MeshFormat::Stl), MeshErrorKind::EmptyFile);
}

// ---------------------------------------------------------------------------------------------
// File-level errors

// Text written by Windows tools may start with a UTF-8 byte order mark; old Mac OS ones end
// lines with '\r' alone.
TEST(MeshReader, ByteOrderMarkAndOldMacLineEndsAreRead) {
    const std::string bom = "\xEF\xBB\xBF";
    const std::string off = "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    const std::string ply = bom + kPlyTetraAscii, stl = bom + ascii_stl_tetra();
    EXPECT_EQ(polygons_of(parse_polygon_soup((bom + off).data(), bom.size() + off.size(), MeshFormat::Off)), kTetraFaces);
    EXPECT_EQ(polygons_of(parse_polygon_soup((bom + obj).data(), bom.size() + obj.size(), MeshFormat::Obj)), kTetraFaces);
    EXPECT_EQ(parse_polygon_soup(ply.data(), ply.size(), MeshFormat::Ply).n_polygons(), 4u);
    EXPECT_EQ(parse_polygon_soup(stl.data(), stl.size(), MeshFormat::Stl).n_polygons(), 4u);
    EXPECT_EQ(parse_kind(bom, MeshFormat::Off), MeshErrorKind::EmptyFile);
    // Classic Mac OS line ends ('\r' alone).
    std::string mac = obj;
    std::replace(mac.begin(), mac.end(), '\n', '\r');
    EXPECT_EQ(polygons_of(parse_polygon_soup(mac.data(), mac.size(), MeshFormat::Obj)), kTetraFaces);
    // UTF-16 text is named as such, not reported as an unknown statement of NUL bytes.
    for (const std::string& utf16_bom : {std::string("\xFE\xFF", 2), std::string("\xFF\xFE", 2)}) {
        std::string utf16 = utf16_bom;
        for (char c : obj) utf16 += utf16_bom[0] == '\xFE' ? std::string{'\0', c} : std::string{c, '\0'};
        try {
            parse_polygon_soup(utf16.data(), utf16.size(), MeshFormat::Obj);
            ADD_FAILURE() << "UTF-16 text was read";
        } catch (const MeshError& e) {
            EXPECT_EQ(e.kind, MeshErrorKind::ParseError);
            EXPECT_NE(std::string(e.what()).find("UTF-16"), std::string::npos) << e.what();
        }
    }
}

TEST(MeshReader, FileLevelErrors) {
    const test::TempDir dir;
    EXPECT_EQ(read_kind((dir.path() / "missing.off").string()), MeshErrorKind::FileNotFound);
    std::filesystem::create_directory(dir.path() / "folder.off");
    EXPECT_EQ(read_kind((dir.path() / "folder.off").string()), MeshErrorKind::Unreadable);
    // Refused before reading: a FIFO blocks until a writer comes, /dev/zero never ends.
    ASSERT_EQ(::mkfifo((dir.path() / "fifo.off").c_str(), 0600), 0);
    EXPECT_EQ(read_kind((dir.path() / "fifo.off").string()), MeshErrorKind::Unreadable);
    std::filesystem::create_symlink("/dev/zero", dir.path() / "zero.stl");
    EXPECT_EQ(read_kind((dir.path() / "zero.stl").string()), MeshErrorKind::Unreadable);
    EXPECT_EQ(read_kind(dir.write("points.xyz", "0 0 0\n")), MeshErrorKind::UnknownFormat);
    EXPECT_EQ(read_kind(dir.write("empty.off", "")), MeshErrorKind::EmptyFile);
    EXPECT_EQ(read_kind(dir.write("comments.off", "# only\n# comments\n")),
              MeshErrorKind::EmptyFile);
    EXPECT_EQ(read_kind(dir.write("zero.off", "OFF\n0 0 0\n")), MeshErrorKind::EmptyFile);
    // Over the memory limit: refused unread.
    const std::string tetra = dir.write("tetra.off", "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                                                     "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
    EXPECT_EQ(read_polygon_soup(tetra, std::filesystem::file_size(tetra)).n_polygons(), 4u);
    try {
        read_polygon_soup(tetra, std::filesystem::file_size(tetra) - 1);
        ADD_FAILURE() << "expected too_large";
    } catch (const MeshError& e) {
        EXPECT_EQ(e.kind, MeshErrorKind::TooLarge);
        EXPECT_NE(e.detail.find("memory limit"), std::string::npos) << e.detail;
    }
}

// Hostile bytes: every prefix and random byte flips of a valid file of each format must either
// parse or throw MeshError; anything else (another exception, a crash) fails the test.
TEST(MeshReader, CorruptedInputsOnlyThrowMeshError) {
    const std::uint64_t seed = 20240611;
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937_64 rng(seed);
    const std::string off =
        "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
        "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    const std::string obj =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1/1 2/2 4/1\n"
        "f -4//1 -1//1 -2//1\nf 2 3 4\n";
    const std::pair<std::string, MeshFormat> inputs[] = {{off, MeshFormat::Off},
                                                         {obj, MeshFormat::Obj},
                                                         {kPlyTetraAscii, MeshFormat::Ply},
                                                         {binary_tetra_ply(false), MeshFormat::Ply},
                                                         {binary_tetra_ply(true), MeshFormat::Ply},
                                                         {ascii_stl_tetra(), MeshFormat::Stl},
                                                         {binary_stl_tetra("x"), MeshFormat::Stl}};
    std::size_t parsed = 0, refused = 0;
    auto attempt = [&](const std::string& bytes, MeshFormat format) {
        // A copy sized exactly: reading past the end would touch memory outside the string.
        const std::vector<char> buffer(bytes.begin(), bytes.end());
        try {
            parse_polygon_soup(buffer.data(), buffer.size(), format);
            ++parsed;
        } catch (const MeshError&) {
            ++refused;
        }
    };
    for (const auto& [bytes, format] : inputs) {
        for (std::size_t n = 0; n < bytes.size(); ++n) attempt(bytes.substr(0, n), format);
        std::uniform_int_distribution<std::size_t> where(0, bytes.size() - 1);
        std::uniform_int_distribution<int> value(0, 255);
        const char interesting[] = {'-', '9', '\n', ' ', '\0', '\xff', '#', '/', 'e', '.'};
        std::uniform_int_distribution<std::size_t> pick(0, sizeof interesting - 1);
        for (int trial = 0; trial < 2000; ++trial) {
            std::string mutated = bytes;
            for (int k = 0; k < 1 + trial % 4; ++k) {
                mutated[where(rng)] =
                    trial % 2 == 0 ? static_cast<char>(value(rng)) : interesting[pick(rng)];
            }
            attempt(mutated, format);
        }
    }
    EXPECT_GT(parsed, 0u);
    EXPECT_GT(refused, 0u);
}

// ---------------------------------------------------------------------------------------------
// Real meshes

std::vector<std::filesystem::path> corpus_files(const std::string& extension) {
    std::vector<std::filesystem::path> files;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(HOLOFLOW_CORPUS_DIR, ec))
        if (entry.path().extension() == extension) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return files;
}

// Same polygon up to a rotation of its corner list.
bool same_cycle(const std::vector<std::int64_t>& a, const std::vector<std::int64_t>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t r = 0; r < a.size(); ++r) {
        bool equal = true;
        for (std::size_t k = 0; k < a.size() && equal; ++k) equal = a[(r + k) % a.size()] == b[k];
        if (equal) return true;
    }
    return a.empty();
}

//! The file without '#' comments and without the blank lines they leave behind.
std::string strip_comments(const std::string& bytes) {
    std::string out, line;
    std::size_t pos = 0;
    while (pos < bytes.size()) {
        std::size_t nl = bytes.find('\n', pos);
        if (nl == std::string::npos) nl = bytes.size();
        line = bytes.substr(pos, nl - pos);
        line = line.substr(0, line.find('#'));
        if (line.find_first_not_of(" \t\r") != std::string::npos) out += line + '\n';
        pos = nl + 1;
    }
    return out;
}

TEST(OffReader, CorpusAgreesWithOpenMesh) {
    const auto files = corpus_files(".off");
    const test::TempDir dir;
    std::size_t compared = 0, same_faces = 0, stripped_files = 0, duplicating = 0;
    for (const auto& file : files) {
        SCOPED_TRACE(file.string());
        const PolygonSoup ours = read_polygon_soup(file.string());
        // OpenMesh's OFF reader does not understand '#' comments (it fails on a commented header
        // and reads comments in the body as numbers); it gets a copy with the comments removed.
        std::string reference = file.string();
        const std::string bytes = slurp(file);
        if (bytes.find('#') != std::string::npos) {
            reference = dir.write(file.filename().string(), strip_comments(bytes));
            ++stripped_files;
        }
        OpenMesh::PolyMesh_ArrayKernelT<> theirs;
        if (!OpenMesh::IO::read_mesh(theirs, reference)) {
            ADD_FAILURE() << "OpenMesh could not read it";
            continue;
        }
        ++compared;
        // OpenMesh adds a face it cannot insert ("complex") on fresh copies of its vertices,
        // appended after the file's vertices. Both sides' corners are mapped to the first
        // vertex at their position, so the file's vertices and faces can be compared exactly.
        ASSERT_GE(theirs.n_vertices(), ours.n_vertices());
        const auto n = static_cast<int>(ours.n_vertices());
        std::map<std::array<float, 3>, int> first_at;
        std::vector<std::int64_t> canonical(theirs.n_vertices());
        for (const auto vh : theirs.vertices()) {
            const auto& p = theirs.point(vh);
            const auto it =
                first_at.emplace(std::array<float, 3>{p[0], p[1], p[2]}, vh.idx()).first;
            ASSERT_TRUE(vh.idx() < n || it->second < n)
                << "OpenMesh vertex " << vh.idx() << " is no copy of a file vertex";
            canonical[static_cast<std::size_t>(vh.idx())] = it->second;
            if (vh.idx() >= n) continue;
            for (int d = 0; d < 3; ++d) {
                const double x = ours.positions[3 * static_cast<std::size_t>(vh.idx()) +
                                                static_cast<std::size_t>(d)];
                ASSERT_NEAR(x, p[d], kFloatTol * std::max(1.0, std::abs(x)));
            }
        }
        if (theirs.n_vertices() > ours.n_vertices()) ++duplicating;
        EXPECT_GE(ours.n_polygons(), theirs.n_faces());  // OpenMesh may drop "complex" faces
        if (ours.n_polygons() != theirs.n_faces()) continue;
        ++same_faces;
        const Polygons polys = polygons_of(ours);
        for (const auto fh : theirs.faces()) {
            std::vector<std::int64_t> mine = polys[static_cast<std::size_t>(fh.idx())], cycle;
            for (auto& i : mine) {
                ASSERT_TRUE(i >= 0 && i < n);
                i = canonical[static_cast<std::size_t>(i)];
            }
            for (const auto vh : theirs.fv_range(fh))
                cycle.push_back(canonical[static_cast<std::size_t>(vh.idx())]);
            ASSERT_TRUE(same_cycle(mine, cycle)) << "face " << fh.idx();
        }
    }
    EXPECT_GE(compared, 50u) << "corpus at " << HOLOFLOW_CORPUS_DIR;
    std::printf(
        "[ corpus   ] %zu OFF files compared with OpenMesh (%zu with comments removed for "
        "OpenMesh, %zu where OpenMesh duplicated vertices), %zu with identical faces\n",
        compared, stripped_files, duplicating, same_faces);
    EXPECT_GE(same_faces, compared / 2);  // most corpus meshes are plain manifold meshes
}

TEST(PlyReader, CorpusPlyAndStlFiles) {
    // sphere.off, sphere.ply and sphere.stl of libcgal-demo hold the same 162-vertex sphere.
    const std::string dir = HOLOFLOW_CORPUS_DIR;
    if (!std::filesystem::exists(dir + "/sphere.ply") ||
        !std::filesystem::exists(dir + "/sphere.stl"))
        GTEST_SKIP() << "sphere.ply/stl not in the corpus";
    const PolygonSoup off = read_polygon_soup(dir + "/sphere.off");
    const PolygonSoup ply = read_polygon_soup(dir + "/sphere.ply");
    const PolygonSoup stl = read_polygon_soup(dir + "/sphere.stl");
    EXPECT_EQ(ply.n_vertices(), off.n_vertices());
    EXPECT_EQ(ply.n_polygons(), off.n_polygons());
    EXPECT_EQ(stl.n_polygons(), off.n_polygons());
    EXPECT_EQ(stl.n_vertices(), off.n_vertices());
    EXPECT_EQ(stl.welded_vertices, 3 * stl.n_polygons() - stl.n_vertices());
}

TEST(PlyReader, IgeaTristrips) {
    const std::string path = std::string(HOLOFLOW_SHARED_MESHES) + "/igea.ply";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
    const PolygonSoup s = read_polygon_soup(path);
    EXPECT_EQ(s.n_vertices(), 134345u);
    EXPECT_EQ(s.n_polygons(), 268686u);
    // A closed genus-0 triangle mesh has F = 2V - 4: the strip decoding lost and added nothing.
    EXPECT_EQ(s.n_polygons(), 2 * s.n_vertices() - 4);
    std::size_t bad = 0;
    for (std::size_t p = 0; p < s.n_polygons(); ++p) {
        const auto* t = s.indices.data() + s.offsets[p];
        if (s.offsets[p + 1] - s.offsets[p] != 3 || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
            std::min({t[0], t[1], t[2]}) < 0 ||
            std::max({t[0], t[1], t[2]}) >= static_cast<std::int64_t>(s.n_vertices()))
            ++bad;
    }
    EXPECT_EQ(bad, 0u);
}

}  // namespace
}  // namespace holoflow::engine
