#pragma once

#include <algorithm>
#include <chrono>

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace holoflow::engine {

//! Wall time of each stage in order, milliseconds.
using StageTimes = std::vector<std::pair<std::string, double>>;

//! Adds each stage of `more` to the entry of that name in `times`, appended where there is none.
inline void add_stage_times(StageTimes& times, const StageTimes& more) {
    for (const auto& entry : more) {  // no structured binding: clang 14 (the fuzz build) cannot capture one
        const auto it = std::find_if(times.begin(), times.end(), [&](const auto& e) { return e.first == entry.first; });
        if (it == times.end()) times.push_back(entry);
        else it->second += entry.second;
    }
}

//! Appends the time since the previous lap (or construction) under a stage name.
class StageClock {
 public:
    explicit StageClock(StageTimes& times) : times_(times) {}
    void lap(const char* stage) {
        const auto now = std::chrono::steady_clock::now();
        times_.emplace_back(stage, std::chrono::duration<double, std::milli>(now - last_).count());
        last_ = now;
    }
    //! Starts the next lap now, leaving out the time since the previous one (work timed elsewhere).
    void restart() { last_ = std::chrono::steady_clock::now(); }

 private:
    StageTimes& times_;
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

//! `timings_ms` of the reports: one entry per stage plus their `total`.
inline nlohmann::json timings_report(const StageTimes& times) {
    nlohmann::json timings = nlohmann::json::object();
    double total = 0;
    for (const auto& [stage, ms] : times) {
        timings[stage] = ms;
        total += ms;
    }
    timings["total"] = total;
    return timings;
}

}  // namespace holoflow::engine
