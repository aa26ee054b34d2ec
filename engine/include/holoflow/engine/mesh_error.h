#pragma once

#include <string>

#include "holoflow/kernels/errors.h"

namespace holoflow::engine {

//! Every way a mesh file can be refused. Each kind has a stable name (printed as
//! `error: <name>: <detail>`) and an exit status; README.md documents both.
enum class MeshErrorKind {
    FileNotFound,        // the path does not exist
    Unreadable,          // exists but cannot be opened or read (permissions, a directory, FIFO or device, I/O)
    UnknownFormat,       // extension/magic is not OFF, OBJ, PLY or STL
    EmptyFile,           // zero bytes, or no vertices/faces at all
    Truncated,           // ends before the data the header announced
    HeaderMismatch,      // header counts disagree with the data or cannot fit in the file
    ParseError,          // malformed token, unsupported property type, bad syntax
    NonFiniteCoordinate, // NaN or infinity in a vertex position
    IndexOutOfRange,     // a face refers to a vertex that does not exist
    DegenerateFace,      // fewer than three vertices
    RepeatedVertex,      // a face uses one vertex twice
    ZeroAreaFace,        // a triangle (after polygon triangulation) with zero area
    DuplicateFace,       // two faces on the same vertex set
    NonManifoldEdge,     // an edge with more than two faces
    NonManifoldVertex,   // a vertex whose faces form several fans
    NonOrientable,       // no consistent orientation exists (Moebius strip)
    TooLarge,            // more elements than the engine's 32-bit indices or a --max-* limit allow
    CoordinateRange,     // coordinates spanning more or less than doubles can square twice
};

const char* to_string(MeshErrorKind kind);
int exit_status(MeshErrorKind kind);

struct MeshError : InvalidInput {
    MeshError(MeshErrorKind kind_, const std::string& detail_)
        : InvalidInput(std::string(to_string(kind_)) + ": " + detail_), kind(kind_), detail(detail_) {}
    MeshErrorKind kind;
    std::string detail;
};

}  // namespace holoflow::engine
