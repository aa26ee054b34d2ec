#include "holoflow/engine/segmentation_output.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "holoflow/engine/mesh_reader.h"
#include "holoflow/kernels/shapes.h"

namespace holoflow::engine {
namespace {

using Picture = SegmentationPicture;
using Complex = std::complex<double>;

// ---------------------------------------------------------------------------------------------
// Pictures

//! Two unit squares side by side in z = 0, left one patch 0 (uv = xy), right one patch 1 with a
//! chart twice as large (uv = 2 (x - 1, y)). Faces of the two patches alternate in index order.
Picture two_squares() {
    Picture p;
    p.V.resize(6, 3);
    p.V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0;
    p.F.resize(4, 3);
    p.F << 1, 2, 5,  // patch 1
        0, 1, 4,     // patch 0
        1, 5, 4,     // patch 1
        0, 4, 3;     // patch 0
    p.face_patch = {1, 0, 1, 0};
    p.patch_size = {{1.0, 1.0}, {2.0, 2.0}};
    for (Index f = 0; f < 4; ++f)
        for (int k = 0; k < 3; ++k) {
            const double x = p.V(p.F(f, k), 0), y = p.V(p.F(f, k), 1);
            p.corner_uv.push_back(p.face_patch[f] == 0 ? Complex(x, y)
                                                       : Complex(2 * (x - 1), 2 * y));
        }
    return p;
}

//! shapes::flat_grid(n, n) cut into 4 patches by quadrant of the face centroid: patch
//! (x >= 1/2) + 2 (y >= 1/2), chart uv = xy minus the quadrant's corner, size 1/2 x 1/2.
Picture quadrants(int n) {
    const MeshView grid = shapes::flat_grid(n, n);
    Picture p;
    p.V = grid.V;
    p.F = grid.F;
    p.patch_size.assign(4, {0.5, 0.5});
    for (Index f = 0; f < grid.n_faces(); ++f) {
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (int k = 0; k < 3; ++k) c += grid.V.row(grid.F(f, k)).transpose() / 3.0;
        const int qx = c.x() >= 0.5, qy = c.y() >= 0.5;
        p.face_patch.push_back(qx + 2 * qy);
        for (int k = 0; k < 3; ++k)
            p.corner_uv.emplace_back(grid.V(grid.F(f, k), 0) - 0.5 * qx,
                                     grid.V(grid.F(f, k), 1) - 0.5 * qy);
    }
    return p;
}

template <class Writer>
std::string written(Writer writer, const Picture& p) {
    std::ostringstream out;
    writer(out, p);
    return out.str();
}

std::string ply_of(const Picture& p) { return written(write_segments_ply, p); }
std::string obj_of(const Picture& p) { return written(write_patches_obj, p); }
std::string lines_of(const Picture& p) { return written(write_trajectories_obj, p); }
std::string svg_of(const Picture& p) { return written(write_domains_svg, p); }

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
        ++n;
    return n;
}

std::vector<std::string> lines_starting(const std::string& text, const std::string& prefix) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
        if (line.rfind(prefix, 0) == 0) out.push_back(line);
    return out;
}

// ---------------------------------------------------------------------------------------------
// Hand parsing of segments.ply: the header lines and the binary records.

struct PlyFile {
    std::vector<std::string> header;  // lines up to and including end_header
    std::size_t data = 0;             // offset of the first vertex record
};

PlyFile split_ply(const std::string& bytes) {
    PlyFile f;
    std::size_t pos = 0;
    for (;;) {
        const std::size_t nl = bytes.find('\n', pos);
        if (nl == std::string::npos) {
            ADD_FAILURE() << "PLY header has no end_header";
            return f;
        }
        f.header.push_back(bytes.substr(pos, nl - pos));
        pos = nl + 1;
        if (f.header.back() == "end_header") break;
    }
    f.data = pos;
    return f;
}

template <class T>
T load_le(const std::string& bytes, std::size_t at) {
    char b[sizeof(T)];
    std::memcpy(b, bytes.data() + at, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
}

constexpr std::size_t kPlyVertexRecord = 5 * 8;            // x y z u v, doubles
constexpr std::size_t kPlyFaceRecord = 1 + 3 * 4 + 4 + 3;  // count, indices, patch, rgb

std::size_t ply_count(const PlyFile& f, const std::string& element) {
    for (const std::string& line : f.header)
        if (line.rfind("element " + element + " ", 0) == 0)
            return std::stoul(line.substr(9 + element.size()));
    ADD_FAILURE() << "no element " << element;
    return 0;
}

// ---------------------------------------------------------------------------------------------
// Hand parsing of an OBJ's vt and f lines (our reader keeps positions and faces only).

struct ObjCorners {
    std::vector<Complex> vt;
    std::vector<std::array<std::array<std::int64_t, 2>, 3>> faces;  // (v, vt), 1-based
    std::vector<std::string> groups;                                // in file order
    std::vector<std::size_t> group_of_face;
};

ObjCorners parse_obj_corners(const std::string& text) {
    ObjCorners o;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        std::istringstream words(line);
        std::string key;
        words >> key;
        if (key == "vt") {
            double u = 0, v = 0;
            words >> u >> v;
            o.vt.emplace_back(u, v);
        } else if (key == "g") {
            std::string name;
            words >> name;
            o.groups.push_back(name);
        } else if (key == "f") {
            std::array<std::array<std::int64_t, 2>, 3> face{};
            for (auto& corner : face) {
                std::string token;
                words >> token;
                const std::size_t slash = token.find('/');
                corner = {std::stoll(token.substr(0, slash)), std::stoll(token.substr(slash + 1))};
            }
            std::string extra;
            EXPECT_FALSE(words >> extra) << "a triangle line has more than 3 corners: " << line;
            o.faces.push_back(face);
            o.group_of_face.push_back(o.groups.size() - 1);
        }
    }
    return o;
}

