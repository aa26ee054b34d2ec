#include "holoflow/engine/output.h"

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "holoflow/kernels/errors.h"

namespace holoflow::engine {

std::string json_text(const nlohmann::json& j, int indent) {
    return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

void prepare_output_folder(const std::filesystem::path& folder) {
    std::error_code ec;
    std::filesystem::create_directories(folder, ec);
    if (ec || !std::filesystem::is_directory(folder))
        throw OutputError("cannot create output folder '" + folder.string() + "': " +
                          (ec ? ec.message() : "not a directory"));
    if (::access(folder.c_str(), W_OK) != 0)
        throw OutputError("output folder '" + folder.string() + "' is not writable");
}

namespace {

namespace fs = std::filesystem;

constexpr const char* kTemporaryTag = ".tmp";  // temporaries are .<name>.tmp<pid>
constexpr const char* kBackupTag = ".old";     // a set's old files during its commit: .<name>.old<pid>

fs::path hidden_name(const fs::path& path, const char* tag) {
    return path.parent_path() / ("." + path.filename().string() + tag + std::to_string(::getpid()));
}

bool process_running(long pid) {
    return pid > 0 && pid <= std::numeric_limits<pid_t>::max() &&
           (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM);
}

// Streams `write` into the temporary of `path` and returns its name; on failure nothing is left.
fs::path write_temporary(const fs::path& path, const std::function<void(std::ostream&)>& write) {
    const fs::path temporary = hidden_name(path, kTemporaryTag);
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    try {
        if (out) write(out);
    } catch (...) {  // a writer that refuses its data leaves no temporary behind
        out.close();
        std::error_code ignored;
        fs::remove(temporary, ignored);
        throw;
    }
    out.flush();
    if (!out) {
        out.close();
        std::error_code ignored;
        fs::remove(temporary, ignored);
        throw OutputError("cannot write '" + path.string() + "' (disk full or not writable)");
    }
    return temporary;
}

void move_into_place(const fs::path& temporary, const fs::path& path) {
    std::error_code ec;
    fs::rename(temporary, path, ec);
    if (ec) {
        fs::remove(temporary, ec);
        throw OutputError("cannot move the finished '" + path.string() + "' into place");
    }
}

}  // namespace

void remove_stale_temporaries(const fs::path& folder, const std::vector<std::string>& names) {
    std::error_code ec;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string file = it->path().filename().string();
        for (const std::string& name : names)
            for (const char* tag : {kTemporaryTag, kBackupTag}) {
                const std::string prefix = "." + name + tag;
                if (file.size() <= prefix.size() || file.compare(0, prefix.size(), prefix) != 0 ||
                    file.size() - prefix.size() > 18 ||
                    file.find_first_not_of("0123456789", prefix.size()) != std::string::npos)
                    continue;
                // Another run writing into this folder right now keeps its files.
                if (process_running(std::stol(file.substr(prefix.size())))) continue;
                std::error_code ignored;
                fs::remove(it->path(), ignored);
            }
    }
}

void write_file_atomic(const fs::path& path, const std::function<void(std::ostream&)>& write) {
    move_into_place(write_temporary(path, write), path);
}

FileSet::~FileSet() {
    std::error_code ignored;
    for (const Staged& s : staged_) fs::remove(s.temporary, ignored);
}

void FileSet::add(const fs::path& path, const std::function<void(std::ostream&)>& write) {
    staged_.push_back({write_temporary(path, write), path});
}

void FileSet::add(const fs::path& path, const std::string& content) {
    add(path, [&](std::ostream& out) { out.write(content.data(), static_cast<std::streamsize>(content.size())); });
}

void FileSet::commit() {
    if (staged_.empty()) return;
    std::error_code ec;
    // Nothing is touched where a file cannot take its place (a folder of that name, a device).
    for (const Staged& s : staged_) {
        const fs::file_status status = fs::symlink_status(s.path, ec);
        if (fs::exists(status) && !fs::is_regular_file(status) && !fs::is_symlink(status))
            throw OutputError("cannot write '" + s.path.string() + "': a folder or special file is in its place");
    }
    // The old files move aside, the marker's first (the old set is then no longer claimed whole),
    // and the new ones move in; where a move fails, the old set is put back as it was.
    std::vector<Staged> aside;  // {backup, path}
    std::vector<fs::path> placed;
    auto move_aside = [&](const fs::path& path) {
        if (!fs::exists(fs::symlink_status(path, ec))) return;
        const fs::path backup = hidden_name(path, kBackupTag);
        fs::rename(path, backup, ec);
        if (ec) throw OutputError("cannot move the old '" + path.string() + "' aside");
        aside.push_back({backup, path});
    };
    try {
        move_aside(staged_.back().path);
        for (const Staged& s : staged_) {
            if (&s != &staged_.back()) move_aside(s.path);
            move_into_place(s.temporary, s.path);
            placed.push_back(s.path);
        }
    } catch (...) {
        std::error_code ignored;
        for (const fs::path& path : placed) fs::remove(path, ignored);
        for (auto it = aside.rbegin(); it != aside.rend(); ++it) fs::rename(it->temporary, it->path, ignored);
        throw;  // the destructor removes the temporaries
    }
    for (const Staged& old : aside) fs::remove(old.temporary, ec);
    staged_.clear();
}

OutputFolder::OutputFolder(fs::path folder) : folder_(std::move(folder)) {
    std::error_code ec;
    fs::path level = folder_.lexically_normal();
    if (!level.has_filename()) level = level.parent_path();  // "out/"
    for (; !level.empty() && !fs::exists(fs::symlink_status(level, ec)); level = level.parent_path()) {
        created_.push_back(level);
        if (level == level.parent_path()) break;
    }
    try {
        prepare_output_folder(folder_);
        lock();
    } catch (...) {
        remove_created();
        throw;
    }
}

OutputFolder::~OutputFolder() {
    if (lock_fd_ >= 0) {
        ::unlink((folder_ / kOutputLockFile).c_str());  // while still holding it: see lock()
        ::close(lock_fd_);
    }
    remove_created();
}

void OutputFolder::remove_created() {
    std::error_code ignored;
    for (const fs::path& level : created_) fs::remove(level, ignored);  // only if empty
}

void OutputFolder::lock() {
    const fs::path file = folder_ / kOutputLockFile;
    for (int attempt = 0; attempt < 100; ++attempt) {
        const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0)
            throw OutputError("cannot create the lock file '" + file.string() + "': " + std::strerror(errno));
        if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
            const int error = errno;
            std::string holder;
            if (error == EWOULDBLOCK) {
                char text[32] = {};
                if (::pread(fd, text, sizeof text - 1, 0) > 0) holder = std::string(" (process ") + text + ")";
            }
            ::close(fd);
            if (error == EWOULDBLOCK)
                throw OutputError("output folder '" + folder_.string() + "' is in use by another holoflow run" +
                                  holder + "; wait for it or choose another folder");
            if (error == ENOLCK || error == EOPNOTSUPP) return;  // a file system without locks: go on unlocked
            throw OutputError("cannot lock '" + file.string() + "': " + std::strerror(error));
        }
        // The run before us removes the file while it still holds the lock: if we opened the
        // file it removed, our lock guards nothing, so open the one now there.
        struct stat held {}, named {};
        if (::fstat(fd, &held) == 0 && ::stat(file.c_str(), &named) == 0 && held.st_dev == named.st_dev &&
            held.st_ino == named.st_ino) {
            const std::string pid = std::to_string(::getpid());
            if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
                // The pid is only for the message a second run prints.
            }
            lock_fd_ = fd;
            return;
        }
        ::close(fd);
    }
    throw OutputError("cannot lock '" + file.string() + "': it keeps being replaced");
}

