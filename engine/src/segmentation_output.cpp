#include "holoflow/engine/segmentation_output.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

// Every writer checks the whole picture before its first byte, then streams through a fixed
// 64 KiB buffer: no output is ever assembled as one string, whatever the mesh size.

namespace holoflow::engine {
namespace {

using Picture = SegmentationPicture;

//! Buffered writer over an ostream: text numbers via std::to_chars, binary little-endian.
class Sink {
  public:
    explicit Sink(std::ostream& out) : out_(out) {}
    Sink(const Sink&) = delete;
    Sink& operator=(const Sink&) = delete;

    Sink& text(std::string_view s) {
        if (s.size() > room()) flush();
        if (s.size() > sizeof buffer_) {
            out_.write(s.data(), static_cast<std::streamsize>(s.size()));
            return *this;
        }
        std::memcpy(buffer_ + used_, s.data(), s.size());
        used_ += s.size();
        return *this;
    }
    Sink& ch(char c) {
        if (room() == 0) flush();
        buffer_[used_++] = c;
        return *this;
    }
    //! Shortest decimal that reads back to the same value (integers as integers).
    template <class T>
    Sink& num(T x) {
        if (room() < kNumberRoom) flush();
        const auto r = std::to_chars(buffer_ + used_, buffer_ + sizeof buffer_, x);
        used_ = static_cast<std::size_t>(r.ptr - buffer_);
        return *this;
    }
    //! Fixed-point with `digits` decimals: SVG pixel coordinates need no more than 1/100 px.
    Sink& fixed(double x, int digits) {
        if (room() < kNumberRoom) flush();
        const auto r = std::to_chars(buffer_ + used_, buffer_ + sizeof buffer_, x,
                                     std::chars_format::fixed, digits);
        if (r.ec != std::errc()) return ch('0');  // beyond any picture: cannot happen in px
        used_ = static_cast<std::size_t>(r.ptr - buffer_);
        return *this;
    }
    template <class T>
    Sink& little_endian(T value) {
        static_assert(std::is_arithmetic_v<T>);
        if (room() < sizeof(T)) flush();
        char bytes[sizeof(T)];
        std::memcpy(bytes, &value, sizeof(T));
        if constexpr (std::endian::native == std::endian::big)
            std::reverse(bytes, bytes + sizeof(T));
        std::memcpy(buffer_ + used_, bytes, sizeof(T));
        used_ += sizeof(T);
        return *this;
    }
    void flush() {
        out_.write(buffer_, static_cast<std::streamsize>(used_));
        used_ = 0;
    }

  private:
    // Longest to_chars output: a double in shortest form is at most 24 characters; fixed
    // output is only used on pixel coordinates (far below 1e40) and checked anyway.
    static constexpr std::size_t kNumberRoom = 64;
    std::size_t room() const { return sizeof buffer_ - used_; }

