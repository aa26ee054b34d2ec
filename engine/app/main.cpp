// holoflow command line: one executable, one subcommand per job. Errors go to stderr as
// `error: <kind>: <detail>` with a distinct exit status per kind (README "Exit status").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <new>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/memory_limits.h"
#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/output.h"
#include "holoflow/engine/report.h"
#include "holoflow/engine/segmentation_output.h"
#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/engine/status.h"
#include "holoflow/graphs/collection.h"
#include "holoflow/graphs/segmentation_graph.h"
#include "holoflow/kernels/topology.h"

namespace {

using namespace holoflow;
using engine::kExitUsage;

// `segment` notes on stderr when at least this share of the surface's uv collapsed.
constexpr double kCollapsedAreaNote = 0.01;

int report_error(const std::string& kind, const std::string& detail, int status) {
    std::cerr << "error: " << kind << ": " << detail << std::endl;
    return status;
}

int report_error(const engine::Status& status) {
    return report_error(status.kind, status.message, status.exit_code);
}

// Runs one subcommand and turns every failure into one stderr line and an exit status; what it
// printed must have reached stdout (a full disk, a closed pipe).
int run_guarded(const std::function<int()>& body) {
    try {
        const int status = body();
        if (!std::cout.flush())
            return report_error("output_error", "cannot write to standard output", engine::kExitOutputError);
        return status;
    } catch (...) {
        return report_error(engine::status_from_exception(std::current_exception(), "main"));
    }
}

// A range check where a value that is no number is named as such: CLI11's Range alone calls
// "abc" out of range, and lets "nan" through (every comparison with it is false).
template <class T>
CLI::Validator number_in(T low, T high) {
    return CLI::Validator(
        [low, high](std::string& text) {
            const bool number = CLI::Number(text).empty() && !std::isnan(std::strtod(text.c_str(), nullptr));
            return number ? CLI::Range(low, high)(text) : "not a number: " + text;
        },
        CLI::Range(low, high).get_description());
}

// What the address-space limit leaves the solver: set by main before a solving command runs.
engine::AddressSpacePlan solver_address_space;

// The memory limit without --max-memory.
std::size_t default_memory_limit_bytes() { return engine::default_memory_limit_bytes(solver_address_space); }

// Loading options of every subcommand.
struct LoadArgs {
    std::string components = "all";
    std::string pinched_vertices = "split", zero_area_faces = "repair", duplicate_faces = "drop", seams = "zip",
                non_manifold_edges = "split";
    std::size_t max_faces = 0;

    void add_to(CLI::App& command) {
        command
            .add_option("--component", components,
                        "several components: keep all, or only the largest")
            ->check(CLI::IsMember({"all", "largest"}));
        command
            .add_option("--pinched-vertices", pinched_vertices,
                        "a vertex whose faces form several fans: split it into one vertex per fan, or refuse the mesh")
            ->check(CLI::IsMember({"split", "refuse"}));
        command
            .add_option("--zero-area-faces", zero_area_faces,
                        "triangles with collinear or coincident corners: remove them by edge collapses and flips "
                        "that keep the topology, or refuse the mesh")
            ->check(CLI::IsMember({"repair", "refuse"}));
        command
            .add_option("--duplicate-faces", duplicate_faces,
                        "a triangle on the same vertices as an earlier one: drop it, or refuse the mesh")
            ->check(CLI::IsMember({"drop", "refuse"}));
        command
            .add_option("--seams", seams,
                        "two boundary edges on the same two positions (a triangle soup, vertices duplicated "
                        "along seams): zip them into one edge, or keep both as boundary")
            ->check(CLI::IsMember({"zip", "keep"}));
        command
            .add_option("--non-manifold-edges", non_manifold_edges,
                        "an edge shared by more than two faces: pair its faces off two by two, each pair its "
                        "own edge, or refuse the mesh")
            ->check(CLI::IsMember({"split", "refuse"}));
        command.add_option("--max-faces", max_faces, "refuse meshes with more triangles (0: no limit)");
    }
    engine::LoadOptions options() const {
        engine::LoadOptions o;
        o.components = components == "largest" ? engine::ComponentPolicy::Largest
                                               : engine::ComponentPolicy::All;
        o.pinched_vertices = pinched_vertices == "refuse" ? engine::PinchedVertexPolicy::Refuse
                                                          : engine::PinchedVertexPolicy::Split;
        o.zero_area_faces = zero_area_faces == "refuse" ? engine::ZeroAreaPolicy::Refuse : engine::ZeroAreaPolicy::Repair;
        o.duplicate_faces =
            duplicate_faces == "refuse" ? engine::DuplicateFacePolicy::Refuse : engine::DuplicateFacePolicy::Drop;
        o.seams = seams == "keep" ? engine::SeamPolicy::Keep : engine::SeamPolicy::Zip;
        o.non_manifold_edges = non_manifold_edges == "refuse" ? engine::NonManifoldEdgePolicy::Refuse
                                                              : engine::NonManifoldEdgePolicy::Split;
        o.max_faces = max_faces;
        o.max_file_bytes = default_memory_limit_bytes();  // `segment` and `batch`: --max-memory
        return o;
    }
};

struct MeshArgs {
    std::string path;
    LoadArgs load;

