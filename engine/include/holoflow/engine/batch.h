#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "holoflow/engine/output.h"
#include "holoflow/engine/stage_clock.h"
#include "holoflow/engine/status.h"

namespace holoflow::engine {

//! One model of a batch.
struct ModelTask {
    std::uint64_t id = 0;         //!< position in the expanded input list
    std::string path;             //!< mesh file
    std::string name;             //!< result folder name, unique in the batch
    std::filesystem::path out_dir;  //!< OUT/name; empty: write nothing
};

//! What a batch records of one model (a summary.json object, and its model folder's result.json).
struct ModelOutcome {
    ModelTask task;
    Status status;
    std::size_t vertices = 0, faces = 0;  //!< of the mesh as loaded (0 if loading failed)
    int genus = -1, working_genus = -1;
    std::int64_t zeros = -1, patches = -1;
    double collapsed_area = -1;           //!< segmentation.json's collapsed_area; -1 if not reached
    StageTimes timings_ms;                //!< load, the pipeline stages, write
};

//! \brief Mesh files named by command-line inputs, in order: a mesh file (.off .obj .ply .stl)
//! as is; a folder: its mesh files, recursively, sorted by path; any other file: a list with one
//! path per line (blank lines and lines starting with # skipped; relative paths are relative to
//! the list's folder; binary files and meshes under other names are refused). A file named
//! twice, in any spelling or through a symbolic link, is kept once (its first place). Folders are searched
//! without the model folders of `out_root` (a batch whose output lies among its inputs).
//! \throw InvalidInput naming an input that does not exist or a list line that names nothing.
std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs,
                                       const std::filesystem::path& out_root = {});

//! Tasks for the paths, each writing into out_root/<name>: the file's stem (its first 200 bytes),
//! made unique in input order by a `~2`, `~3`, ... suffix.
std::vector<ModelTask> make_tasks(const std::vector<std::string>& paths, const std::filesystem::path& out_root);

//! The summary object of one model (keys in README "holoflow batch").
nlohmann::json outcome_json(const ModelOutcome& outcome);

//! \brief `result.json` in the model's folder: outcome_json plus the settings it was computed
//! with and the input's size and time; written last (atomically), so its presence marks a
//! finished model. A failed model's segmentation files are removed first. \throw OutputError.
void write_model_result(const ModelOutcome& outcome, const nlohmann::json& settings);

//! The outcome of an earlier run of `task` with the same settings that succeeded, if its
//! result.json says so, its input file has the size and modification time it had then, and its
//! segmentation files are all there (failed models are retried).
std::optional<ModelOutcome> finished_model(const ModelTask& task, const nlohmann::json& settings);

//! Writes out_root/summary.json (array in task order) and summary.csv (one row per model,
//! one column per stage), atomically. \throw OutputError.
void write_batch_summary(const std::filesystem::path& out_root, const std::vector<ModelOutcome>& outcomes);

//! Batch progress on a stream: a redrawn bar (done/total, failures, models per second, ETA)
//! when `interactive` (a terminal), else one plain line per `interval` and one at the end.
class BatchProgress {
  public:
    BatchProgress(std::size_t total, std::ostream& out, bool interactive,
                  std::chrono::milliseconds interval = std::chrono::seconds(10));
    //! One more model finished (reused ones count as done, not in the rate).
    void model_finished(bool failed, bool reused);
    void finish();

  private:
    void print(bool final_line);

    std::size_t total_, done_ = 0, failed_ = 0, computed_ = 0;
    std::ostream& out_;
    bool interactive_;
    std::chrono::milliseconds interval_;
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    std::chrono::steady_clock::time_point last_print_ = start_;
};

}  // namespace holoflow::engine
