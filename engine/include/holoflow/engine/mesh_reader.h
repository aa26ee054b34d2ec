#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "holoflow/engine/mesh_error.h"

namespace holoflow::engine {

enum class MeshFormat { Off, Obj, Ply, Stl };

//! Vertices and polygons exactly as a file states them (no validation beyond syntax).
struct PolygonSoup {
    std::vector<double> positions;          //!< 3 per vertex, x y z
    std::vector<std::int64_t> indices;      //!< polygon corners, concatenated (0-based, as read)
    std::vector<std::uint64_t> offsets{0};  //!< polygon p is indices[offsets[p] .. offsets[p+1])
    std::size_t welded_vertices = 0;        //!< STL only: corners merged by identical position
    std::size_t ignored_lines = 0;          //!< OFF only: lines after the faces the header announces

    std::size_t n_vertices() const { return positions.size() / 3; }
    std::size_t n_polygons() const { return offsets.size() - 1; }
};

//! The mesh format a file name ends in (`.off .obj .ply .stl`, any case; a file named `.off`
//! too), if any.
std::optional<MeshFormat> mesh_format_of_name(const std::filesystem::path& path);

//! Format from the file extension (mesh_format_of_name); \throw MeshError UnknownFormat.
MeshFormat format_from_path(const std::string& path);

//! Reads OFF, OBJ, PLY (ascii, binary little/big endian, `face` lists and `tristrips`) or STL
//! (ascii or binary; corners welded by exact position). Never allocates more than the file can
//! hold: header counts are checked against the file size first. A file of more than
//! `max_bytes` (the memory limit; 0: none) is refused unread (TooLarge), and so are FIFOs and
//! devices (Unreadable: a FIFO blocks until a writer comes, /dev/zero never ends).
//! \throw MeshError with the kind naming the problem.
PolygonSoup read_polygon_soup(const std::string& path, std::uint64_t max_bytes = 0);

//! The same from bytes already in memory (fuzzers and tests).
PolygonSoup parse_polygon_soup(const char* data, std::size_t size, MeshFormat format);

}  // namespace holoflow::engine
