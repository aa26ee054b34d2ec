#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "holoflow/engine/conformal_pipeline.h"

namespace holoflow::engine {

//! An output folder or file could not be written (exit status 6, kind `output_error`).
struct OutputError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

//! Streams `write(out)` into a temporary name in the same folder, then renames it over `path`,
//! so a reader (or a killed run) never sees a half-written file. \throw OutputError.
void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write);
void write_file_atomic(const std::filesystem::path& path, const std::string& content);

//! Removes the temporaries write_file_atomic leaves in `folder` when a run is killed while
//! writing one of `names` (only those: the folder may hold the user's own files).
void remove_stale_temporaries(const std::filesystem::path& folder, const std::vector<std::string>& names);

//! JSON text of `j` (`indent` as nlohmann::json::dump). Strings that are not valid UTF-8 (a file
//! name in another encoding) get U+FFFD for their bad bytes instead of failing the dump.
std::string json_text(const nlohmann::json& j, int indent = 2);

//! Creates the folder (and parents) if needed and checks it is writable. \throw OutputError.
void prepare_output_folder(const std::filesystem::path& folder);

//! A mesh as OFF, coordinates as the shortest decimals that read back to the same doubles.
void write_off(std::ostream& out, const MeshView& mesh);

//! `uv.obj`: the input mesh with one texture coordinate per wedge of the chosen form's map
//! (faces of the first copy for double-covered input).
void write_uv_obj(std::ostream& out, const MeshView& input, const ConformalResult& result);

//! `forms`: documented plain text, one line per edge of the working surface.
void write_forms(std::ostream& out, const ConformalResult& result);

}  // namespace holoflow::engine