    void add_to(CLI::App& command) {
        command.add_option("MESH", path, "mesh file: .off .obj .ply .stl")->required();
        load.add_to(command);
    }
    engine::LoadOptions options() const { return load.options(); }
};

int run_info(const MeshArgs& mesh_args, bool json) {
    const engine::LoadedMesh loaded = engine::load_mesh(mesh_args.path, mesh_args.options());
    const kernels::Topology topology = kernels::compute_topology(*loaded.mesh);
    const nlohmann::json report = engine::info_report(mesh_args.path, loaded, topology);
    if (json)
        std::cout << engine::json_text(report) << std::endl;
    else
        std::cout << engine::format_info_text(report);
    return 0;
}

int run_conformal(const MeshArgs& mesh_args, const std::string& out_dir, const std::string& laplacian,
                  bool json) {
    const engine::OutputFolder output(out_dir);  // fail before the work, not after
    const std::filesystem::path& folder = output.path();
    const std::vector<std::string> names = {"uv.obj", "forms", "conformal.json"};
    std::vector<std::filesystem::path> outputs;
    for (const std::string& name : names) outputs.push_back(folder / name);
    engine::refuse_overwriting_inputs(outputs, {mesh_args.path});
    engine::remove_stale_temporaries(folder, names);
    const engine::LoadedMesh loaded = engine::load_mesh(mesh_args.path, mesh_args.options());
    engine::ConformalOptions options;
    options.laplacian = laplacian == "extrinsic" ? engine::LaplacianKind::Extrinsic
                                                 : engine::LaplacianKind::IntrinsicDelaunay;
    const engine::ConformalResult result = engine::compute_conformal(*loaded.mesh, options);
    nlohmann::json report = engine::conformal_report(result);
    report["file"] = mesh_args.path;
    report["laplacian"] = laplacian;
    engine::FileSet files;  // conformal.json marks a whole set
    files.add(folder / "uv.obj", [&](std::ostream& out) { engine::write_uv_obj(out, *loaded.mesh, result); });
    files.add(folder / "forms", [&](std::ostream& out) { engine::write_forms(out, result); });
    files.add(folder / "conformal.json", engine::json_text(report) + "\n");
    files.commit();
    if (json) std::cout << engine::json_text(report) << std::endl;
    else
        std::cout << "genus " << report["genus"] << ", working genus " << report["working_genus"]
                  << ", star error " << report["star_square_error"] << ", period symmetry error "
                  << report["period_symmetry_error"] << "\nwrote " << (folder / "uv.obj").string()
                  << ", forms, conformal.json\n";
    return 0;
}

// Options shared by `segment` and `batch`.
struct SegmentSettings {
    LoadArgs load;
    std::string mode = "layout", laplacian = "intrinsic";
    std::size_t max_memory_mb = 0;
    CLI::Option* max_memory = nullptr;  // not given: default_memory_limit_bytes()
    int max_tips = 8;
    double hole_size = 0.02;
    int fan_refinements = 3;
    holoflow::Index fill_holes = 0;
    int max_working_genus = engine::SegmentOptions{}.holes.max_working_genus;
    bool keep_holes_at_failed_fans = false;
    bool slice_tips = false;

