#include "holoflow/kernels/parallel.h"

#include <algorithm>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace holoflow::par {

void for_each_range(std::size_t n, std::size_t grain,
                    const std::function<void(std::size_t, std::size_t)>& fn) {
    if (n == 0) return;
    if (n < grain) {
        fn(0, n);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { fn(r.begin(), r.end()); });
}

}  // namespace holoflow::par

namespace holoflow::par {

void for_each_index(std::size_t n, bool parallel, const std::function<void(std::size_t)>& fn) {
    for_each_range(n, parallel ? 1 : n + 1, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) fn(i);
    });
}

void run_together(bool parallel, std::initializer_list<std::function<void()>> jobs) {
    for_each_index(jobs.size(), parallel, [&](std::size_t i) { jobs.begin()[i](); });
}

Eigen::SparseMatrix<double> sparse_from_columns(Eigen::Index rows, Eigen::Index cols, bool parallel,
                                                const std::function<void(Eigen::Index, double*)>& fill) {
    std::vector<std::vector<Eigen::Triplet<double>>> columns(static_cast<std::size_t>(cols));
    for_each_range(columns.size(), parallel ? 1 : columns.size() + 1, [&](std::size_t begin, std::size_t end) {
        std::vector<double> column(static_cast<std::size_t>(rows));
        for (std::size_t c = begin; c < end; ++c) {
            const auto j = static_cast<Eigen::Index>(c);
            std::fill(column.begin(), column.end(), 0.0);
            fill(j, column.data());
            for (Eigen::Index i = 0; i < rows; ++i)
                if (column[static_cast<std::size_t>(i)] != 0.0) columns[c].emplace_back(i, j, column[static_cast<std::size_t>(i)]);
        }
    });
    std::vector<Eigen::Triplet<double>> entries;
    for (const auto& column : columns) entries.insert(entries.end(), column.begin(), column.end());
    Eigen::SparseMatrix<double> out(rows, cols);
    out.setFromTriplets(entries.begin(), entries.end());
    return out;
}

}  // namespace holoflow::par
