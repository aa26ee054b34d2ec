#include "holoflow/engine/batch.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>

#include "holoflow/engine/mesh_reader.h"
#include "holoflow/engine/output.h"
#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/kernels/errors.h"

namespace holoflow::engine {
namespace {

namespace fs = std::filesystem;

bool is_mesh_file(const fs::path& path) { return mesh_format_of_name(path).has_value(); }

// Keeps the path as spelled, unless an earlier input is the same file (another spelling, a
// symbolic link to it): a model is computed once.
void add_unique(std::vector<std::string>& out, std::set<std::string>& seen, const fs::path& path) {
    if (seen.insert(file_identity(path).string()).second) out.push_back(path.lexically_normal().string());
}

// Why `path` (not a mesh file by name) cannot be a list of paths, or empty if it can: lists are
// text, and a mesh under another name is better named as such than read line by line.
std::string not_a_list(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::string head(4096, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    if (head.find('\0') != std::string::npos) return "it holds binary data";
    if (head.compare(0, 3, "\xEF\xBB\xBF") == 0) head.erase(0, 3);
    std::string first = head.substr(0, head.find_first_of("\r\n"));
    first.erase(0, first.find_first_not_of(" \t"));
    const std::string word = first.substr(0, first.find_first_of(" \t"));
    for (const char* mesh : {"OFF", "COFF", "NOFF", "CNOFF", "STOFF", "ply", "solid"})
        if (word == mesh)
            return "it looks like a mesh file; name it with its format's extension (.off .obj .ply .stl)";
    return {};
}

// The mesh files under `folder`, except in the model folders of `out_root` (a batch writing into
// a folder it reads would take its own outputs as inputs on the next run). Links to folders are
// followed, each folder once (a link to an ancestor would loop); a file with a mesh name that
// is no regular file (a broken link, a FIFO) is taken too, to fail as a model rather than be
// missed without a word; a folder that cannot be read refuses the batch.
void add_folder(std::vector<std::string>& out, std::set<std::string>& seen, const fs::path& folder,
                const fs::path& out_root) {
    std::vector<fs::path> files;
    std::set<fs::path> entered;
    std::error_code ec;
    entered.insert(fs::weakly_canonical(folder, ec));
    fs::path last = folder;
    for (fs::recursive_directory_iterator it(folder, fs::directory_options::follow_directory_symlink, ec), end;
         !ec && it != end; it.increment(ec)) {
        last = it->path();
        std::error_code type_ec;
        if (it->is_directory(type_ec)) {
            const bool own_output = !out_root.empty() && fs::equivalent(it->path().parent_path(), out_root, type_ec);
            if (own_output || !entered.insert(fs::weakly_canonical(it->path(), type_ec)).second)
                it.disable_recursion_pending();
        } else if (is_mesh_file(it->path())) {
            files.push_back(it->path());
        }
    }
    if (ec)
        throw InvalidInput("cannot list folder '" + folder.string() + "' (at '" + last.string() + "'): " + ec.message());
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) add_unique(out, seen, f);
}

// A CSV field, quoted when it holds a separator, quote or line break.
std::string csv_cell(const std::string& text) {
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) {
        if (c == '"') quoted += '"';
        quoted += c;
    }
    return quoted + "\"";
}

std::string format_ms(double ms) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(3) << ms;
    return s.str();
}

// Stage columns of summary.csv in pipeline order (result.json gives a reused model's stages back
// sorted by name); stages not listed follow in order of appearance.
const std::vector<std::string> kStageOrder = {
    "load", "hole_filling", "tip_slicing", "double_cover", "intrinsic_delaunay", "laplacian_assembly",
    "cut_graph_and_closed_forms", "wedge_matrix", "carry_forms", "analyse", "factorise", "overlap",
    "solves", "hodge_star", "holomorphic_basis", "integration", "zeros", "zero_fans", "tracing",
    "cutting", "patches", "write"};

}  // namespace

std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs, const fs::path& out_root) {
    std::vector<std::string> out;
    std::set<std::string> seen;
    for (const std::string& input : inputs) {
        const fs::path path(input);
        std::error_code ec;
        if (fs::is_directory(path, ec)) {
            add_folder(out, seen, path, out_root);
        } else if (!fs::exists(path, ec)) {
            if (fs::is_symlink(fs::symlink_status(path, ec)))
                throw InvalidInput("input '" + input + "' is a symbolic link to nothing (a missing target or a loop)");
            throw InvalidInput("input '" + input + "' does not exist");
        } else if (is_mesh_file(path)) {
            add_unique(out, seen, path);
        } else {
            std::ifstream list(path);
            if (!list) throw InvalidInput("cannot read the list '" + input + "'");
            if (const std::string why = not_a_list(path); !why.empty())
                throw InvalidInput("input '" + input + "' is not a mesh file (.off .obj .ply .stl), a folder or a "
                                   "text list of paths: " + why);
            std::string line;
            std::size_t number = 0;
            while (std::getline(list, line)) {
                ++number;
                line.erase(0, line.find_first_not_of(" \t\r"));
                line.erase(line.find_last_not_of(" \t\r") + 1);
                if (line.empty() || line[0] == '#') continue;
                fs::path entry(line);
                if (entry.is_relative()) entry = path.parent_path() / entry;
                if (fs::is_directory(entry, ec)) {
                    add_folder(out, seen, entry, out_root);
                } else {
                    // A missing file becomes a failed model (file_not_found), not a refused batch:
                    // lists are often written before the files exist everywhere.
                    if (!is_mesh_file(entry) && fs::exists(entry, ec))
                        throw InvalidInput("line " + std::to_string(number) + " of '" + input +
                                           "' names '" + line + "', not a mesh file or folder");
                    add_unique(out, seen, entry);
                }
            }
        }
    }
    return out;
}

