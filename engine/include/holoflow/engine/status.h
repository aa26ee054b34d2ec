#pragma once

#include <exception>
#include <string>

namespace holoflow::engine {

//! Process exit statuses besides the mesh error kinds (10-26, mesh_error.h); README "Exit status".
constexpr int kExitInternal = 1;
constexpr int kExitUsage = 2;
constexpr int kExitInvalidInput = 3;
constexpr int kExitSolverFailure = 4;
constexpr int kExitOutOfMemory = 5;
constexpr int kExitOutputError = 6;
constexpr int kExitResourceLimit = 7;
constexpr int kExitTimeout = 8;
constexpr int kExitBatchFailures = 9;  //!< a batch finished, some of its models failed

//! The outcome of one model's run: ok, or a failure with its kind (as the CLI prints it:
//! `error: <kind>: <message>`), the stage it happened in and the exit status it maps to.
struct Status {
    std::string kind;     //!< empty when ok
    std::string stage;
    std::string message;
    int exit_code = 0;

    bool ok() const { return kind.empty(); }
    static Status failure(std::string kind, std::string stage, std::string message, int exit_code) {
        return {std::move(kind), std::move(stage), std::move(message), exit_code};
    }
};

//! The failure an exception stands for (MeshError kinds, invalid_input, solver_failure,
//! resource_limit, output_error, out_of_memory, internal), at `stage`.
Status status_from_exception(std::exception_ptr error, const std::string& stage);

}  // namespace holoflow::engine
