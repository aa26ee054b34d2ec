#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "holoflow/engine/mesh_loader.h"

namespace holoflow::test {

// Appended in place: GCC 12's -Warray-bounds misreads `std::string(...) + "/" + name` inlined.
inline std::string corpus(const std::string& name) {
    std::string path = HOLOFLOW_CORPUS_DIR;
    return path.append("/").append(name);
}

//! A libcgal-demo mesh loaded with the engine; the corpus is always unpacked by the build, so a
//! missing file is a test failure (an exception), never a skip.
inline std::shared_ptr<const MeshView> corpus_mesh(const std::string& name) {
    return engine::load_mesh(corpus(name + ".off")).mesh;
}

inline std::string shared_mesh(const std::string& name) {
    std::string path = HOLOFLOW_SHARED_MESHES;
    return path.append("/").append(name);
}

//! The whole file as bytes ("" if it cannot be read).
inline std::string slurp(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

//! A fresh directory under the system temp dir, removed with its contents on destruction.
class TempDir {
 public:
    TempDir() {
        std::random_device rd;
        path_ = std::filesystem::temp_directory_path() /
                ("holoflow-test-" + std::to_string(rd()) + std::to_string(rd()));
        std::filesystem::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const std::filesystem::path& path() const { return path_; }
    std::string write(const std::string& name, const std::string& bytes) const {
        const auto file = path_ / name;
        std::ofstream(file, std::ios::binary) << bytes;
        return file.string();
    }

 private:
    std::filesystem::path path_;
};

struct CommandResult {
    int status = -1;  // exit status, or -1 if the process did not exit normally (signal)
    std::string out, err;
};

//! Runs the holoflow CLI with `args` (already shell-quoted), capturing stdout and stderr.
inline CommandResult run_cli(const std::string& args) {
    TempDir dir;
    const std::string out = (dir.path() / "out").string(), err = (dir.path() / "err").string();
    const std::string command =
        std::string("'") + HOLOFLOW_CLI + "' " + args + " >'" + out + "' 2>'" + err + "'";
    const int raw = std::system(command.c_str());
    CommandResult r;
    r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    auto slurp = [](const std::string& file) {
        std::ifstream in(file, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
}

//! Up to `count` faces of `mesh` that share no vertex with each other, taken in the order
//! (i * step) mod #F (spread over the surface for a large step): deleting them leaves one 3-edge
//! hole each and every vertex manifold.
inline std::vector<Index> pinhole_faces(const MeshView& mesh, Index count, Index step) {
    std::vector<char> used(mesh.n_vertices(), 0);
    std::vector<Index> faces;
    for (Index i = 0; i < mesh.n_faces() && static_cast<Index>(faces.size()) < count; ++i) {
        const Index f = static_cast<Index>((static_cast<long long>(i) * step) % mesh.n_faces());
        if (used[mesh.F(f, 0)] || used[mesh.F(f, 1)] || used[mesh.F(f, 2)]) continue;
        for (int k = 0; k < 3; ++k) used[mesh.F(f, k)] = 1;
        faces.push_back(f);
    }
    return faces;
}

//! `mesh` without the faces listed (the others in their order, the vertices all kept).
inline MeshView without_faces(const MeshView& mesh, const std::vector<Index>& drop) {
    std::vector<char> dropped(mesh.n_faces(), 0);
    for (Index f : drop) dropped[f] = 1;
    TriangleMatrix F(mesh.n_faces() - static_cast<Index>(drop.size()), 3);
    Index row = 0;
    for (Index f = 0; f < mesh.n_faces(); ++f)
        if (!dropped[f]) F.row(row++) = mesh.F.row(f);
    return make_mesh_view(mesh.V, F);
}

//! `mesh` with every face f, f % step == first, split at its centroid into three faces in its
//! place (the same surface; the new vertices have valence 3).
inline MeshView centroid_split(const MeshView& mesh, Index step, Index first) {
    const Index n_split = first < mesh.n_faces() ? (mesh.n_faces() - first + step - 1) / step : 0;
    PointMatrix V(mesh.n_vertices() + n_split, 3);
    V.topRows(mesh.n_vertices()) = mesh.V;
    TriangleMatrix F(mesh.n_faces() + 2 * n_split, 3);
    Index row = 0, c = mesh.n_vertices();
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const Index a = mesh.F(f, 0), b = mesh.F(f, 1), d = mesh.F(f, 2);
        if (f < first || (f - first) % step != 0) {
            F.row(row++) = mesh.F.row(f);
            continue;
        }
        V.row(c) = (mesh.V.row(a) + mesh.V.row(b) + mesh.V.row(d)) / 3;
        F.row(row++) << a, b, c;
        F.row(row++) << b, d, c;
        F.row(row++) << d, a, c;
        ++c;
    }
    return make_mesh_view(V, F);
}

}  // namespace holoflow::test