std::vector<ModelTask> make_tasks(const std::vector<std::string>& paths, const fs::path& out_root) {
    std::vector<ModelTask> tasks;
    std::set<std::string> taken = {"summary.json", "summary.csv", kOutputLockFile};  // the batch's own files
    for (std::size_t i = 0; i < paths.size(); ++i) {
        // The file name without its mesh extension (a file named ".off" has an empty one).
        std::string stem = fs::path(paths[i]).filename().string();
        if (is_mesh_file(paths[i])) stem.resize(stem.size() - 4);
        else stem = fs::path(paths[i]).stem().string();
        if (stem.empty() || stem == "." || stem == "..") stem = "model";
        // Room for a suffix within a file name's 255 bytes, cut between UTF-8 characters.
        constexpr std::size_t kMaxStem = 200;
        if (stem.size() > kMaxStem) {
            std::size_t cut = kMaxStem;
            while (cut > 0 && (static_cast<unsigned char>(stem[cut]) & 0xC0) == 0x80) --cut;
            stem.resize(cut);
        }
        std::string name = stem;
        for (int n = 2; taken.count(name); ++n) name = stem + "~" + std::to_string(n);
        taken.insert(name);
        ModelTask task;
        task.id = i;
        task.path = paths[i];
        task.name = name;
        if (!out_root.empty()) task.out_dir = out_root / name;
        tasks.push_back(std::move(task));
    }
    return tasks;
}

nlohmann::json outcome_json(const ModelOutcome& o) {
    nlohmann::json j = {
        {"model", o.task.name},
        {"file", o.task.path},
        {"status", o.status.ok() ? "ok" : "failed"},
        {"vertices", o.vertices},
        {"faces", o.faces},
        {"genus", o.genus},
        {"working_genus", o.working_genus},
        {"zeros", o.zeros},
        {"patches", o.patches},
        {"collapsed_area", o.collapsed_area >= 0 ? nlohmann::json(o.collapsed_area) : nlohmann::json(nullptr)},
        {"timings_ms", timings_report(o.timings_ms)},
    };
    j["error"] = o.status.ok() ? nlohmann::json(nullptr)
                               : nlohmann::json{{"kind", o.status.kind},
                                                {"stage", o.status.stage},
                                                {"message", o.status.message}};
    return j;
}

namespace {

// The input file as a re-run compares it: size and modification time (null if it cannot be read).
nlohmann::json input_stamp(const std::string& path) {
    std::error_code ec;
    const std::uintmax_t bytes = fs::file_size(path, ec);
    if (ec) return nullptr;
    const fs::file_time_type modified = fs::last_write_time(path, ec);
    if (ec) return nullptr;
    return {{"bytes", bytes}, {"modified", modified.time_since_epoch().count()}};
}

}  // namespace

void write_model_result(const ModelOutcome& outcome, const nlohmann::json& settings) {
    if (outcome.task.out_dir.empty()) return;
    prepare_output_folder(outcome.task.out_dir);
    remove_stale_temporaries(outcome.task.out_dir, {"result.json"});
    if (!outcome.status.ok()) {
        // A failed model keeps no segmentation files (an earlier run's, or its own half set):
        // they would pass for its result.
        std::error_code ec;
        for (const std::string& name : kSegmentationFiles) fs::remove(outcome.task.out_dir / name, ec);
    }
    nlohmann::json j = outcome_json(outcome);
    j["settings"] = settings;
    j["input"] = input_stamp(outcome.task.path);
    write_file_atomic(outcome.task.out_dir / "result.json", json_text(j) + "\n");
}

