// holoflow command line: one executable, one subcommand per job. Errors go to stderr as
// `error: <kind>: <detail>` with a distinct exit status per kind (README "Exit status").
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/output.h"
#include "holoflow/engine/report.h"
#include "holoflow/engine/segmentation_output.h"
#include "holoflow/engine/segmentation_pipeline.h"
#include "holoflow/kernels/topology.h"

namespace {

using namespace holoflow;

constexpr int kExitInternal = 1;
constexpr int kExitUsage = 2;
constexpr int kExitInvalidInput = 3;
constexpr int kExitSolverFailure = 4;
constexpr int kExitOutOfMemory = 5;
constexpr int kExitOutputError = 6;

int report_error(const std::string& kind, const std::string& detail, int status) {
    std::cerr << "error: " << kind << ": " << detail << std::endl;
    return status;
}

// Runs one subcommand and turns every failure into one stderr line and an exit status.
int run_guarded(const std::function<int()>& body) {
    try {
        return body();
    } catch (const engine::MeshError& e) {
        return report_error(engine::to_string(e.kind), e.detail, engine::exit_status(e.kind));
    } catch (const InvalidInput& e) {
        return report_error("invalid_input", e.what(), kExitInvalidInput);
    } catch (const SolverFailure& e) {
        return report_error("solver_failure", e.what(), kExitSolverFailure);
    } catch (const engine::OutputError& e) {
        return report_error("output_error", e.what(), kExitOutputError);
    } catch (const std::bad_alloc&) {
        return report_error("out_of_memory", "allocation failed", kExitOutOfMemory);
    } catch (const std::exception& e) {
        return report_error("internal", e.what(), kExitInternal);
    }
}

struct MeshArgs {
    std::string path;
    std::string components = "all";
    std::size_t max_faces = 0;

