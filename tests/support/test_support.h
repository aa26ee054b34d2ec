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

#include "holoflow/engine/mesh_loader.h"

namespace holoflow::test {

inline std::string corpus(const std::string& name) {
    return std::string(HOLOFLOW_CORPUS_DIR) + "/" + name;
}

//! A libcgal-demo mesh loaded with the engine; the corpus is always unpacked by the build, so a
//! missing file is a test failure (an exception), never a skip.
inline std::shared_ptr<const MeshView> corpus_mesh(const std::string& name) {
    return engine::load_mesh(corpus(name + ".off")).mesh;
}

inline std::string shared_mesh(const std::string& name) {
    return std::string(HOLOFLOW_SHARED_MESHES) + "/" + name;
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

}  // namespace holoflow::test