void write_file_atomic(const std::filesystem::path& path, const std::string& content) {
    write_file_atomic(path, [&](std::ostream& out) {
        out.write(content.data(), static_cast<std::streamsize>(content.size()));
    });
}

fs::path file_identity(const fs::path& path) {
    std::error_code ec;
    const fs::path canonical = fs::weakly_canonical(path, ec);
    return ec ? fs::absolute(path, ec).lexically_normal() : canonical;
}

void refuse_overwriting_inputs(const std::vector<fs::path>& outputs, const std::vector<std::string>& inputs) {
    std::map<fs::path, std::string> input_of;
    for (const std::string& input : inputs) input_of.emplace(file_identity(input), input);
    std::map<fs::path, fs::path> folder_identity;  // outputs share few folders: resolve each once
    for (const fs::path& output : outputs) {
        auto [folder, added] = folder_identity.try_emplace(output.parent_path());
        if (added) folder->second = file_identity(output.parent_path().empty() ? fs::path(".") : output.parent_path());
        // An output that is a link to an input would be replaced, not written through: only the
        // folder is resolved.
        if (const auto it = input_of.find(folder->second / output.filename()); it != input_of.end())
            throw InvalidInput("the output '" + output.string() + "' is the input '" + it->second +
                               "': it would be overwritten (choose another output folder)");
    }
}

