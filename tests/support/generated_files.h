#pragma once

// Mesh files made in code for tests and benchmarks (no macros: benchmarks include it too).

#include <cmath>
#include <cstdio>
#include <string>

namespace holoflow::test {

//! OFF text with `polygons` copies of one polygon of `corners` vertices on the unit circle; with
//! `doubled` the circle is walked twice with distinct vertex numbers (a polygon with no ear).
inline std::string polygon_stack_off(int corners, int polygons, bool doubled) {
    const int points = doubled ? corners / 2 : corners;
    std::string off = "OFF\n" + std::to_string(corners) + " " + std::to_string(polygons) + " 0\n";
    char line[96];
    for (int i = 0; i < corners; ++i) {
        const double a = 2 * M_PI * (i % points) / points;
        std::snprintf(line, sizeof line, "%.17g %.17g 0\n", std::cos(a), std::sin(a));
        off += line;
    }
    std::string polygon = std::to_string(corners);
    for (int i = 0; i < corners; ++i) {
        polygon += ' ';
        polygon += std::to_string(i);
    }
    polygon += '\n';
    for (int p = 0; p < polygons; ++p) off += polygon;
    return off;
}

}  // namespace holoflow::test
