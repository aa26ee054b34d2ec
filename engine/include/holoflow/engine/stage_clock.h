#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace holoflow::engine {

//! Wall time of each stage in order, milliseconds.
using StageTimes = std::vector<std::pair<std::string, double>>;

//! Appends the time since the previous lap (or construction) under a stage name.
class StageClock {
 public:
    explicit StageClock(StageTimes& times) : times_(times) {}
    void lap(const char* stage) {
        const auto now = std::chrono::steady_clock::now();
        times_.emplace_back(stage, std::chrono::duration<double, std::milli>(now - last_).count());
        last_ = now;
    }

 private:
    StageTimes& times_;
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

}  // namespace holoflow::engine