namespace {

// Shortest text that reads back to the same double, or an integer.
template <class T>
void put(std::ostream& out, T x) {
    char buffer[32];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, x);
    out.write(buffer, result.ptr - buffer);
}

}  // namespace

void write_off(std::ostream& out, const MeshView& mesh) {
    out << "OFF\n" << mesh.n_vertices() << ' ' << mesh.n_faces() << " 0\n";
    for (Index v = 0; v < mesh.n_vertices(); ++v) {
        for (int k = 0; k < 3; ++k) {
            put(out, mesh.V(v, k));
            out << (k < 2 ? ' ' : '\n');
        }
    }
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        out << '3';
        for (int k = 0; k < 3; ++k) {
            out << ' ';
            put(out, mesh.F(f, k));
        }
        out << '\n';
    }
}

void write_uv_obj(std::ostream& out, const MeshView& input, const ConformalResult& result) {
    const MeshView& surface = *result.surface;
    out << "# holoflow uv map of the chosen holomorphic 1-form; vt per wedge\n";
    for (Index v = 0; v < input.n_vertices(); ++v) {
        out << 'v';
        for (int k = 0; k < 3; ++k) {
            out << ' ';
            put(out, input.V(v, k));
        }
        out << '\n';
    }
    for (const auto& z : result.map.wedge_uv) {
        out << "vt ";
        put(out, z.real());
        out << ' ';
        put(out, z.imag());
        out << '\n';
    }
    // Cover faces f < #F(input) are the input faces with the same vertex numbers.
    for (Index f = 0; f < input.n_faces(); ++f) {
        out << 'f';
        for (int k = 0; k < 3; ++k) {
            out << ' ';
            put(out, surface.F(f, k) + 1);
            out << '/';
            put(out, result.homology.corner_wedge[3 * f + k] + 1);
        }
        out << '\n';
    }
}

void write_forms(std::ostream& out, const ConformalResult& result) {
    const MeshView& surface = *result.surface;
    const Eigen::Index n = result.harmonic.cols();
    const Eigen::MatrixXd& C = result.star.star;  // *omega_i = sum_j C(i, j) omega_j
    out << "# holoflow forms 1\n"
           "# harmonic basis omega_1..omega_2g dual to the generator loops, then their Hodge "
           "stars *omega_1..*omega_2g\n"
           "# one line per edge of the working surface: tail head values...\n"
        << "genus " << n / 2 << " edges " << surface.n_edges() << "\n";
    Eigen::VectorXd row(n), star(n);
    for (Index e = 0; e < surface.n_edges(); ++e) {
        row = result.harmonic.row(e).transpose();
        star.noalias() = C * row;
        put(out, surface.E(e, 0));
        out << ' ';
        put(out, surface.E(e, 1));
        for (Eigen::Index i = 0; i < n; ++i) {
            out << ' ';
            put(out, row(i));
        }
        for (Eigen::Index i = 0; i < n; ++i) {
            out << ' ';
            put(out, star(i));
        }
        out << '\n';
    }
}

}  // namespace holoflow::engine
