// Batch inputs, result markers and summaries, and `holoflow batch` end to end: bad files,
// resumption after a kill, identical results for any thread count.
#include "holoflow/engine/batch.h"

#include <csignal>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <unistd.h>
#include <sys/wait.h>

#include "holoflow/engine/segmentation_pipeline.h"
#include "support/test_support.h"

extern char** environ;

namespace holoflow::engine {
namespace {

namespace fs = std::filesystem;
using test::corpus;
using test::run_cli;
using test::TempDir;
using test::slurp;

// summary.json without what may differ between runs (timings).
nlohmann::json summary_without_timings(const fs::path& out) {
    nlohmann::json summary = nlohmann::json::parse(slurp(out / "summary.json"));
    for (auto& model : summary) model.erase("timings_ms");
    return summary;
}

TEST(ExpandInputs, FilesFoldersAndLists) {
    const TempDir dir;
    fs::create_directories(dir.path() / "set" / "sub");
    const std::string b = dir.write("set/b.off", "x"), a = dir.write("set/sub/a.obj", "x");
    dir.write("set/notes.txt", "not a mesh");
    const std::string c = dir.write("c.ply", "x");
    const std::string list = dir.write("list.txt", "# models\n\n  c.ply  \nset/b.off\nmissing.stl\n");
    const std::vector<std::string> paths = expand_inputs({(dir.path() / "set").string(), list});
    const std::vector<std::string> expected = {b, a, c, (dir.path() / "missing.stl").string()};
    EXPECT_EQ(paths, expected) << "folder sorted and recursive, list relative to itself, b kept once";
    EXPECT_THROW(expand_inputs({(dir.path() / "nowhere").string()}), InvalidInput);
    const std::string bad_list = dir.write("bad.txt", "notes\n");
    dir.write("notes", "plain text");
    EXPECT_THROW(expand_inputs({bad_list}), InvalidInput);
}

// One file in several spellings, or through a link, is one model; a list must be text.
TEST(ExpandInputs, OneFileIsOneModelAndListsAreText) {
    const TempDir dir;
    const std::string a = dir.write("a.off", "x");
    fs::create_symlink("a.off", dir.path() / "link.off");
    const std::string list = dir.write("list.txt", "a.off\n./a.off\n" + fs::absolute(a).string() + "\n");
    const std::vector<std::string> paths =
        expand_inputs({a, (dir.path() / "." / "a.off").string(), (dir.path() / "link.off").string(), list});
    EXPECT_EQ(paths, std::vector<std::string>{a});

    const auto refusal = [&](const std::string& name, const std::string& bytes) {
        try {
            expand_inputs({dir.write(name, bytes)});
        } catch (const InvalidInput& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    EXPECT_NE(refusal("program", std::string("\x7f" "ELF\x02\x01\0\0a.off\n", 12)).find("binary data"),
              std::string::npos);
    EXPECT_NE(refusal("mesh", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").find("looks like a mesh file"),
              std::string::npos);
    EXPECT_NE(refusal("mesh.txt", "\xEF\xBB\xBFply\nformat ascii 1.0\n").find("looks like a mesh file"),
              std::string::npos);
}

// Folders: links to folders are followed once (a link back up does not loop), files with mesh
// names that are no regular files (a broken link, a FIFO) become models that will fail, and a
// file named just ".off" is a mesh.
TEST(ExpandInputs, LinksBrokenLinksFifosAndDotNames) {
    const TempDir dir;
    fs::create_directories(dir.path() / "set");
    fs::create_directories(dir.path() / "elsewhere");
    const std::string a = dir.write("set/a.off", "x"), b = dir.write("elsewhere/b.off", "x");
    const std::string dot = dir.write("set/.off", "x");
    fs::create_directory_symlink(dir.path() / "elsewhere", dir.path() / "set" / "linked");
    fs::create_directory_symlink(dir.path() / "set", dir.path() / "set" / "up");  // a loop
    fs::create_symlink(dir.path() / "nowhere.off", dir.path() / "set" / "broken.off");
    ASSERT_EQ(::mkfifo((dir.path() / "set" / "pipe.obj").c_str(), 0644), 0);
    const std::vector<std::string> paths = expand_inputs({(dir.path() / "set").string()});
    const std::vector<std::string> expected = {dot, a, (dir.path() / "set" / "broken.off").string(),
                                               (dir.path() / "set" / "linked" / "b.off").string(),
                                               (dir.path() / "set" / "pipe.obj").string()};
    EXPECT_EQ(paths, expected);
    EXPECT_EQ(expand_inputs({dot}), std::vector<std::string>{dot}) << "not read as a list";
    EXPECT_EQ(make_tasks({dot}, "out")[0].name, "model");
    if (::geteuid() != 0) {  // root reads every folder
        fs::create_directories(dir.path() / "set" / "closed");
        fs::permissions(dir.path() / "set" / "closed", fs::perms::none);
        EXPECT_THROW(expand_inputs({(dir.path() / "set").string()}), InvalidInput);
        fs::permissions(dir.path() / "set" / "closed", fs::perms::owner_all);
    }
}

TEST(MakeTasks, UniqueFolderNamesInInputOrder) {
    const std::vector<ModelTask> tasks = make_tasks({"x/bull.off", "y/bull.obj", "z/cow.off", "w/bull.ply"}, "out");
    ASSERT_EQ(tasks.size(), 4u);
    EXPECT_EQ(tasks[0].name, "bull");
    EXPECT_EQ(tasks[1].name, "bull~2");
    EXPECT_EQ(tasks[2].name, "cow");
    EXPECT_EQ(tasks[3].name, "bull~3");
    for (std::size_t i = 0; i < tasks.size(); ++i) {
        EXPECT_EQ(tasks[i].id, i);
        EXPECT_EQ(tasks[i].out_dir, fs::path("out") / tasks[i].name);
    }
    // A folder name must fit in 255 bytes with its suffix: long stems are cut between characters.
    std::string long_stem;
    for (int i = 0; i < 125; ++i) long_stem += "\xC3\xA9";  // 250 bytes of e-acute
    const std::vector<ModelTask> odd = make_tasks({"x/" + long_stem + ".off", "y/" + long_stem + ".off",
                                                   "z/.holoflow.lock.off"}, "out");
    EXPECT_EQ(odd[0].name, long_stem.substr(0, 200));
    EXPECT_EQ(odd[1].name, long_stem.substr(0, 200) + "~2");
    EXPECT_EQ(odd[2].name, ".holoflow.lock~2") << "the output folder's lock file";
}

TEST(ModelResult, RoundTripsAndChecksSettings) {
    const TempDir dir;
    ModelOutcome o;
    o.task = make_tasks({dir.write("eight.off", slurp(corpus("eight.off")))}, dir.path() / "out").front();
    o.vertices = 316;
    o.faces = 634;
    o.genus = o.working_genus = 2;
    o.zeros = 2;
    o.patches = 12;
    o.collapsed_area = 0.0625;
    o.timings_ms = {{"load", 1.5}, {"analyse", 0.25}, {"write", 2}};
    const nlohmann::json settings = {{"mode", "layout"}};
    write_model_result(o, settings);
    EXPECT_FALSE(finished_model(o.task, settings).has_value()) << "no segmentation files: recompute";
    for (const std::string& file : kSegmentationFiles) std::ofstream(o.task.out_dir / file) << "x";
    const std::optional<ModelOutcome> back = finished_model(o.task, settings);
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(outcome_json(*back), outcome_json(o));
    EXPECT_FALSE(finished_model(o.task, {{"mode", "vertical"}}).has_value()) << "other settings: recompute";
    std::ofstream(o.task.path, std::ios::app) << "# edited\n";
    EXPECT_FALSE(finished_model(o.task, settings).has_value()) << "input changed: recompute";
    write_model_result(o, settings);
    ASSERT_TRUE(finished_model(o.task, settings).has_value());
    fs::remove(o.task.out_dir / "patches.obj");
    EXPECT_FALSE(finished_model(o.task, settings).has_value()) << "an output missing: recompute";
    o.status = Status::failure("solver_failure", "factorise", "not positive definite", kExitSolverFailure);
    write_model_result(o, settings);
    EXPECT_FALSE(finished_model(o.task, settings).has_value()) << "failed models are retried";
    std::ofstream(o.task.out_dir / "result.json") << "{ truncated";
    EXPECT_FALSE(finished_model(o.task, settings).has_value());
}

TEST(BatchSummary, CsvHasOneRowPerModelAndQuotesErrors) {
    const TempDir dir;
    std::vector<ModelTask> tasks = make_tasks({"a.off", "b.off"}, dir.path());
    std::vector<ModelOutcome> outcomes(2);
    outcomes[0].task = tasks[0];
    outcomes[0].timings_ms = {{"load", 1}, {"zeros", 2}};
    outcomes[0].collapsed_area = 0.5;
    outcomes[1].task = tasks[1];
    outcomes[1].status = Status::failure("parse_error", "read", "line 3: bad token \"x\", expected a number", 16);
    write_batch_summary(dir.path(), outcomes);
    const nlohmann::json summary = nlohmann::json::parse(slurp(dir.path() / "summary.json"));
    ASSERT_EQ(summary.size(), 2u);
    EXPECT_EQ(summary[0]["status"], "ok");
    EXPECT_EQ(summary[1]["error"]["kind"], "parse_error");
    EXPECT_DOUBLE_EQ(summary[0]["timings_ms"]["total"].get<double>(), 3.0);
    EXPECT_EQ(summary[0]["collapsed_area"], 0.5);
    EXPECT_TRUE(summary[1]["collapsed_area"].is_null()) << "a failed model has none";
    std::istringstream csv(slurp(dir.path() / "summary.csv"));
    std::string header, row0, row1, extra;
    std::getline(csv, header);
    std::getline(csv, row0);
    std::getline(csv, row1);
    EXPECT_FALSE(std::getline(csv, extra));
    EXPECT_NE(header.find("ms_zeros"), std::string::npos);
    EXPECT_NE(header.find(",patches,collapsed_area,"), std::string::npos) << header;
    EXPECT_NE(row0.find(",0.5,"), std::string::npos) << row0;
    EXPECT_NE(row1.find("\"line 3: bad token \"\"x\"\", expected a number\""), std::string::npos) << row1;
}

// A list of real models plus broken files (a FIFO would block a reader until a writer comes).
std::string write_batch_list(const TempDir& dir) {
    dir.write("broken.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
    EXPECT_EQ(::mkfifo((dir.path() / "fifo.off").c_str(), 0600), 0);
    std::string list;
    for (const char* m : {"eight", "knot", "head", "elephant", "bull", "femur"}) list += corpus(std::string(m) + ".off") + "\n";
    list += "broken.off\nnot-there.off\nfifo.off\n";
    return dir.write("models.txt", list);
}

TEST(BatchCommand, BadFilesFailAloneAndThreadCountsAgree) {
    const TempDir dir;
    const std::string list = write_batch_list(dir);
    const fs::path one = dir.path() / "one", two = dir.path() / "two";
    const test::CommandResult r1 = run_cli("batch '" + list + "' -o '" + one.string() + "' --threads 1");
    const test::CommandResult r2 = run_cli("batch '" + list + "' -o '" + two.string() + "' --threads 2");
    EXPECT_EQ(r1.status, kExitBatchFailures) << r1.err;
    EXPECT_EQ(r2.status, kExitBatchFailures) << r2.err;
    EXPECT_NE(r1.out.find("9 models: 6 ok, 3 failed"), std::string::npos) << r1.out;
    EXPECT_NE(r1.err.find("progress: 9/9 done, 3 failed"), std::string::npos) << r1.err;
    EXPECT_EQ(summary_without_timings(one), summary_without_timings(two));
    const nlohmann::json summary = summary_without_timings(one);
    EXPECT_EQ(summary[6]["error"]["kind"], "non_finite_coordinate");
    EXPECT_EQ(summary[7]["error"]["kind"], "file_not_found");
    EXPECT_EQ(summary[8]["error"]["kind"], "unreadable");
    for (const char* m : {"eight", "knot", "head", "elephant", "bull", "femur"})
        for (const char* file : {"segments.ply", "complex.json", "patches.obj"})
            EXPECT_EQ(slurp(one / m / file), slurp(two / m / file)) << m << "/" << file;
    // The same model alone through `segment` writes the same files.
    const fs::path alone = dir.path() / "alone";
    ASSERT_EQ(run_cli("segment '" + corpus("head.off") + "' -o '" + alone.string() + "'").status, 0);
    EXPECT_EQ(slurp(alone / "segments.ply"), slurp(one / "head" / "segments.ply"));
}

TEST(BatchCommand, KilledRunResumesToTheSameSummary) {
    const TempDir dir;
    // Enough work that the kill (within milliseconds of the second result) lands mid-run: copies
    // of one mid-sized model (femur, 50 ms each; the test is the slowest under TSan) after the list.
    std::string list = slurp(write_batch_list(dir));
    for (int i = 0; i < 6; ++i) {
        fs::copy_file(corpus("femur.off"), dir.path() / ("femur" + std::to_string(i) + ".off"));
        list += "femur" + std::to_string(i) + ".off\n";
    }
    const std::string list_path = dir.write("long.txt", list);
    const fs::path killed = dir.path() / "killed", whole = dir.path() / "whole";

    std::vector<std::string> args = {HOLOFLOW_CLI, "batch", list_path, "-o", killed.string(), "--threads", "1"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ), 0);
    posix_spawn_file_actions_destroy(&actions);
    const auto finished_models = [&] {
        std::size_t n = 0;
        std::error_code ec;
        for (fs::directory_iterator it(killed, ec), end; !ec && it != end; it.increment(ec))
            n += fs::exists(it->path() / "result.json");
        return n;
    };
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (finished_models() < 2 && std::chrono::steady_clock::now() < give_up)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the batch finished before it could be killed";
    EXPECT_FALSE(fs::exists(killed / "summary.json"));
    const std::size_t before = finished_models();
    EXPECT_LT(before, 14u);

    const test::CommandResult resumed = run_cli("batch '" + list_path + "' -o '" + killed.string() + "' --threads 2");
    EXPECT_EQ(resumed.status, kExitBatchFailures) << resumed.err;
    EXPECT_NE(resumed.out.find("reused from an earlier run"), std::string::npos);
    const test::CommandResult uninterrupted = run_cli("batch '" + list_path + "' -o '" + whole.string() + "'");
    EXPECT_EQ(uninterrupted.status, kExitBatchFailures) << uninterrupted.err;
    EXPECT_EQ(summary_without_timings(killed), summary_without_timings(whole));
    // No temporary survives the resumed run.
    for (const auto& entry : fs::recursive_directory_iterator(killed))
        EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
    // --force recomputes everything.
    const test::CommandResult forced = run_cli("batch '" + list_path + "' -o '" + killed.string() + "' --force");
    EXPECT_NE(forced.out.find(", 0 reused"), std::string::npos) << forced.out;
}

// Models computed side by side share the memory limit; one whose refinement that share refuses
// is computed again alone, so the batch writes what `segment` writes with the same limit.
TEST(BatchCommand, ModelsOverTheirMemoryShareAreComputedAgainAlone) {
    const TempDir dir;
    const std::string anchor = corpus("anchor.off");  // 3 fans fail until its midpoint refinement
    const auto segment = [&](std::size_t mib, const std::string& name) {
        const fs::path out = dir.path() / name;
        const test::CommandResult r = run_cli("segment '" + anchor + "' -o '" + out.string() + "' --json --max-memory " +
                                              std::to_string(mib));
        return std::pair{r, r.status == 0 ? nlohmann::json::parse(r.out) : nlohmann::json()};
    };
    // The limit: the input's need (raised after each refusal: the dense forms are counted before
    // the homology, the factor after the analysis), then doubled until no refinement is
    // refused; at half of it, the share of 2 threads, one is.
    std::size_t limit = 1;
    auto [run, report] = segment(limit, "fits");
    for (int attempt = 0; run.status != 0; ++attempt) {
        ASSERT_LT(attempt, 3) << run.err;
        const std::size_t at = run.err.find("about ");
        ASSERT_NE(at, std::string::npos) << run.err;
        limit = std::stoul(run.err.substr(at + 6)) + 1;
        std::tie(run, report) = segment(limit, "fits");
    }
    ASSERT_GT(report["tries_over_memory_limit"], 0) << "the input fits, its refinement not";
    while (report["tries_over_memory_limit"] != 0) {
        ASSERT_LT(limit, 1u << 16) << "the refinement never fits";
        report = segment(limit *= 2, "fits").second;
        ASSERT_TRUE(report.is_object()) << limit;
    }
    const fs::path inputs = dir.path() / "in";
    fs::create_directories(inputs);
    fs::copy_file(anchor, inputs / "a.off");  // two files: links to one would be one model
    fs::copy_file(anchor, inputs / "b.off");
    for (const char* threads : {"2", "1"}) {
        const fs::path out = dir.path() / (std::string("batch") + threads);
        const test::CommandResult r = run_cli("batch '" + inputs.string() + "' -o '" + out.string() + "' --threads " +
                                              threads + " --max-memory " + std::to_string(limit));
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_EQ(r.err.find("computed again one at a time with " + std::to_string(limit) + " MiB: a b\n") !=
                      std::string::npos,
                  std::string(threads) == "2")
            << r.err;
        for (const char* model : {"a", "b"}) {
            EXPECT_TRUE(slurp(out / model / "segments.ply") == slurp(dir.path() / "fits" / "segments.ply")) << model;
            EXPECT_EQ(nlohmann::json::parse(slurp(out / model / "segmentation.json"))["tries_over_memory_limit"], 0);
        }
    }
}

// Inputs that tripped the batch up: an output folder among its inputs (the next run took its own
// outputs as meshes), a model named like the summary (the summary could not be written), a file
// name that is not UTF-8 (the JSON writer threw: no summary at all), and --dot naming an input
// (written first, it replaced the mesh).
TEST(BatchCommand, OddNamesAndFoldersAreHandled) {
    const TempDir dir;
    const fs::path in = dir.path() / "in";
    fs::create_directories(in);
    fs::copy_file(corpus("eight.off"), in / "summary.json.off");
    fs::copy_file(corpus("eight.off"), in / "caf\xe9.off");
    for (int run = 0; run < 2; ++run) {
        const test::CommandResult r = run_cli("batch '" + in.string() + "' -o '" + in.string() + "'");
        ASSERT_EQ(r.status, 0) << r.err;
        EXPECT_NE(r.out.find(run == 0 ? "2 models: 2 ok, 0 failed, 0 reused" : "2 models: 2 ok, 0 failed, 2 reused"),
                  std::string::npos)
            << r.out;
    }
    EXPECT_TRUE(fs::is_regular_file(in / "summary.json~2" / "segments.ply"));
    const nlohmann::json summary = nlohmann::json::parse(slurp(in / "summary.json"));
    ASSERT_EQ(summary.size(), 2u);
    EXPECT_EQ(summary[0]["model"], "caf\xef\xbf\xbd");  // the byte that is no UTF-8 shown as U+FFFD

    const std::string before = slurp(in / "summary.json.off");
    const test::CommandResult dot = run_cli("batch '" + in.string() + "' -o '" + (dir.path() / "out").string() +
                                            "' --dot '" + (in / "summary.json.off").string() + "'");
    EXPECT_EQ(dot.status, kExitInvalidInput) << dot.err;
    EXPECT_NE(dot.err.find("it would be overwritten"), std::string::npos) << dot.err;
    EXPECT_EQ(slurp(in / "summary.json.off"), before);
}

// A re-run that names the same file another way reuses its result.
TEST(BatchCommand, ReuseAcrossPathSpellings) {
    const TempDir dir;
    fs::create_directories(dir.path() / "in");
    fs::copy_file(corpus("eight.off"), dir.path() / "in" / "m.off");
    const std::string out = (dir.path() / "out").string();
    ASSERT_EQ(run_cli("batch '" + (dir.path() / "in" / "m.off").string() + "' -o '" + out + "'").status, 0);
    fs::create_directory_symlink(dir.path() / "in", dir.path() / "link");
    const test::CommandResult again = run_cli("batch '" + (dir.path() / "link" / "m.off").string() + "' -o '" + out + "'");
    ASSERT_EQ(again.status, 0) << again.err;
    EXPECT_NE(again.out.find("1 reused"), std::string::npos) << again.out;
}

// A model that fails keeps no files of an earlier run, which would pass for its result.
TEST(BatchCommand, AFailedModelKeepsNoEarlierFiles) {
    const TempDir dir;
    const fs::path mesh = dir.path() / "m.off", out = dir.path() / "out";
    fs::copy_file(corpus("eight.off"), mesh);
    ASSERT_EQ(run_cli("batch '" + mesh.string() + "' -o '" + out.string() + "'").status, 0);
    ASSERT_TRUE(fs::exists(out / "m" / "segments.ply"));
    std::ofstream(mesh, std::ios::trunc) << "OFF\n3 1 0\n0 0 0\n";
    EXPECT_EQ(run_cli("batch '" + mesh.string() + "' -o '" + out.string() + "'").status, kExitBatchFailures);
    for (const std::string& file : kSegmentationFiles) EXPECT_FALSE(fs::exists(out / "m" / file)) << file;
    EXPECT_EQ(nlohmann::json::parse(slurp(out / "m" / "result.json"))["status"], "failed");
}

TEST(BatchCommand, RefusesMissingInputsAndUnwritableOutput) {
    const TempDir dir;
    const test::CommandResult missing = run_cli("batch '" + (dir.path() / "none").string() + "' -o '" +
                                                (dir.path() / "out").string() + "'");
    EXPECT_EQ(missing.status, kExitInvalidInput);
    EXPECT_NE(missing.err.find("does not exist"), std::string::npos);
    fs::create_symlink(dir.path() / "loop", dir.path() / "loop");
    const test::CommandResult loop = run_cli("batch '" + (dir.path() / "loop").string() + "' -o '" +
                                             (dir.path() / "out").string() + "'");
    EXPECT_EQ(loop.status, kExitInvalidInput);
    EXPECT_NE(loop.err.find("is a symbolic link to nothing (a missing target or a loop)"), std::string::npos) << loop.err;
    fs::create_directories(dir.path() / "empty");
    const test::CommandResult nothing = run_cli("batch '" + (dir.path() / "empty").string() + "' -o '" +
                                                (dir.path() / "out" / "deeper").string() + "'");
    EXPECT_EQ(nothing.status, kExitInvalidInput);
    EXPECT_NE(nothing.err.find("name no mesh files"), std::string::npos) << nothing.err;
    EXPECT_FALSE(fs::exists(dir.path() / "out")) << "a refused batch leaves no empty output folder";
    const std::string file = dir.write("file", "x");
    const test::CommandResult unwritable = run_cli("batch '" + corpus("eight.off") + "' -o '" + file + "/sub'");
    EXPECT_EQ(unwritable.status, kExitOutputError) << unwritable.err;
}

TEST(BatchCommand, WritesTheGraphAsDot) {
    const TempDir dir;
    const std::string dot = (dir.path() / "graph.dot").string();
    const test::CommandResult r = run_cli("batch '" + corpus("eight.off") + "' -o '" + (dir.path() / "o").string() +
                                          "' --dot '" + dot + "'");
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(slurp(dot).rfind("digraph", 0), 0u);
}

}  // namespace
}  // namespace holoflow::engine
