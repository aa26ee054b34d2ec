#include "holoflow/engine/output.h"

#include <charconv>
#include <cstdio>
#include <fstream>
#include <unistd.h>

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
constexpr const char* kTemporaryTag = ".tmp";  // temporaries are .<name>.tmp<pid>
}  // namespace

void remove_stale_temporaries(const std::filesystem::path& folder, const std::vector<std::string>& names) {
    std::error_code ec;
    for (std::filesystem::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string file = it->path().filename().string();
        for (const std::string& name : names) {
            const std::string prefix = "." + name + kTemporaryTag;
            if (file.size() > prefix.size() && file.compare(0, prefix.size(), prefix) == 0 &&
                file.find_first_not_of("0123456789", prefix.size()) == std::string::npos) {
                std::error_code ignored;
                std::filesystem::remove(it->path(), ignored);
            }
        }
    }
}

void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write) {
    std::string name = ".";
    name += path.filename().string();
    name += kTemporaryTag;
    name += std::to_string(::getpid());
    const std::filesystem::path temporary = path.parent_path() / name;
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        try {
            if (out) write(out);
        } catch (...) {  // a writer that refuses its data leaves no temporary behind
            out.close();
            std::error_code ignored;
            std::filesystem::remove(temporary, ignored);
            throw;
        }
        out.flush();
        if (!out) {
            out.close();
            std::error_code ignored;
            std::filesystem::remove(temporary, ignored);
            throw OutputError("cannot write '" + path.string() + "' (disk full or not writable)");
        }
    }
    std::error_code ec;
    std::filesystem::rename(temporary, path, ec);
    if (ec) {
        std::filesystem::remove(temporary, ec);
        throw OutputError("cannot move the finished '" + path.string() + "' into place");
    }
}

void write_file_atomic(const std::filesystem::path& path, const std::string& content) {
    write_file_atomic(path, [&](std::ostream& out) {
        out.write(content.data(), static_cast<std::streamsize>(content.size()));
    });
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
