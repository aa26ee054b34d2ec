#include "holoflow/kernels/shapes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/subdivision.h"

namespace holoflow::shapes {
namespace {

// Planar grid of nx by ny cells of size dx by dy, skipping the cells `removed` names. Diagonals
// follow the quadrant of the cell ("union jack"), so each corner cell's diagonal runs from the
// corner into the interior and never joins two boundary vertices.
MeshView grid_sheet(int nx, int ny, double dx, double dy,
                    const std::function<bool(int, int)>& removed) {
    auto id = [nx](int i, int j) { return static_cast<Index>(j) * (nx + 1) + i; };
    std::vector<Index> tris;
    tris.reserve(6 * static_cast<std::size_t>(nx) * ny);
    for (int j = 0; j < ny; ++j) {
        for (int i = 0; i < nx; ++i) {
            if (removed(i, j)) continue;
            const Index a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            const bool main_diagonal =
                static_cast<long>(2 * i + 1 - nx) * static_cast<long>(2 * j + 1 - ny) > 0;
            if (main_diagonal)
                tris.insert(tris.end(), {a, b, c, a, c, d});
            else
                tris.insert(tris.end(), {a, b, d, b, c, d});
        }
    }
    // Drop the vertices inside holes, keeping the row-major order of the rest.
    const Index n_all = id(nx, ny) + 1;
    std::vector<Index> new_id(n_all, -1);
    for (Index v : tris) new_id[v] = 0;
    Index n_v = 0;
    for (Index v = 0; v < n_all; ++v)
        if (new_id[v] == 0) new_id[v] = n_v++;
    PointMatrix V(n_v, 3);
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i)
            if (new_id[id(i, j)] >= 0) V.row(new_id[id(i, j)]) << i * dx, j * dy, 0.0;
    TriangleMatrix F(static_cast<Eigen::Index>(tris.size() / 3), 3);
    for (std::size_t k = 0; k < tris.size(); ++k)
        F(static_cast<Eigen::Index>(k / 3), static_cast<Eigen::Index>(k % 3)) = new_id[tris[k]];
    return make_mesh_view(std::move(V), std::move(F));
}

// Quads (i, j) -> (i+1, j) -> (i+1, j+1) -> (i, j+1) of a grid whose vertex (i, j) has index
// i * stride_i + j * stride_j, with i wrapping at ni and j at nj when asked.
TriangleMatrix quad_strip_faces(int ni, int nj, bool wrap_j, int stride_i, int stride_j) {
    const int cells_j = wrap_j ? nj : nj - 1;
    TriangleMatrix F(2 * static_cast<Eigen::Index>(ni) * cells_j, 3);
    Eigen::Index f = 0;
    for (int i = 0; i < ni; ++i) {
        for (int j = 0; j < cells_j; ++j) {
            const int i1 = (i + 1) % ni, j1 = wrap_j ? (j + 1) % nj : j + 1;
            auto id = [&](int a, int b) { return static_cast<Index>(a * stride_i + b * stride_j); };
            F.row(f++) << id(i, j), id(i1, j), id(i1, j1);
            F.row(f++) << id(i, j), id(i1, j1), id(i, j1);
        }
    }
    return F;
}

}  // namespace

MeshView torus(double R, double r, int nu, int nv) {
    HOLOFLOW_REQUIRE(r > 0 && R > r, "need R > r > 0");
    HOLOFLOW_REQUIRE(nu >= 3 && nv >= 3, "need nu, nv >= 3");
    PointMatrix V(static_cast<Eigen::Index>(nu) * nv, 3);
    for (int i = 0; i < nu; ++i) {
        const double u = 2.0 * std::numbers::pi * i / nu;
        for (int j = 0; j < nv; ++j) {
            const double v = 2.0 * std::numbers::pi * j / nv;
            V.row(static_cast<Eigen::Index>(i) * nv + j) << (R + r * std::cos(v)) * std::cos(u),
                (R + r * std::cos(v)) * std::sin(u), r * std::sin(v);
        }
    }
    // d/du x d/dv points outward, so (i, j) -> (i+1, j) -> (i+1, j+1) is counter-clockwise.
    return make_mesh_view(std::move(V), quad_strip_faces(nu, nv, true, nv, 1));
}

MeshView icosphere(int level) {
    HOLOFLOW_REQUIRE(level >= 0 && level <= 10, "level must lie in [0, 10]");
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    PointMatrix V(12, 3);
    V << -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0,  //
        0, -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t,   //
        t, 0, -1, t, 0, 1, -t, 0, -1, -t, 0, 1;
    V.rowwise().normalize();
    TriangleMatrix F(20, 3);
    F << 0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11,  //
        1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8,   //
        3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9,       //
        4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1;
    MeshView mesh = make_mesh_view(std::move(V), std::move(F));
    for (int l = 0; l < level; ++l) {
        mesh = kernels::subdivide_midpoint(mesh);
        mesh.V.rowwise().normalize();  // positions only: the connectivity stays valid
    }
    return mesh;
}

