#include "holoflow/engine/mesh_error.h"

namespace holoflow::engine {

//! Stable snake_case name of an error kind (printed as `error: <name>: <detail>`).
const char* to_string(MeshErrorKind kind) {
    switch (kind) {
        case MeshErrorKind::FileNotFound: return "file_not_found";
        case MeshErrorKind::Unreadable: return "unreadable";
        case MeshErrorKind::UnknownFormat: return "unknown_format";
        case MeshErrorKind::EmptyFile: return "empty_file";
        case MeshErrorKind::Truncated: return "truncated";
        case MeshErrorKind::HeaderMismatch: return "header_mismatch";
        case MeshErrorKind::ParseError: return "parse_error";
        case MeshErrorKind::NonFiniteCoordinate: return "non_finite_coordinate";
        case MeshErrorKind::IndexOutOfRange: return "index_out_of_range";
        case MeshErrorKind::DegenerateFace: return "degenerate_face";
        case MeshErrorKind::RepeatedVertex: return "repeated_vertex";
        case MeshErrorKind::ZeroAreaFace: return "zero_area_face";
        case MeshErrorKind::DuplicateFace: return "duplicate_face";
        case MeshErrorKind::NonManifoldEdge: return "non_manifold_edge";
        case MeshErrorKind::NonManifoldVertex: return "non_manifold_vertex";
        case MeshErrorKind::NonOrientable: return "non_orientable";
        case MeshErrorKind::TooLarge: return "too_large";
        case MeshErrorKind::CoordinateRange: return "coordinate_range";
    }
    return "unknown_error";  // only reachable through a cast of an out-of-range value
}

//! Process exit status for an error kind: 10 + the enum ordinal, so every kind is distinct and
//! none collides with 0 (success), 1 (generic failure) or 2 (usage error).
int exit_status(MeshErrorKind kind) { return 10 + static_cast<int>(kind); }

}  // namespace holoflow::engine