    void add_to(CLI::App& command) {
        command.add_option("--mode", mode, "vertical: the paper's trajectories; layout: both families, "
                                           "motorcycle rule, every patch a rectangle")
            ->check(CLI::IsMember({"vertical", "layout"}));
        command.add_option("--laplacian", laplacian, "cotan weights: intrinsic Delaunay or the mesh itself")
            ->check(CLI::IsMember({"intrinsic", "extrinsic"}));
        load.add_to(command);
        max_memory = command.add_option("--max-memory", max_memory_mb,
                                        "MiB the conformal stage may use: a model that would need more is refused "
                                        "and a refinement that would is skipped; models computed at once share it, "
                                        "and one over its share is computed again alone (0: no limit; default: "
                                        "3/4 of the memory, or of the address space `ulimit -v` leaves)")
                         ->check(number_in(std::size_t{0}, std::size_t{1} << 30));
        command.add_option("--max-tips", max_tips, "most tips detected automatically")
            ->check(number_in(2, 64));
        command.add_flag("--slice-tips", slice_tips,
                         "slice tip holes on every surface, not only closed genus 0 and disks: along a limb "
                         "of a surface with handles the form decays and its patches shrink to points "
                         "(`collapsed_area`)");
        command.add_option("--hole-size", hole_size, "tip hole radius, fraction of sqrt(area / 4 pi)")
            ->check(number_in(0.0, 0.5));
        command.add_option("--fan-refinements", fan_refinements,
                           "where zero fans fail: rounds of refinement around them, each a new conformal "
                           "solve (0: none)")
            ->check(number_in(0, 8));
        command.add_option("--fill-holes", fill_holes, "fill every boundary loop of at most this many edges")
            ->check(number_in(0, 256));
        command.add_option("--max-working-genus", max_working_genus,
                           "past this genus of the double cover, fill the shortest boundary loops until it "
                           "fits (0: never)")
            ->check(number_in(0, 1 << 20));
        command.add_flag("--keep-holes-at-failed-fans", keep_holes_at_failed_fans,
                         "leave open the small holes next to zeros whose fans fail (default: fill them and "
                         "solve again)");
    }
    //! The memory limit in bytes (0: none).
    std::size_t memory_limit_bytes() const {
        return max_memory != nullptr && max_memory->count() == 0 ? default_memory_limit_bytes() : max_memory_mb << 20;
    }
    //! With the whole memory limit (a batch splits it between the models computed at once).
    graphs::SegmentationGraphOptions graph_options() const {
        graphs::SegmentationGraphOptions o;
        o.load = load.options();
        o.load.max_file_bytes = memory_limit_bytes();  // the whole limit, whatever the share
        o.segment.conformal.laplacian =
            laplacian == "extrinsic" ? engine::LaplacianKind::Extrinsic : engine::LaplacianKind::IntrinsicDelaunay;
        o.segment.conformal.max_solver_bytes = memory_limit_bytes();
        o.segment.mode = mode == "vertical" ? engine::SegmentMode::Vertical : engine::SegmentMode::Layout;
        o.segment.max_tips = max_tips;
        o.segment.hole_size = hole_size;
        o.segment.slice_tips = slice_tips;
        o.segment.fan_refinement_rounds = fan_refinements;
        o.segment.holes.max_loop_edges = fill_holes;
        o.segment.holes.max_working_genus = max_working_genus;
        o.segment.fill_holes_at_failed_fans = !keep_holes_at_failed_fans;
        return o;
    }
    //! What a finished model's results depend on: a re-run with other values recomputes it.
    nlohmann::json fingerprint() const {
        return {{"mode", mode}, {"laplacian", laplacian}, {"component", load.components},
                {"pinched_vertices", load.pinched_vertices}, {"zero_area_faces", load.zero_area_faces},
                {"duplicate_faces", load.duplicate_faces}, {"seams", load.seams},
                {"non_manifold_edges", load.non_manifold_edges},
                {"max_tips", max_tips}, {"hole_size", hole_size}, {"slice_tips", slice_tips}, {"fan_refinements", fan_refinements},
                {"fill_holes", fill_holes}, {"max_working_genus", max_working_genus},
                {"keep_holes_at_failed_fans", keep_holes_at_failed_fans}, {"max_memory_mb", memory_limit_bytes() >> 20},
                {"version", HOLOFLOW_VERSION}};
    }
};

struct SegmentArgs {
    std::string path, out_dir;
    SegmentSettings settings;
    std::vector<holoflow::Index> tips;
    bool json = false;
};

// The per-model flow graph on one mesh.
int run_segment(const SegmentArgs& args) {
    const engine::OutputFolder output(args.out_dir);  // fail before the work, not after
    const std::filesystem::path& folder = output.path();
    std::vector<std::filesystem::path> outputs;
    for (const std::string& name : engine::kSegmentationFiles) outputs.push_back(folder / name);
    engine::refuse_overwriting_inputs(outputs, {args.path});
    graphs::SegmentationGraphOptions options = args.settings.graph_options();
    options.segment.tips = args.tips;
    options.max_in_flight = 1;
    engine::ModelTask task;
    task.path = args.path;
    task.name = std::filesystem::path(args.path).stem().string();
    task.out_dir = folder;
    const std::vector<graphs::ModelRun> runs = graphs::SegmentationGraph(options).run({task});
    const graphs::ModelRun& run = runs.front();
    if (!run.outcome.status.ok()) return report_error(run.outcome.status);
    const nlohmann::json& report = run.report;
    if (args.json) {
        std::cout << engine::json_text(report) << std::endl;
    } else {
        std::cout << "genus " << report["genus"] << ", working genus " << report["working_genus"] << ", "
                  << report["zero_count"] << " zeros (" << report["artifacts"] << " artifact clusters), "
                  << report["trajectories"] << " trajectories (" << report["unfinished_trajectories"]
                  << " unfinished), " << report["patch_count"] << " patches " << engine::json_text(report["patch_types"], -1)
                  << ", flipped uv triangles " << report["flipped_uv_triangles"] << ", rectangle error "
                  << report["rectangle_error_max"] << "\nwrote segments.ply, patches.obj, trajectories.obj, "
                  << "domains.svg, complex.json, segmentation.json in " << folder.string() << "\n";
    }
    if (const double collapsed = report["collapsed_area"].get<double>(); collapsed >= kCollapsedAreaNote) {
        std::cerr << "note: " << std::setprecision(3) << 100 * collapsed << " % of the surface maps to under "
                  << engine::kCollapsedScale << " of the mean uv scale (protrusions, where the form decays)";
        if (report["tips"].empty()) std::cerr << "; --slice-tips cuts holes at the tips, which keeps them";
        std::cerr << "\n";
    }
    return 0;
}

struct BatchArgs {
    std::vector<std::string> inputs;
    std::string out_dir, dot;
    SegmentSettings settings;
    unsigned threads = 0;
    std::size_t max_in_flight = 0;
    double timeout_s = 0;
    bool force = false, serial = false;
};

// The collection flow graph: every model of the inputs, one folder each, a summary.
int run_batch(const BatchArgs& args) {
    const engine::OutputFolder output(args.out_dir);
    const std::filesystem::path& out_root = output.path();
    const std::vector<engine::ModelTask> tasks = engine::make_tasks(engine::expand_inputs(args.inputs, out_root), out_root);
    if (tasks.empty()) throw InvalidInput("the inputs name no mesh files (.off .obj .ply .stl)");
    graphs::CollectionOptions options;
    options.threads = args.threads > 0 ? args.threads : std::max(1u, std::thread::hardware_concurrency());
    options.graph = args.settings.graph_options();
    options.graph.max_in_flight = args.max_in_flight > 0 ? args.max_in_flight : 2 * options.threads;
    // Rounded up: a positive limit under a millisecond is 1 ms, not 0 (no limit).
    options.graph.timeout = std::chrono::milliseconds(static_cast<long long>(std::ceil(args.timeout_s * 1000)));
    options.settings = args.settings.fingerprint();
    options.force = args.force;
    options.serial = args.serial;
    {   // No output may replace an input (a mesh or a list): the diagram, the summaries, a model's files.
        std::vector<std::string> inputs = args.inputs;
        for (const engine::ModelTask& task : tasks) inputs.push_back(task.path);
        std::vector<std::filesystem::path> outputs = {out_root / "summary.json", out_root / "summary.csv"};
        if (!args.dot.empty()) outputs.push_back(args.dot);
        for (const engine::ModelTask& task : tasks) {
            for (const std::string& name : engine::kSegmentationFiles) outputs.push_back(task.out_dir / name);
            outputs.push_back(task.out_dir / "result.json");
        }
        engine::refuse_overwriting_inputs(outputs, inputs);
    }
    if (!args.dot.empty()) {
        engine::write_file_atomic(args.dot, [&](std::ostream& out) { graphs::SegmentationGraph(options.graph).to_dot(out); });
    }

    engine::BatchProgress progress(tasks.size(), std::cerr, ::isatty(STDERR_FILENO) == 1);
    engine::FactorizationCache cache;
    const graphs::CollectionRun run = graphs::run_collection(tasks, options, progress, std::cerr, &cache);
    progress.finish();
    engine::write_batch_summary(out_root, run.outcomes);

    std::size_t failed = 0;
    for (const engine::ModelOutcome& o : run.outcomes) failed += !o.status.ok();
    std::cout << tasks.size() << " models: " << tasks.size() - failed << " ok, " << failed << " failed, "
              << run.reused << " reused from an earlier run; summary in " << (out_root / "summary.csv").string()
              << "\n";
    return failed == 0 ? 0 : engine::kExitBatchFailures;
}

// Two settings only the environment at start-up can make, so the process starts itself again
// with them (once: they are then set); where the exec fails it goes on without.
// * OPENBLAS_NUM_THREADS=1: BLAS runs on its caller's thread anyway (kernels::pin_blas_threads),
//   and at 1 OpenBLAS starts no thread of its own when loaded. That thread maps a 128 MiB work
//   buffer at once, and under an address-space limit that leaves no room for it, it retries
//   forever: even --version hung under `ulimit -v 150000`.
// * The solving jobs run on transparent huge pages: glibc's malloc asks for them where its tunable
//   glibc.malloc.hugetlb=1 is set. The large dense #E x 2g form matrices and factors otherwise
//   fault in 4 KiB at a time, and page faults cost: on a paravirtualised 2-vCPU machine, 2.4M
//   faults made 18 of the 31 s of a holed mesh's segmentation (15 s with huge pages) and the
//   corpus batch took 70 s instead of 33 s; results are byte-identical. HOLOFLOW_HUGE_PAGES=0,
//   or any GLIBC_TUNABLES naming the tunable, leaves the tunable as it is.
// Under valgrind nothing restarts (its tools would lose the restarted process).
void restart_with_startup_settings(int argc, char** argv) {
    const char* preload = std::getenv("LD_PRELOAD");
    if (preload != nullptr && std::strstr(preload, "vgpreload") != nullptr) return;
    const char* blas_threads = std::getenv("OPENBLAS_NUM_THREADS");
    const bool set_blas_threads = blas_threads == nullptr || std::strcmp(blas_threads, "1") != 0;
    const bool light = argc < 2 || std::strncmp(argv[1], "-", 1) == 0 || std::strcmp(argv[1], "info") == 0;
    const char* opt_out = std::getenv("HOLOFLOW_HUGE_PAGES");
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    const std::string before = tunables != nullptr ? tunables : "";
    const bool set_huge_pages = !light && !(opt_out != nullptr && std::strcmp(opt_out, "0") == 0) &&
                                before.find("glibc.malloc.hugetlb") == std::string::npos;
    if (!set_blas_threads && !set_huge_pages) return;
    std::error_code error;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error) return;
    const std::string blas_before = blas_threads != nullptr ? blas_threads : "";
    if (set_blas_threads && setenv("OPENBLAS_NUM_THREADS", "1", 1) != 0) return;
    const std::string with = before.empty() ? "glibc.malloc.hugetlb=1" : before + ":glibc.malloc.hugetlb=1";
    if (set_huge_pages && setenv("GLIBC_TUNABLES", with.c_str(), 1) != 0) return;
    execv(self.c_str(), argv);
    // The exec failed: the environment as it was.
    if (blas_threads != nullptr) setenv("OPENBLAS_NUM_THREADS", blas_before.c_str(), 1);
    else unsetenv("OPENBLAS_NUM_THREADS");
    if (tunables != nullptr) setenv("GLIBC_TUNABLES", before.c_str(), 1);
    else unsetenv("GLIBC_TUNABLES");
}

}  // namespace