std::optional<ModelOutcome> finished_model(const ModelTask& task, const nlohmann::json& settings) {
    if (task.out_dir.empty()) return std::nullopt;
    std::ifstream in(task.out_dir / "result.json");
    if (!in) return std::nullopt;
    // A result.json we cannot read back (edited, or from another version) means: recompute.
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    try {
        // The path as result.json holds it (bytes that are no UTF-8 written as U+FFFD).
        const std::string file = nlohmann::json::parse(json_text(task.path, -1)).get<std::string>();
        // The same file, maybe spelled another way (./models/a.off, an absolute path, a link).
        const auto same_file = [&](const std::string& recorded) {
            return recorded == file || file_identity(recorded) == file_identity(task.path);
        };
        if (!j.is_object() || j.value("status", "") != "ok" || !same_file(j.value("file", "")) ||
            !j.contains("settings") || j["settings"] != settings)
            return std::nullopt;
        // The input changed since (edited, replaced), or an output went missing: recompute.
        const nlohmann::json stamp = input_stamp(task.path);
        if (stamp.is_null() || !j.contains("input") || j["input"] != stamp) return std::nullopt;
        std::error_code ec;
        for (const std::string& name : kSegmentationFiles)
            if (!fs::is_regular_file(task.out_dir / name, ec)) return std::nullopt;
        ModelOutcome o;
        o.task = task;
        o.vertices = j.at("vertices").get<std::size_t>();
        o.faces = j.at("faces").get<std::size_t>();
        o.genus = j.at("genus").get<int>();
        o.working_genus = j.at("working_genus").get<int>();
        o.zeros = j.at("zeros").get<std::int64_t>();
        o.patches = j.at("patches").get<std::int64_t>();
        o.collapsed_area = j.at("collapsed_area").get<double>();  // absent before 2026-12-08: recomputed
        // Back in key order: the summary looks stages up by name, so order does not matter.
        for (const auto& [stage, ms] : j.at("timings_ms").items())
            if (stage != "total") o.timings_ms.emplace_back(stage, ms.get<double>());
        return o;
    } catch (const nlohmann::json::exception&) {
        return std::nullopt;
    }
}

void write_batch_summary(const fs::path& out_root, const std::vector<ModelOutcome>& outcomes) {
    remove_stale_temporaries(out_root, {"summary.json", "summary.csv"});
    nlohmann::json all = nlohmann::json::array();
    for (const ModelOutcome& o : outcomes) all.push_back(outcome_json(o));

    std::vector<std::string> stages = kStageOrder;
    for (const ModelOutcome& o : outcomes)
        for (const auto& [stage, ms] : o.timings_ms)
            if (std::find(stages.begin(), stages.end(), stage) == stages.end()) stages.push_back(stage);
    std::ostringstream csv;
    csv << "model,file,status,error_kind,error_stage,error,vertices,faces,genus,working_genus,zeros,patches,collapsed_area";
    for (const std::string& s : stages) csv << ",ms_" << s;
    csv << ",ms_total\n";
    for (const ModelOutcome& o : outcomes) {
        csv << csv_cell(o.task.name) << ',' << csv_cell(o.task.path) << ',' << (o.status.ok() ? "ok" : "failed")
            << ',' << csv_cell(o.status.kind) << ',' << csv_cell(o.status.stage) << ','
            << csv_cell(o.status.message) << ',' << o.vertices << ',' << o.faces << ',' << o.genus << ','
            << o.working_genus << ',' << o.zeros << ',' << o.patches << ',';
        if (o.collapsed_area >= 0) csv << o.collapsed_area;
        double total = 0;
        for (const std::string& s : stages) {
            csv << ',';
            for (const auto& [stage, ms] : o.timings_ms)
                if (stage == s) {
                    csv << format_ms(ms);
                    total += ms;
                    break;
                }
        }
        csv << ',' << format_ms(total) << '\n';
    }
    FileSet files;  // summary.json, the marker, last: it never stands beside another run's csv
    files.add(out_root / "summary.csv", csv.str());
    files.add(out_root / "summary.json", json_text(all) + "\n");
    files.commit();
}

BatchProgress::BatchProgress(std::size_t total, std::ostream& out, bool interactive,
                             std::chrono::milliseconds interval)
    : total_(total), out_(out), interactive_(interactive), interval_(interval) {}

void BatchProgress::model_finished(bool failed, bool reused) {
    ++done_;
    failed_ += failed;
    computed_ += !reused;
    const auto now = std::chrono::steady_clock::now();
    // A terminal redraws at most ten times a second; a log gets a line per interval.
    const auto gap = interactive_ ? std::chrono::milliseconds(100) : interval_;
    if (now - last_print_ >= gap || (interactive_ && done_ == total_)) {
        last_print_ = now;
        print(false);
    }
}

void BatchProgress::finish() { print(true); }

void BatchProgress::print(bool final_line) {
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double rate = seconds > 0 ? computed_ / seconds : 0;
    const std::size_t left = total_ - done_;
    std::ostringstream line;
    if (interactive_) {
        constexpr int kWidth = 30;
        const int filled = total_ ? static_cast<int>(kWidth * done_ / total_) : kWidth;
        line << '[' << std::string(filled, '#') << std::string(kWidth - filled, '.') << "] ";
    }
    line << done_ << '/' << total_ << " done, " << failed_ << " failed, " << std::fixed
         << std::setprecision(2) << rate << " models/s";
    if (left > 0 && rate > 0) {
        const long eta = std::lround(left / rate);
        line << ", ETA " << eta / 3600 << ':' << std::setw(2) << std::setfill('0') << (eta / 60) % 60 << ':'
             << std::setw(2) << eta % 60;
    } else if (final_line) {
        line << ", " << std::setprecision(1) << seconds << " s";
    }
    if (interactive_)
        out_ << '\r' << line.str() << "\x1b[K" << (final_line ? "\n" : "") << std::flush;
    else
        out_ << "progress: " << line.str() << std::endl;
}

}  // namespace holoflow::engine
