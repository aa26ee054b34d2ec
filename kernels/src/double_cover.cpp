#include "holoflow/kernels/double_cover.h"

#include "holoflow/kernels/errors.h"

namespace holoflow::kernels {

DoubleCover double_cover(const MeshView& open_mesh) {
    const MeshView& in = open_mesh;
    HOLOFLOW_REQUIRE(!in.is_closed(), "mesh has no boundary");
    const Index n_v = in.n_vertices(), n_f = in.n_faces(), n_h = in.n_halfedges();

    std::vector<char> on_boundary(n_v, 0);
    for (Index h = 0; h < n_h; ++h)
        if (in.is_boundary_halfedge(h)) on_boundary[in.tail(h)] = 1;

    DoubleCover dc;
    // Copy 1 image of each input vertex: boundary vertices are shared, interior ones duplicated.
    std::vector<Index> mirror_vertex(n_v);
    dc.original_vertex.resize(n_v);
    for (Index v = 0; v < n_v; ++v) dc.original_vertex[v] = v;
    for (Index v = 0; v < n_v; ++v) {
        if (on_boundary[v]) {
            mirror_vertex[v] = v;
        } else {
            mirror_vertex[v] = static_cast<Index>(dc.original_vertex.size());
            dc.original_vertex.push_back(v);
        }
    }
    const Index cover_v = static_cast<Index>(dc.original_vertex.size());

    PointMatrix V(cover_v, 3);
    for (Index v = 0; v < cover_v; ++v) V.row(v) = in.V.row(dc.original_vertex[v]);

    // Mirror face (c0, c2, c1): its halfedge 2 - k runs against input halfedge k.
    TriangleMatrix F(2 * n_f, 3);
    for (Index f = 0; f < n_f; ++f) {
        F.row(f) = in.F.row(f);
        F(n_f + f, 0) = mirror_vertex[in.F(f, 0)];
        F(n_f + f, 1) = mirror_vertex[in.F(f, 2)];
        F(n_f + f, 2) = mirror_vertex[in.F(f, 1)];
    }
    auto mirror_halfedge = [n_f](Index h) { return 3 * (n_f + h / 3) + 2 - h % 3; };

    // Interior pairs repeat in both copies; a boundary halfedge pairs with its own mirror.
    std::vector<Index> twin(2 * static_cast<std::size_t>(n_h));
    for (Index h = 0; h < n_h; ++h) {
        const Index t = in.twin[h];
        if (t == kNoHalfedge) {
            twin[h] = mirror_halfedge(h);
            twin[mirror_halfedge(h)] = h;
        } else {
            twin[h] = t;
            twin[mirror_halfedge(h)] = mirror_halfedge(t);
        }
    }

    dc.vertex_involution.resize(cover_v);
    for (Index v = 0; v < n_v; ++v) dc.vertex_involution[v] = mirror_vertex[v];
    for (Index v = n_v; v < cover_v; ++v) dc.vertex_involution[v] = dc.original_vertex[v];
    dc.face_involution.resize(2 * static_cast<std::size_t>(n_f));
    dc.original_face.resize(2 * static_cast<std::size_t>(n_f));
    for (Index f = 0; f < n_f; ++f) {
        dc.face_involution[f] = n_f + f;
        dc.face_involution[n_f + f] = f;
        dc.original_face[f] = f;
        dc.original_face[n_f + f] = f;
    }
    dc.mesh = make_mesh_view(std::move(V), std::move(F), std::move(twin));
    return dc;
}

}  // namespace holoflow::kernels
