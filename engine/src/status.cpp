#include "holoflow/engine/status.h"

#include <new>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/mesh_error.h"
#include "holoflow/engine/output.h"

namespace holoflow::engine {

Status status_from_exception(std::exception_ptr error, const std::string& stage) {
    try {
        std::rethrow_exception(error);
    } catch (const MeshError& e) {
        return Status::failure(to_string(e.kind), stage, e.detail, exit_status(e.kind));
    } catch (const InvalidInput& e) {
        return Status::failure("invalid_input", stage, e.what(), kExitInvalidInput);
    } catch (const SolverFailure& e) {
        return Status::failure("solver_failure", stage, e.what(), kExitSolverFailure);
    } catch (const ResourceLimit& e) {
        return Status::failure("resource_limit", stage, e.what(), kExitResourceLimit);
    } catch (const OutputError& e) {
        return Status::failure("output_error", stage, e.what(), kExitOutputError);
    } catch (const std::bad_alloc&) {
        return Status::failure("out_of_memory", stage, "allocation failed", kExitOutOfMemory);
    } catch (const std::exception& e) {
        return Status::failure("internal", stage, e.what(), kExitInternal);
    } catch (...) {
        return Status::failure("internal", stage, "unknown exception", kExitInternal);
    }
}

}  // namespace holoflow::engine
