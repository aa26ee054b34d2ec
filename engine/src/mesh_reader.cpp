#include "holoflow/engine/mesh_reader.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <sstream>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>

// Own parsers instead of OpenMesh's readers: those read OFF into float, report no error kind,
// know no PLY tristrips and cannot be hardened against hostile files. Everything here parses from
// one in-memory buffer by pointer scanning; numbers go through std::from_chars (locale-free).

namespace holoflow::engine {
namespace {

using Kind = MeshErrorKind;

template <class... Parts>
[[noreturn]] void fail(Kind kind, const Parts&... parts) {
    std::ostringstream out;
    (out << ... << parts);
    throw MeshError(kind, out.str());
}

// Horizontal white space; '\n' ends a line and is handled apart so that lines can be counted.
inline bool is_blank(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}
inline bool is_space(char c) { return is_blank(c) || c == '\n'; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
inline bool is_alpha(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }

//! The token at p for an error message: quoted, at most 32 characters, bytes outside ASCII escaped.
std::string show_token(const char* p, const char* end) {
    if (p >= end) return "end of file";
    if (*p == '\n') return "end of line";
    std::string s = "'";
    for (int k = 0; p < end && !is_space(*p) && k < 32; ++p, ++k) {
        const auto u = static_cast<unsigned char>(*p);
        if (u >= 0x20 && u < 0x7f) {
            s += *p;
        } else {
            static const char* hex = "0123456789abcdef";
            s += "\\x";
            s += hex[u >> 4];
            s += hex[u & 15];
        }
    }
    return s + "'";
}

// from_chars reports out_of_range without a value; decide overflow (-> inf) or underflow (-> 0)
// from the decimal exponent of the leading non-zero digit, so that huge values stay non-finite
// for the loader to report and tiny ones become zero as strtod would make them.
double out_of_range_value(const char* b, const char* e) {
    bool negative = false;
    if (b < e && (*b == '-' || *b == '+')) negative = *b++ == '-';
    long long lead = 0;
    bool found = false, point = false;
    for (; b < e; ++b) {
        if (*b == '.') {
            point = true;
            continue;
        }
        if (!is_digit(*b)) break;
        if (!found) {
            if (*b != '0') {
                found = true;
                lead = point ? lead - 1 : 0;
            } else if (point) {
                --lead;
            }
        } else if (!point) {
            ++lead;
        }
    }
    long long exponent = 0;
    if (b < e && (*b == 'e' || *b == 'E')) {
        ++b;
        bool negative_exponent = false;
        if (b < e && (*b == '-' || *b == '+')) negative_exponent = *b++ == '-';
        for (; b < e && is_digit(*b); ++b)
            exponent = std::min(exponent * 10 + (*b - '0'), 1000000LL);
        if (negative_exponent) exponent = -exponent;
    }
    const double magnitude =
        found && lead + exponent > 0 ? std::numeric_limits<double>::infinity() : 0.0;
    return negative ? -magnitude : magnitude;
}

// 3 if the bytes start with the UTF-8 byte order mark, else 0.
std::size_t utf8_bom_size(const char* data, std::size_t size) {
    return size >= 3 && std::memcmp(data, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0;
}

// An optional '+' is not accepted by from_chars; skip it when a number follows.
inline const char* skip_plus(const char* p, const char* end) {
    if (p + 1 < end && *p == '+' &&
        (is_digit(p[1]) || p[1] == '.' || p[1] == 'i' || p[1] == 'I' || p[1] == 'n' || p[1] == 'N'))
        return p + 1;
    return p;
}

//! Parses a double at p (advancing p); false if no number starts there.
inline bool parse_double(const char*& p, const char* end, double& out) {
    const char* start = skip_plus(p, end);
    const auto [ptr, ec] = std::from_chars(start, end, out);
    if (ec == std::errc::invalid_argument) return false;
    if (ec == std::errc::result_out_of_range) out = out_of_range_value(start, ptr);
    p = ptr;
    return true;
}

enum class IntParse { Ok, NotANumber, Overflow };

//! Parses a decimal integer at p (advancing p).
inline IntParse parse_int(const char*& p, const char* end, std::int64_t& out) {
    const char* start = skip_plus(p, end);
    const auto [ptr, ec] = std::from_chars(start, end, out);
    if (ec == std::errc::invalid_argument) return IntParse::NotANumber;
    p = ptr;
    return ec == std::errc::result_out_of_range ? IntParse::Overflow : IntParse::Ok;
}

inline bool equal_nocase(std::string_view a, std::string_view b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
        char x = a[i], y = b[i];
        if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
        if (x != y) return false;
    }
    return true;
}

//! Checked a*b + c on sizes; false on overflow.
inline bool mul_add(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t& out) {
    std::uint64_t product = 0;
    if (__builtin_mul_overflow(a, b, &product)) return false;
    return !__builtin_add_overflow(product, c, &out);
}

// ---------------------------------------------------------------------------------------------
// Line-oriented cursor (OFF, OBJ): '#' starts a comment, lines are counted for messages.

class LineCursor {
  public:
    LineCursor(const char* begin, const char* end, bool continuation)
        : p(begin), end_(end), continuation_(continuation) {}

    const char* p;
    std::size_t line = 1;

    const char* end() const { return end_; }

    //! Skips blanks on the current line (and OBJ's backslash-newline continuations).
    void skip_blanks() {
        for (;;) {
            while (p < end_ && is_blank(*p)) ++p;
            if (!continuation_ || p == end_ || *p != '\\') return;
            const char* q = p + 1;
            if (q < end_ && *q == '\r') ++q;
            if (q < end_ && *q == '\n') {
                p = q + 1;
                ++line;
            } else {
                return;
            }
        }
    }

    //! After skip_blanks: nothing more of interest on this line.
    bool at_line_end() const { return p == end_ || *p == '\n' || *p == '#'; }

    //! True if a token ends at p (a number must be followed by one of these).
    bool at_token_end() const { return p == end_ || is_space(*p) || *p == '#'; }

    //! Moves past the next newline (continued lines count as one).
    void next_line() {
        for (;;) {
            const void* nl = std::memchr(p, '\n', static_cast<std::size_t>(end_ - p));
            if (!nl) {
                p = end_;
                return;
            }
            const char* q = static_cast<const char*>(nl);
            ++line;
            const bool continued = continuation_ && ((q > p && q[-1] == '\\') ||
                                                     (q - 1 > p && q[-1] == '\r' && q[-2] == '\\'));
            p = q + 1;
            if (!continued) return;
        }
    }

    //! Skips blank and comment lines; false at end of file, else p is at a token.
    bool skip_to_content() {
        for (;;) {
            skip_blanks();
            if (p == end_) return false;
            if (*p == '\n') {
                ++p;
                ++line;
            } else if (*p == '#') {
                next_line();
            } else {
                return true;
            }
        }
    }

    //! The token starting at p (up to blank, newline or '#'), p moved past it.
    std::string_view take_word() {
        const char* b = p;
        while (p < end_ && !is_space(*p) && *p != '#') ++p;
        return {b, static_cast<std::size_t>(p - b)};
    }

  private:
    const char* end_;
    bool continuation_;
};

// ---------------------------------------------------------------------------------------------
// OFF

std::int64_t off_count(LineCursor& c, const char* what) {
    std::int64_t value = 0;
    const char* at = c.p;
    const IntParse r = parse_int(c.p, c.end(), value);
    if (r == IntParse::Overflow)
        fail(Kind::HeaderMismatch, "line ", c.line, ": ", what, " count ", show_token(at, c.end()),
             " does not fit in 64 bits");
    if (r != IntParse::Ok || !c.at_token_end())
        fail(Kind::ParseError, "line ", c.line, ": expected the ", what, " count, found ",
             show_token(at, c.end()));
    if (value < 0)
        fail(Kind::HeaderMismatch, "line ", c.line, ": header claims a negative ", what, " count, ", value);
    return value;
}

// `free_layout`: the body is read as one stream of tokens (Geomview's OFF is free-format:
// elements may share or span lines), so nothing may follow an element on its line (colours),
// and after the last face only blanks and comments. Otherwise each vertex and face is one line
// and the rest of it is skipped (colours, normals, texture coordinates).
PolygonSoup parse_off(const char* data, std::size_t size, bool free_layout) {
    LineCursor c(data, data + size, false);
    // Moves to the next token of the element at hand: on its line, or anywhere after in free layout.
    const auto to_next_token = [&] {
        if (free_layout) return c.skip_to_content();
        c.skip_blanks();
        return !c.at_line_end();
    };
    if (!c.skip_to_content()) fail(Kind::EmptyFile, "OFF file holds only comments and blank lines");

    // Header keyword [ST][C][N][4][n]OFF; files without it start directly with the counts.
    const char* at = c.p;
    const std::string_view word = c.take_word();
    if ((!is_digit(*at) && *at != '+') || word.ends_with("OFF")) {
        bool keyword = word.size() >= 3 && word.substr(word.size() - 3) == "OFF";
        std::string_view prefix = keyword ? word.substr(0, word.size() - 3) : std::string_view{};
        bool four = false, ndim = false;
        if (prefix.starts_with("ST")) prefix.remove_prefix(2);
        if (prefix.starts_with("C")) prefix.remove_prefix(1);
        if (prefix.starts_with("N")) prefix.remove_prefix(1);
        if (prefix.starts_with("4")) {
            prefix.remove_prefix(1);
            four = true;
        }
        if (prefix.starts_with("n")) {
            prefix.remove_prefix(1);
            ndim = true;
        }
        if (!keyword || !prefix.empty())
            fail(Kind::ParseError, "line ", c.line,
                 ": expected the OFF header keyword ([ST][C][N][4][n]OFF), found ",
                 show_token(at, c.end()));
        if (four)
            fail(Kind::ParseError, "line ", c.line, ": '", word,
                 "' announces 4D vertices; only 3D OFF is supported");
        if (ndim)
            fail(Kind::ParseError, "line ", c.line, ": '", word,
                 "' announces a vertex dimension line; only 3D OFF is supported");
        c.skip_blanks();
        if (!c.at_line_end()) {
            const char* after = c.p;
            if (c.take_word() == "BINARY")
                fail(Kind::ParseError, "line ", c.line,
                     ": binary OFF ('OFF BINARY') is not supported, only ascii OFF");
            c.p = after;
        }
        if (c.at_line_end() && !c.skip_to_content())
            fail(Kind::Truncated, "file ends after the OFF keyword, before the vertex/face counts");
    } else {
        c.p = at;  // no keyword: the counts come first
    }

    const std::int64_t n_vertices = off_count(c, "vertex");
    c.skip_blanks();
    if (c.at_line_end())
        fail(c.p == c.end() ? Kind::Truncated : Kind::ParseError, "line ", c.line,
             ": counts line has the vertex count only, expected 'vertices faces edges'");
    const std::int64_t n_faces = off_count(c, "face");
    if (!free_layout) {
        c.next_line();  // the edge count and anything after it are not used
    } else {
        c.skip_blanks();
        if (!c.at_line_end()) off_count(c, "edge");  // optional, and only on the counts' line
    }

    // Refuse impossible counts before reserving: each vertex line takes at least "0 0 0\n" and
    // each face line "3 0 1 2\n" (one byte of slack for a missing final newline).
    const auto remaining = static_cast<std::uint64_t>(c.end() - c.p);
    std::uint64_t need = 0, need_faces = 0;
    if (!mul_add(static_cast<std::uint64_t>(n_faces), 8, 0, need_faces) ||
        !mul_add(static_cast<std::uint64_t>(n_vertices), 6, need_faces, need) ||
        need > remaining + 1)
        fail(Kind::HeaderMismatch, "header claims ", n_vertices, " vertices and ", n_faces,
             " faces but only ", remaining, " bytes follow (at least 6 per vertex and 8 per face)");

    PolygonSoup soup;
    soup.positions.resize(3 * static_cast<std::size_t>(n_vertices));
    double* xyz = soup.positions.data();
    for (std::int64_t v = 0; v < n_vertices; ++v) {
        if (!c.skip_to_content())
            fail(Kind::Truncated, "file ends after ", v, " of ", n_vertices, " vertices");
        for (int k = 0; k < 3; ++k) {
            if (!to_next_token()) {
                if (c.p == c.end())
                    fail(Kind::Truncated, "file ends inside vertex ", v, " (line ", c.line,
                         ") after ", k, " of 3 coordinates");
                fail(Kind::ParseError, "line ", c.line, ": vertex ", v, " has ", k,
                     " coordinates, expected 3");
            }
            const char* at = c.p;
            if (!parse_double(c.p, c.end(), *xyz++) || !c.at_token_end())
                fail(Kind::ParseError, "line ", c.line, ": vertex ", v, " coordinate ", k,
                     ": expected a number, found ", show_token(at, c.end()));
        }
        if (!free_layout) c.next_line();  // colours, normals, texture coordinates
    }

    soup.offsets.resize(static_cast<std::size_t>(n_faces) + 1);
    soup.indices.reserve(3 * static_cast<std::size_t>(n_faces));
    for (std::int64_t f = 0; f < n_faces; ++f) {
        if (!c.skip_to_content())
            fail(Kind::Truncated, "file ends after ", f, " of ", n_faces, " faces");
        const char* at = c.p;
        std::int64_t n = 0;
        if (parse_int(c.p, c.end(), n) != IntParse::Ok || !c.at_token_end())
            fail(Kind::ParseError, "line ", c.line, ": face ", f,
                 ": expected the corner count, found ", show_token(at, c.end()));
        if (n < 0)
            fail(Kind::ParseError, "line ", c.line, ": face ", f, " has negative corner count ", n);
        for (std::int64_t k = 0; k < n; ++k) {
            if (!to_next_token()) {
                if (c.p == c.end())
                    fail(Kind::Truncated, "file ends inside face ", f, " (line ", c.line,
                         ") after ", k, " of ", n, " corners");
                fail(Kind::ParseError, "line ", c.line, ": face ", f, " announces ", n,
                     " corners but lists ", k);
            }
            at = c.p;
            std::int64_t index = 0;
            const IntParse r = parse_int(c.p, c.end(), index);
            if (r == IntParse::Overflow)
                fail(Kind::ParseError, "line ", c.line, ": face ", f, ": index ",
                     show_token(at, c.end()), " does not fit in 64 bits");
            if (r != IntParse::Ok || !c.at_token_end())
                fail(Kind::ParseError, "line ", c.line, ": face ", f, " corner ", k,
                     ": expected a vertex index, found ", show_token(at, c.end()));
            soup.indices.push_back(index);
        }
        soup.offsets[static_cast<std::size_t>(f) + 1] = soup.indices.size();
        if (!free_layout) c.next_line();  // face colour
    }
    if (free_layout && c.skip_to_content())
        fail(Kind::ParseError, "line ", c.line, ": ", show_token(c.p, c.end()), " after the last face");
    // Lines past the announced faces are not read, as other OFF readers do (CGAL's prim.off has
    // one face more than its header says), but counted: the report shows what was left out.
    for (; c.skip_to_content(); c.next_line()) ++soup.ignored_lines;
    return soup;
}

// Line by line first (colours and normals after an element are skipped); where that fails, the
// file may be free-format OFF, which is taken if it reads as exactly the announced elements.
PolygonSoup parse_off(const char* data, std::size_t size) {
    try {
        return parse_off(data, size, false);
    } catch (const MeshError&) {
        std::exception_ptr line_error = std::current_exception();
        try {
            return parse_off(data, size, true);
        } catch (const MeshError&) {
            std::rethrow_exception(line_error);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ

PolygonSoup parse_obj(const char* data, std::size_t size) {
    LineCursor c(data, data + size, true);
    PolygonSoup soup;
    while (c.skip_to_content()) {
        const char* at = c.p;
        const std::string_view word = c.take_word();
        if (word == "v") {
            double xyz[3];
            for (int k = 0; k < 3; ++k) {
                c.skip_blanks();
                const char* num = c.p;
                if (c.at_line_end())
                    fail(Kind::ParseError, "line ", c.line, ": vertex ", soup.n_vertices(), " has ",
                         k, " coordinates, expected 3");
                if (!parse_double(c.p, c.end(), xyz[k]) || !c.at_token_end())
                    fail(Kind::ParseError, "line ", c.line, ": vertex ", soup.n_vertices(),
                         " coordinate ", k, ": expected a number, found ",
                         show_token(num, c.end()));
            }
            soup.positions.insert(soup.positions.end(), xyz, xyz + 3);
        } else if (word == "f") {
            const auto n_vertices = static_cast<std::int64_t>(soup.n_vertices());
            const std::size_t first = soup.indices.size();
            for (;;) {
                c.skip_blanks();
                if (c.at_line_end()) break;
                const char* corner = c.p;
                std::int64_t index = 0;
                const IntParse r = parse_int(c.p, c.end(), index);
                if (r == IntParse::Overflow)
                    fail(Kind::ParseError, "line ", c.line, ": index ", show_token(corner, c.end()),
                         " does not fit in 64 bits");
                if (r != IntParse::Ok)
                    fail(Kind::ParseError, "line ", c.line, ": expected a vertex index, found ",
                         show_token(corner, c.end()));
                // a, a/t, a//n, a/t/n: only the vertex part matters.
                if (c.p < c.end() && *c.p == '/') {
                    while (c.p < c.end() &&
                           (*c.p == '/' || *c.p == '-' || *c.p == '+' || is_digit(*c.p)))
                        ++c.p;
                }
                if (!c.at_token_end())
                    fail(Kind::ParseError, "line ", c.line, ": malformed face corner ",
                         show_token(corner, c.end()));
                if (index == 0)
                    fail(Kind::ParseError, "line ", c.line,
                         ": vertex index 0 (OBJ indices start at 1)");
                // Negative indices count back from the last vertex read so far.
                soup.indices.push_back(index > 0 ? index - 1 : n_vertices + index);
            }
            if (soup.indices.size() == first)
                fail(Kind::ParseError, "line ", c.line, ": face without vertex indices");
            soup.offsets.push_back(soup.indices.size());
        } else if (!word.empty() && is_alpha(word[0])) {
            // vt vn vp o g s usemtl mtllib l p and the free-form geometry statements
        } else {
            fail(Kind::ParseError, "line ", c.line, ": unknown statement ",
                 show_token(at, c.end()));
        }
        c.next_line();
    }
    if (soup.n_vertices() == 0 && soup.n_polygons() == 0)
        fail(Kind::EmptyFile, "OBJ file has no vertices and no faces");
    return soup;
}

// ---------------------------------------------------------------------------------------------
// PLY

enum class PType : std::uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };

constexpr std::size_t type_size(PType t) {
    switch (t) {
        case PType::I8:
        case PType::U8: return 1;
        case PType::I16:
        case PType::U16: return 2;
        case PType::I32:
        case PType::U32:
        case PType::F32: return 4;
        case PType::F64: return 8;
    }
    return 0;
}
constexpr bool is_float(PType t) { return t == PType::F32 || t == PType::F64; }

bool type_from_name(std::string_view s, PType& t) {
    static constexpr std::pair<std::string_view, PType> names[] = {
        {"char", PType::I8},    {"int8", PType::I8},     {"uchar", PType::U8},
        {"uint8", PType::U8},   {"short", PType::I16},   {"int16", PType::I16},
        {"ushort", PType::U16}, {"uint16", PType::U16},  {"int", PType::I32},
        {"int32", PType::I32},  {"uint", PType::U32},    {"uint32", PType::U32},
        {"float", PType::F32},  {"float32", PType::F32}, {"double", PType::F64},
        {"float64", PType::F64}};
    for (const auto& [name, type] : names)
        if (s == name) {
            t = type;
            return true;
        }
    return false;
}

struct PlyProperty {
    std::string name;
    bool list = false;
    PType count_type = PType::U8;  // lists only
    PType type = PType::F32;       // scalar type, or item type of a list
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::size_t header_line = 0;
    std::vector<PlyProperty> properties;
};

enum class PlyEncoding { Ascii, BinaryLittle, BinaryBig };

struct PlyHeader {
    PlyEncoding encoding = PlyEncoding::Ascii;
    std::vector<PlyElement> elements;
    std::size_t data_offset = 0;
    std::size_t data_line = 0;  // line where ascii data starts
};

PlyHeader parse_ply_header(const char* data, std::size_t size) {
    PlyHeader h;
    bool have_format = false;
    std::size_t pos = 0, line = 0;
    std::vector<std::string_view> words;
    for (;;) {
        if (pos >= size)
            fail(Kind::Truncated, "PLY header ends at line ", line, " without end_header");
        ++line;
        const void* nl = std::memchr(data + pos, '\n', size - pos);
        const std::size_t line_end =
            nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - data) : size;
        std::string_view text(data + pos, line_end - pos);
        pos = nl ? line_end + 1 : size;
        words.clear();
        for (std::size_t i = 0; i < text.size();) {
            while (i < text.size() && is_blank(text[i])) ++i;
            const std::size_t b = i;
            while (i < text.size() && !is_blank(text[i])) ++i;
            if (i > b) words.push_back(text.substr(b, i - b));
        }
        if (line == 1) {
            if (words.size() != 1 || words[0] != "ply")
                fail(Kind::ParseError, "line 1: a PLY file starts with 'ply', found ",
                     show_token(text.data(), text.data() + text.size()));
            continue;
        }
        if (words.empty()) continue;
        const std::string_view key = words[0];
        if (key == "comment" || key == "obj_info") continue;
        if (key == "end_header") {
            if (!have_format) fail(Kind::ParseError, "PLY header has no format line");
            h.data_offset = pos;
            h.data_line = line + 1;
            return h;
        }
        if (key == "format") {
            if (words.size() < 2)
                fail(Kind::ParseError, "line ", line, ": format line without a format");
            if (words[1] == "ascii") {
                h.encoding = PlyEncoding::Ascii;
            } else if (words[1] == "binary_little_endian") {
                h.encoding = PlyEncoding::BinaryLittle;
            } else if (words[1] == "binary_big_endian") {
                h.encoding = PlyEncoding::BinaryBig;
            } else {
                fail(Kind::ParseError, "line ", line, ": unknown PLY format '", words[1],
                     "' (expected ascii, binary_little_endian or binary_big_endian)");
            }
            have_format = true;
        } else if (key == "element") {
            if (words.size() != 3)
                fail(Kind::ParseError, "line ", line, ": expected 'element NAME COUNT'");
            PlyElement e;
            e.name = std::string(words[1]);
            e.header_line = line;
            const std::string_view count = words[2];
            if (count.starts_with('-'))
                fail(Kind::HeaderMismatch, "line ", line, ": element ", e.name,
                     " claims a negative count ", count);
            const auto [ptr, ec] =
                std::from_chars(count.data(), count.data() + count.size(), e.count);
            if (ec == std::errc::result_out_of_range)
                fail(Kind::HeaderMismatch, "line ", line, ": element ", e.name, " count ", count,
                     " does not fit in 64 bits");
            if (ec != std::errc() || ptr != count.data() + count.size())
                fail(Kind::ParseError, "line ", line, ": element ", e.name,
                     ": expected a count, found '", count, "'");
            h.elements.push_back(std::move(e));
        } else if (key == "property") {
            if (h.elements.empty())
                fail(Kind::ParseError, "line ", line, ": property before any element");
            PlyProperty p;
            if (words.size() >= 2 && words[1] == "list") {
                if (words.size() != 5)
                    fail(Kind::ParseError, "line ", line,
                         ": expected 'property list COUNTTYPE ITEMTYPE NAME'");
                if (!type_from_name(words[2], p.count_type))
                    fail(Kind::ParseError, "line ", line, ": unsupported property type '", words[2],
                         "'");
                if (is_float(p.count_type))
                    fail(Kind::ParseError, "line ", line, ": list count type '", words[2],
                         "' is not an integer type");
                if (!type_from_name(words[3], p.type))
                    fail(Kind::ParseError, "line ", line, ": unsupported property type '", words[3],
                         "'");
                p.list = true;
                p.name = std::string(words[4]);
            } else {
                if (words.size() != 3)
                    fail(Kind::ParseError, "line ", line, ": expected 'property TYPE NAME'");
                if (!type_from_name(words[1], p.type))
                    fail(Kind::ParseError, "line ", line, ": unsupported property type '", words[1],
                         "'");
                p.name = std::string(words[2]);
            }
            h.elements.back().properties.push_back(std::move(p));
        } else if (!h.elements.empty()) {
            fail(Kind::ParseError, "line ", line, ": unknown PLY header keyword '", key, "'");
        }
        // Before the first element no line can change how the data reads: an unknown one is a
        // comment written without its keyword (Blender 2.4's "Created by ..." line).
    }
}

enum class Role { Other, Vertex, Face, Strips };

// Which properties of an element the reader uses: x, y, z or the index list.
struct ElementPlan {
    Role role = Role::Other;
    int x = -1, y = -1, z = -1;
    int list = -1;
};

ElementPlan plan_element(const PlyElement& e) {
    ElementPlan plan;
    auto find = [&e](std::string_view name) {
        int found = -1;
        for (std::size_t i = 0; i < e.properties.size(); ++i) {
            if (e.properties[i].name != name) continue;
            if (found >= 0)  // which of the two holds the data is anyone's guess
                fail(Kind::ParseError, "line ", e.header_line, ": element ", e.name, " declares property ",
                     name, " twice");
            found = static_cast<int>(i);
        }
        return found;
    };
    if (e.name == "vertex") {
        plan.role = Role::Vertex;
        plan.x = find("x"), plan.y = find("y"), plan.z = find("z");
        if (e.count > 0) {
            const char* axis[3] = {"x", "y", "z"};
            const int which[3] = {plan.x, plan.y, plan.z};
            for (int k = 0; k < 3; ++k) {
                if (which[k] < 0)
                    fail(Kind::ParseError, "line ", e.header_line,
                         ": element vertex has no property ", axis[k]);
                if (e.properties[static_cast<std::size_t>(which[k])].list)
                    fail(Kind::ParseError, "line ", e.header_line, ": vertex property ", axis[k],
                         " is a list, expected a scalar");
            }
        }
    } else if (e.name == "face" || e.name == "tristrips") {
        plan.role = e.name == "face" ? Role::Face : Role::Strips;
        plan.list = find("vertex_indices");
        if (plan.list < 0 && plan.role == Role::Face) plan.list = find("vertex_index");
        if (e.count > 0) {
            if (plan.list < 0)
                fail(Kind::ParseError, "line ", e.header_line, ": element ", e.name,
                     " has no list property vertex_indices");
            if (!e.properties[static_cast<std::size_t>(plan.list)].list)
                fail(Kind::ParseError, "line ", e.header_line, ": property vertex_indices of ",
                     e.name, " is not a list");
        }
    }
    return plan;
}

//! Triangles of one strip (no -1 inside): alternate winding, degenerate joins skipped.
void decode_strip(const std::int64_t* s, std::size_t n, PolygonSoup& soup) {
    for (std::size_t i = 0; i + 2 < n; ++i) {
        const std::int64_t a = (i % 2 == 0) ? s[i] : s[i + 1];
        const std::int64_t b = (i % 2 == 0) ? s[i + 1] : s[i];
        const std::int64_t c = s[i + 2];
        if (a == b || b == c || a == c) continue;
        soup.indices.push_back(a);
        soup.indices.push_back(b);
        soup.indices.push_back(c);
        soup.offsets.push_back(soup.indices.size());
    }
}

//! Splits a tristrips list at -1 restarts and decodes each strip.
void decode_strips(const std::vector<std::int64_t>& list, PolygonSoup& soup) {
    std::size_t begin = 0;
    for (std::size_t i = 0; i <= list.size(); ++i) {
        if (i == list.size() || list[i] == -1) {
            decode_strip(list.data() + begin, i - begin, soup);
            begin = i + 1;
        }
    }
}

// Index values stored as floats are accepted when they are whole numbers.
template <class Where>
std::int64_t float_to_index(double v, const Where& where) {
    if (!(v == std::floor(v) && std::abs(v) < 9.2e18))
        fail(Kind::ParseError, where(), ": index ", v, " is not an integer");
    return static_cast<std::int64_t>(v);
}

// Binary PLY source: every read is bounds-checked against the end of the buffer.
template <bool Swap>
class BinarySource {
  public:
    BinarySource(const char* p, const char* end) : p_(p), end_(end) {}

    const char* element = "";
    std::uint64_t record = 0;

    std::string where() const {
        std::ostringstream s;
        s << "element " << element << " record " << record;
        return s.str();
    }

    void need(std::uint64_t bytes) {
        if (bytes > static_cast<std::uint64_t>(end_ - p_))
            fail(Kind::Truncated, where(), " needs ", bytes, " bytes but only ", end_ - p_,
                 " are left in the file");
    }

    double get_double(PType t) {
        need(type_size(t));
        return load_double(t);
    }

    std::int64_t get_int(PType t) {
        need(type_size(t));
        if (is_float(t)) return float_to_index(load_double(t), [this] { return where(); });
        return load_int(t);
    }

    //! A list length: non-negative and its items must fit in the rest of the file.
    std::uint64_t get_count(const PlyProperty& prop) {
        const std::int64_t n = get_int(prop.count_type);
        if (n < 0)
            fail(Kind::HeaderMismatch, where(), ": list ", prop.name, " has negative length ", n);
        const auto items = static_cast<std::uint64_t>(n);
        if (items > static_cast<std::uint64_t>(end_ - p_) / type_size(prop.type))
            fail(Kind::Truncated, where(), ": list ", prop.name, " of ", items, " items needs ",
                 items * type_size(prop.type), " bytes but only ", end_ - p_, " are left");
        return items;
    }

    void skip(PType t) {
        need(type_size(t));
        p_ += type_size(t);
    }
    void skip_items(PType t, std::uint64_t n) { p_ += n * type_size(t); }  // checked by get_count
    void skip_bytes(std::uint64_t n) {
        need(n);
        p_ += n;
    }

  private:
    template <class T>
    T load() {
        T v;
        std::memcpy(&v, p_, sizeof(T));
        p_ += sizeof(T);
        if constexpr (Swap && sizeof(T) == 2) {
            v = std::bit_cast<T>(__builtin_bswap16(std::bit_cast<std::uint16_t>(v)));
        } else if constexpr (Swap && sizeof(T) == 4) {
            v = std::bit_cast<T>(__builtin_bswap32(std::bit_cast<std::uint32_t>(v)));
        } else if constexpr (Swap && sizeof(T) == 8) {
            v = std::bit_cast<T>(__builtin_bswap64(std::bit_cast<std::uint64_t>(v)));
        }
        return v;
    }
    double load_double(PType t) {
        switch (t) {
            case PType::F32: return load<float>();
            case PType::F64: return load<double>();
            default: return static_cast<double>(load_int(t));
        }
    }
    std::int64_t load_int(PType t) {
        switch (t) {
            case PType::I8: return load<std::int8_t>();
            case PType::U8: return load<std::uint8_t>();
            case PType::I16: return load<std::int16_t>();
            case PType::U16: return load<std::uint16_t>();
            case PType::I32: return load<std::int32_t>();
            case PType::U32: return load<std::uint32_t>();
            case PType::F32: return static_cast<std::int64_t>(load<float>());
            case PType::F64: return static_cast<std::int64_t>(load<double>());
        }
        return 0;
    }

    const char* p_;
    const char* end_;
};

// Ascii PLY source: whitespace-separated tokens, lines counted for messages.
class AsciiSource {
  public:
    AsciiSource(const char* p, const char* end, std::size_t line) : p_(p), end_(end), line_(line) {}

    const char* element = "";
    std::uint64_t record = 0;

    std::string where() const {
        std::ostringstream s;
        s << "line " << line_ << ": element " << element << " record " << record;
        return s.str();
    }

    double get_double(PType t) {
        start_token();
        const char* at = p_;
        double v = 0;
        if (!is_float(t)) return static_cast<double>(get_integer(at));
        if (!parse_double(p_, end_, v) || !at_token_end())
            fail(Kind::ParseError, where(), ": expected a number, found ", show_token(at, end_));
        return v;
    }

    std::int64_t get_int(PType t) {
        start_token();
        const char* at = p_;
        if (is_float(t)) {
            double v = 0;
            if (!parse_double(p_, end_, v) || !at_token_end())
                fail(Kind::ParseError, where(), ": expected a number, found ",
                     show_token(at, end_));
            return float_to_index(v, [this] { return where(); });
        }
        return get_integer(at);
    }

    std::uint64_t get_count(const PlyProperty& prop) {
        const std::int64_t n = get_int(prop.count_type);
        if (n < 0)
            fail(Kind::HeaderMismatch, where(), ": list ", prop.name, " has negative length ", n);
        return static_cast<std::uint64_t>(n);
    }

    void skip(PType) {
        start_token();
        while (p_ < end_ && !is_space(*p_)) ++p_;
    }
    void skip_items(PType t, std::uint64_t n) {
        for (std::uint64_t i = 0; i < n; ++i) skip(t);
    }

  private:
    void start_token() {
        for (; p_ < end_ && is_space(*p_); ++p_)
            if (*p_ == '\n') ++line_;
        if (p_ == end_) fail(Kind::Truncated, "file ends in ", where());
    }
    bool at_token_end() const { return p_ == end_ || is_space(*p_); }
    std::int64_t get_integer(const char* at) {
        std::int64_t v = 0;
        const IntParse r = parse_int(p_, end_, v);
        if (r == IntParse::Overflow)
            fail(Kind::ParseError, where(), ": integer ", show_token(at, end_),
                 " does not fit in 64 bits");
        if (r != IntParse::Ok || !at_token_end())
            fail(Kind::ParseError, where(), ": expected an integer, found ", show_token(at, end_));
        return v;
    }

    const char* p_;
    const char* end_;
    std::size_t line_;
};

template <class Source>
void read_ply_elements(Source& src, const PlyHeader& h, std::uint64_t bytes_left,
                       PolygonSoup& soup) {
    constexpr bool binary = !std::is_same_v<Source, AsciiSource>;
    std::vector<std::int64_t> strip;
    for (const PlyElement& e : h.elements) {
        const ElementPlan plan = plan_element(e);  // checks x, y, z and the index list
        if (e.properties.empty() || e.count == 0) continue;
        src.element = e.name.c_str();
        if constexpr (binary) {
            // Elements the reader does not use and whose records have a fixed size: one jump.
            if (plan.role == Role::Other &&
                std::none_of(e.properties.begin(), e.properties.end(),
                             [](const PlyProperty& p) { return p.list; })) {
                std::uint64_t record_size = 0;
                for (const PlyProperty& p : e.properties) record_size += type_size(p.type);
                src.record = 0;
                src.skip_bytes(e.count * record_size);  // no overflow: checked against the size
                continue;
            }
        }
        // Reservations are bounded by the header check against the file size.
        if (plan.role == Role::Vertex) soup.positions.reserve(soup.positions.size() + 3 * e.count);
        if (plan.role == Role::Face) {
            soup.offsets.reserve(soup.offsets.size() + e.count);
            soup.indices.reserve(soup.indices.size() +
                                 std::min<std::uint64_t>(3 * e.count, bytes_left));
        }
        for (std::uint64_t r = 0; r < e.count; ++r) {
            src.record = r;
            double xyz[3] = {0, 0, 0};
            for (std::size_t j = 0; j < e.properties.size(); ++j) {
                const PlyProperty& prop = e.properties[j];
                const int i = static_cast<int>(j);
                if (prop.list) {
                    const std::uint64_t n = src.get_count(prop);
                    if (i != plan.list) {
                        src.skip_items(prop.type, n);
                    } else if (plan.role == Role::Face) {
                        for (std::uint64_t k = 0; k < n; ++k)
                            soup.indices.push_back(src.get_int(prop.type));
                        soup.offsets.push_back(soup.indices.size());
                    } else {
                        strip.clear();
                        for (std::uint64_t k = 0; k < n; ++k)
                            strip.push_back(src.get_int(prop.type));
                        decode_strips(strip, soup);
                    }
                } else if (plan.role == Role::Vertex &&
                           (i == plan.x || i == plan.y || i == plan.z)) {
                    xyz[i == plan.x ? 0 : i == plan.y ? 1 : 2] = src.get_double(prop.type);
                } else {
                    src.skip(prop.type);
                }
            }
            if (plan.role == Role::Vertex)
                soup.positions.insert(soup.positions.end(), xyz, xyz + 3);
        }
    }
}

PolygonSoup parse_ply(const char* data, std::size_t size) {
    const PlyHeader h = parse_ply_header(data, size);
    const std::uint64_t bytes_left = size - h.data_offset;

    // Before allocating anything: the smallest possible record of every element must fit in the
    // bytes after the header (binary: scalar sizes plus list count fields; ascii: one character
    // and one separator per value, plus one byte of slack for a missing final newline).
    std::uint64_t need = 0;
    std::ostringstream claims;
    for (const PlyElement& e : h.elements) {
        std::uint64_t record = 0;
        for (const PlyProperty& p : e.properties)
            record +=
                h.encoding == PlyEncoding::Ascii ? 2 : type_size(p.list ? p.count_type : p.type);
        claims << (claims.tellp() > 0 ? ", " : "") << e.name << ": " << e.count << " x " << record;
        if (!mul_add(e.count, record, need, need)) need = std::numeric_limits<std::uint64_t>::max();
    }
    const std::uint64_t slack = h.encoding == PlyEncoding::Ascii ? 1 : 0;
    if (need > bytes_left + slack)
        fail(Kind::HeaderMismatch, "PLY header announces elements needing at least ",
             need == std::numeric_limits<std::uint64_t>::max() ? std::string("2^64")
                                                               : std::to_string(need),
             " bytes (", claims.str(), ") but only ", bytes_left, " bytes follow the header");

    PolygonSoup soup;
    const char* begin = data + h.data_offset;
    const char* end = data + size;
    if (h.encoding == PlyEncoding::Ascii) {
        AsciiSource src(begin, end, h.data_line);
        read_ply_elements(src, h, bytes_left, soup);
    } else if ((h.encoding == PlyEncoding::BinaryBig) ==
               (std::endian::native == std::endian::big)) {
        BinarySource<false> src(begin, end);
        read_ply_elements(src, h, bytes_left, soup);
    } else {
        BinarySource<true> src(begin, end);
        read_ply_elements(src, h, bytes_left, soup);
    }
    return soup;
}

// ---------------------------------------------------------------------------------------------
// STL

//! Merges corners (9 coordinates per triangle) at bit-identical positions into shared vertices,
//! in order of first appearance, with an open-addressing hash table sized once.
void weld_corners(const std::vector<double>& corners, PolygonSoup& soup) {
    const std::size_t n_corners = corners.size() / 3;
    std::size_t capacity = 16;
    while (capacity < 2 * n_corners) capacity *= 2;
    const std::size_t mask = capacity - 1;
    std::vector<std::uint64_t> table(capacity, 0);  // vertex + 1, 0 = empty
    soup.positions.reserve(corners.size());
    soup.indices.reserve(n_corners);
    soup.offsets.reserve(n_corners / 3 + 1);
    for (std::size_t k = 0; k < n_corners; ++k) {
        double p[3];
        std::uint64_t bits[3];
        for (int d = 0; d < 3; ++d) {
            const double v = corners[3 * k + static_cast<std::size_t>(d)];
            p[d] = v == 0.0 ? 0.0 : v;  // -0.0 and 0.0 are one position
            bits[d] = std::bit_cast<std::uint64_t>(p[d]);
        }
        std::uint64_t hash = bits[0] * 0x9e3779b97f4a7c15ULL ^ bits[1] * 0xc2b2ae3d27d4eb4fULL ^
                             bits[2] * 0x165667b19e3779f9ULL;
        hash ^= hash >> 31;
        hash *= 0xbf58476d1ce4e5b9ULL;
        hash ^= hash >> 29;
        std::size_t slot = static_cast<std::size_t>(hash) & mask;
        std::uint64_t vertex = 0;
        for (;; slot = (slot + 1) & mask) {
            if (table[slot] == 0) {
                vertex = soup.n_vertices();
                table[slot] = vertex + 1;
                soup.positions.insert(soup.positions.end(), p, p + 3);
                break;
            }
            const double* q = soup.positions.data() + 3 * (table[slot] - 1);
            if (std::memcmp(q, p, sizeof p) == 0) {
                vertex = table[slot] - 1;
                break;
            }
        }
        soup.indices.push_back(static_cast<std::int64_t>(vertex));
        if (k % 3 == 2) soup.offsets.push_back(soup.indices.size());
    }
    soup.welded_vertices = n_corners - soup.n_vertices();
}

//! Whether `text` holds `word` (any case) as a whole whitespace-separated token.
bool contains_word_nocase(std::string_view text, std::string_view word) {
    std::size_t i = 0;
    while (i < text.size()) {
        while (i < text.size() && is_space(text[i])) ++i;
        const std::size_t b = i;
        while (i < text.size() && !is_space(text[i])) ++i;
        if (equal_nocase(text.substr(b, i - b), word)) return true;
    }
    return false;
}

std::vector<double> parse_stl_ascii(const char* data, std::size_t size) {
    const char* p = data;
    const char* end = data + size;
    std::size_t line = 1;
    auto next = [&]() -> std::string_view {
        for (; p < end && is_space(*p); ++p)
            if (*p == '\n') ++line;
        const char* b = p;
        while (p < end && !is_space(*p)) ++p;
        return {b, static_cast<std::size_t>(p - b)};
    };
    // A solid's name is free text to the end of its line, but files written all on one line
    // go on with the facets there: the name stops before a keyword that starts the next item.
    auto skip_name = [&](std::initializer_list<std::string_view> next_items) {
        for (;;) {
            while (p < end && *p != '\n' && is_space(*p)) ++p;
            if (p == end || *p == '\n') return;
            const char* b = p;
            while (p < end && !is_space(*p)) ++p;
            const std::string_view word(b, static_cast<std::size_t>(p - b));
            for (const std::string_view item : next_items)
                if (equal_nocase(word, item)) {
                    p = b;
                    return;
                }
        }
    };
    auto number = [&](std::size_t facet) {
        for (; p < end && is_space(*p); ++p)
            if (*p == '\n') ++line;
        if (p == end) fail(Kind::Truncated, "file ends inside facet ", facet);
        const char* at = p;
        double v = 0;
        if (!parse_double(p, end, v) || (p < end && !is_space(*p)))
            fail(Kind::ParseError, "line ", line, ": facet ", facet, ": expected a number, found ",
                 show_token(at, end));
        return v;
    };
    auto expect = [&](std::string_view word, std::size_t facet) {
        const std::size_t at_line = line;
        const char* at = p;
        const std::string_view got = next();
        if (got.empty())
            fail(Kind::Truncated, "file ends inside facet ", facet, ", expected '", word, "'");
        if (!equal_nocase(got, word)) {
            for (; at < end && is_space(*at); ++at) {
            }
            fail(Kind::ParseError, "line ", std::max(at_line, line), ": facet ", facet,
                 ": expected '", word, "', found ", show_token(at, end));
        }
    };

    std::vector<double> corners;
    std::size_t facet = 0;
    if (!equal_nocase(next(), "solid"))
        fail(Kind::ParseError, "line 1: ascii STL starts with 'solid'");
    skip_name({"facet", "endsolid"});
    for (;;) {
        const char* at = p;
        const std::string_view word = next();
        if (word.empty()) break;  // a missing final endsolid is tolerated
        if (equal_nocase(word, "solid")) {
            skip_name({"facet", "endsolid"});
            continue;
        }
        if (equal_nocase(word, "endsolid")) {
            skip_name({"solid"});
            // Some exporters pad the file with NUL bytes after the last solid.
            const char* q = p;
            while (q < end && (*q == '\0' || is_space(*q))) ++q;
            if (q == end) break;
            continue;
        }
        if (!equal_nocase(word, "facet")) {
            for (; at < end && is_space(*at); ++at) {
            }
            fail(Kind::ParseError, "line ", line, ": expected 'facet' or 'endsolid', found ",
                 show_token(at, end));
        }
        const char* before = p;
        const std::size_t before_line = line;
        if (equal_nocase(next(), "normal")) {
            for (int k = 0; k < 3; ++k) number(facet);
        } else {
            p = before, line = before_line;
        }
        expect("outer", facet);
        expect("loop", facet);
        int n = 0;
        for (;;) {
            const char* w = p;
            const std::string_view v = next();
            if (v.empty()) fail(Kind::Truncated, "file ends inside facet ", facet);
            if (equal_nocase(v, "endloop")) break;
            if (!equal_nocase(v, "vertex")) {
                for (; w < end && is_space(*w); ++w) {
                }
                fail(Kind::ParseError, "line ", line, ": facet ", facet,
                     ": expected 'vertex' or 'endloop', found ", show_token(w, end));
            }
            double xyz[3];
            for (int k = 0; k < 3; ++k) xyz[k] = number(facet);
            if (n < 3) corners.insert(corners.end(), xyz, xyz + 3);
            ++n;
        }
        if (n != 3)
            fail(Kind::ParseError, "line ", line, ": facet ", facet, " has ", n,
                 " vertices, expected 3");
        expect("endfacet", facet);
        ++facet;
    }
    return corners;
}

PolygonSoup parse_stl(const char* data, std::size_t size) {
    std::uint64_t count = 0;
    if (size >= 84) {
        std::uint32_t c32 = 0;
        std::memcpy(&c32, data + 80, 4);
        if constexpr (std::endian::native == std::endian::big) c32 = __builtin_bswap32(c32);
        count = c32;
    }
    const std::uint64_t expected = 84 + 50 * count;
    std::vector<double> corners;
    if (size < 84 || expected != size) {
        // Not binary by size. A binary header may also start with "solid", but binary STL
        // almost always holds NUL bytes (zero attribute words) early on: the file is ascii if
        // it starts with "solid" and its first NUL, if any, comes after a facet or endsolid.
        const std::size_t bom = utf8_bom_size(data, size);
        const char* p = data + bom;
        while (p < data + size && is_space(*p)) ++p;
        const bool solid = data + size - p >= 5 && equal_nocase(std::string_view(p, 5), "solid");
        const char* nul = static_cast<const char*>(std::memchr(data, 0, size));
        const std::string_view before_nul(p, static_cast<std::size_t>((nul ? nul : data + size) - p));
        const bool ascii = solid && (!nul || contains_word_nocase(before_nul, "facet") ||
                                     contains_word_nocase(before_nul, "endsolid"));
        if (ascii) {
            corners = parse_stl_ascii(data + bom, size - bom);
        } else if (size < 84) {
            fail(Kind::Truncated, "binary STL needs an 84-byte header, file has ", size, " bytes");
        } else if (expected > size) {
            fail(Kind::Truncated, "binary STL header claims ", count, " triangles (", expected,
                 " bytes) but the file has ", size, " bytes");
        } else {
            fail(Kind::HeaderMismatch, "binary STL header claims ", count, " triangles (", expected,
                 " bytes) but the file has ", size, " bytes");
        }
    } else {
        corners.resize(9 * count);
        for (std::uint64_t t = 0; t < count; ++t) {
            const char* rec = data + 84 + 50 * t + 12;  // skip the facet normal
            for (int k = 0; k < 9; ++k) {
                std::uint32_t bits = 0;
                std::memcpy(&bits, rec + 4 * k, 4);
                if constexpr (std::endian::native == std::endian::big)
                    bits = __builtin_bswap32(bits);
                corners[9 * t + static_cast<std::uint64_t>(k)] = std::bit_cast<float>(bits);
            }
        }
    }
    PolygonSoup soup;
    weld_corners(corners, soup);
    return soup;
}

}  // namespace

namespace {

// The file name's last dot and what follows, lower case ("" without a dot); unlike
// path::extension(), a name that starts with its only dot (".off") has one.
std::string name_suffix(const std::filesystem::path& path) {
    const std::string name = path.filename().string();
    const std::size_t dot = name.rfind('.');
    std::string ext = dot == std::string::npos ? std::string() : name.substr(dot);
    for (char& ch : ext)
        if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
    return ext;
}

}  // namespace

std::optional<MeshFormat> mesh_format_of_name(const std::filesystem::path& path) {
    const std::string ext = name_suffix(path);
    if (ext == ".off") return MeshFormat::Off;
    if (ext == ".obj") return MeshFormat::Obj;
    if (ext == ".ply") return MeshFormat::Ply;
    if (ext == ".stl") return MeshFormat::Stl;
    return std::nullopt;
}

MeshFormat format_from_path(const std::string& path) {
    if (const std::optional<MeshFormat> format = mesh_format_of_name(path)) return *format;
    fail(Kind::UnknownFormat, "'", path, "': extension '", name_suffix(path),
         "' is not one of .off .obj .ply .stl");
}

PolygonSoup parse_polygon_soup(const char* data, std::size_t size, MeshFormat format) {
    if (size == 0) fail(Kind::EmptyFile, "0 bytes");
    // Text written by Windows tools may start with a UTF-8 byte order mark (binary STL's header
    // is any 80 bytes: parse_stl skips one only before an ascii "solid").
    const std::size_t bom = format == MeshFormat::Stl ? 0 : utf8_bom_size(data, size);
    // UTF-16 text (a byte order mark, then every other byte NUL) would fail on its first line.
    if (format != MeshFormat::Stl && size >= 2 &&
        (std::memcmp(data, "\xFE\xFF", 2) == 0 || std::memcmp(data, "\xFF\xFE", 2) == 0))
        fail(Kind::ParseError, "the file is UTF-16 text (it starts with a UTF-16 byte order mark); save it as UTF-8 or ASCII");
    // Classic Mac OS text ends its lines with '\r' alone: OFF and OBJ are read line by line.
    std::string lines;
    if ((format == MeshFormat::Off || format == MeshFormat::Obj) && !std::memchr(data, '\n', size) &&
        std::memchr(data, '\r', size)) {
        lines.assign(data, size);
        std::replace(lines.begin(), lines.end(), '\r', '\n');
        data = lines.data();
    }
    PolygonSoup soup;
    switch (format) {
        case MeshFormat::Off: soup = parse_off(data + bom, size - bom); break;
        case MeshFormat::Obj: soup = parse_obj(data + bom, size - bom); break;
        case MeshFormat::Ply: soup = parse_ply(data + bom, size - bom); break;
        case MeshFormat::Stl: soup = parse_stl(data, size); break;
    }
    if (soup.n_vertices() == 0 && soup.n_polygons() == 0)
        fail(Kind::EmptyFile, "no vertices and no faces");
    return soup;
}

PolygonSoup read_polygon_soup(const std::string& path, std::uint64_t max_bytes) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (status.type() == fs::file_type::not_found)
        fail(Kind::FileNotFound, "'", path, "' does not exist");
    if (ec) fail(Kind::Unreadable, "'", path, "': ", ec.message());
    if (status.type() == fs::file_type::directory)
        fail(Kind::Unreadable, "'", path, "' is a directory, not a file");
    // A FIFO would block the read until a writer comes, and a device such as /dev/zero never ends.
    if (status.type() != fs::file_type::regular)
        fail(Kind::Unreadable, "'", path, "' is not a regular file (a FIFO, socket or device)");
    const MeshFormat format = format_from_path(path);
    const std::uintmax_t hint = fs::file_size(path, ec);
    if (!ec && max_bytes > 0 && hint > max_bytes)
        fail(Kind::TooLarge, "'", path, "' is ", hint >> 20, " MiB, more than the memory limit (", max_bytes >> 20,
             " MiB)");

    std::FILE* file = std::fopen(path.c_str(), "rb");
    if (!file) fail(Kind::Unreadable, "cannot open '", path, "': ", std::strerror(errno));
    std::string bytes;
    if (!ec && hint > 0) bytes.reserve(static_cast<std::size_t>(hint));
    char chunk[1 << 16];
    for (;;) {
        const std::size_t got = std::fread(chunk, 1, sizeof chunk, file);
        bytes.append(chunk, got);
        if (got < sizeof chunk) break;
    }
    const bool read_error = std::ferror(file) != 0;
    std::fclose(file);
    if (read_error) fail(Kind::Unreadable, "I/O error while reading '", path, "'");
    if (bytes.empty()) fail(Kind::EmptyFile, "'", path, "' has 0 bytes");
    try {
        return parse_polygon_soup(bytes.data(), bytes.size(), format);
    } catch (const MeshError& e) {
        throw MeshError(e.kind, "'" + path + "': " + e.detail);
    }
}

}  // namespace holoflow::engine