// ---------------------------------------------------------------------------------------------
// SVG checks

//! Every element opened is closed in order (self-closing ones count as both), with <svg> the
//! one root; the XML declaration and comments are skipped. Not a full XML parser, but enough
//! to catch an unclosed group or a stray '<' in the output.
bool balanced_tags(const std::string& svg, std::string& why) {
    std::vector<std::string> open;
    int roots = 0;
    for (std::size_t at = svg.find('<'); at != std::string::npos; at = svg.find('<', at + 1)) {
        const std::size_t end = svg.find('>', at);
        if (end == std::string::npos) {
            why = "unterminated tag at " + std::to_string(at);
            return false;
        }
        const std::string tag = svg.substr(at + 1, end - at - 1);
        if (tag.starts_with('?') || tag.starts_with("!--")) continue;
        if (tag.find('<') != std::string::npos) {
            why = "'<' inside a tag at " + std::to_string(at);
            return false;
        }
        if (tag.starts_with('/')) {
            const std::string name = tag.substr(1);
            if (open.empty() || open.back() != name) {
                why = "</" + name + "> closes " + (open.empty() ? "nothing" : open.back());
                return false;
            }
            open.pop_back();
            continue;
        }
        std::size_t n = 0;
        while (n < tag.size() &&
               (std::isalnum(static_cast<unsigned char>(tag[n])) || tag[n] == ':'))
            ++n;
        const std::string name = tag.substr(0, n);
        if (name.empty()) {
            why = "tag without a name at " + std::to_string(at);
            return false;
        }
        if (open.empty()) ++roots;
        if (!tag.ends_with('/')) open.push_back(name);
        if (open.empty() || name == "svg") {
            if (name != "svg") {
                why = "element " + name + " outside <svg>";
                return false;
            }
        }
        at = end;
    }
    if (!open.empty()) {
        why = "<" + open.back() + "> never closed";
        return false;
    }
    if (roots != 1) {
        why = std::to_string(roots) + " root elements";
        return false;
    }
    return true;
}

void expect_no_non_finite_text(const std::string& text) {
    std::string lower(text);
    for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    EXPECT_EQ(lower.find("nan"), std::string::npos);
    EXPECT_EQ(lower.find("inf"), std::string::npos);
}

//! Numeric attribute `name` of the first `<element` after `from`.
double attribute(const std::string& svg, std::size_t from, const std::string& element,
                 const std::string& name) {
    const std::size_t tag = svg.find("<" + element + " ", from);
    const std::size_t at = svg.find(" " + name + "=\"", tag);
    EXPECT_NE(tag, std::string::npos);
    EXPECT_LT(at, svg.find('>', tag)) << "no " << name << " in <" << element;
    return std::stod(svg.substr(at + name.size() + 3));
}

std::size_t group_of_patch(const std::string& svg, Index p) {
    const std::size_t at = svg.find("<g id=\"patch-" + std::to_string(p) + "\">");
    EXPECT_NE(at, std::string::npos) << "no group for patch " << p;
    return at;
}

//! The triangles drawn in patch p's uv path (each is "M x y L x y L x y Z").
std::size_t drawn_triangles(const std::string& svg, Index p) {
    const std::size_t g = group_of_patch(svg, p);
    const std::size_t end = svg.find("</g>", g);
    const std::size_t path = svg.find("<path clip-path", g);
    if (path == std::string::npos || path > end) return 0;
    const std::size_t d = svg.find(" d=\"", path) + 4;
    const std::string data = svg.substr(d, svg.find('"', d) - d);
    EXPECT_EQ(count(data, "L"), 2 * count(data, "M"));
    return count(data, "Z");
}

