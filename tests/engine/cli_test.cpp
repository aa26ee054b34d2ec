// End-to-end checks of the holoflow executable: output format, error lines and exit statuses.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "holoflow/engine/mesh_error.h"
#include "holoflow/engine/output.h"
#include "holoflow/engine/status.h"
#include "holoflow/kernels/shapes.h"
#include "support/test_support.h"

namespace holoflow {
namespace {

using engine::MeshErrorKind;

TEST(Cli, VersionAndHelp) {
    const auto version = test::run_cli("--version");
    EXPECT_EQ(version.status, 0);
    EXPECT_NE(version.out.find("holoflow"), std::string::npos);
    const auto help = test::run_cli("info --help");
    EXPECT_EQ(help.status, 0);
    EXPECT_NE(help.out.find("--json"), std::string::npos);
}

TEST(Cli, UsageErrorsExitTwo) {
    EXPECT_EQ(test::run_cli("").status, 2);
    EXPECT_EQ(test::run_cli("info").status, 2);
    const auto r = test::run_cli("info x.off --component some");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(r.err.rfind("error: usage: ", 0), 0u) << r.err;
}

TEST(Cli, InfoJsonOnCorpusMesh) {
    const auto r = test::run_cli("info --json '" + test::corpus("eight.off") + "'");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    for (const char* key : {"vertices", "edges", "faces", "components", "boundary_loops",
                            "euler_characteristic", "genus", "orientable", "repairs"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["genus"], 2);
    EXPECT_EQ(j["components"], 1);
    EXPECT_EQ(j["boundary_loops"], 0);
    EXPECT_EQ(j["orientable"], true);
    EXPECT_EQ(j["euler_characteristic"].get<int>(),
              j["vertices"].get<int>() - j["edges"].get<int>() + j["faces"].get<int>());
    EXPECT_TRUE(j["repairs"].is_object());
    EXPECT_TRUE(r.err.empty()) << r.err;
}

struct BadFile {
    const char* name;
    const char* bytes;
    MeshErrorKind kind;
};

class CliBadInput : public ::testing::TestWithParam<BadFile> {};

TEST_P(CliBadInput, OneErrorLineAndTheKindsExitStatus) {
    test::TempDir dir;
    const std::string path = dir.write(GetParam().name, GetParam().bytes);
    for (const std::string flag : {"", "--json "}) {
        const auto r = test::run_cli("info " + flag + "'" + path + "'");
        EXPECT_EQ(r.status, engine::exit_status(GetParam().kind)) << r.err;
        const std::string prefix = std::string("error: ") + engine::to_string(GetParam().kind) + ": ";
        EXPECT_EQ(r.err.rfind(prefix, 0), 0u) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_TRUE(r.out.empty()) << "partial output: " << r.out;
    }
}

const BadFile kBadFiles[] = {
    {"empty.off", "", MeshErrorKind::EmptyFile},
    {"mesh.xyz", "1 2 3\n", MeshErrorKind::UnknownFormat},
    {"huge.off", "OFF\n1000000000000 1 0\n0 0 0\n", MeshErrorKind::HeaderMismatch},
    {"short.off",
     "OFF\n4 1 0\n0.000000000 0.000000000 0.000000000\n1.000000000 0.000000000 0.000000000\n"
     "0.000000000 1.000000000 0.000000000\n",
     MeshErrorKind::Truncated},
    {"nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n", MeshErrorKind::NonFiniteCoordinate},
    {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", MeshErrorKind::IndexOutOfRange},
    {"repeat.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1\n", MeshErrorKind::RepeatedVertex},
    {"flat.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n", MeshErrorKind::ZeroAreaFace},
    {"moebius.obj",
     "v 1 0 0\nv 1.2 0 0\nv -0.5 0.9 0.2\nv -0.6 1 -0.2\nv -0.5 -0.9 0\nv -0.6 -1 0\n"
     "f 1 3 4 2\nf 3 5 6 4\nf 5 2 1 6\n",
     MeshErrorKind::NonOrientable},
};

INSTANTIATE_TEST_SUITE_P(Files, CliBadInput, ::testing::ValuesIn(kBadFiles),
                         [](const auto& param_info) {
                             std::string n = param_info.param.name;
                             std::replace(n.begin(), n.end(), '.', '_');
                             return n;
                         });

TEST(Cli, PinchedVerticesAreSplitUnlessRefused) {
    test::TempDir dir;
    const std::string path = dir.write("bowtie.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv -1 0 0\nv 0 -1 0\nf 1 2 3\nf 1 4 5\n");
    const auto split = test::run_cli("info --json '" + path + "'");
    ASSERT_EQ(split.status, 0) << split.err;
    const auto j = nlohmann::json::parse(split.out);
    EXPECT_EQ(j["repairs"]["split_vertices"], 1);
    EXPECT_EQ(j["vertices"], 6);
    EXPECT_EQ(j["components"], 2);
    const auto refused = test::run_cli("info --pinched-vertices refuse '" + path + "'");
    EXPECT_EQ(refused.status, engine::exit_status(MeshErrorKind::NonManifoldVertex)) << refused.err;
    EXPECT_EQ(refused.err.rfind("error: non_manifold_vertex: ", 0), 0u) << refused.err;
    EXPECT_TRUE(refused.out.empty());
}

// A fin (three triangles on one edge): the first two stay joined, the third is detached, unless refused.
TEST(Cli, NonManifoldEdgesAreSplitUnlessRefused) {
    test::TempDir dir;
    const std::string path =
        dir.write("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
    const auto split = test::run_cli("info --json '" + path + "'");
    ASSERT_EQ(split.status, 0) << split.err;
    const auto j = nlohmann::json::parse(split.out);
    EXPECT_EQ(j["repairs"]["split_edges"], 1);
    EXPECT_EQ(j["repairs"]["split_vertices"], 2);
    EXPECT_EQ(j["components"], 2);
    EXPECT_EQ(j["boundary_loops"], 2);
    const auto refused = test::run_cli("info --non-manifold-edges refuse '" + path + "'");
    EXPECT_EQ(refused.status, engine::exit_status(MeshErrorKind::NonManifoldEdge)) << refused.err;
    EXPECT_EQ(refused.err.rfind("error: non_manifold_edge: ", 0), 0u) << refused.err;
}

// An STL with its body written twice (welded onto the same vertices): the copies are dropped
// unless refused.
TEST(Cli, DuplicateFacesAreDroppedUnlessRefused) {
    test::TempDir dir;
    std::string solid = "solid twice\n";
    const char* corners[4][3] = {{"0 0 0", "0 1 0", "1 0 0"}, {"0 0 0", "1 0 0", "0 0 1"},
                                 {"0 0 0", "0 0 1", "0 1 0"}, {"1 0 0", "0 1 0", "0 0 1"}};
    for (int copy = 0; copy < 2; ++copy)
        for (const auto& face : corners) {
            solid += "facet normal 0 0 0\nouter loop\n";
            for (const char* corner : face) solid += std::string("vertex ") + corner + "\n";
            solid += "endloop\nendfacet\n";
        }
    const std::string path = dir.write("twice.stl", solid + "endsolid twice\n");
    const auto dropped = test::run_cli("info --json '" + path + "'");
    ASSERT_EQ(dropped.status, 0) << dropped.err;
    const auto j = nlohmann::json::parse(dropped.out);
    EXPECT_EQ(j["repairs"]["duplicate_faces"], 4);
    EXPECT_EQ(j["faces"], 4);
    EXPECT_EQ(j["closed"], true);
    const auto refused = test::run_cli("info --duplicate-faces refuse '" + path + "'");
    EXPECT_EQ(refused.status, engine::exit_status(MeshErrorKind::DuplicateFace)) << refused.err;
    EXPECT_EQ(refused.err.rfind("error: duplicate_face: ", 0), 0u) << refused.err;
}

// A tetrahedron written as a soup (each face its own three corners) is one closed surface unless
// its seams are kept.
TEST(Cli, SeamsAreZippedUnlessKept) {
    test::TempDir dir;
    const char* corner[4] = {"0 0 0", "1 0 0", "0 1 0", "0 0 1"};
    const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    std::string off = "OFF\n12 4 0\n", indices;
    for (int f = 0; f < 4; ++f) {
        for (int k = 0; k < 3; ++k) off += std::string(corner[faces[f][k]]) + "\n";
        indices += "3 " + std::to_string(3 * f) + " " + std::to_string(3 * f + 1) + " " + std::to_string(3 * f + 2) + "\n";
    }
    const std::string path = dir.write("soup.off", off + indices);
    const auto zipped = test::run_cli("info --json '" + path + "'");
    ASSERT_EQ(zipped.status, 0) << zipped.err;
    const auto z = nlohmann::json::parse(zipped.out);
    EXPECT_EQ(z["repairs"]["zipped_edges"], 6);
    EXPECT_EQ(z["repairs"]["zipped_vertices"], 8);
    EXPECT_EQ(z["closed"], true);
    const auto kept = test::run_cli("info --json --seams keep '" + path + "'");
    ASSERT_EQ(kept.status, 0) << kept.err;
    EXPECT_EQ(nlohmann::json::parse(kept.out)["components"], 4);
}

// Option values that parsed before and meant nothing: a negative memory limit (wrapped to 2^64 - 1),
// a NaN time limit (no limit), a tip past the input's vertices (checked on the refined mesh).
TEST(Cli, OptionValuesOutOfTheirDomainAreRefused) {
    test::TempDir dir;
    const std::string mesh = test::corpus("eight.off"), out = (dir.path() / "o").string();
    EXPECT_EQ(test::run_cli("batch '" + mesh + "' -o '" + out + "' --max-memory -1").status, engine::kExitUsage);
    EXPECT_EQ(test::run_cli("batch '" + mesh + "' -o '" + out + "' --timeout nan").status, engine::kExitUsage);
    const auto nan_size = test::run_cli("segment '" + mesh + "' -o '" + out + "' --hole-size nan");
    EXPECT_EQ(nan_size.status, engine::kExitUsage);
    EXPECT_NE(nan_size.err.find("--hole-size: not a number: nan"), std::string::npos) << nan_size.err;
    const auto word = test::run_cli("batch '" + mesh + "' -o '" + out + "' --threads abc");
    EXPECT_EQ(word.status, engine::kExitUsage);
    EXPECT_NE(word.err.find("--threads: not a number: abc"), std::string::npos) << word.err;  // not "out of range"
    const auto tip = test::run_cli("segment '" + test::corpus("bull.off") + "' -o '" + out + "' --tips 1,90000");
    EXPECT_EQ(tip.status, engine::kExitInvalidInput) << tip.err;
    EXPECT_NE(tip.err.find("tip 90000 is not a vertex of the mesh"), std::string::npos) << tip.err;
    EXPECT_EQ(test::run_cli("segment '" + mesh + "' -o '" + out + "' --tips ''").status, engine::kExitUsage);
    // A limit under a millisecond is a limit (it was truncated to 0 ms: none).
    const auto brief = test::run_cli("batch '" + test::corpus("elephant.off") + "' -o '" + out + "' --timeout 0.0005");
    EXPECT_NE(brief.status, 0) << brief.err;
    EXPECT_NE(test::slurp(out + "/summary.csv").find("timeout"), std::string::npos);
}

// What a command prints must reach stdout: a full device is an output error, not success. And a
// file larger than the memory could hold is refused unread by `info` too (a sparse file here).
TEST(Cli, StdoutThatCannotBeWrittenAndHugeFilesAreErrors) {
    test::TempDir dir;
    const std::string err = (dir.path() / "err").string();
    const int raw = std::system(("'" + std::string(HOLOFLOW_CLI) + "' info --json '" + test::corpus("eight.off") +
                                 "' >/dev/full 2>'" + err + "'")
                                    .c_str());
    ASSERT_TRUE(WIFEXITED(raw));
    EXPECT_EQ(WEXITSTATUS(raw), engine::kExitOutputError) << test::slurp(err);
    EXPECT_NE(test::slurp(err).find("cannot write to standard output"), std::string::npos);

    const std::filesystem::path huge = dir.path() / "huge.off";
    std::ofstream(huge) << "OFF\n";
    std::error_code ec;
    std::filesystem::resize_file(huge, std::uintmax_t{1} << 40, ec);  // 1 TiB, sparse
    if (ec) GTEST_SKIP() << "this file system has no 1 TiB sparse files: " << ec.message();
    const auto r = test::run_cli("info '" + huge.string() + "'");
    EXPECT_EQ(r.status, engine::exit_status(MeshErrorKind::TooLarge)) << r.err;
}

// knot2 is two knotted tori: each is segmented, the report holds both.
TEST(Cli, SegmentTakesEveryComponent) {
    test::TempDir dir;
    const auto all = test::run_cli("segment '" + test::corpus("knot2.off") + "' -o '" + (dir.path() / "all").string() + "' --json");
    ASSERT_EQ(all.status, 0) << all.err;
    const auto j = nlohmann::json::parse(all.out);
    EXPECT_EQ(j["component_count"], 2);
    EXPECT_EQ(j["components"].size(), 2u);
    EXPECT_EQ(j["genus"], 2);  // 1 + 1
    EXPECT_EQ(j["patch_count"], 2);
    const auto largest = test::run_cli("segment '" + test::corpus("knot2.off") + "' -o '" +
                                       (dir.path() / "largest").string() + "' --json --component largest");
    ASSERT_EQ(largest.status, 0) << largest.err;
    const auto one = nlohmann::json::parse(largest.out);
    EXPECT_FALSE(one.contains("component_count"));
    EXPECT_EQ(one["genus"], 1);
}

// Vertical mode picks the form per component: eight (genus 2) takes integer periods, a sphere
// (sliced at its tips: a planar domain) the generic form; the merged report says `mixed`.
TEST(Cli, VerticalModeReportsEachComponentsForm) {
    test::TempDir dir;
    const std::shared_ptr<const MeshView> eight = test::corpus_mesh("eight");
    const std::shared_ptr<const MeshView> sphere = test::corpus_mesh("sphere");
    PointMatrix V(eight->n_vertices() + sphere->n_vertices(), 3);
    TriangleMatrix F(eight->n_faces() + sphere->n_faces(), 3);
    V.topRows(eight->n_vertices()) = eight->V;
    V.bottomRows(sphere->n_vertices()) = sphere->V.rowwise() + Eigen::RowVector3d(10, 0, 0);
    F.topRows(eight->n_faces()) = eight->F;
    F.bottomRows(sphere->n_faces()) = sphere->F.array() + eight->n_vertices();
    const std::filesystem::path both = dir.path() / "both.off";
    {
        std::ofstream out(both);
        engine::write_off(out, make_mesh_view(std::move(V), std::move(F)));
    }
    const auto r = test::run_cli("segment '" + both.string() + "' -o '" + (dir.path() / "out").string() +
                                 "' --mode vertical --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j["component_count"], 2);
    EXPECT_EQ(j["form"], "mixed");
    std::vector<std::string> forms;
    for (const auto& part : j["components"]) forms.push_back(part["form"]);
    std::sort(forms.begin(), forms.end());
    EXPECT_EQ(forms, (std::vector<std::string>{"generic", "integer_periods"}));
}

TEST(Cli, MissingFileAndDirectory) {
    const auto missing = test::run_cli("info /nonexistent/dir/mesh.off");
    EXPECT_EQ(missing.status, engine::exit_status(MeshErrorKind::FileNotFound));
    EXPECT_EQ(missing.err.rfind("error: file_not_found: ", 0), 0u) << missing.err;
    test::TempDir dir;
    std::filesystem::create_directories(dir.path() / "folder.off");
    const auto folder = test::run_cli("info '" + (dir.path() / "folder.off").string() + "'");
    EXPECT_EQ(folder.status, engine::exit_status(MeshErrorKind::Unreadable)) << folder.err;
}

// A folder another run writes into is refused before any work; a run that fails before writing
// leaves no folder of its own making.
TEST(Cli, OutputFoldersInUseOrLeftEmpty) {
    test::TempDir dir;
    const std::filesystem::path out = dir.path() / "out";
    const std::string mesh = test::corpus("eight.off");
    {
        const engine::OutputFolder held(out);
        for (const std::string command : {"segment", "conformal", "batch"}) {
            const auto r = test::run_cli(command + " '" + mesh + "' -o '" + out.string() + "'");
            EXPECT_EQ(r.status, engine::kExitOutputError) << command;
            EXPECT_NE(r.err.find("is in use by another holoflow run"), std::string::npos) << r.err;
        }
    }
    EXPECT_FALSE(std::filesystem::exists(out)) << "nothing written into the held folder, which was made for it";
    for (const std::string command : {"segment", "conformal"}) {
        const auto r = test::run_cli(command + " '" + (dir.path() / "none.off").string() + "' -o '" +
                                     (dir.path() / "new" / "out").string() + "'");
        EXPECT_EQ(r.status, engine::exit_status(MeshErrorKind::FileNotFound)) << command << r.err;
        EXPECT_FALSE(std::filesystem::exists(dir.path() / "new")) << command;
    }
}

// A mesh named like an output, in the output folder (or a link to one there), is never replaced.
TEST(Cli, OutputsNeverReplaceInputs) {
    test::TempDir dir;
    const std::filesystem::path out = dir.path() / "out";
    std::filesystem::create_directories(out / "segments");
    const std::string mesh = test::slurp(test::corpus("eight.off"));
    const auto refused = [&](const std::string& command, const std::string& input, const std::string& output) {
        const auto r = test::run_cli(command + " '" + input + "' -o '" + output + "'");
        EXPECT_EQ(r.status, engine::kExitInvalidInput) << command << " " << input << r.err;
        EXPECT_NE(r.err.find("it would be overwritten"), std::string::npos) << r.err;
    };
    const std::string ply = dir.write("out/segments.ply", "ply\nformat ascii 1.0\n");  // not even read
    refused("segment", ply, out.string());
    std::filesystem::create_symlink(ply, dir.path() / "link.ply");
    refused("segment", (dir.path() / "link.ply").string(), (dir.path() / "out" / ".").string());
    const std::string obj = dir.write("out/uv.obj", "v 0 0 0\n");
    refused("conformal", obj, out.string());
    const std::string nested = dir.write("out/segments/segments.ply", mesh);  // its model folder is out/segments
    refused("batch", nested, out.string());
    EXPECT_EQ(test::slurp(ply), "ply\nformat ascii 1.0\n");
    EXPECT_EQ(test::slurp(obj), "v 0 0 0\n");
    EXPECT_EQ(test::slurp(nested), mesh);
}

TEST(Cli, ConformalWritesItsFilesAndJson) {
    test::TempDir dir;
    const std::string out = (dir.path() / "eight").string();
    const auto r = test::run_cli("conformal '" + test::corpus("eight.off") + "' -o '" + out + "' --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    for (const char* key :
         {"genus", "period_matrix", "wedge_det", "star_square_error", "star_isometry_error",
          "period_symmetry_error", "period_im_min_eigenvalue", "closedness_max", "coclosedness_max",
          "flipped_uv_triangles", "conformal_distortion", "timings_ms"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_EQ(j["genus"], 2);
    EXPECT_EQ(j["period_matrix"].size(), 2u);
    EXPECT_EQ(j["period_matrix"][0][1].size(), 2u);  // [re, im]
    for (const char* stage : {"cut_graph_and_closed_forms", "carry_forms", "intrinsic_delaunay",
                              "laplacian_assembly", "analyse", "factorise", "overlap", "solves",
                              "hodge_star", "integration"})
        EXPECT_TRUE(j["timings_ms"].contains(stage)) << stage;
    EXPECT_EQ(nlohmann::json::parse(std::ifstream(out + "/conformal.json")), j);
    std::ifstream uv(out + "/uv.obj");
    std::string line;
    std::size_t faces = 0, texcoords = 0;
    while (std::getline(uv, line)) {
        faces += line.rfind("f ", 0) == 0;
        texcoords += line.rfind("vt ", 0) == 0;
    }
    EXPECT_EQ(faces, 634u);
    EXPECT_GT(texcoords, 315u);  // the cut duplicates vertices along the cut graph
    std::ifstream forms(out + "/forms");
    ASSERT_TRUE(forms.good());
    for (const auto& entry : std::filesystem::directory_iterator(out))
        EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos);  // no leftovers
}

TEST(Cli, ConformalRefusesSphereAndUnwritableFolder) {
    test::TempDir dir;
    const auto sphere = test::run_cli("conformal '" + test::corpus("bull.off") + "' -o '" +
                                      (dir.path() / "bull").string() + "'");
    EXPECT_EQ(sphere.status, 3) << sphere.err;
    EXPECT_EQ(sphere.err.rfind("error: invalid_input: ", 0), 0u) << sphere.err;
    const std::string blocker = dir.write("file", "x");  // a file where a folder must go
    const auto unwritable =
        test::run_cli("conformal '" + test::corpus("eight.off") + "' -o '" + blocker + "/sub'");
    EXPECT_EQ(unwritable.status, 6) << unwritable.err;
    EXPECT_EQ(unwritable.err.rfind("error: output_error: ", 0), 0u) << unwritable.err;
}

TEST(Cli, SegmentWritesItsFilesAndJson) {
    test::TempDir dir;
    const std::string out = (dir.path() / "eight").string();
    const auto r = test::run_cli("segment '" + test::corpus("eight.off") + "' -o '" + out + "' --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto report = nlohmann::json::parse(r.out);
    for (const char* key : {"genus", "working_genus", "zero_count", "zeros", "artifacts", "patches",
                            "patch_types", "flipped_uv_triangles", "rectangle_error_max",
                            "unfinished_trajectories", "timings_ms"})
        EXPECT_TRUE(report.contains(key)) << key;
    EXPECT_EQ(report["genus"], 2);
    EXPECT_EQ(report["working_genus"], 2);
    EXPECT_EQ(report["zero_count"], 2);
    EXPECT_EQ(report["flipped_uv_triangles"], 0);
    for (const auto& zero : report["zeros"]) {  // both of eight's zeros are refined into a face
        EXPECT_EQ(zero["order"], 1);
        EXPECT_GE(zero["vertex"].get<int>(), 0);
        EXPECT_GE(zero["face"].get<int>(), 0);
        EXPECT_EQ(zero["barycentric"].size(), 3u);
        EXPECT_EQ(zero["position"].size(), 3u);
    }
    for (const char* file : {"segments.ply", "patches.obj", "trajectories.obj", "domains.svg", "complex.json",
                             "segmentation.json"})
        EXPECT_GT(std::filesystem::file_size(std::filesystem::path(out) / file), 0u) << file;
    std::ifstream saved(std::filesystem::path(out) / "segmentation.json");
    EXPECT_EQ(nlohmann::json::parse(saved)["patch_count"], report["patch_count"]);
    std::ifstream complex_file(std::filesystem::path(out) / "complex.json");
    const auto complex = nlohmann::json::parse(complex_file);
    EXPECT_EQ(complex["faces"].size(), report["patch_count"].get<std::size_t>());
    // Vertical mode on an open surface, and tips given by hand on a genus-0 mesh.
    const auto vertical = test::run_cli("segment '" + test::corpus("head.off") + "' -o '" + out +
                                        "-v' --mode vertical --json");
    ASSERT_EQ(vertical.status, 0) << vertical.err;
    EXPECT_EQ(nlohmann::json::parse(vertical.out)["mode"], "vertical");
    EXPECT_EQ(nlohmann::json::parse(vertical.out)["form"], "generic");  // a planar domain
}

// With the extrinsic Laplacian the form is harmonic for the mesh's own cotan weights, so its
// saddles are counted on the mesh, not on the intrinsic Delaunay triangulation; the count stays
// exactly 2g - 2.
// `segment` starts itself again with malloc on transparent huge pages (main.cpp); the restart
// keeps every argument (paths with spaces), and the results do not depend on the page size.
TEST(Cli, HugePagesRestartKeepsArgumentsAndResults) {
    test::TempDir dir;
    const auto run = [&](const std::string& name) {
        const std::string out = (dir.path() / name).string();
        const auto r = test::run_cli("segment '" + test::corpus("femur.off") + "' -o '" + out + "'");
        EXPECT_EQ(r.status, 0) << r.err;
        std::ifstream in(std::filesystem::path(out) / "segments.ply", std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const std::string huge = run("huge pages");
    ASSERT_EQ(setenv("HOLOFLOW_HUGE_PAGES", "0", 1), 0);
    const std::string small = run("small pages");
    unsetenv("HOLOFLOW_HUGE_PAGES");
    EXPECT_FALSE(huge.empty());
    EXPECT_TRUE(huge == small);
}

TEST(Cli, SegmentWithExtrinsicLaplacianCountsZerosOnTheMesh) {
    test::TempDir dir;
    for (const auto& [name, genus] : {std::pair{"eight", 2}, {"helmet", 3}}) {
        SCOPED_TRACE(name);
        const auto r = test::run_cli("segment '" + test::corpus(std::string(name) + ".off") + "' -o '" +
                                     (dir.path() / name).string() + "' --laplacian extrinsic --json");
        ASSERT_EQ(r.status, 0) << r.err;
        const auto report = nlohmann::json::parse(r.out);
        EXPECT_EQ(report["saddle_triangulation"], "mesh");
        EXPECT_EQ(report["genus"], genus);
        EXPECT_EQ(report["zero_count"], 2 * genus - 2);
        EXPECT_EQ(report["zero_index_total"], 2 * genus - 2);
    }
}

// --tips names vertices as the file numbers them, and the report gives them back so: bull with
// an unreferenced vertex written first (the loader drops it, every id after it moves down)
// segments as bull at the same tips, one id higher; that vertex itself is refused by name.
TEST(Cli, TipsAreTheFilesVertexIds) {
    test::TempDir dir;
    const std::string bull = test::corpus("bull.off"), out = (dir.path() / "bull").string();
    const auto detected = test::run_cli("segment '" + bull + "' -o '" + out + "' --json");
    ASSERT_EQ(detected.status, 0) << detected.err;
    const std::vector<Index> tips = nlohmann::json::parse(detected.out)["tips"];
    ASSERT_GE(tips.size(), 2u);
    std::ifstream in(bull);
    std::string line, counts;
    std::getline(in, line);
    std::getline(in, counts);
    std::istringstream c(counts);
    Index n_v = 0, n_f = 0;
    c >> n_v >> n_f;
    std::ostringstream moved;
    moved << "OFF\n" << n_v + 1 << ' ' << n_f << " 0\n9 9 9\n";
    for (Index v = 0; v < n_v && std::getline(in, line);) {
        if (line.empty()) continue;
        moved << line << '\n';
        ++v;
    }
    for (Index f = 0; f < n_f; ++f) {
        Index k = 0, a = 0, b = 0, d = 0;
        in >> k >> a >> b >> d;
        moved << "3 " << a + 1 << ' ' << b + 1 << ' ' << d + 1 << '\n';
    }
    const std::string shifted = dir.write("shifted.off", moved.str());
    std::string ids;
    for (Index t : tips) ids += (ids.empty() ? "" : ",") + std::to_string(t + 1);
    const std::string out_shifted = (dir.path() / "shifted").string();
    const auto given = test::run_cli("segment '" + shifted + "' -o '" + out_shifted + "' --json --tips " + ids);
    ASSERT_EQ(given.status, 0) << given.err;
    std::vector<Index> reported = nlohmann::json::parse(given.out)["tips"];
    for (Index& t : reported) --t;
    EXPECT_EQ(reported, tips);
    EXPECT_EQ(test::slurp(out + "/segments.ply"), test::slurp(out_shifted + "/segments.ply"));
    const auto dropped = test::run_cli("segment '" + shifted + "' -o '" + out_shifted + "' --tips 0," + std::to_string(tips[0] + 1));
    EXPECT_EQ(dropped.status, 3);
    EXPECT_NE(dropped.err.find("tip 0 is a vertex the loader dropped"), std::string::npos) << dropped.err;
}

// b9_mesh's small genus-0 parts are too coarse to slice and are refined first, and some of
// their tips are found on vertices the refinement added: those are no vertex of the file (null),
// every other tip is one (each part's ids were once taken as the refined part's, out of range).
TEST(Cli, TipsOnRefinedPartsAreFileVerticesOrNull) {
    test::TempDir dir;
    const auto r = test::run_cli("segment '" + test::corpus("b9_mesh.off") + "' -o '" + (dir.path() / "b9").string() + "' --json");
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    const auto info = nlohmann::json::parse(test::run_cli("info --json '" + test::corpus("b9_mesh.off") + "'").out);
    const Index file_vertices = info["file_vertices"];
    std::size_t added = 0;
    for (const auto& tip : report["tips"]) {
        ASSERT_TRUE(tip.contains("vertex")) << tip;
        if (tip["vertex"].is_null()) {
            ++added;
            EXPECT_GT(report["components"][tip["component"].get<std::size_t>()]["tip_refinements"].get<int>(), 0) << tip;
        } else {
            EXPECT_GE(tip["vertex"].get<Index>(), 0) << tip;
            EXPECT_LT(tip["vertex"].get<Index>(), file_vertices) << tip;
        }
    }
    EXPECT_GT(added, 0u);
    EXPECT_LT(added, report["tips"].size());
}

// femur (genus 2): a sixteenth of it, the far end of its shaft, maps to under a millionth of the
// mean uv scale, which `segment` notes on stderr; with --slice-tips, or tips given on a surface
// with handles (once refused), the limbs keep their scale and nothing is noted.
TEST(Cli, CollapsedLimbsAreNotedAndTipsSliceAnySurface) {
    test::TempDir dir;
    const std::string femur = test::corpus("femur.off"), out = (dir.path() / "femur").string();
    const auto plain = test::run_cli("segment '" + femur + "' -o '" + out + "' --json");
    ASSERT_EQ(plain.status, 0) << plain.err;
    EXPECT_GT(nlohmann::json::parse(plain.out)["collapsed_area"].get<double>(), 0.03);
    EXPECT_NE(plain.err.find("of the surface maps to under 1e-06 of the mean uv scale"), std::string::npos) << plain.err;
    EXPECT_NE(plain.err.find("--slice-tips"), std::string::npos) << plain.err;
    const auto sliced = test::run_cli("segment '" + femur + "' -o '" + out + "' --json --slice-tips");
    ASSERT_EQ(sliced.status, 0) << sliced.err;
    const auto j = nlohmann::json::parse(sliced.out);
    EXPECT_LT(j["collapsed_area"].get<double>(), 1e-3);
    EXPECT_GE(j["tips"].size(), 1u);
    EXPECT_EQ(j["working_genus"].get<int>(), 2 * 2 + static_cast<int>(j["tips"].size()) - 1);
    EXPECT_EQ(sliced.err, "");
    const auto given = test::run_cli("segment '" + test::corpus("eight.off") + "' -o '" + out + "' --json --tips 63,34");
    ASSERT_EQ(given.status, 0) << given.err;
    const auto g = nlohmann::json::parse(given.out);
    EXPECT_EQ(g["tips"], nlohmann::json::array({63, 34}));  // its two ends
    EXPECT_EQ(g["working_genus"], 5);
    EXPECT_EQ(g["zero_count"], 8);
}

TEST(Cli, SegmentRefusesBadOptions) {
    test::TempDir dir;
    const std::string out = (dir.path() / "x").string();
    EXPECT_EQ(test::run_cli("segment '" + test::corpus("eight.off") + "' -o '" + out + "' --mode diagonal").status, 2);
    const auto bad_tip = test::run_cli("segment '" + test::corpus("bull.off") + "' -o '" + out + "' --tips 1,999999999");
    EXPECT_EQ(bad_tip.status, 3) << bad_tip.err;
    for (const char* rounds : {"-1", "9", "many"}) {
        const auto r = test::run_cli("segment '" + test::corpus("eight.off") + "' -o '" + out + "' --fan-refinements " + rounds);
        EXPECT_EQ(r.status, 2) << rounds;
        EXPECT_NE(r.err.find("--fan-refinements"), std::string::npos) << r.err;
    }
}

// oblong's one failed fan: refined by default (exact rectangles), left as it is with 0 rounds.
TEST(Cli, FanRefinementsCanBeTurnedOff) {
    test::TempDir dir;
    const std::string mesh = test::corpus("oblong.off");
    const auto refined = test::run_cli("segment '" + mesh + "' -o '" + (dir.path() / "a").string() + "' --json");
    ASSERT_EQ(refined.status, 0) << refined.err;
    const auto a = nlohmann::json::parse(refined.out);
    EXPECT_GE(a["fan_refinements"].get<int>(), 1);
    EXPECT_EQ(a["zero_fans"]["failed"], 0);
    EXPECT_EQ(a["zero_fans"]["failed_weight"], 0);
    EXPECT_LT(a["rectangle_error_max"].get<double>(), 1e-9);
    const auto plain =
        test::run_cli("segment '" + mesh + "' -o '" + (dir.path() / "b").string() + "' --json --fan-refinements 0");
    ASSERT_EQ(plain.status, 0) << plain.err;
    const auto b = nlohmann::json::parse(plain.out);
    EXPECT_EQ(b["fan_refinements"], 0);
    EXPECT_GT(b["zero_fans"]["failed"].get<int>(), 0);
    EXPECT_GE(b["zero_fans"]["failed_weight"].get<int>(), b["zero_fans"]["failed"].get<int>());  // each weighs >= 1
    EXPECT_LT(b["faces"].get<int>(), a["faces"].get<int>());
}

// elephant-with-holes (genus 3, 106 loops of 6 to 78 edges; its double cover has genus 111):
// --fill-holes 100 closes every loop, leaving the closed genus-3 surface with its 4 zeros and
// exact rectangles; bad values are usage errors.
TEST(Cli, FillHolesClosesLoopsUpToTheGivenLength) {
    test::TempDir dir;
    const std::string mesh = test::corpus("elephant-with-holes.off");
    const auto r = test::run_cli("segment '" + mesh + "' -o '" + (dir.path() / "a").string() + "' --json --fill-holes 100");
    ASSERT_EQ(r.status, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["filled_holes"]["holes"], 106);
    EXPECT_EQ(j["filled_holes"]["left_open"], 0);
    EXPECT_EQ(j["genus"], 3);
    EXPECT_EQ(j["working_genus"], 3);
    EXPECT_EQ(j["double_covered"], false);
    EXPECT_EQ(j["zero_count"], 4);
    EXPECT_EQ(j["artifacts"], 0);
    EXPECT_EQ(j["flipped_uv_triangles"], 0);
    EXPECT_LT(j["rectangle_error_max"].get<double>(), 1e-9);
    for (const char* bad : {"--fill-holes -1", "--fill-holes 257", "--max-working-genus -3", "--max-working-genus x"}) {
        const auto b = test::run_cli("segment '" + mesh + "' -o '" + (dir.path() / "b").string() + "' " + bad);
        EXPECT_EQ(b.status, 2) << bad << ": " << b.err;
    }
}

// --max-memory refuses a model over it (resource_limit, exit 7, the estimate and the form count
// named) and writes nothing; 0 lifts the limit, and without the option the default share of the
// machine's memory lets an ordinary model through.
TEST(Cli, MaxMemoryRefusesAModelOverIt) {
    test::TempDir dir;
    const std::string mesh = test::corpus("eight.off");
    const auto refused = test::run_cli("segment '" + test::corpus("cheese.off") + "' -o '" + (dir.path() / "a").string() +
                                       "' --max-memory 1");  // genus 133: about 19 MiB for its form
    EXPECT_EQ(refused.status, 7) << refused.err;
    EXPECT_NE(refused.err.find("error: resource_limit: "), std::string::npos) << refused.err;
    EXPECT_NE(refused.err.find("266 forms"), std::string::npos) << refused.err;
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "a" / "segmentation.json"));
    // A file larger than the limit is refused before it is read.
    const std::string padded = dir.write("padded.off", test::slurp(mesh) + "#" + std::string(2 << 20, 'x') + "\n");
    const auto big = test::run_cli("segment '" + padded + "' -o '" + (dir.path() / "c").string() + "' --max-memory 1");
    EXPECT_EQ(big.status, engine::exit_status(MeshErrorKind::TooLarge)) << big.err;
    EXPECT_NE(big.err.find("more than the memory limit (1 MiB)"), std::string::npos) << big.err;
    for (const char* limit : {" --max-memory 0", ""}) {
        const auto r = test::run_cli("segment '" + mesh + "' -o '" + (dir.path() / "b").string() + "'" + limit);
        EXPECT_EQ(r.status, 0) << limit << ": " << r.err;
    }
}

// A sphere pressed into a needle-thin disc 1e12 times wider than thick: its cotan weights span
// 24 orders of magnitude and the factorization fails; the error says why.
TEST(Cli, AMeshTooStretchedForDoublePrecisionIsNamedSo) {
    test::TempDir dir;
    const MeshView sphere = shapes::icosphere(2);
    std::string off = "OFF\n" + std::to_string(sphere.n_vertices()) + " " + std::to_string(sphere.n_faces()) + " 0\n";
    char line[128];
    for (Index v = 0; v < sphere.n_vertices(); ++v) {
        std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", sphere.V(v, 0) * 1e6, sphere.V(v, 1), sphere.V(v, 2) * 1e-6);
        off += line;
    }
    for (Index f = 0; f < sphere.n_faces(); ++f)
        off += "3 " + std::to_string(sphere.F(f, 0)) + " " + std::to_string(sphere.F(f, 1)) + " " + std::to_string(sphere.F(f, 2)) + "\n";
    const auto r = test::run_cli("segment '" + dir.write("disc.off", off) + "' -o '" + (dir.path() / "out").string() + "'");
    EXPECT_EQ(r.status, engine::kExitSolverFailure) << r.err;
    EXPECT_NE(r.err.find("its cotan weights run from "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("too thin or stretched for double precision"), std::string::npos) << r.err;
}

// Under an address-space limit (`ulimit -v`) OpenBLAS retries a work buffer it cannot map
// forever: the process must refuse cleanly where the limit is too small, run where it is not,
// and never hang (`timeout` turns a hang into exit status 124). Sanitizers reserve terabytes of
// address space and cannot run under such a limit.
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
TEST(Cli, AddressSpaceLimitIsRefusedOrHonouredNeverHangs) {
    test::TempDir dir;
    const auto run = [&](int limit_mib, const std::string& args) {
        const std::string err = (dir.path() / "err").string();
        const std::string command = "ulimit -v " + std::to_string(limit_mib << 10) + " && exec timeout 120 '" +
                                    HOLOFLOW_CLI + "' " + args + " >/dev/null 2>'" + err + "'";
        const int raw = std::system(("sh -c \"" + command + "\"").c_str());
        return std::make_pair(WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, test::slurp(err));
    };
    const std::string mesh = "'" + test::corpus("eight.off") + "'";
    EXPECT_EQ(run(150, "--version").first, 0);
    EXPECT_EQ(run(150, "info " + mesh).first, 0);
    for (const int limit : {150, 250}) {
        const auto [status, err] = run(limit, "segment " + mesh + " -o '" + (dir.path() / "a").string() + "'");
        EXPECT_EQ(status, engine::kExitResourceLimit) << limit << " MiB: " << err;
        EXPECT_NE(err.find("address-space limit (ulimit -v) of " + std::to_string(limit) + " MiB"), std::string::npos)
            << err;
    }
    const auto [status, err] = run(1024, "batch " + mesh + " -o '" + (dir.path() / "b").string() + "' --threads 2");
    EXPECT_EQ(status, 0) << err;
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "b" / "eight" / "segmentation.json"));
}
#endif

}  // namespace
}  // namespace holoflow
