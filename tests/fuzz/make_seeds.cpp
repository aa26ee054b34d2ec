// Writes fuzz seed corpora for every format from small OFF meshes:
//   holoflow_fuzz_seeds OUT_DIR MESH.off...
// creates OUT_DIR/{off,obj,ply,stl}/<mesh>.<variant>. Meshes are never committed: the seeds are
// made at run time from the libcgal-demo files that the configure step unpacks.

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "holoflow/engine/mesh_reader.h"

namespace {

namespace fs = std::filesystem;
using holoflow::engine::PolygonSoup;

std::string number(double v) {
    char buffer[32];
    const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, v);
    return ec == std::errc() ? std::string(buffer, end) : std::string("0");
}

void write(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

template <class T>
void put(std::string& out, T value, bool big_endian) {
    auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
    if (big_endian != (std::endian::native == std::endian::big))
        std::reverse(bytes.begin(), bytes.end());
    out.append(bytes.data(), bytes.size());
}

std::vector<std::int64_t> polygon(const PolygonSoup& s, std::size_t p) {
    return {s.indices.begin() + static_cast<std::ptrdiff_t>(s.offsets[p]),
            s.indices.begin() + static_cast<std::ptrdiff_t>(s.offsets[p + 1])};
}

std::string to_obj(const PolygonSoup& s, bool negative) {
    std::string out = "# seed\n";
    for (std::size_t v = 0; v < s.n_vertices(); ++v)
        out += "v " + number(s.positions[3 * v]) + " " + number(s.positions[3 * v + 1]) + " " +
               number(s.positions[3 * v + 2]) + "\n";
    const auto n = static_cast<std::int64_t>(s.n_vertices());
    for (std::size_t p = 0; p < s.n_polygons(); ++p) {
        out += "f";
        for (std::int64_t i : polygon(s, p))
            out += " " + std::to_string(negative ? i - n : i + 1) + (negative ? "" : "//1");
        out += "\n";
    }
    return out;
}

std::string ply_header(const PolygonSoup& s, const char* format, const char* scalar,
                       const char* list, const char* element) {
    return std::string("ply\nformat ") + format + " 1.0\ncomment seed\nelement vertex " +
           std::to_string(s.n_vertices()) + "\nproperty " + scalar + " x\nproperty " + scalar +
           " y\nproperty " + scalar + " z\nelement " + element + " " +
           std::to_string(std::string(element) == "face" ? s.n_polygons() : 1) +
           "\nproperty list " + list + " vertex_indices\nend_header\n";
}

std::string to_ply_ascii(const PolygonSoup& s) {
    std::string out = ply_header(s, "ascii", "double", "uchar int", "face");
    for (std::size_t v = 0; v < s.n_vertices(); ++v)
        out += number(s.positions[3 * v]) + " " + number(s.positions[3 * v + 1]) + " " +
               number(s.positions[3 * v + 2]) + "\n";
    for (std::size_t p = 0; p < s.n_polygons(); ++p) {
        const auto corners = polygon(s, p);
        out += std::to_string(corners.size());
        for (std::int64_t i : corners) out += " " + std::to_string(i);
        out += "\n";
    }
    return out;
}

std::string to_ply_binary(const PolygonSoup& s, bool big_endian) {
    std::string out = ply_header(s, big_endian ? "binary_big_endian" : "binary_little_endian",
                                 big_endian ? "double" : "float", "uchar uint", "face");
    for (double x : s.positions) {
        if (big_endian)
            put(out, x, true);
        else
            put(out, static_cast<float>(x), false);
    }
    for (std::size_t p = 0; p < s.n_polygons(); ++p) {
        const auto corners = polygon(s, p);
        put(out, static_cast<std::uint8_t>(corners.size()), big_endian);
        for (std::int64_t i : corners) put(out, static_cast<std::uint32_t>(i), big_endian);
    }
    return out;
}

// Triangles by fan (seeds need no good triangulation).
std::vector<std::int64_t> fan_triangles(const PolygonSoup& s) {
    std::vector<std::int64_t> t;
    for (std::size_t p = 0; p < s.n_polygons(); ++p) {
        const auto c = polygon(s, p);
        for (std::size_t i = 1; i + 1 < c.size(); ++i) t.insert(t.end(), {c[0], c[i], c[i + 1]});
    }
    return t;
}

// One strip per triangle, joined by -1 restarts, all in a single tristrips record.
std::string to_ply_strips(const PolygonSoup& s) {
    std::string out = ply_header(s, "binary_little_endian", "float", "int int", "tristrips");
    for (double x : s.positions) put(out, static_cast<float>(x), false);
    const auto t = fan_triangles(s);
    const std::size_t n = t.size() / 3;
    put(out, static_cast<std::int32_t>(n == 0 ? 0 : 4 * n - 1), false);
    for (std::size_t k = 0; k < n; ++k) {
        if (k > 0) put(out, std::int32_t{-1}, false);
        for (int j = 0; j < 3; ++j) put(out, static_cast<std::int32_t>(t[3 * k + j]), false);
    }
    return out;
}

std::string to_stl_ascii(const PolygonSoup& s) {
    std::string out = "solid seed\n";
    const auto t = fan_triangles(s);
    for (std::size_t k = 0; k + 2 < t.size(); k += 3) {
        out += "facet normal 0 0 0\n outer loop\n";
        for (int j = 0; j < 3; ++j) {
            const double* p = s.positions.data() + 3 * t[k + j];
            out += "  vertex " + number(p[0]) + " " + number(p[1]) + " " + number(p[2]) + "\n";
        }
        out += " endloop\nendfacet\n";
    }
    return out + "endsolid seed\n";
}

std::string to_stl_binary(const PolygonSoup& s) {
    std::string out(80, ' ');
    out.replace(0, 11, "binary seed");
    const auto t = fan_triangles(s);
    put(out, static_cast<std::uint32_t>(t.size() / 3), false);
    for (std::size_t k = 0; k + 2 < t.size(); k += 3) {
        for (int j = 0; j < 3; ++j) put(out, 0.0f, false);
        for (int j = 0; j < 3; ++j)
            for (int d = 0; d < 3; ++d)
                put(out, static_cast<float>(s.positions[3 * t[k + j] + d]), false);
        put(out, std::uint16_t{0}, false);
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s OUT_DIR MESH.off...\n", argv[0]);
        return 2;
    }
    const fs::path root = argv[1];
    for (const char* format : {"off", "obj", "ply", "stl"}) fs::create_directories(root / format);
    int written = 0;
    for (int a = 2; a < argc; ++a) {
        const fs::path mesh = argv[a];
        PolygonSoup s;
        try {
            s = holoflow::engine::read_polygon_soup(mesh.string());
        } catch (const std::exception& e) {
            std::fprintf(stderr, "skipping %s: %s\n", argv[a], e.what());
            continue;
        }
        const std::string stem = mesh.stem().string();
        fs::copy_file(mesh, root / "off" / (stem + ".off"), fs::copy_options::overwrite_existing);
        write(root / "obj" / (stem + ".obj"), to_obj(s, false));
        write(root / "obj" / (stem + ".negative.obj"), to_obj(s, true));
        write(root / "ply" / (stem + ".ascii.ply"), to_ply_ascii(s));
        write(root / "ply" / (stem + ".le.ply"), to_ply_binary(s, false));
        write(root / "ply" / (stem + ".be.ply"), to_ply_binary(s, true));
        write(root / "ply" / (stem + ".strips.ply"), to_ply_strips(s));
        write(root / "stl" / (stem + ".ascii.stl"), to_stl_ascii(s));
        write(root / "stl" / (stem + ".binary.stl"), to_stl_binary(s));
        ++written;
    }
    std::printf("seeds written for %d meshes\n", written);
    return written > 0 ? 0 : 1;
}