MeshView flat_grid(int nx, int ny) {
    HOLOFLOW_REQUIRE(nx >= 1 && ny >= 1, "need nx, ny >= 1");
    return grid_sheet(nx, ny, 1.0 / nx, 1.0 / ny, [](int, int) { return false; });
}

MeshView cylinder(double radius, double height, int nu, int nv) {
    HOLOFLOW_REQUIRE(radius > 0 && height > 0, "need radius, height > 0");
    HOLOFLOW_REQUIRE(nu >= 3 && nv >= 1, "need nu >= 3, nv >= 1");
    PointMatrix V(static_cast<Eigen::Index>(nu) * (nv + 1), 3);
    for (int j = 0; j <= nv; ++j) {
        for (int i = 0; i < nu; ++i) {
            const double u = 2.0 * std::numbers::pi * i / nu;
            V.row(static_cast<Eigen::Index>(j) * nu + i) << radius * std::cos(u),
                radius * std::sin(u), height * j / nv;
        }
    }
    return make_mesh_view(std::move(V), quad_strip_faces(nu, nv + 1, false, 1, nu));
}

MeshView perforated_sheet(int holes, int resolution) {
    HOLOFLOW_REQUIRE(holes >= 0 && resolution >= 1, "need holes >= 0, resolution >= 1");
    const int s = resolution, m = std::max(2, resolution);
    const int ny = s + 2 * m;
    HOLOFLOW_REQUIRE(holes <= (1 << 20) / (s + m), "too many holes");
    const int nx = std::max(ny, holes * s + (holes + 1) * m);
    auto in_hole = [=](int i, int j) {
        if (j < m || j >= m + s || i < m) return false;
        const int k = (i - m) / (s + m);  // hole k spans cells m + k (s + m) .. + s - 1
        return k < holes && (i - m) % (s + m) < s;
    };
    return grid_sheet(nx, ny, 1.0 / ny, 1.0 / ny, in_hole);
}

MeshView genus_surface(int genus, int resolution) {
    HOLOFLOW_REQUIRE(genus >= 0 && resolution >= 1, "need genus >= 0, resolution >= 1");
    const MeshView sheet = perforated_sheet(genus, resolution);
    const Index n_v = sheet.n_vertices();

    // Grid distance to the boundary: breadth-first search from all boundary vertices at once.
    std::vector<Index> start(static_cast<std::size_t>(n_v) + 1, 0);
    for (Index e = 0; e < sheet.n_edges(); ++e) {
        ++start[sheet.E(e, 0) + 1];
        ++start[sheet.E(e, 1) + 1];
    }
    for (Index v = 0; v < n_v; ++v) start[v + 1] += start[v];
    std::vector<Index> adjacent(start.back());
    {
        std::vector<Index> fill(start.begin(), start.end() - 1);
        for (Index e = 0; e < sheet.n_edges(); ++e) {
            adjacent[fill[sheet.E(e, 0)]++] = sheet.E(e, 1);
            adjacent[fill[sheet.E(e, 1)]++] = sheet.E(e, 0);
        }
    }
    std::vector<Index> distance(n_v, -1), queue;
    queue.reserve(n_v);
    for (Index h = 0; h < sheet.n_halfedges(); ++h) {
        if (sheet.is_boundary_halfedge(h) && distance[sheet.tail(h)] < 0) {
            distance[sheet.tail(h)] = 0;
            queue.push_back(sheet.tail(h));
        }
    }
    for (std::size_t q = 0; q < queue.size(); ++q) {
        const Index v = queue[q];
        for (Index k = start[v]; k < start[v + 1]; ++k) {
            if (distance[adjacent[k]] >= 0) continue;
            distance[adjacent[k]] = distance[v] + 1;
            queue.push_back(adjacent[k]);
        }
    }

    // Lift copy 0 up and copy 1 down; the square root rounds the rim like a pillow's seam.
    const int cap = std::max(2, resolution);
    const double cell = sheet.V(1, 0) - sheet.V(0, 0);
    const double bulge = 0.5 * cap * cell;
    kernels::DoubleCover dc = kernels::double_cover(sheet);
    for (Index v = 0; v < dc.mesh.n_vertices(); ++v) {
        const Index d = std::min<Index>(distance[dc.original_vertex[v]], cap);
        const double h = bulge * std::sqrt(static_cast<double>(d) / cap);
        dc.mesh.V(v, 2) = v < n_v ? h : -h;
    }
    return std::move(dc.mesh);
}

}  // namespace holoflow::shapes
