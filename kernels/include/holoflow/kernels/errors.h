#pragma once

#include <stdexcept>
#include <string>

namespace holoflow {

//! Input that violates a kernel's precondition (not a disk, non-manifold, ...).
struct InvalidInput : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

//! A numerical step failed (factorization not positive definite, non-finite result, ...).
struct SolverFailure : std::runtime_error {
    using std::runtime_error::runtime_error;
};

}  // namespace holoflow

#define HOLOFLOW_REQUIRE(cond, msg)                                                    \
    do {                                                                               \
        if (!(cond)) throw ::holoflow::InvalidInput(std::string(__func__) + ": " + (msg)); \
    } while (0)