//! Rectangles of patches 0 .. n-1 lie inside the picture and at least 8 px apart (the gap).
void expect_packed(const std::string& svg, Index n) {
    const double width = attribute(svg, 0, "svg", "width");
    const double height = attribute(svg, 0, "svg", "height");
    EXPECT_LE(width, 1600);
    std::vector<std::array<double, 4>> boxes;
    for (Index q = 0; q < n; ++q) {
        const std::size_t g = group_of_patch(svg, q);
        boxes.push_back({attribute(svg, g, "rect", "x"), attribute(svg, g, "rect", "y"),
                         attribute(svg, g, "rect", "width"), attribute(svg, g, "rect", "height")});
        const auto& b = boxes.back();
        EXPECT_GE(b[0], 0);
        EXPECT_GE(b[1], 0);
        EXPECT_LE(b[0] + b[2], width + 0.01) << q;
        EXPECT_LE(b[1] + b[3], height + 0.01) << q;
    }
    constexpr double kGapTol = 0.02;  // coordinates are written with 2 decimals
    for (std::size_t a = 0; a < boxes.size(); ++a)
        for (std::size_t b = a + 1; b < boxes.size(); ++b) {
            const auto &p = boxes[a], &q = boxes[b];
            const bool apart =
                p[0] + p[2] + 8 <= q[0] + kGapTol || q[0] + q[2] + 8 <= p[0] + kGapTol ||
                p[1] + p[3] + 8 <= q[1] + kGapTol || q[1] + q[3] + 8 <= p[1] + kGapTol;
            EXPECT_TRUE(apart) << "patches " << a << " and " << b << " overlap";
        }
}

// ---------------------------------------------------------------------------------------------
// patch_colour

double colour_distance(const std::array<std::uint8_t, 3>& a, const std::array<std::uint8_t, 3>& b) {
    double s = 0;
    for (int k = 0; k < 3; ++k) s += std::pow(double(a[k]) - double(b[k]), 2);
    return std::sqrt(s);
}

