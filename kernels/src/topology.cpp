#include "holoflow/kernels/topology.h"

#include <string>

#include "holoflow/kernels/errors.h"

namespace holoflow::kernels {
namespace {

// Face flood fill through twins with an explicit stack; components are numbered in the order of
// their smallest face because the seeds are visited in increasing face order.
int label_components(const MeshView& mesh, std::vector<Index>& face_component) {
    const Index n_f = mesh.n_faces();
    face_component.assign(n_f, -1);
    std::vector<Index> stack;
    int n_components = 0;
    for (Index seed = 0; seed < n_f; ++seed) {
        if (face_component[seed] != -1) continue;
        const Index c = n_components++;
        face_component[seed] = c;
        stack.push_back(seed);
        while (!stack.empty()) {
            const Index f = stack.back();
            stack.pop_back();
            for (Index k = 0; k < 3; ++k) {
                const Index t = mesh.twin[3 * f + k];
                if (t == kNoHalfedge) continue;
                const Index g = MeshView::face(t);
                if (face_component[g] != -1) continue;
                face_component[g] = c;
                stack.push_back(g);
            }
        }
    }
    return n_components;
}

}  // namespace

Topology compute_topology(const MeshView& mesh) {
    Topology t;
    t.vertices = mesh.n_vertices();
    t.edges = mesh.n_edges();
    t.faces = mesh.n_faces();
    t.components = label_components(mesh, t.face_component);
    t.per_component.assign(t.components, ComponentTopology{});

    // Every vertex and edge lies in some face (MeshView guarantees it), so the component of any
    // incident face is the element's component.
    for (Index f = 0; f < t.faces; ++f) ++t.per_component[t.face_component[f]].faces;
    for (Index e = 0; e < t.edges; ++e)
        ++t.per_component[t.face_component[MeshView::face(mesh.edge_halfedge[e])]].edges;
    for (Index v = 0; v < t.vertices; ++v)
        ++t.per_component[t.face_component[MeshView::face(mesh.vertex_halfedge[v])]].vertices;

    // Boundary loops: after the boundary halfedge into v comes v's outgoing boundary halfedge,
    // which MeshView stores as vertex_halfedge[v] (one boundary fan per vertex).
    const Index n_h = mesh.n_halfedges();
    std::vector<char> visited(n_h, 0);
    for (Index start = 0; start < n_h; ++start) {
        if (!mesh.is_boundary_halfedge(start) || visited[start]) continue;
        std::vector<Index> cycle;
        Index h = start;
        do {
            HOLOFLOW_REQUIRE(mesh.is_boundary_halfedge(h) && !visited[h],
                             "boundary walk broke at halfedge " + std::to_string(h));
            visited[h] = 1;
            cycle.push_back(mesh.tail(h));
            h = mesh.vertex_halfedge[mesh.head(h)];
        } while (h != start);
        ++t.per_component[t.face_component[MeshView::face(start)]].boundary_loops;
        t.boundary_cycles.push_back(std::move(cycle));
    }
    t.boundary_loops = static_cast<int>(t.boundary_cycles.size());

    t.euler_characteristic = static_cast<int>(t.vertices - t.edges + t.faces);
    for (ComponentTopology& c : t.per_component) {
        c.euler_characteristic = static_cast<int>(c.vertices - c.edges + c.faces);
        // An orientable connected surface has chi = 2 - 2g - b, so 2 - chi - b is even and >= 0.
        const int twice_genus = 2 - c.euler_characteristic - c.boundary_loops;
        HOLOFLOW_REQUIRE(twice_genus >= 0 && twice_genus % 2 == 0,
                         "Euler characteristic " + std::to_string(c.euler_characteristic) +
                             " with " + std::to_string(c.boundary_loops) +
                             " boundary loops is not an orientable surface");
        c.genus = twice_genus / 2;
        t.genus += c.genus;
    }
    return t;
}

std::vector<ComponentMesh> component_meshes(const MeshView& mesh, const Topology& topology) {
    HOLOFLOW_REQUIRE(static_cast<Index>(topology.face_component.size()) == mesh.n_faces(),
                     "the topology must be this mesh's");
    const std::size_t n_components = topology.per_component.size();
    std::vector<Index> vertex_component(mesh.n_vertices(), -1), new_vertex(mesh.n_vertices()), new_face(mesh.n_faces());
    for (Index f = 0; f < mesh.n_faces(); ++f)
        for (int k = 0; k < 3; ++k) vertex_component[mesh.F(f, k)] = topology.face_component[f];
    std::vector<Index> vertices(n_components, 0), faces(n_components, 0);
    for (Index v = 0; v < mesh.n_vertices(); ++v) new_vertex[v] = vertices[vertex_component[v]]++;
    for (Index f = 0; f < mesh.n_faces(); ++f) new_face[f] = faces[topology.face_component[f]]++;
    std::vector<PointMatrix> V(n_components);
    std::vector<TriangleMatrix> F(n_components);
    std::vector<std::vector<Index>> twin(n_components);
    for (std::size_t c = 0; c < n_components; ++c) {
        V[c].resize(vertices[c], 3);
        F[c].resize(faces[c], 3);
        twin[c].assign(3 * static_cast<std::size_t>(faces[c]), kNoHalfedge);
    }
    for (Index v = 0; v < mesh.n_vertices(); ++v) V[vertex_component[v]].row(new_vertex[v]) = mesh.V.row(v);
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        const Index c = topology.face_component[f], g = new_face[f];
        for (int k = 0; k < 3; ++k) {
            F[c](g, k) = new_vertex[mesh.F(f, k)];
            const Index t = mesh.twin[3 * f + k];
            if (t != kNoHalfedge) twin[c][3 * g + k] = 3 * new_face[MeshView::face(t)] + t % 3;
        }
    }
    std::vector<ComponentMesh> out(n_components);
    for (std::size_t c = 0; c < n_components; ++c) {
        out[c].mesh = make_mesh_view(std::move(V[c]), std::move(F[c]), std::move(twin[c]));
        out[c].source_vertex.reserve(static_cast<std::size_t>(vertices[c]));
    }
    for (Index v = 0; v < mesh.n_vertices(); ++v) out[vertex_component[v]].source_vertex.push_back(v);
    return out;
}

}  // namespace holoflow::kernels