    std::ostream& out_;
    char buffer_[1 << 16];
    std::size_t used_ = 0;
};

// Non-finite numbers are written as 0: every reader we have (and most others) refuses NaN or
// inf, and such a value carries no geometry worth keeping. The segmentation never produces
// them on valid input; this keeps a broken upstream from producing unreadable files.
double finite_or_zero(double x) { return std::isfinite(x) ? x : 0.0; }

[[noreturn]] void refuse(const char* writer, const std::string& problem) {
    throw InvalidInput(std::string(writer) + ": " + problem);
}

//! The mesh arrays agree with each other; \throw InvalidInput naming the first mismatch.
void require_mesh(const Picture& p, const char* writer) {
    using std::to_string;
    const Eigen::Index n_faces = p.F.rows();
    // Output vertex and corner numbers are 32-bit (PLY int, our Index) and 3 #F of them exist.
    if (n_faces > std::numeric_limits<Index>::max() / 3)
        refuse(writer, to_string(n_faces) + " faces is more than 32-bit corner numbers allow");
    if (static_cast<Eigen::Index>(p.face_patch.size()) != n_faces)
        refuse(writer, "face_patch has " + to_string(p.face_patch.size()) + " entries for " +
                           to_string(n_faces) + " faces");
    if (static_cast<Eigen::Index>(p.corner_uv.size()) != 3 * n_faces)
        refuse(writer, "corner_uv has " + to_string(p.corner_uv.size()) +
                           " entries, expected 3 per face = " + to_string(3 * n_faces));
    if (p.patch_size.size() > static_cast<std::size_t>(std::numeric_limits<Index>::max()))
        refuse(writer, "more patches than 32-bit ids allow");
    const Index n_patches = p.n_patches();
    const Eigen::Index n_vertices = p.V.rows();
    for (Eigen::Index f = 0; f < n_faces; ++f) {
        const Index patch = p.face_patch[static_cast<std::size_t>(f)];
        if (patch < 0 || patch >= n_patches)
            refuse(writer, "face " + to_string(f) + " has patch id " + to_string(patch) +
                               ", outside 0 .. " + to_string(n_patches - 1));
        for (int k = 0; k < 3; ++k) {
            const Index v = p.F(f, k);
            if (v < 0 || v >= n_vertices)
                refuse(writer, "face " + to_string(f) + " corner " + to_string(k) +
                                   " refers to vertex " + to_string(v) + " but there are " +
                                   to_string(n_vertices) + " vertices");
        }
    }
}

//! Faces sorted by patch (a stable counting sort: index order within each patch).
struct FacesByPatch {
    std::vector<Index> faces;
    std::vector<Index> start;  // patch p owns faces[start[p] .. start[p + 1])
};

FacesByPatch faces_by_patch(const Picture& p) {
    FacesByPatch g;
    const auto n_patches = static_cast<std::size_t>(p.n_patches());
    g.start.assign(n_patches + 1, 0);
    for (const Index patch : p.face_patch) ++g.start[static_cast<std::size_t>(patch) + 1];
    std::partial_sum(g.start.begin(), g.start.end(), g.start.begin());
    g.faces.resize(p.face_patch.size());
    std::vector<Index> cursor(g.start.begin(), g.start.end() - 1);
    for (std::size_t f = 0; f < p.face_patch.size(); ++f)
        g.faces[static_cast<std::size_t>(cursor[static_cast<std::size_t>(p.face_patch[f])]++)] =
            static_cast<Index>(f);
    return g;
}

//! Split vertices: one per (vertex, patch) pair in use, numbered in order of first use when
//! scanning corners 3 f + k in order. Corners are bucketed by vertex (counting sort) and each
//! bucket sorted by patch, so the work is O(C log d) for C corners and valence d: no hashing
//! and nothing quadratic even at a vertex shared by many patches.
struct SplitVertices {
    std::vector<Index> corner_vertex;  // 3 #F: output vertex of each corner
    std::vector<Index> first_corner;   // per output vertex: the corner that introduced it
};

SplitVertices split_vertices(const Picture& p) {
    const auto n_corners = static_cast<std::size_t>(3 * p.F.rows());
    const auto n_vertices = static_cast<std::size_t>(p.V.rows());
    auto vertex_of = [&p](std::size_t c) {
        return static_cast<std::size_t>(
            p.F(static_cast<Eigen::Index>(c / 3), static_cast<int>(c % 3)));
    };
    auto patch_of = [&p](Index c) { return p.face_patch[static_cast<std::size_t>(c / 3)]; };

    std::vector<Index> start(n_vertices + 1, 0);
    for (std::size_t c = 0; c < n_corners; ++c) ++start[vertex_of(c) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<Index> by_vertex(n_corners);
    {
        std::vector<Index> cursor(start.begin(), start.end() - 1);
        for (std::size_t c = 0; c < n_corners; ++c)
            by_vertex[static_cast<std::size_t>(cursor[vertex_of(c)]++)] = static_cast<Index>(c);
    }
    // leader[c]: the smallest corner with the same vertex and patch as c.
    std::vector<Index> leader(n_corners);
    for (std::size_t v = 0; v < n_vertices; ++v) {
        const auto b = by_vertex.begin() + start[v], e = by_vertex.begin() + start[v + 1];
        // Stable: corners of one patch stay in increasing order, so the first is the leader.
        std::stable_sort(b, e, [&](Index x, Index y) { return patch_of(x) < patch_of(y); });
        for (auto i = b; i != e;) {
            auto j = i;
            while (j != e && patch_of(*j) == patch_of(*i))
                leader[static_cast<std::size_t>(*j++)] = *i;
            i = j;
        }
    }
    SplitVertices s;
    s.corner_vertex.resize(n_corners);
    for (std::size_t c = 0; c < n_corners; ++c) {
        const auto l = static_cast<std::size_t>(leader[c]);
        if (l == c) {
            s.corner_vertex[c] = static_cast<Index>(s.first_corner.size());
            s.first_corner.push_back(static_cast<Index>(c));
        } else {
            s.corner_vertex[c] = s.corner_vertex[l];  // l < c: already numbered
        }
    }
    return s;
}

std::string_view family_name(Picture::Family family) {
    switch (family) {
        case Picture::Family::Vertical: return "vertical";
        case Picture::Family::Horizontal: return "horizontal";
        case Picture::Family::Boundary: return "boundary";
    }
    return "";
}

bool finite_point(const Eigen::Vector3d& x) { return x.allFinite(); }

// domains.svg layout, in px.
constexpr double kMaxWidth = 1600;   // the whole picture
constexpr double kMargin = 10;       // around the picture
constexpr double kGap = 8;           // between rectangles
constexpr double kPlaceholder = 24;  // side of the square drawn for a patch without usable size

bool usable_size(const std::array<double, 2>& s) {
    return std::isfinite(s[0]) && std::isfinite(s[1]) && s[0] > 0 && s[1] > 0;
}

struct DomainLayout {
    std::vector<double> x, y, w, h;  // per patch: top-left corner and size
    // The common scale: px = (chart length / unit) * px_per_scaled. Kept as two factors so
    // that charts measured in tiny or huge units cannot overflow the product.
    double unit = 1, px_per_scaled = 0;
    double width = 0, height = 0;  // of the whole picture, whole px
};

//! Shelf packing at one common scale: rectangles tallest first (ties by id), left to right, a
//! new shelf when a row is full. The scale is searched among shelf widths from the longest side
//! (no rectangle larger than the page width either way) to one row of all, keeping the picture
//! closest to a 16:10 landscape page for its scale; each trial is one linear pass over the two
//! presorted lists (usable rectangles, placeholders) merged by height in px.
DomainLayout layout_domains(const Picture& picture) {
    const std::size_t n = picture.patch_size.size();
    const double limit = kMaxWidth - 2 * kMargin;
    // Sizes divided by the largest side first, so that huge or tiny charts cannot overflow.
    double largest = 0;
    for (const auto& s : picture.patch_size)
        if (usable_size(s)) largest = std::max({largest, s[0], s[1]});
    std::vector<double> sw(n, 0), sh(n, 0);  // scaled sizes
    std::vector<Index> tall, placeholders;
    double row = 0;
    for (std::size_t p = 0; p < n; ++p) {
        if (usable_size(picture.patch_size[p])) {
            sw[p] = picture.patch_size[p][0] / largest;
            sh[p] = picture.patch_size[p][1] / largest;
            row += sw[p];
            tall.push_back(static_cast<Index>(p));
        } else {
            placeholders.push_back(static_cast<Index>(p));
        }
    }
    std::sort(tall.begin(), tall.end(), [&](Index a, Index b) {
        const double ha = sh[static_cast<std::size_t>(a)], hb = sh[static_cast<std::size_t>(b)];
        return ha != hb ? ha > hb : a < b;
    });

    DomainLayout out;
    out.x.assign(n, 0);
    out.y.assign(n, 0);
    out.w.assign(n, kPlaceholder);
    out.h.assign(n, kPlaceholder);
    // Packs at `scale` px per scaled unit; returns the used width and height (margins apart).
    auto pack = [&](double scale, bool place) {
        double x = 0, y = 0, shelf = 0, used = 0;
        std::size_t i = 0, j = 0;
        while (i < tall.size() || j < placeholders.size()) {
            bool take_tall = j == placeholders.size();
            if (!take_tall && i < tall.size()) {
                const double h = sh[static_cast<std::size_t>(tall[i])] * scale;
                take_tall = h > kPlaceholder || (h == kPlaceholder && tall[i] < placeholders[j]);
            }
            const auto p = static_cast<std::size_t>(take_tall ? tall[i++] : placeholders[j++]);
            const double w = take_tall ? sw[p] * scale : kPlaceholder;
            const double h = take_tall ? sh[p] * scale : kPlaceholder;
            if (x > 0 && x + w > limit) {
                y += shelf + kGap;
                x = shelf = 0;
            }
            if (place) {
                out.x[p] = kMargin + x;
                out.y[p] = kMargin + y;
                out.w[p] = w;
                out.h[p] = h;
            }
            used = std::max(used, x + w);
            shelf = std::max(shelf, h);
            x += w + kGap;
        }
        return std::array<double, 2>{used, y + shelf};
    };
    double best_scale = 1;  // without a usable size only placeholders are drawn: any scale
    if (!tall.empty()) {
        // Shelf width L (scaled units) maps to scale = limit / L. At L = 1 the longest side
        // (1 after scaling) spans the page; a little past L = row everything fits one row.
        constexpr double kLandscape = 1.6;  // page width / height aimed at
        auto side = [&](double shelf_width) {
            const double scale = limit / shelf_width;
            const auto [w, h] = pack(scale, false);
            return std::max(w, kLandscape * h) / scale;
        };
        auto search = [&](double lo, double hi, int steps) {
            double best = lo, best_side = side(lo);
            for (int k = 1; k <= steps; ++k) {
                const double L = lo * std::pow(hi / lo, static_cast<double>(k) / steps);
                const double s = side(L);
                if (s < best_side) best = L, best_side = s;
            }
            return best;
        };
        const double lo = 1, hi = std::max(1.0, 1.1 * row);
        constexpr int kCoarse = 24, kFine = 16;
        const double step = std::pow(hi / lo, 1.0 / kCoarse);
        const double coarse = search(lo, hi, kCoarse);
        const double fine = search(std::max(lo, coarse / step), std::min(hi, coarse * step), kFine);
        best_scale = limit / fine;
        out.unit = largest;
        out.px_per_scaled = best_scale;
    }
    const auto [used, tall_height] = pack(best_scale, true);
    out.width = std::ceil(2 * kMargin + used);
    out.height = std::ceil(2 * kMargin + tall_height);
    return out;
}

}  // namespace

std::array<std::uint8_t, 3> patch_colour(Index patch) {
    HOLOFLOW_REQUIRE(patch >= 0, "patch id " + std::to_string(patch) + " is negative");
    // Hue steps of 1/phi turn (137.5 degrees): consecutive ids land far apart on the wheel and
    // no two of the first few hundred coincide. Saturation and value are fixed and light, so
    // the dark strokes and labels drawn over the colour stay readable.
    constexpr double kGoldenConjugate = 0.6180339887498949;  // 1 / phi = phi - 1
    constexpr double kSaturation = 0.55, kValue = 0.93;
    const double hue = std::fmod(0.08 + static_cast<double>(patch) * kGoldenConjugate, 1.0);
    const double h6 = hue * 6.0;
    const int sector = std::min(5, static_cast<int>(h6));
    const double f = h6 - sector;
    const double p = kValue * (1.0 - kSaturation);
    const double q = kValue * (1.0 - kSaturation * f);
    const double t = kValue * (1.0 - kSaturation * (1.0 - f));
    double r = 0, g = 0, b = 0;
    switch (sector) {
        case 0: r = kValue, g = t, b = p; break;
        case 1: r = q, g = kValue, b = p; break;
        case 2: r = p, g = kValue, b = t; break;
        case 3: r = p, g = q, b = kValue; break;
        case 4: r = t, g = p, b = kValue; break;
        default: r = kValue, g = p, b = q; break;
    }
    auto byte = [](double x) { return static_cast<std::uint8_t>(std::lround(255.0 * x)); };
    return {byte(r), byte(g), byte(b)};
}

void write_segments_ply(std::ostream& out, const SegmentationPicture& picture) {
    require_mesh(picture, "write_segments_ply");
    const SplitVertices split = split_vertices(picture);
    const Index n_patches = picture.n_patches();
    std::vector<std::array<std::uint8_t, 3>> colour(static_cast<std::size_t>(n_patches));
    for (Index p = 0; p < n_patches; ++p) colour[static_cast<std::size_t>(p)] = patch_colour(p);

    Sink sink(out);
    sink.text("ply\nformat binary_little_endian 1.0\ncomment holoflow segments\ncomment patches ")
        .num(n_patches)
        .text("\ncomment vertices split per patch; u v in the patch's rectangle chart\n")
        .text("element vertex ")
        .num(split.first_corner.size())
        .text(
            "\nproperty double x\nproperty double y\nproperty double z\n"
            "property double u\nproperty double v\nelement face ")
        .num(picture.F.rows())
        .text(
            "\nproperty list uchar int vertex_indices\nproperty int patch\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n");
    for (const Index c : split.first_corner) {
        const Index v = picture.F(c / 3, c % 3);
        for (int k = 0; k < 3; ++k) sink.little_endian(finite_or_zero(picture.V(v, k)));
        // Corners of one face sharing this vertex within the patch agree by contract: the
        // first corner's uv stands for all of them.
        const std::complex<double> uv = picture.corner_uv[static_cast<std::size_t>(c)];
        sink.little_endian(finite_or_zero(uv.real())).little_endian(finite_or_zero(uv.imag()));
    }
    for (Eigen::Index f = 0; f < picture.F.rows(); ++f) {
        sink.little_endian(std::uint8_t{3});
        for (int k = 0; k < 3; ++k)
            sink.little_endian(
                std::int32_t{split.corner_vertex[static_cast<std::size_t>(3 * f + k)]});
        const Index patch = picture.face_patch[static_cast<std::size_t>(f)];
        sink.little_endian(std::int32_t{patch});
        for (const std::uint8_t channel : colour[static_cast<std::size_t>(patch)])
            sink.little_endian(channel);
    }
    sink.flush();
}

void write_patches_obj(std::ostream& out, const SegmentationPicture& picture) {
    require_mesh(picture, "write_patches_obj");
    const FacesByPatch groups = faces_by_patch(picture);
    Sink sink(out);
    sink.text("# holoflow patches: the cut mesh, one vt per face corner in its patch's chart\n")
        .text("# patches ")
        .num(picture.n_patches())
        .ch('\n');
    for (Eigen::Index v = 0; v < picture.V.rows(); ++v) {
        sink.ch('v');
        for (int k = 0; k < 3; ++k) sink.ch(' ').num(finite_or_zero(picture.V(v, k)));
        sink.ch('\n');
    }
    for (const std::complex<double>& uv : picture.corner_uv)
        sink.text("vt ")
            .num(finite_or_zero(uv.real()))
            .ch(' ')
            .num(finite_or_zero(uv.imag()))
            .ch('\n');
    // Every patch gets its group line, even one without faces, so groups and ids correspond.
    for (Index p = 0; p < picture.n_patches(); ++p) {
        sink.text("g patch_").num(p).ch('\n');
        const auto b = static_cast<std::size_t>(groups.start[static_cast<std::size_t>(p)]);
        const auto e = static_cast<std::size_t>(groups.start[static_cast<std::size_t>(p) + 1]);
        for (std::size_t i = b; i < e; ++i) {
            const Index f = groups.faces[i];
            sink.ch('f');
            for (int k = 0; k < 3; ++k)
                sink.ch(' ').num(picture.F(f, k) + 1).ch('/').num(std::int64_t{3} * f + k + 1);
            sink.ch('\n');
        }
    }
    sink.flush();
}

void write_trajectories_obj(std::ostream& out, const SegmentationPicture& picture) {
    const auto& lines = picture.trajectories;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        const auto family = static_cast<int>(lines[i].family);
        if (family < 0 || family > 2)
            refuse("write_trajectories_obj", "trajectory " + std::to_string(i) +
                                                 " has unknown family " + std::to_string(family));
    }
    // A non-finite point cannot be drawn: the polyline is split there into runs, and only
    // runs of two or more points are written (single points and empty lines draw nothing).
    // Pass 1 writes the vertices of the drawable runs and remembers where each line starts.
    auto for_each_run = [](const Picture::Polyline& line, auto&& fn) {
        const std::size_t n = line.points.size();
        for (std::size_t i = 0; i < n;) {
            while (i < n && !finite_point(line.points[i])) ++i;
            std::size_t j = i;
            while (j < n && finite_point(line.points[j])) ++j;
            if (j - i >= 2) fn(i, j);
            i = j;
        }
    };
    Sink sink(out);
    sink.text("# holoflow trajectories: critical trajectories as polylines (l elements)\n");
    std::vector<std::int64_t> first_vertex(lines.size(), 0);  // 1-based number of its first v
    std::array<bool, 3> family_used{false, false, false};
    std::int64_t n_written = 0;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        first_vertex[i] = n_written + 1;
        for_each_run(lines[i], [&](std::size_t b, std::size_t e) {
            family_used[static_cast<std::size_t>(lines[i].family)] = true;
            for (std::size_t k = b; k < e; ++k) {
                sink.ch('v');
                for (int a = 0; a < 3; ++a) sink.ch(' ').num(lines[i].points[k](a));
                sink.ch('\n');
            }
            n_written += static_cast<std::int64_t>(e - b);
        });
    }
    // Pass 2: groups in the fixed order vertical, horizontal, boundary; empty ones omitted.
    for (const Picture::Family family :
         {Picture::Family::Vertical, Picture::Family::Horizontal, Picture::Family::Boundary}) {
        if (!family_used[static_cast<std::size_t>(family)]) continue;
        sink.text("g ").text(family_name(family)).ch('\n');
        for (std::size_t i = 0; i < lines.size(); ++i) {
            if (lines[i].family != family) continue;
            std::int64_t next = first_vertex[i];
            for_each_run(lines[i], [&](std::size_t b, std::size_t e) {
                sink.ch('l');
                for (std::size_t k = b; k < e; ++k) sink.ch(' ').num(next++);
                sink.ch('\n');
            });
        }
    }
    sink.flush();
}

