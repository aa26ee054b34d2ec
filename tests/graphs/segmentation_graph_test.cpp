// The segmentation flow graph against its serial twin, failures inside a batch, time limits,
// the factorization cache on a pose collection, and the DOT diagram.
#include "holoflow/graphs/segmentation_graph.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/output.h"
#include "holoflow/kernels/topology.h"
#include "support/test_support.h"

namespace holoflow::graphs {
namespace {

using test::corpus;
using test::TempDir;
using test::slurp;

// Everything a model writes, timings left out (they are the only thing allowed to differ).
std::string fingerprint(const ModelRun& run) {
    nlohmann::json report = run.report;
    if (report.is_object()) {
        report.erase("timings_ms");
        if (report.contains("components"))
            for (auto& part : report["components"]) part.erase("timings_ms");
    }
    std::ostringstream s;
    s << run.outcome.status.kind << '|' << run.outcome.status.stage << '|' << run.outcome.status.message << '|'
      << run.outcome.vertices << '|' << run.outcome.faces << '|' << run.outcome.genus << '|'
      << run.outcome.working_genus << '|' << run.outcome.zeros << '|' << run.outcome.patches << '|'
      << report.dump();
    if (!run.outcome.task.out_dir.empty())
        for (const char* file : {"segments.ply", "patches.obj", "trajectories.obj", "domains.svg", "complex.json"})
            s << '|' << slurp(run.outcome.task.out_dir / file);
    return s.str();
}

// A mixed collection: closed of genus 1-3, open (double cover), genus 0 (tips), and broken files.
std::vector<std::string> mixed_collection(const TempDir& dir) {
    return {corpus("eight.off"),
            dir.write("truncated.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n"),
            corpus("knot.off"),
            corpus("head.off"),
            dir.write("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
            corpus("elephant.off"),
            (dir.path() / "missing.off").string(),
            corpus("bull.off"),
            corpus("knot2.off"),  // two knotted tori: segmented per component
            corpus("oblong.off"),  // its failed fan gets room on the bisected surface
            corpus("ALSTOM_TEST4.off")};  // six CAD disks; one strip collapsed and gets a tip
}

class ThreadSweep : public ::testing::TestWithParam<int> {};

TEST_P(ThreadSweep, GraphMatchesSerialTwin) {
    const TempDir dir;
    const std::vector<std::string> paths = mixed_collection(dir);
    SegmentationGraphOptions options;
    options.max_in_flight = 3;
    std::vector<ModelRun> serial, graph;
    {
        engine::FactorizationCache cache;
        serial = SegmentationGraph(options, &cache).run_serial(engine::make_tasks(paths, dir.path() / "serial"));
    }
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, GetParam());
        engine::FactorizationCache cache;
        std::vector<int> seen;
        graph = SegmentationGraph(options, &cache).run(engine::make_tasks(paths, dir.path() / "graph"),
                                                       [&](ModelRun& run) { seen.push_back(static_cast<int>(run.outcome.task.id)); });
        EXPECT_EQ(seen.size(), paths.size()) << "one callback per model";
    }
    ASSERT_EQ(serial.size(), paths.size());
    ASSERT_EQ(graph.size(), paths.size());
    for (std::size_t i = 0; i < paths.size(); ++i) {
        SCOPED_TRACE(paths[i]);
        EXPECT_EQ(graph[i].outcome.task.id, i);
        EXPECT_EQ(fingerprint(graph[i]), fingerprint(serial[i]));
    }
    // The broken files failed with the kind naming their problem; the rest succeeded.
    EXPECT_EQ(graph[1].outcome.status.kind, "header_mismatch");  // 4 vertices announced, 2 given
    EXPECT_EQ(graph[4].outcome.status.kind, "index_out_of_range");
    EXPECT_EQ(graph[6].outcome.status.kind, "file_not_found");
    for (std::size_t i : {0u, 2u, 3u, 5u, 7u, 8u, 9u}) {
        EXPECT_TRUE(graph[i].outcome.status.ok()) << paths[i] << ": " << graph[i].outcome.status.message;
        EXPECT_GT(graph[i].outcome.patches, 0);
    }
    EXPECT_EQ(graph[0].outcome.zeros, 2);  // eight: 2g - 2
    EXPECT_EQ(graph[5].outcome.zeros, 4);  // elephant
    EXPECT_EQ(graph[8].report["component_count"], 2);
    EXPECT_GE(graph[9].report["fan_refinements"].get<int>(), 1);
}

INSTANTIATE_TEST_SUITE_P(Threads, ThreadSweep, ::testing::Values(1, 2, 8),
                         [](const ::testing::TestParamInfo<int>& sweep) { return "threads_" + std::to_string(sweep.param); });

TEST(SegmentationGraph, BatchModelsMatchSingleModelRuns) {
    const TempDir dir;
    const std::vector<std::string> paths = mixed_collection(dir);
    const SegmentationGraph graph(SegmentationGraphOptions{});
    const std::vector<ModelRun> batch = graph.run(engine::make_tasks(paths, dir.path() / "batch"));
    for (std::size_t i = 0; i < paths.size(); ++i) {
        SCOPED_TRACE(paths[i]);
        engine::ModelTask alone = engine::make_tasks({paths[i]}, dir.path() / ("alone" + std::to_string(i))).front();
        const std::vector<ModelRun> single = graph.run({alone});
        ASSERT_EQ(single.size(), 1u);
        // Same files and report; only the folder differs.
        ModelRun a = batch[i], b = single[0];
        EXPECT_EQ(a.outcome.status.kind, b.outcome.status.kind);
        a.outcome.task = b.outcome.task = {};
        std::string fa = fingerprint(a), fb = fingerprint(b);
        if (a.outcome.status.ok()) {
            for (const char* file : {"segments.ply", "patches.obj", "complex.json"})
                EXPECT_EQ(slurp(batch[i].outcome.task.out_dir / file), slurp(single[0].outcome.task.out_dir / file));
        }
        EXPECT_EQ(fa, fb);
    }
}

// A mesh of several components: each is segmented as if it were a mesh of its own, and the
// report and folder hold them together. Tips are reported as the file's vertex ids (the
// component's own ids, alone): the component's vertex at that position.
TEST(SegmentationGraph, ComponentsAreSegmentedOneByOne) {
    const TempDir dir;
    SegmentationGraphOptions options;
    options.keep_results = true;
    const std::string path = corpus("blobby_3cc.off");
    const std::vector<ModelRun> runs = SegmentationGraph(options).run(engine::make_tasks({path}, dir.path()));
    ASSERT_TRUE(runs[0].outcome.status.ok()) << runs[0].outcome.status.message;
    const nlohmann::json& report = runs[0].report;
    const std::shared_ptr<const MeshView> mesh = engine::load_mesh(path).mesh;
    const kernels::Topology topology = kernels::compute_topology(*mesh);
    ASSERT_EQ(topology.components, 3);
    ASSERT_EQ(report["component_count"], 3);
    ASSERT_EQ(runs[0].components->size(), 3u);
    const std::vector<kernels::ComponentMesh> parts = kernels::component_meshes(*mesh, topology);
    std::int64_t zeros = 0, patches = 0, faces = 0;
    for (std::size_t c = 0; c < parts.size(); ++c) {
        SCOPED_TRACE(c);
        nlohmann::json alone = engine::segmentation_report(engine::segment(parts[c].mesh));
        nlohmann::json part = report["components"][c];
        alone.erase("timings_ms");
        part.erase("timings_ms");
        ASSERT_EQ(part["tips"].size(), alone["tips"].size());
        for (std::size_t t = 0; t < alone["tips"].size(); ++t)
            EXPECT_EQ(mesh->V.row(part["tips"][t].get<Index>()), parts[c].mesh.V.row(alone["tips"][t].get<Index>()));
        alone.erase("tips");
        part.erase("tips");
        EXPECT_EQ(part, alone);
        zeros += alone["zero_count"].get<std::int64_t>();
        patches += alone["patch_count"].get<std::int64_t>();
        faces += alone["faces"].get<std::int64_t>();
    }
    EXPECT_EQ(report["zero_count"], zeros);
    EXPECT_EQ(report["patch_count"], patches);
    EXPECT_EQ(report["faces"], faces);
    EXPECT_EQ(report["patches"].size(), static_cast<std::size_t>(patches));
    EXPECT_EQ(report["patches"].back()["component"], 2);
    EXPECT_EQ(runs[0].outcome.patches, patches);
    // The folder: one mesh with every component's patches, their complexes side by side.
    const std::string ply = slurp(runs[0].outcome.task.out_dir / "segments.ply");
    EXPECT_NE(ply.find("comment patches " + std::to_string(patches) + "\n"), std::string::npos);
    const nlohmann::json complex = nlohmann::json::parse(slurp(runs[0].outcome.task.out_dir / "complex.json"));
    EXPECT_EQ(complex["faces"].size(), static_cast<std::size_t>(patches));
    EXPECT_EQ(complex["faces"].back()["patch"], patches - 1);
    for (const auto& edge : complex["edges"])
        for (const auto& patch : edge["patches"]) EXPECT_LT(patch.get<std::int64_t>(), patches);
}

// A part computing its form alone (cheese: 266 forms) has no solve blocks; the part after it (eight)
// does. The blocks' wall time is shared out from the first part's `solves` clock, which
// begin_solves starts with or without blocks: no stage of either takes longer than the whole run
// (it was counted from a clock never started: 15 hours).
TEST(SegmentationGraph, APartComputingItsFormAloneLeavesTheStageTimesSound) {
    const TempDir dir;
    Index offset = 0;
    std::ostringstream vertices, faces;
    vertices.precision(17);
    Index n_vertices = 0, n_faces = 0;
    for (const char* name : {"cheese.off", "eight.off"}) {
        const std::shared_ptr<const MeshView> mesh = engine::load_mesh(corpus(name)).mesh;
        for (Index v = 0; v < mesh->n_vertices(); ++v)
            vertices << mesh->V(v, 0) << ' ' << mesh->V(v, 1) << ' ' << mesh->V(v, 2) << '\n';
        for (Index f = 0; f < mesh->n_faces(); ++f)
            faces << "3 " << offset + mesh->F(f, 0) << ' ' << offset + mesh->F(f, 1) << ' ' << offset + mesh->F(f, 2) << '\n';
        offset += mesh->n_vertices();
        n_vertices += mesh->n_vertices();
        n_faces += mesh->n_faces();
    }
    const std::string path = dir.write("cheese_and_eight.off", "OFF\n" + std::to_string(n_vertices) + ' ' +
                                                                  std::to_string(n_faces) + " 0\n" + vertices.str() + faces.str());
    SegmentationGraphOptions options;
    options.keep_results = true;
    const auto start = std::chrono::steady_clock::now();
    const std::vector<ModelRun> runs = SegmentationGraph(options).run(engine::make_tasks({path}, dir.path()));
    const double wall_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(runs[0].outcome.status.ok()) << runs[0].outcome.status.message;
    const nlohmann::json& report = runs[0].report;
    ASSERT_EQ(report["component_count"], 2);
    EXPECT_EQ(report["components"][0]["working_genus"], 133);
    EXPECT_FALSE(report["components"][0]["timings_ms"].contains("solves"));  // its form alone
    EXPECT_TRUE(report["components"][1]["timings_ms"].contains("solves"));
    for (const nlohmann::json* times : {&report["timings_ms"], &report["components"][0]["timings_ms"],
                                        &report["components"][1]["timings_ms"]})
        for (const auto& [stage, ms] : times->items()) EXPECT_LT(ms.get<double>(), wall_ms) << stage;
}

TEST(SegmentationGraph, TimeLimitFailsTheModelNotTheBatch) {
    const TempDir dir;
    SegmentationGraphOptions options;
    options.timeout = std::chrono::milliseconds(1);
    // A mesh large enough that its stages take more than a millisecond in total.
    const std::vector<ModelRun> runs =
        SegmentationGraph(options).run(engine::make_tasks({corpus("turbine.off"), corpus("elephant.off")}, dir.path()));
    ASSERT_EQ(runs.size(), 2u);
    for (const ModelRun& run : runs) {
        EXPECT_EQ(run.outcome.status.kind, "timeout");
        EXPECT_EQ(run.outcome.status.exit_code, engine::kExitTimeout);
        EXPECT_FALSE(run.outcome.status.stage.empty());
        EXPECT_FALSE(std::filesystem::exists(run.outcome.task.out_dir / "segmentation.json"));
    }
}

TEST(SegmentationGraph, SolverMemoryLimitIsAResourceLimitFailure) {
    const TempDir dir;
    SegmentationGraphOptions options;
    options.segment.conformal.max_solver_bytes = 1024;  // far below any factor
    const std::vector<ModelRun> runs = SegmentationGraph(options).run(engine::make_tasks({corpus("eight.off")}, dir.path()));
    EXPECT_EQ(runs[0].outcome.status.kind, "resource_limit");
    EXPECT_EQ(runs[0].outcome.status.stage, "homology_and_factorise");
    EXPECT_NE(runs[0].outcome.status.message.find("MiB"), std::string::npos);
}

// Poses: the same triangles with smoothly moved vertices. With the extrinsic Laplacian every
// pose has the input's pattern, so all but the first reuse its analysis, with the same bits.
TEST(SegmentationGraph, PoseCollectionReusesTheSymbolicAnalysis) {
    const TempDir dir;
    const auto mesh = test::corpus_mesh("elephant");
    std::vector<std::string> paths;
    for (int pose = 0; pose < 4; ++pose) {
        MeshView moved = *mesh;
        for (Index v = 0; v < moved.n_vertices(); ++v) {
            const double z = moved.V(v, 2);
            moved.V(v, 0) += 0.02 * pose * std::sin(3 * z);
            moved.V(v, 1) += 0.02 * pose * std::cos(2 * z);
        }
        const std::filesystem::path file = dir.path() / ("pose" + std::to_string(pose) + ".off");
        engine::write_file_atomic(file, [&](std::ostream& out) { engine::write_off(out, moved); });
        paths.push_back(file.string());
    }
    SegmentationGraphOptions options;
    options.segment.conformal.laplacian = engine::LaplacianKind::Extrinsic;
    engine::FactorizationCache cache;
    const std::vector<ModelRun> cached = SegmentationGraph(options, &cache).run_serial(engine::make_tasks(paths, dir.path() / "a"));
    EXPECT_EQ(cache.stats().misses, 1u);
    EXPECT_EQ(cache.stats().hits, 3u);
    const std::vector<ModelRun> fresh = SegmentationGraph(options).run_serial(engine::make_tasks(paths, dir.path() / "b"));
    for (std::size_t i = 0; i < paths.size(); ++i) {
        ASSERT_TRUE(cached[i].outcome.status.ok()) << cached[i].outcome.status.message;
        nlohmann::json a = cached[i].report, b = fresh[i].report;
        a.erase("timings_ms");
        b.erase("timings_ms");
        EXPECT_EQ(a, b) << paths[i];
    }
}

TEST(SegmentationGraph, PrintsItselfAsDot) {
    std::ostringstream dot;
    SegmentationGraph(SegmentationGraphOptions{}).to_dot(dot);
    const std::string text = dot.str();
    EXPECT_EQ(text.rfind("digraph", 0), 0u);
    for (const char* node : {"read", "validate", "homology_and_factorise", "split_solves", "solve", "trace", "tips_where_collapsed",
                             "write", "collect"})
        EXPECT_NE(text.find(std::string("label=\"") + node + "\""), std::string::npos) << node;
    EXPECT_NE(text.find("decrement"), std::string::npos);
    EXPECT_EQ(std::count(text.begin(), text.end(), '{'), std::count(text.begin(), text.end(), '}'));
}

}  // namespace
}  // namespace holoflow::graphs
