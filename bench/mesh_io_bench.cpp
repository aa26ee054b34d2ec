// Mesh input throughput, split by layer: parsing an OFF file (read_polygon_soup), the whole load
// (parse + validation + MeshView connectivity, load_mesh) and the topology kernel on the loaded
// mesh. Inputs: the largest libcgal-demo meshes, and man and turbine midpoint-subdivided up to
// about 2M faces (written once to a temporary OFF outside any timing loop, removed at exit).
// Items processed are faces, so Google Benchmark prints faces per second.
#include <benchmark/benchmark.h>

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <oneapi/tbb/version.h>
#include <unistd.h>

#include "holoflow/engine/mesh_loader.h"
#include "support/generated_files.h"
#include "holoflow/engine/output.h"
#include "holoflow/engine/mesh_reader.h"
#include "holoflow/kernels/subdivision.h"
#include "holoflow/kernels/topology.h"

namespace {

using holoflow::Index;
using holoflow::MeshView;
namespace engine = holoflow::engine;
namespace kernels = holoflow::kernels;
namespace fs = std::filesystem;

struct Input {
    std::string mesh;  // corpus name without .off
    int max_level;     // midpoint subdivisions benchmarked: 0 .. max_level
};

// Level 0 of each, plus the subdivided series: man reaches 2.24M faces, turbine 1.18M.
const std::vector<Input> kInputs = {
    {"refined_elephant", 0}, {"man", 3}, {"turbine", 3}, {"cheese", 0}, {"lion", 0}};

fs::path temp_folder() {
    static const fs::path folder =
        fs::temp_directory_path() / ("holoflow_mesh_io_bench_" + std::to_string(::getpid()));
    return folder;
}

void write_off(const MeshView& mesh, const std::string& path) {
    engine::write_file_atomic(path, [&](std::ostream& out) { engine::write_off(out, mesh); });
}

struct Prepared {
    std::string path;
    Index faces = 0;
    int genus = 0;  // of the corpus mesh; subdivision keeps it
};

// The file for (mesh, level), written on first use and shared by the three benchmarks.
const Prepared& prepare(const std::string& mesh, int level) {
    static std::map<std::pair<std::string, int>, Prepared> cache;
    const auto key = std::make_pair(mesh, level);
    if (auto it = cache.find(key); it != cache.end()) return it->second;
    const std::string source = std::string(HOLOFLOW_CORPUS_DIR) + "/" + mesh + ".off";
    if (!fs::exists(source)) throw std::runtime_error("corpus mesh missing: " + source);
    MeshView m = *engine::load_mesh(source).mesh;
    Prepared p{source, m.n_faces(), kernels::compute_topology(m).genus};
    if (level > 0) {
        for (int l = 0; l < level; ++l) m = kernels::subdivide_midpoint(m);
        fs::create_directories(temp_folder());
        const fs::path out = temp_folder() / (mesh + "_midpoint" + std::to_string(level) + ".off");
        write_off(m, out);
        p.path = out.string();
        p.faces = m.n_faces();
    }
    return cache.emplace(key, std::move(p)).first->second;
}

// Runs `body(prepared)` as the benchmark, or reports why the input is unavailable.
template <class Body>
void with_input(benchmark::State& state, const std::string& mesh, Body body) {
    const Prepared* p = nullptr;
    try {
        p = &prepare(mesh, static_cast<int>(state.range(0)));
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    body(*p);
    state.counters["faces"] = static_cast<double>(p->faces);
}

void BM_engine_read_off(benchmark::State& state, const std::string& mesh) {
    with_input(state, mesh, [&](const Prepared& p) {
        const engine::PolygonSoup check = engine::read_polygon_soup(p.path);  // warm-up, validate
        if (check.n_polygons() != static_cast<std::size_t>(p.faces)) {
            state.SkipWithError("polygon count differs from the mesh written");
            return;
        }
        for (auto _ : state) benchmark::DoNotOptimize(engine::read_polygon_soup(p.path));
        state.SetItemsProcessed(state.iterations() * p.faces);
        state.SetBytesProcessed(state.iterations() *
                                static_cast<std::int64_t>(fs::file_size(p.path)));
    });
}

void BM_engine_load(benchmark::State& state, const std::string& mesh) {
    with_input(state, mesh, [&](const Prepared& p) {
        const engine::LoadedMesh check = engine::load_mesh(p.path);
        if (check.mesh->n_faces() != p.faces) {
            state.SkipWithError("loaded face count differs from the mesh written");
            return;
        }
        for (auto _ : state) benchmark::DoNotOptimize(engine::load_mesh(p.path));
        state.SetItemsProcessed(state.iterations() * p.faces);
    });
}

void BM_kernel_topology(benchmark::State& state, const std::string& mesh) {
    with_input(state, mesh, [&](const Prepared& p) {
        const auto loaded = engine::load_mesh(p.path).mesh;
        const kernels::Topology check = kernels::compute_topology(*loaded);
        if (check.genus != p.genus || check.components != 1) {
            state.SkipWithError("topology of the subdivided mesh differs from the input's");
            return;
        }
        for (auto _ : state) benchmark::DoNotOptimize(kernels::compute_topology(*loaded));
        state.SetItemsProcessed(state.iterations() * p.faces);
    });
}

// Ear clipping of 256-gons, convex (earless:0) or walking one circle twice (earless:1, no ear):
// both must cost about the same (the earless case was O(n^3) per polygon before it fell back to
// a fan). Both files are refused after triangulation, which is part of the timed work.
void BM_engine_load_polygons(benchmark::State& state) {
    constexpr int kCorners = 256, kPolygons = 50;
    const std::string off = holoflow::test::polygon_stack_off(kCorners, kPolygons, state.range(0) == 1);
    auto load = [&] {
        try {
            engine::mesh_from_soup(engine::parse_polygon_soup(off.data(), off.size(),
                                                              engine::MeshFormat::Off));
        } catch (const engine::MeshError&) {
            return true;
        }
        return false;
    };
    if (!load()) {
        state.SkipWithError("the stacked polygons should be refused (duplicate or zero area)");
        return;
    }
    for (auto _ : state) benchmark::DoNotOptimize(load());
    state.SetItemsProcessed(state.iterations() * kPolygons);
}

void register_all() {
    benchmark::RegisterBenchmark("BM_engine_load_polygons", BM_engine_load_polygons)
        ->ArgName("earless")
        ->DenseRange(0, 1)
        ->Unit(benchmark::kMillisecond);
    using Fn = void (*)(benchmark::State&, const std::string&);
    const std::pair<const char*, Fn> kinds[] = {{"BM_engine_read_off", &BM_engine_read_off},
                                                {"BM_engine_load", &BM_engine_load},
                                                {"BM_kernel_topology", &BM_kernel_topology}};
    for (const auto& [name, fn] : kinds)
        for (const Input& input : kInputs)
            benchmark::RegisterBenchmark((std::string(name) + "/mesh:" + input.mesh).c_str(), fn,
                                         input.mesh)
                ->ArgName("midpoint")
                ->DenseRange(0, input.max_level)
                ->Unit(benchmark::kMillisecond);
}

}  // namespace

int main(int argc, char** argv) {
    register_all();
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::AddCustomContext("corpus", HOLOFLOW_CORPUS_DIR);
    benchmark::AddCustomContext("tbb", TBB_VERSION_STRING);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    std::error_code ignored;
    fs::remove_all(temp_folder(), ignored);
    return 0;
}
