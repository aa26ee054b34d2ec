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

}  // namespace holoflow::kernels