TEST(PatchColour, DeterministicAndNeighboursFarApart) {
    // Consecutive ids are 137.5 degrees apart in hue, ids two apart 85 degrees: at the fixed
    // saturation and value that is over 100 (of 441) in RGB for every id checked.
    constexpr double kNeighbourDistance = 100;
    for (Index p = 0; p < 2000; ++p) {
        EXPECT_GT(colour_distance(patch_colour(p), patch_colour(p + 1)), kNeighbourDistance) << p;
        EXPECT_GT(colour_distance(patch_colour(p), patch_colour(p + 2)), 0.6 * kNeighbourDistance)
            << p;
    }
    // The first dozen (what a typical segmentation uses) are pairwise distinguishable.
    for (Index a = 0; a < 12; ++a)
        for (Index b = a + 1; b < 12; ++b)
            EXPECT_GT(colour_distance(patch_colour(a), patch_colour(b)), 20) << a << " " << b;
    // Fixed values (hue 0.08 turn, saturation 0.55, value 0.93), so every picture of a run and
    // every run agree; value and saturation are the same for every id: max and min channel.
    EXPECT_EQ(patch_colour(0), (std::array<std::uint8_t, 3>{237, 169, 107}));
    for (Index p = 0; p < 2000; p += 7) {
        const auto c = patch_colour(p);
        EXPECT_NEAR(*std::max_element(c.begin(), c.end()), 237, 1) << p;
        EXPECT_NEAR(*std::min_element(c.begin(), c.end()), 107, 1) << p;
    }
    EXPECT_THROW(patch_colour(-1), InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// segments.ply

TEST(SegmentsPly, TwoSquaresSplitPerPatchInOrderOfFirstUse) {
    const Picture p = two_squares();
    const std::string bytes = ply_of(p);
    const PolygonSoup soup = parse_polygon_soup(bytes.data(), bytes.size(), MeshFormat::Ply);

    // Scanning corners in order: f0 (patch 1) introduces 1, 2, 5; f1 (patch 0) 0, 1, 4; f2
    // (patch 1) reuses 1 and 5 and adds 4; f3 (patch 0) reuses 0, 4 and adds 3. Vertices 1 and
    // 4 lie on the patch border and appear twice.
    const std::vector<Index> source = {1, 2, 5, 0, 1, 4, 4, 3};
    const std::vector<std::vector<std::int64_t>> faces = {
        {0, 1, 2}, {3, 4, 5}, {0, 2, 6}, {3, 5, 7}};
    ASSERT_EQ(soup.n_vertices(), source.size());
    ASSERT_EQ(soup.n_polygons(), faces.size());
    for (std::size_t i = 0; i < source.size(); ++i)
        for (int k = 0; k < 3; ++k)
            EXPECT_EQ(soup.positions[3 * i + k], p.V(source[i], k)) << "vertex " << i;
    for (std::size_t f = 0; f < faces.size(); ++f)
        EXPECT_EQ(std::vector<std::int64_t>(soup.indices.begin() + soup.offsets[f],
                                            soup.indices.begin() + soup.offsets[f + 1]),
                  faces[f]);

    // The header exactly as the header file documents it.
    const PlyFile file = split_ply(bytes);
    const std::vector<std::string> properties = {"element vertex 8",
                                                 "property double x",
                                                 "property double y",
                                                 "property double z",
                                                 "property double u",
                                                 "property double v",
                                                 "element face 4",
                                                 "property list uchar int vertex_indices",
                                                 "property int patch",
                                                 "property uchar red",
                                                 "property uchar green",
                                                 "property uchar blue",
                                                 "end_header"};
    ASSERT_GE(file.header.size(), 3u);
    EXPECT_EQ(file.header[0], "ply");
    EXPECT_EQ(file.header[1], "format binary_little_endian 1.0");
    std::vector<std::string> structure, comments;
    for (std::size_t i = 2; i < file.header.size(); ++i)
        (file.header[i].rfind("comment ", 0) == 0 ? comments : structure).push_back(file.header[i]);
    EXPECT_EQ(structure, properties);
    EXPECT_TRUE(std::count(comments.begin(), comments.end(), "comment holoflow segments"));
    EXPECT_TRUE(std::count(comments.begin(), comments.end(), "comment patches 2"));

    // Records by hand: nothing more, nothing less than the header announces.
    ASSERT_EQ(bytes.size(), file.data + 8 * kPlyVertexRecord + 4 * kPlyFaceRecord);
    for (std::size_t i = 0; i < source.size(); ++i) {
        const std::size_t at = file.data + i * kPlyVertexRecord;
        EXPECT_EQ(load_le<double>(bytes, at + 16), 0.0);  // z
        // u v: the chart of the patch of the face that introduced the vertex
        const bool right = i < 3 || i == 6;
        const double x = p.V(source[i], 0), y = p.V(source[i], 1);
        EXPECT_EQ(load_le<double>(bytes, at + 24), right ? 2 * (x - 1) : x) << i;
        EXPECT_EQ(load_le<double>(bytes, at + 32), right ? 2 * y : y) << i;
    }
    for (std::size_t f = 0; f < 4; ++f) {
        const std::size_t at = file.data + 8 * kPlyVertexRecord + f * kPlyFaceRecord;
        EXPECT_EQ(static_cast<unsigned char>(bytes[at]), 3u);
        for (int k = 0; k < 3; ++k)
            EXPECT_EQ(load_le<std::int32_t>(bytes, at + 1 + 4 * k), faces[f][k]);
        const auto patch = load_le<std::int32_t>(bytes, at + 13);
        EXPECT_EQ(patch, p.face_patch[f]);
        const auto rgb = patch_colour(patch);
        for (int k = 0; k < 3; ++k)
            EXPECT_EQ(static_cast<std::uint8_t>(bytes[at + 17 + k]), rgb[k]) << "face " << f;
    }
}

TEST(SegmentsPly, QuadrantGridCountsAndCharts) {
    constexpr int n = 224;  // 100 352 faces: the size the writers must stream
    const Picture p = quadrants(n);
    const std::string bytes = ply_of(p);
    const PolygonSoup soup = parse_polygon_soup(bytes.data(), bytes.size(), MeshFormat::Ply);
    // Each quadrant holds (n/2 + 1)^2 vertices of its own: the two mid lines are doubled and
    // the centre is quadrupled.
    const std::size_t per_quadrant = (n / 2 + 1) * (n / 2 + 1);
    ASSERT_EQ(soup.n_vertices(), 4 * per_quadrant);
    ASSERT_EQ(soup.n_vertices(), static_cast<std::size_t>(p.V.rows()) + 2 * n + 3);
    ASSERT_EQ(soup.n_polygons(), static_cast<std::size_t>(p.F.rows()));

    const PlyFile file = split_ply(bytes);
    ASSERT_EQ(ply_count(file, "vertex"), soup.n_vertices());
    ASSERT_EQ(ply_count(file, "face"), soup.n_polygons());
    ASSERT_EQ(bytes.size(), file.data + soup.n_vertices() * kPlyVertexRecord +
                                soup.n_polygons() * kPlyFaceRecord);
    std::int64_t next_new = 0;
    std::vector<int> patch_of_vertex(soup.n_vertices(), -1);
    for (std::size_t f = 0; f < soup.n_polygons(); ++f) {
        const std::size_t rec =
            file.data + soup.n_vertices() * kPlyVertexRecord + f * kPlyFaceRecord;
        const auto patch = load_le<std::int32_t>(bytes, rec + 13);
        ASSERT_EQ(patch, p.face_patch[f]);
        for (int k = 0; k < 3; ++k) {
            const std::int64_t v = soup.indices[soup.offsets[f] + k];
            // numbered in order of first use: a new number is always the next one
            ASSERT_LE(v, next_new);
            if (v == next_new) ++next_new;
            // same place as the input corner, one patch per output vertex, uv = xy - corner
            for (int a = 0; a < 3; ++a) ASSERT_EQ(soup.positions[3 * v + a], p.V(p.F(f, k), a));
            if (patch_of_vertex[v] < 0) patch_of_vertex[v] = patch;
            ASSERT_EQ(patch_of_vertex[v], patch) << "output vertex " << v << " in two patches";
            const std::size_t at = file.data + v * kPlyVertexRecord;
            EXPECT_EQ(load_le<double>(bytes, at + 24), p.corner_uv[3 * f + k].real());
            EXPECT_EQ(load_le<double>(bytes, at + 32), p.corner_uv[3 * f + k].imag());
        }
    }
    EXPECT_EQ(next_new, static_cast<std::int64_t>(soup.n_vertices()));
}

TEST(SegmentsPly, VertexSharedByManyPatchesIsSplitInLinearTime) {
    // A fan of 20 000 triangles around one centre, every triangle its own patch: the centre is
    // split 20 000 times (a quadratic search would take seconds here).
    constexpr Index kFan = 20000;
    Picture p;
    p.V.resize(kFan + 1, 3);
    p.V.row(0) << 0, 0, 0;
    for (Index i = 0; i < kFan; ++i) {
        const double a = 2 * std::numbers::pi * i / kFan;
        p.V.row(i + 1) << std::cos(a), std::sin(a), 0;
    }
    p.F.resize(kFan, 3);
    for (Index i = 0; i < kFan; ++i) {
        p.F.row(i) << 0, i + 1, (i + 1) % kFan + 1;
        p.face_patch.push_back(i);
        p.patch_size.push_back({1.0, 0.5});
        p.corner_uv.insert(p.corner_uv.end(), {Complex(0, 0), Complex(1, 0), Complex(0, 0.5)});
    }
    const std::string bytes = ply_of(p);
    const PolygonSoup soup = parse_polygon_soup(bytes.data(), bytes.size(), MeshFormat::Ply);
    EXPECT_EQ(soup.n_vertices(), 3u * kFan);
    for (std::size_t c = 0; c < soup.indices.size(); ++c)
        EXPECT_EQ(soup.indices[c], static_cast<std::int64_t>(c));
    // The same picture in the SVG: 20 000 shelf-packed rectangles of one size.
    const std::string svg = svg_of(p);
    EXPECT_EQ(count(svg, "<rect "), static_cast<std::size_t>(kFan));
    std::string why;
    EXPECT_TRUE(balanced_tags(svg, why)) << why;
    EXPECT_LE(attribute(svg, 0, "svg", "width"), 1600);
}

// ---------------------------------------------------------------------------------------------
// patches.obj

TEST(PatchesObj, TwoSquaresGroupedByPatchWithCornerUv) {
    const Picture p = two_squares();
    const std::string text = obj_of(p);
    const PolygonSoup soup = parse_polygon_soup(text.data(), text.size(), MeshFormat::Obj);
    ASSERT_EQ(soup.n_vertices(), 6u);  // the cut mesh itself, not split
    for (Index v = 0; v < 6; ++v)
        for (int k = 0; k < 3; ++k) EXPECT_EQ(soup.positions[3 * v + k], p.V(v, k));
    // patch 0 (faces 1, 3), then patch 1 (faces 0, 2), index order inside each
    const std::vector<Index> order = {1, 3, 0, 2};
    ASSERT_EQ(soup.n_polygons(), 4u);
    for (std::size_t i = 0; i < 4; ++i)
        for (int k = 0; k < 3; ++k) EXPECT_EQ(soup.indices[soup.offsets[i] + k], p.F(order[i], k));

    const ObjCorners o = parse_obj_corners(text);
    EXPECT_EQ(o.groups, (std::vector<std::string>{"patch_0", "patch_1"}));
    ASSERT_EQ(o.vt.size(), 12u);
    for (std::size_t c = 0; c < 12; ++c) EXPECT_EQ(o.vt[c], p.corner_uv[c]);
    ASSERT_EQ(o.faces.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(o.group_of_face[i], i / 2);
        for (int k = 0; k < 3; ++k) EXPECT_EQ(o.faces[i][k][1], 3 * order[i] + k + 1);
    }
}

TEST(PatchesObj, QuadrantGridReadsBack) {
    const Picture p = quadrants(40);
    const std::string text = obj_of(p);
    const PolygonSoup soup = parse_polygon_soup(text.data(), text.size(), MeshFormat::Obj);
    ASSERT_EQ(soup.n_vertices(), static_cast<std::size_t>(p.V.rows()));
    ASSERT_EQ(soup.n_polygons(), static_cast<std::size_t>(p.F.rows()));
    for (Index v = 0; v < p.V.rows(); ++v)
        for (int k = 0; k < 3; ++k) ASSERT_EQ(soup.positions[3 * v + k], p.V(v, k));
    const ObjCorners o = parse_obj_corners(text);
    EXPECT_EQ(o.groups, (std::vector<std::string>{"patch_0", "patch_1", "patch_2", "patch_3"}));
    ASSERT_EQ(o.vt.size(), p.corner_uv.size());
    // Each face line: its group is its patch, and every corner's vt is that corner's chart uv
    // at the same vertex (vt numbers point back at the face).
    std::vector<int> per_group(4, 0);
    std::int64_t last_face = -1;
    std::size_t last_group = 0;
    for (std::size_t i = 0; i < o.faces.size(); ++i) {
        const std::int64_t f = (o.faces[i][0][1] - 1) / 3;
        ASSERT_EQ(p.face_patch[f], static_cast<Index>(o.group_of_face[i]));
        if (o.group_of_face[i] == last_group) {
            EXPECT_GT(f, last_face);  // index order inside a group
        }
        last_group = o.group_of_face[i];
        last_face = f;
        ++per_group[o.group_of_face[i]];
        for (int k = 0; k < 3; ++k) {
            ASSERT_EQ(o.faces[i][k][1], 3 * f + k + 1);
            ASSERT_EQ(o.faces[i][k][0], p.F(f, k) + 1);
            ASSERT_EQ(o.vt[3 * f + k], p.corner_uv[3 * f + k]);
        }
    }
    EXPECT_EQ(per_group, std::vector<int>(4, 40 * 40 / 2));
}

// ---------------------------------------------------------------------------------------------
// trajectories.obj

Picture::Polyline polyline(Picture::Family family, std::vector<Eigen::Vector3d> points) {
    Picture::Polyline l;
    l.family = family;
    l.points = std::move(points);
    return l;
}

TEST(TrajectoriesObj, GroupsInFamilyOrderShortLinesSkipped) {
    using F = Picture::Family;
    const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(1, 1, 0), d(0, 1, 0.5);
    Picture p;
    p.trajectories = {polyline(F::Boundary, {a, b}),         // vertices 1 2
                      polyline(F::Vertical, {a, b, c}),      // vertices 3 4 5
                      polyline(F::Horizontal, {d}),          // one point: skipped
                      polyline(F::Horizontal, {}),           // empty: skipped
                      polyline(F::Vertical, {d, c, b, a})};  // vertices 6 7 8 9
    const std::string text = lines_of(p);
    const PolygonSoup soup = parse_polygon_soup(text.data(), text.size(), MeshFormat::Obj);
    EXPECT_EQ(soup.n_polygons(), 0u);
    const std::vector<Eigen::Vector3d> expected = {a, b, a, b, c, d, c, b, a};
    ASSERT_EQ(soup.n_vertices(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i)
        for (int k = 0; k < 3; ++k) EXPECT_EQ(soup.positions[3 * i + k], expected[i](k));
    // vertical before boundary; no horizontal group since none of its lines is drawable
    EXPECT_EQ(lines_starting(text, "g "), (std::vector<std::string>{"g vertical", "g boundary"}));
    EXPECT_EQ(lines_starting(text, "l "),
              (std::vector<std::string>{"l 3 4 5", "l 6 7 8 9", "l 1 2"}));
    EXPECT_LT(text.find("g vertical"), text.find("l 3 4 5"));
    EXPECT_LT(text.find("l 6 7 8 9"), text.find("g boundary"));
    EXPECT_LT(text.find("g boundary"), text.find("l 1 2"));
}

TEST(TrajectoriesObj, NonFinitePointsSplitTheLine) {
    using F = Picture::Family;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(1, 1, 0), bad(nan, 0, 0), far(0, inf, 0);
    Picture p;
    p.trajectories = {polyline(F::Horizontal, {a, b, bad, c, a, b}),  // runs a b | c a b
                      polyline(F::Horizontal, {a, far, b})};          // two single points
    const std::string text = lines_of(p);
    expect_no_non_finite_text(text);
    EXPECT_EQ(lines_starting(text, "v ").size(), 5u);
    EXPECT_EQ(lines_starting(text, "l "), (std::vector<std::string>{"l 1 2", "l 3 4 5"}));
    EXPECT_EQ(lines_starting(text, "g "), std::vector<std::string>{"g horizontal"});
}

TEST(TrajectoriesObj, NoTrajectoriesIsAValidEmptyFile) {
    const std::string text = lines_of(Picture{});
    EXPECT_TRUE(lines_starting(text, "v ").empty());
    EXPECT_TRUE(lines_starting(text, "l ").empty());
    EXPECT_TRUE(lines_starting(text, "g ").empty());
}

// ---------------------------------------------------------------------------------------------
// domains.svg

TEST(DomainsSvg, TwoSquaresCommonScaleShelfPacked) {
    const Picture p = two_squares();
    const std::string svg = svg_of(p);
    std::string why;
    ASSERT_TRUE(balanced_tags(svg, why)) << why;
    expect_no_non_finite_text(svg);
    EXPECT_NE(svg.find("<svg xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
    EXPECT_NE(svg.find("viewBox=\"0 0 "), std::string::npos);
    EXPECT_EQ(count(svg, "<rect "), 2u);
    EXPECT_EQ(count(svg, "<g "), 2u);
    EXPECT_EQ(count(svg, "<text "), 2u);
    EXPECT_LE(attribute(svg, 0, "svg", "width"), 1600);

    const std::size_t g0 = group_of_patch(svg, 0), g1 = group_of_patch(svg, 1);
    const double w0 = attribute(svg, g0, "rect", "width"),
                 h0 = attribute(svg, g0, "rect", "height");
    const double w1 = attribute(svg, g1, "rect", "width"),
                 h1 = attribute(svg, g1, "rect", "height");
    EXPECT_GT(w0, 10);
    EXPECT_NEAR(w1, 2 * w0, 0.02);  // one scale for all: sizes compare (2 decimals written)
    EXPECT_NEAR(h1, 2 * h0, 0.02);
    // Tallest first: patch 1 opens the first shelf at the top-left margin.
    EXPECT_EQ(attribute(svg, g1, "rect", "x"), 10);
    EXPECT_EQ(attribute(svg, g1, "rect", "y"), 10);
    expect_packed(svg, 2);
    // Fill is the patch colour.
    const auto rgb = patch_colour(1);
    char hex[8];
    std::snprintf(hex, sizeof hex, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
    EXPECT_NE(svg.find(std::string("fill=\"") + hex + "\"", g1), std::string::npos);
    EXPECT_EQ(drawn_triangles(svg, 0), 2u);
    EXPECT_EQ(drawn_triangles(svg, 1), 2u);
    // The first triangle of patch 1 (face 0, uv (0,0) (2,0) (2,2)) with y flipped: corner (0,0)
    // is the rectangle's bottom-left.
    const std::size_t path = svg.find(" d=\"M", svg.find("<path clip-path", g1)) + 5;
    double x = 0, y = 0;
    std::istringstream(svg.substr(path, 40)) >> x >> y;
    EXPECT_NEAR(x, attribute(svg, g1, "rect", "x"), 0.011);
    EXPECT_NEAR(y, attribute(svg, g1, "rect", "y") + h1, 0.011);
}

TEST(DomainsSvg, QuadrantGridDrawsEveryTriangle) {
    const Picture p = quadrants(224);
    const std::string svg = svg_of(p);
    std::string why;
    ASSERT_TRUE(balanced_tags(svg, why)) << why;
    expect_no_non_finite_text(svg);
    EXPECT_EQ(count(svg, "<rect "), 4u);
    EXPECT_EQ(count(svg, "<g "), 4u);
    // 4 equal squares, shelf 1.25 sqrt(total area) wide: two shelves of two, in id order.
    const double w = attribute(svg, group_of_patch(svg, 0), "rect", "width");
    for (Index q = 0; q < 4; ++q) {
        EXPECT_EQ(attribute(svg, group_of_patch(svg, q), "rect", "width"), w);
        EXPECT_EQ(attribute(svg, group_of_patch(svg, q), "rect", "height"), w);
        EXPECT_EQ(drawn_triangles(svg, q), 224u * 224u / 2);  // uv inside: no wrapped copies
    }
    expect_packed(svg, 4);
    // Equal heights: shelf order is id order, left to right then top to bottom.
    for (Index q = 0; q + 1 < 4; ++q) {
        const double y0 = attribute(svg, group_of_patch(svg, q), "rect", "y");
        const double y1 = attribute(svg, group_of_patch(svg, q + 1), "rect", "y");
        const double x0 = attribute(svg, group_of_patch(svg, q), "rect", "x");
        const double x1 = attribute(svg, group_of_patch(svg, q + 1), "rect", "x");
        EXPECT_TRUE(y1 > y0 || (y1 == y0 && x1 > x0)) << q;
    }
    EXPECT_LE(attribute(svg, 0, "svg", "width"), 1600);
}

TEST(DomainsSvg, UnusableSizesBecomePlaceholdersAndNoPatchesIsValid) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    Picture p = two_squares();
    p.patch_size = {{nan, 1.0}, {0.0, 2.0}};
    p.patch_size.push_back({inf, 1.0});
    p.patch_size.push_back({-1.0, 1.0});
    p.patch_size.push_back({3.0, 1.0});  // the only usable one
    p.corner_uv[0] = Complex(nan, 0);
    std::string svg = svg_of(p);
    std::string why;
    EXPECT_TRUE(balanced_tags(svg, why)) << why;
    expect_no_non_finite_text(svg);
    EXPECT_EQ(count(svg, "<rect "), 5u);
    EXPECT_EQ(count(svg, "<g "), 5u);
    EXPECT_EQ(count(svg, "stroke-dasharray"), 4u);  // the four placeholders
    for (Index q = 0; q < 4; ++q) {
        EXPECT_EQ(attribute(svg, group_of_patch(svg, q), "rect", "width"), 24);
        EXPECT_EQ(drawn_triangles(svg, q), 0u);  // no chart to draw in
    }
    EXPECT_NE(svg.find(">3</text>"), std::string::npos);  // labelled

    // Every size unusable: only placeholders, still finite.
    p.patch_size.pop_back();
    svg = svg_of(p);
    EXPECT_TRUE(balanced_tags(svg, why)) << why;
    expect_no_non_finite_text(svg);

    svg = svg_of(Picture{});
    EXPECT_TRUE(balanced_tags(svg, why)) << why;
    EXPECT_NE(svg.find("<svg xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
    EXPECT_EQ(count(svg, "<rect"), 0u);
    EXPECT_EQ(count(svg, "<g "), 0u);
    EXPECT_GT(attribute(svg, 0, "svg", "width"), 0);
}

TEST(DomainsSvg, ChartUnitsDoNotChangeThePicture) {
    // Charts in units of 2^-1000 or 2^1000 (exact scalings) draw the very same rectangles,
    // triangles and labels: the scale is taken relative to the largest side, never overflows.
    auto drawing = [](double unit) {
        Picture p = two_squares();
        for (auto& s : p.patch_size) s = {s[0] * unit, s[1] * unit};
        for (auto& z : p.corner_uv) z *= unit;
        std::string kept;
        std::istringstream in(svg_of(p));
        for (std::string line; std::getline(in, line);)
            if (line.starts_with("<rect") || line.starts_with("<path") ||
                line.starts_with("<clipPath") || line.starts_with("<text"))
                kept += line + "\n";
        return kept;
    };
    const std::string plain = drawing(1);
    EXPECT_EQ(count(plain, "<rect"), 2u);
    EXPECT_EQ(drawing(std::ldexp(1.0, -1000)), plain);
    EXPECT_EQ(drawing(std::ldexp(1.0, 1000)), plain);
}

TEST(DomainsSvg, CylinderChartWrapsAcrossTheSeam) {
    // One patch of width 1; a triangle straddling u = 1 is drawn again shifted by -1 so the part
    // past the right side shows at the left, and one straddling u = 0 again at +1.
    Picture p;
    p.V.resize(3, 3);
    p.V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    p.F.resize(3, 3);
    p.F << 0, 1, 2, 0, 1, 2, 0, 1, 2;
    p.face_patch = {0, 0, 0};
    p.patch_size = {{1.0, 1.0}};
    p.corner_uv = {Complex(0.9, 0),    Complex(1.1, 0),   Complex(0.9, 0.5),   // past the right
                   Complex(-0.1, 0.5), Complex(0.1, 0.5), Complex(0, 1),       // past the left
                   Complex(0.2, 0.2),  Complex(0.8, 0.2), Complex(0.5, 0.8)};  // inside
    const std::string svg = svg_of(p);
    EXPECT_EQ(drawn_triangles(svg, 0), 5u);
    EXPECT_NE(svg.find("<clipPath id=\"clip-0\">"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Inconsistent input and non-finite numbers

TEST(SegmentationWriters, InconsistentArraysThrowBeforeWriting) {
    // Every mesh writer refuses with InvalidInput, names itself and the problem, and has not
    // written a byte.
    auto expect_refused = [](const Picture& p, const std::string& problem) {
        SCOPED_TRACE(problem);
        const std::pair<const char*, void (*)(std::ostream&, const Picture&)> writers[] = {
            {"write_segments_ply", write_segments_ply},
            {"write_patches_obj", write_patches_obj},
            {"write_domains_svg", write_domains_svg}};
        for (const auto& [name, writer] : writers) {
            std::ostringstream out;
            try {
                writer(out, p);
                ADD_FAILURE() << name << " accepted the picture";
            } catch (const InvalidInput& e) {
                const std::string message = e.what();
                EXPECT_NE(message.find(name), std::string::npos) << message;
                EXPECT_NE(message.find(problem), std::string::npos) << message;
            }
            EXPECT_TRUE(out.str().empty()) << name << " wrote before refusing";
        }
    };
    Picture p = two_squares();
    p.face_patch.pop_back();
    expect_refused(p, "face_patch has 3 entries for 4 faces");
    p = two_squares();
    p.corner_uv.push_back(Complex(0, 0));
    expect_refused(p, "corner_uv has 13 entries");
    p = two_squares();
    p.face_patch[2] = 2;
    expect_refused(p, "face 2 has patch id 2, outside 0 .. 1");
    p.face_patch[2] = -1;
    expect_refused(p, "face 2 has patch id -1");
    p = two_squares();
    p.F(3, 2) = 6;
    expect_refused(p, "face 3 corner 2 refers to vertex 6 but there are 6 vertices");
    p.F(3, 2) = -1;
    expect_refused(p, "refers to vertex -1");
    p = two_squares();
    p.patch_size.clear();
    expect_refused(p, "face 0 has patch id 1, outside 0 .. -1");

    Picture lines;
    lines.trajectories.push_back(polyline(static_cast<Picture::Family>(7), {{0, 0, 0}, {1, 0, 0}}));
    std::ostringstream out;
    EXPECT_THROW(write_trajectories_obj(out, lines), InvalidInput);
    EXPECT_TRUE(out.str().empty());
}

TEST(SegmentationWriters, NonFiniteNumbersAreWrittenAsZero) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    Picture p = two_squares();
    p.V(5, 1) = nan;
    p.V(3, 0) = -std::numeric_limits<double>::infinity();
    p.corner_uv[0] = Complex(nan, std::numeric_limits<double>::infinity());
    const std::string obj = obj_of(p);
    expect_no_non_finite_text(obj);
    const PolygonSoup soup = parse_polygon_soup(obj.data(), obj.size(), MeshFormat::Obj);
    EXPECT_EQ(soup.positions[3 * 5 + 1], 0.0);
    EXPECT_EQ(soup.positions[3 * 3 + 0], 0.0);
    EXPECT_EQ(parse_obj_corners(obj).vt[0], Complex(0, 0));

    const std::string ply = ply_of(p);
    const PlyFile file = split_ply(ply);
    for (std::size_t i = 0; i < 8 * 5; ++i)
        EXPECT_TRUE(std::isfinite(load_le<double>(ply, file.data + 8 * i))) << "double " << i;
    // vertex 0 of the PLY came from corner 0: its uv is (0, 0) now
    EXPECT_EQ(load_le<double>(ply, file.data + 24), 0.0);
    EXPECT_EQ(load_le<double>(ply, file.data + 32), 0.0);
    expect_no_non_finite_text(svg_of(p));
}

}  // namespace
}  // namespace holoflow::engine
