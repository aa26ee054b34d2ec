#pragma once

#include <cstddef>
#include <functional>
#include <initializer_list>

#include <Eigen/SparseCore>

namespace holoflow::par {

//! Calls fn(begin, end) on disjoint subranges covering [0, n); runs on oneTBB workers when n is
//! at least `grain`, serially otherwise. Kernel headers stay free of TBB.
void for_each_range(std::size_t n, std::size_t grain,
                    const std::function<void(std::size_t, std::size_t)>& fn);

}  // namespace holoflow::par

namespace holoflow::par {

//! Calls fn(i) for every i in [0, n), one task per index when `parallel` (coarse work items such
//! as the columns of a #E x 2g matrix), serially otherwise. Each index writes its own output, so
//! results do not depend on the thread count.
void for_each_index(std::size_t n, bool parallel, const std::function<void(std::size_t)>& fn);

//! Runs independent jobs (none writes what another reads), concurrently on oneTBB workers when
//! `parallel`, else one after the other; results do not depend on the thread count.
void run_together(bool parallel, std::initializer_list<std::function<void()>> jobs);

//! Column-per-task loops over #E x k form matrices go parallel from this many rows; below it one
//! task beats the TBB split.
constexpr std::ptrdiff_t kParallelColumnRows = 16384;

//! The rows x cols column-compressed matrix whose column j `fill(j, column)` writes into a zeroed
//! dense column of `rows` values: one scratch column per task (columns in parallel when
//! `parallel`), so no rows x cols dense matrix is ever allocated. Exact zeros are left out.
Eigen::SparseMatrix<double> sparse_from_columns(Eigen::Index rows, Eigen::Index cols, bool parallel,
                                                const std::function<void(Eigen::Index, double*)>& fill);

}  // namespace holoflow::par