void write_domains_svg(std::ostream& out, const SegmentationPicture& picture) {
    require_mesh(picture, "write_domains_svg");
    const Index n_patches = picture.n_patches();
    const auto n = static_cast<std::size_t>(n_patches);
    const DomainLayout layout = layout_domains(picture);
    const std::vector<double>&x_px = layout.x, &y_px = layout.y, &w_px = layout.w, &h_px = layout.h;
    const double width = layout.width, height = layout.height;
    auto to_px = [&layout](double chart_length) {
        return chart_length / layout.unit * layout.px_per_scaled;
    };
    auto usable = [&](std::size_t p) { return usable_size(picture.patch_size[p]); };

    Sink sink(out);
    auto coord = [&sink](double v) -> Sink& { return sink.fixed(finite_or_zero(v), 2); };
    sink.text("<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n")
        .text("<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"")
        .num(static_cast<std::int64_t>(width))
        .text("\" height=\"")
        .num(static_cast<std::int64_t>(height))
        .text("\" viewBox=\"0 0 ")
        .num(static_cast<std::int64_t>(width))
        .ch(' ')
        .num(static_cast<std::int64_t>(height))
        .text("\">\n<title>holoflow patch domains</title>\n<desc>")
        .num(n_patches)
        .text(" patch rectangles at one common scale of ");
    sink.num(finite_or_zero(to_px(1.0)))
        .text(" px per chart unit; dashed squares mark patches without a usable size</desc>\n");

    const FacesByPatch groups = faces_by_patch(picture);
    for (std::size_t p = 0; p < n; ++p) {
        const auto rgb = patch_colour(static_cast<Index>(p));
        auto hex = [&sink](const std::array<std::uint8_t, 3>& c) {
            static constexpr char digits[] = "0123456789abcdef";
            sink.ch('#');
            for (const std::uint8_t byte : c) sink.ch(digits[byte >> 4]).ch(digits[byte & 15]);
        };
        const double x0 = x_px[p], y0 = y_px[p], w = w_px[p], h = h_px[p];
        sink.text("<g id=\"patch-").num(p).text("\">\n<title>patch ").num(p);
        if (usable(p)) {
            sink.text(": ").num(picture.patch_size[p][0]).text(" x ").num(picture.patch_size[p][1]);
        } else {
            sink.text(": no usable size");
        }
        sink.text("</title>\n<rect x=\"");
        coord(x0).text("\" y=\"");
        coord(y0).text("\" width=\"");
        coord(w).text("\" height=\"");
        coord(h).text("\" fill=\"");
        hex(rgb);
        if (usable(p)) {
            sink.text("\"/>\n");
        } else {
            sink.text(
                "\" fill-opacity=\"0.4\" stroke=\"#444444\" stroke-width=\"1\" "
                "stroke-dasharray=\"3,2\"/>\n");
        }

        // uv triangles, v flipped (SVG's y points down), clipped to the rectangle. A cylinder's
        // chart wraps in u with period width: a triangle reaching past either side is drawn a
        // second time shifted by one period so the seam shows no gap.
        bool path_open = false;
        auto triangle = [&](const std::array<std::complex<double>, 3>& uv, double shift) {
            if (!path_open) {
                sink.text("<clipPath id=\"clip-").num(p).text("\"><path d=\"M");
                coord(x0).ch(' ');
                coord(y0).text("h");
                coord(w).text("v");
                coord(h).text("h");
                coord(-w)
                    .text("Z\"/></clipPath>\n<path clip-path=\"url(#clip-")
                    .num(p)
                    .text(")\" fill=\"none\" stroke=\"");
                hex({static_cast<std::uint8_t>(rgb[0] * 5 / 10),
                     static_cast<std::uint8_t>(rgb[1] * 5 / 10),
                     static_cast<std::uint8_t>(rgb[2] * 5 / 10)});
                sink.text("\" stroke-width=\"0.4\" stroke-linejoin=\"round\" d=\"");
                path_open = true;
            }
            for (int k = 0; k < 3; ++k) {
                sink.ch(k == 0 ? 'M' : 'L');
                coord(x0 + to_px(uv[static_cast<std::size_t>(k)].real() + shift)).ch(' ');
                coord(y0 + h - to_px(uv[static_cast<std::size_t>(k)].imag()));
            }
            sink.ch('Z');
        };
        if (usable(p)) {
            const double period = picture.patch_size[p][0];
            for (Index i = groups.start[p]; i < groups.start[p + 1]; ++i) {
                const Index f = groups.faces[static_cast<std::size_t>(i)];
                std::array<std::complex<double>, 3> uv;
                bool finite = true;
                for (int k = 0; k < 3; ++k) {
                    uv[static_cast<std::size_t>(k)] =
                        picture.corner_uv[static_cast<std::size_t>(3 * f + k)];
                    finite = finite && std::isfinite(uv[static_cast<std::size_t>(k)].real()) &&
                             std::isfinite(uv[static_cast<std::size_t>(k)].imag());
                }
                if (!finite) continue;  // no chart position: nothing to draw
                // Far outside the chart is garbage, not wrapping: the clip hides it anyway, and
                // bounding the numbers keeps the file free of absurd coordinates.
                bool wild = false;
                for (const auto& z : uv)
                    wild = wild || std::abs(z.real()) > 4 * period ||
                           std::abs(z.imag()) > 4 * picture.patch_size[p][1];
                if (wild) continue;
                triangle(uv, 0);
                const double u_min = std::min({uv[0].real(), uv[1].real(), uv[2].real()});
                const double u_max = std::max({uv[0].real(), uv[1].real(), uv[2].real()});
                // (a relative 1e-9 of slack: rounding at a rectangle's side is not wrapping)
                if (u_max > period * (1 + 1e-9)) triangle(uv, -period);
                if (u_min < -period * 1e-9) triangle(uv, period);
            }
        }
        if (path_open) sink.text("\"/>\n");

        const double font = std::clamp(0.35 * std::min(w, h), 8.0, 28.0);
        sink.text("<text x=\"");
        coord(x0 + w / 2).text("\" y=\"");
        coord(y0 + h / 2 + 0.35 * font).text("\" font-size=\"");
        coord(font).text("\" font-family=\"sans-serif\" text-anchor=\"middle\" fill=\"#1a1a1a\">");
        sink.num(p).text("</text>\n</g>\n");
    }
    sink.text("</svg>\n");
    sink.flush();
}

}  // namespace holoflow::engine
