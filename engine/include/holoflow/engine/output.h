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

//! \brief Files that stand together, written as one set. Each file is streamed to a temporary
//! name when added; commit() moves the old files aside, the last one (the set's marker) first,
//! and renames the new ones into place in order. A commit that fails puts the old set back as
//! it was; one that is killed leaves new files without their marker, never a marker over a mix
//! (remove_stale_temporaries then removes the old files left aside). Temporaries of a set
//! destroyed before commit() are removed.
class FileSet {
  public:
    FileSet() = default;
    FileSet(const FileSet&) = delete;
    FileSet& operator=(const FileSet&) = delete;
    ~FileSet();

    //! \throw OutputError (the temporaries written so far are removed with the set).
    void add(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);
    void add(const std::filesystem::path& path, const std::string& content);
    //! \throw OutputError if a file's place holds a folder (nothing is touched) or a rename
    //! fails (the old set is put back).
    void commit();

  private:
    struct Staged {
        std::filesystem::path temporary, path;
    };
    std::vector<Staged> staged_;
};

//! Removes the temporaries (and a FileSet's old files moved aside) a run killed while writing
//! one of `names` leaves in `folder` (only those: the folder may hold the user's own files), except those
//! of processes still running.
void remove_stale_temporaries(const std::filesystem::path& folder, const std::vector<std::string>& names);

//! JSON text of `j` (`indent` as nlohmann::json::dump). Strings that are not valid UTF-8 (a file
//! name in another encoding) get U+FFFD for their bad bytes instead of failing the dump.
std::string json_text(const nlohmann::json& j, int indent = 2);

//! Creates the folder (and parents) if needed and checks it is writable. \throw OutputError.
void prepare_output_folder(const std::filesystem::path& folder);

//! \brief An output folder held by one run. Created (with missing parents) and checked
//! writable, then locked: another holoflow run that asks for the same folder is refused while
//! this one lives (an advisory lock on its `.holoflow.lock`, which the kernel drops when the
//! process ends, killed or not; the destructor removes the file). Folders it created are removed
//! again by the destructor if still empty (a run that failed before writing anything).
class OutputFolder {
  public:
    //! \throw OutputError (cannot create, not writable, or in use by another run).
    explicit OutputFolder(std::filesystem::path folder);
    OutputFolder(const OutputFolder&) = delete;
    OutputFolder& operator=(const OutputFolder&) = delete;
    ~OutputFolder();

    const std::filesystem::path& path() const { return folder_; }

  private:
    void lock();
    void remove_created();

    std::filesystem::path folder_;
    std::vector<std::filesystem::path> created_;  //!< deepest first
    int lock_fd_ = -1;
};

//! The lock file an OutputFolder holds (not a name a model folder may take).
inline constexpr const char* kOutputLockFile = ".holoflow.lock";

//! What names a file whatever the spelling: its path with links resolved where it exists
//! (absolute and normalised where it does not).
std::filesystem::path file_identity(const std::filesystem::path& path);

//! \brief Refuses a run that would write one of `outputs` over one of `inputs` (the same file by
//! any spelling or link: a mesh named segments.ply segmented into its own folder).
//! \throw InvalidInput naming both.
void refuse_overwriting_inputs(const std::vector<std::filesystem::path>& outputs,
                               const std::vector<std::string>& inputs);

//! A mesh as OFF, coordinates as the shortest decimals that read back to the same doubles.
void write_off(std::ostream& out, const MeshView& mesh);

//! `uv.obj`: the input mesh with one texture coordinate per wedge of the chosen form's map
//! (faces of the first copy for double-covered input).
void write_uv_obj(std::ostream& out, const MeshView& input, const ConformalResult& result);

//! `forms`: documented plain text, one line per edge of the working surface.
void write_forms(std::ostream& out, const ConformalResult& result);

}  // namespace holoflow::engine