    void add_to(CLI::App& command) {
        command.add_option("MESH", path, "mesh file: .off .obj .ply .stl")->required();
        command
            .add_option("--component", components,
                        "several components: keep all, or only the largest")
            ->check(CLI::IsMember({"all", "largest"}));
        command.add_option("--max-faces", max_faces, "refuse meshes with more triangles (0: no limit)");
    }
    engine::LoadOptions options() const {
        engine::LoadOptions o;
        o.components = components == "largest" ? engine::ComponentPolicy::Largest
                                               : engine::ComponentPolicy::All;
        o.max_faces = max_faces;
        return o;
    }
};

int run_info(const MeshArgs& mesh_args, bool json) {
    const engine::LoadedMesh loaded = engine::load_mesh(mesh_args.path, mesh_args.options());
    const kernels::Topology topology = kernels::compute_topology(*loaded.mesh);
    const nlohmann::json report = engine::info_report(mesh_args.path, loaded, topology);
    if (json)
        std::cout << report.dump(2) << std::endl;
    else
        std::cout << engine::format_info_text(report);
    return 0;
}

int run_conformal(const MeshArgs& mesh_args, const std::string& out_dir, const std::string& laplacian,
                  bool json) {
    const std::filesystem::path folder(out_dir);
    engine::prepare_output_folder(folder);  // fail before the work, not after
    const engine::LoadedMesh loaded = engine::load_mesh(mesh_args.path, mesh_args.options());
    engine::ConformalOptions options;
    options.laplacian = laplacian == "extrinsic" ? engine::LaplacianKind::Extrinsic
                                                 : engine::LaplacianKind::IntrinsicDelaunay;
    const engine::ConformalResult result = engine::compute_conformal(*loaded.mesh, options);
    nlohmann::json report = engine::conformal_report(result);
    report["file"] = mesh_args.path;
    report["laplacian"] = laplacian;
    engine::write_file_atomic(folder / "uv.obj", [&](std::ostream& out) {
        engine::write_uv_obj(out, *loaded.mesh, result);
    });
    engine::write_file_atomic(folder / "forms",
                              [&](std::ostream& out) { engine::write_forms(out, result); });
    engine::write_file_atomic(folder / "conformal.json", report.dump(2) + "\n");
    if (json) std::cout << report.dump(2) << std::endl;
    else
        std::cout << "genus " << report["genus"] << ", working genus " << report["working_genus"]
                  << ", star error " << report["star_square_error"] << ", period symmetry error "
                  << report["period_symmetry_error"] << "\nwrote " << (folder / "uv.obj").string()
                  << ", forms, conformal.json\n";
    return 0;
}

struct SegmentArgs {
    MeshArgs mesh;
    std::string out_dir, mode = "layout", laplacian = "intrinsic";
    std::vector<holoflow::Index> tips;
    int max_tips = 8;
    double hole_size = 0.02;
    bool json = false;
};

int run_segment(const SegmentArgs& args) {
    const std::filesystem::path folder(args.out_dir);
    engine::prepare_output_folder(folder);
    const engine::LoadedMesh loaded = engine::load_mesh(args.mesh.path, args.mesh.options());
    engine::SegmentOptions options;
    options.conformal.laplacian = args.laplacian == "extrinsic" ? engine::LaplacianKind::Extrinsic
                                                                : engine::LaplacianKind::IntrinsicDelaunay;
    options.mode = args.mode == "vertical" ? engine::SegmentMode::Vertical : engine::SegmentMode::Layout;
    options.tips = args.tips;
    options.max_tips = args.max_tips;
    options.hole_size = args.hole_size;
    const engine::SegmentationResult result = engine::segment(*loaded.mesh, options);
    nlohmann::json report = engine::segmentation_report(result);
    report["file"] = args.mesh.path;
    const engine::SegmentationPicture picture = engine::segmentation_picture(result);
    engine::write_file_atomic(folder / "segments.ply",
                              [&](std::ostream& out) { engine::write_segments_ply(out, picture); });
    engine::write_file_atomic(folder / "patches.obj",
                              [&](std::ostream& out) { engine::write_patches_obj(out, picture); });
    engine::write_file_atomic(folder / "trajectories.obj",
                              [&](std::ostream& out) { engine::write_trajectories_obj(out, picture); });
    engine::write_file_atomic(folder / "domains.svg",
                              [&](std::ostream& out) { engine::write_domains_svg(out, picture); });
    engine::write_file_atomic(folder / "complex.json", engine::complex_report(result).dump(1) + "\n");
    engine::write_file_atomic(folder / "segmentation.json", report.dump(2) + "\n");
    if (args.json) {
        std::cout << report.dump(2) << std::endl;
    } else {
        std::cout << "genus " << report["genus"] << ", working genus " << report["working_genus"] << ", "
                  << report["zero_count"] << " zeros (" << report["artifacts"] << " artifact clusters), "
                  << report["trajectories"] << " trajectories (" << report["unfinished_trajectories"]
                  << " unfinished), " << report["patch_count"] << " patches " << report["patch_types"].dump()
                  << ", flipped uv triangles " << report["flipped_uv_triangles"] << ", rectangle error "
                  << report["rectangle_error_max"] << "\nwrote segments.ply, patches.obj, trajectories.obj, "
                  << "domains.svg, complex.json, segmentation.json in " << folder.string() << "\n";
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
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
    seg.mesh.add_to(*segment);
    segment->add_option("-o,--output", seg.out_dir, "output folder")->required();
    segment->add_option("--mode", seg.mode, "vertical: the paper's trajectories; layout: both families, "
                                            "motorcycle rule, every patch a rectangle")
        ->check(CLI::IsMember({"vertical", "layout"}));
    segment->add_option("--laplacian", seg.laplacian, "cotan weights: intrinsic Delaunay or the mesh itself")
        ->check(CLI::IsMember({"intrinsic", "extrinsic"}));
    segment->add_option("--tips", seg.tips, "closed genus 0 / disks: vertex ids to slice holes at "
                                            "(default: detected extremities)")
        ->delimiter(',');
    segment->add_option("--max-tips", seg.max_tips, "most tips detected automatically")
        ->check(CLI::Range(2, 64));
    segment->add_option("--hole-size", seg.hole_size, "tip hole radius, fraction of sqrt(area / 4 pi)")
        ->check(CLI::Range(0.0, 0.5));
    segment->add_flag("--json", seg.json, "also print segmentation.json to stdout");

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
    if (conformal->parsed())
        return run_guarded([&] {
            return run_conformal(conformal_mesh, conformal_out, conformal_laplacian, conformal_json);
        });
    if (segment->parsed()) return run_guarded([&] { return run_segment(seg); });
    return report_error("usage", "no subcommand", kExitUsage);
}