int main(int argc, char** argv) {
    restart_with_startup_settings(argc, argv);
    CLI::App app{"holoflow: holomorphic flow segmentation of triangle meshes"};
    app.set_version_flag("--version", std::string("holoflow ") + HOLOFLOW_VERSION);
    app.require_subcommand(1);

    MeshArgs info_mesh;
    bool info_json = false;
    CLI::App* info = app.add_subcommand("info", "topology of a mesh file and the repairs made on loading");
    info_mesh.add_to(*info);
    info->add_flag("--json", info_json, "print one JSON object instead of text");

    MeshArgs conformal_mesh;
    std::string conformal_out, conformal_laplacian = "intrinsic";
    bool conformal_json = false;
    CLI::App* conformal = app.add_subcommand(
        "conformal", "holomorphic 1-form basis, period matrix and the global conformal map");
    conformal_mesh.add_to(*conformal);
    conformal->add_option("-o,--output", conformal_out, "output folder")->required();
    conformal->add_option("--laplacian", conformal_laplacian,
                          "cotan weights on the intrinsic Delaunay triangulation or the mesh itself")
        ->check(CLI::IsMember({"intrinsic", "extrinsic"}));
    conformal->add_flag("--json", conformal_json, "also print conformal.json to stdout");

    SegmentArgs seg;
    CLI::App* segment = app.add_subcommand(
        "segment", "holomorphic flow segmentation: zeros, critical trajectories, rectangular patches");
    segment->add_option("MESH", seg.path, "mesh file: .off .obj .ply .stl")->required();
    segment->add_option("-o,--output", seg.out_dir, "output folder")->required();
    seg.settings.add_to(*segment);
    segment->add_option("--tips", seg.tips, "vertex ids to slice holes at, on any surface (default: "
                                            "detected extremities, on closed genus 0, disks, or with --slice-tips)")
        ->delimiter(',')
        ->check(CLI::Validator(  // CLI11 reads an empty id as 0
            [](const std::string& text) { return text.empty() ? std::string("an empty vertex id") : std::string(); },
            "", "NotEmpty"));
    segment->add_flag("--json", seg.json, "also print segmentation.json to stdout");

    BatchArgs batch_args;
    CLI::App* batch = app.add_subcommand(
        "batch", "segment many models: mesh files, folders, or text files listing paths");
    batch->add_option("INPUT", batch_args.inputs, "mesh files, folders (searched recursively), path lists")
        ->required();
    batch->add_option("-o,--output", batch_args.out_dir, "output folder: one folder per model, summary.csv/json")
        ->required();
    batch_args.settings.add_to(*batch);
    batch->add_option("--threads", batch_args.threads, "worker threads (default: all cores)")
        ->check(number_in(1u, 1024u));
    batch->add_option("--max-in-flight", batch_args.max_in_flight,
                      "models in memory at once (default: twice the threads)")
        ->check(number_in(std::size_t{1}, std::size_t{1} << 20));
    batch->add_option("--timeout", batch_args.timeout_s,
                      "seconds per model, checked between stages (0: no limit)")
        ->check(number_in(0.0, 1e9));
    batch->add_flag("--force", batch_args.force, "recompute models finished by an earlier run");
    batch->add_flag("--serial", batch_args.serial, "run the serial twin instead of the flow graph");
    batch->add_option("--dot", batch_args.dot, "write the flow graph as a Graphviz DOT file");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        return report_error("usage", std::string(e.what()) + " (see --help)", kExitUsage);
    }

    if (info->parsed()) return run_guarded([&] { return run_info(info_mesh, info_json); });
    // Every other command solves: under an address-space limit, plan it before any work. A
    // batch runs --threads (default: every core); the others what oneTBB would (its default
    // follows the process's CPU affinity), capped only where the limit affords fewer.
    const unsigned wanted = batch->parsed() ? (batch_args.threads > 0 ? batch_args.threads
                                                                      : std::max(1u, std::thread::hardware_concurrency()))
                                            : static_cast<unsigned>(std::max(1, tbb::info::default_concurrency()));
    const int planned = run_guarded([&] {
        solver_address_space = engine::plan_address_space(wanted);
        engine::keep_freed_memory(solver_address_space);
        batch_args.threads = solver_address_space.threads;
        return 0;
    });
    if (planned != 0) return planned;
    std::optional<tbb::global_control> parallelism;
    if (solver_address_space.threads < wanted)
        parallelism.emplace(tbb::global_control::max_allowed_parallelism, solver_address_space.threads);
    if (conformal->parsed())
        return run_guarded([&] {
            return run_conformal(conformal_mesh, conformal_out, conformal_laplacian, conformal_json);
        });
    if (segment->parsed()) return run_guarded([&] { return run_segment(seg); });
    if (batch->parsed()) return run_guarded([&] { return run_batch(batch_args); });
    return report_error("usage", "no subcommand", kExitUsage);
}
