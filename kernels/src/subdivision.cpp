#include "holoflow/kernels/subdivision.h"

namespace holoflow::kernels {

namespace {

// The 1-to-4 split shared by every subdivision scheme here; only the positions V (#V + #E rows:
// input vertices, then one per input edge) differ between schemes.
//
// Input face f = (c0, c1, c2) with halfedge k running c_k -> c_{k+1} and midpoint m_k on it.
// Output face 4f + k = (c_k, m_k, m_{k+2}) has halfedges
//   12f + 3k     : c_k -> m_k        first half of input halfedge k
//   12f + 3k + 1 : m_k -> m_{k+2}    inner, opposite the middle face
//   12f + 3k + 2 : m_{k+2} -> c_k    second half of input halfedge k + 2
// and the middle face 4f + 3 = (m0, m1, m2) has halfedge 12f + 9 + j running m_j -> m_{j+1}.
MeshView split_faces(const MeshView& mesh, PointMatrix V) {
    const Index n_v = mesh.n_vertices(), n_f = mesh.n_faces();
    const Index n_h = mesh.n_halfedges();

    TriangleMatrix F(4 * n_f, 3);
    for (Index f = 0; f < n_f; ++f) {
        Index m[3];
        for (Index k = 0; k < 3; ++k) m[k] = n_v + mesh.halfedge_edge[3 * f + k];
        for (Index k = 0; k < 3; ++k) {
            F(4 * f + k, 0) = mesh.F(f, k);
            F(4 * f + k, 1) = m[k];
            F(4 * f + k, 2) = m[(k + 2) % 3];
            F(4 * f + 3, k) = m[k];
        }
    }

    // Halves of input halfedge h = 3f + k, in the output numbering above.
    auto first_half = [](Index h) { return 12 * (h / 3) + 3 * (h % 3); };
    auto second_half = [](Index h) { return 12 * (h / 3) + 3 * ((h % 3 + 1) % 3) + 2; };

    std::vector<Index> twin(12 * static_cast<std::size_t>(n_f), kNoHalfedge);
    for (Index h = 0; h < n_h; ++h) {
        const Index t = mesh.twin[h];
        if (t == kNoHalfedge) continue;
        twin[first_half(h)] = second_half(t);
        twin[second_half(h)] = first_half(t);
    }
    for (Index f = 0; f < n_f; ++f) {
        for (Index k = 0; k < 3; ++k) {
            const Index inner = 12 * f + 3 * k + 1;
            const Index middle = 12 * f + 9 + (k + 2) % 3;  // m_{k+2} -> m_k
            twin[inner] = middle;
            twin[middle] = inner;
        }
    }
    return make_mesh_view(std::move(V), std::move(F), std::move(twin));
}

}  // namespace

MeshView subdivide_midpoint(const MeshView& mesh) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges();
    PointMatrix V(n_v + n_e, 3);
    V.topRows(n_v) = mesh.V;
    for (Index e = 0; e < n_e; ++e)
        V.row(n_v + e) = 0.5 * (mesh.V.row(mesh.E(e, 0)) + mesh.V.row(mesh.E(e, 1)));
    return split_faces(mesh, std::move(V));
}

}  // namespace holoflow::kernels

namespace holoflow::kernels {

Eigen::MatrixXd subdivide_forms_midpoint(const MeshView& mesh, const MeshView& fine,
                                         const Eigen::MatrixXd& forms) {
    HOLOFLOW_REQUIRE(forms.rows() == mesh.n_edges(), "forms must have one row per edge");
    HOLOFLOW_REQUIRE(fine.n_faces() == 4 * mesh.n_faces() &&
                         fine.n_vertices() == mesh.n_vertices() + mesh.n_edges(),
                     "fine mesh is not the midpoint subdivision of mesh");
    const Eigen::Index k = forms.cols();
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(fine.n_edges(), k);
    Eigen::MatrixXd potential(fine.n_vertices(), k);  // per face, only its six vertices are used
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        // Potential at the corners by walking the face's halfedges.
        Eigen::RowVectorXd value = Eigen::RowVectorXd::Zero(k);
        for (int c = 0; c < 3; ++c) {
            const Index h = 3 * f + c;
            potential.row(mesh.tail(h)) = value;
            value += static_cast<double>(mesh.edge_sign(h)) * forms.row(mesh.halfedge_edge[h]);
        }
        for (int c = 0; c < 3; ++c) {
            const Index h = 3 * f + c;
            potential.row(mesh.n_vertices() + mesh.halfedge_edge[h]) =
                0.5 * (potential.row(mesh.tail(h)) + potential.row(mesh.head(h)));
        }
        for (Index child = 4 * f; child < 4 * f + 4; ++child)
            for (int c = 0; c < 3; ++c) {
                const Index h = 3 * child + c;
                // Both faces of an edge write the same value: the form is closed.
                out.row(fine.halfedge_edge[h]) = static_cast<double>(fine.edge_sign(h)) *
                             (potential.row(fine.head(h)) - potential.row(fine.tail(h)));
            }
    }
    return out;
}

}  // namespace holoflow::kernels

namespace holoflow::kernels {

MeshView subdivide_loop(const MeshView& mesh) {
    const Index n_v = mesh.n_vertices(), n_e = mesh.n_edges();
    PointMatrix V(n_v + n_e, 3);

    // Moved input vertices: one-rings walked by halfedge, so an edge repeated on one vertex pair
    // counts once per edge, as the valence does.
    for (Index v = 0; v < n_v; ++v) {
        const Index start = mesh.vertex_halfedge[v];
        Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
        Index valence = 0, h = start, last = start;
        do {
            sum += mesh.V.row(mesh.head(h));
            ++valence;
            last = h;
            h = mesh.rotate(h);
        } while (h != kNoHalfedge && h != start);
        if (h == kNoHalfedge) {
            // The fan starts at the outgoing boundary halfedge (MeshView guarantees it) and ends
            // at the face whose incoming halfedge is on the boundary: the two boundary neighbours.
            const Eigen::RowVector3d ends =
                mesh.V.row(mesh.head(start)) + mesh.V.row(mesh.tail(MeshView::prev(last)));
            V.row(v) = 0.75 * mesh.V.row(v) + 0.125 * ends;
        } else {
            // Warren's weights: Loop's convergence to a C1 limit with plain rational weights.
            const double beta = valence > 3 ? 3.0 / (8.0 * valence) : 3.0 / 16.0;
            V.row(v) = (1.0 - valence * beta) * mesh.V.row(v) + beta * sum;
        }
    }

    // Edge vertices: the two ends and the two opposite corners, found through the halfedges.
    for (Index e = 0; e < n_e; ++e) {
        const Index h = mesh.edge_halfedge[e], t = mesh.twin[h];
        const Eigen::RowVector3d ends = mesh.V.row(mesh.tail(h)) + mesh.V.row(mesh.head(h));
        if (t == kNoHalfedge) {
            V.row(n_v + e) = 0.5 * ends;
        } else {
            const Eigen::RowVector3d opposite =
                mesh.V.row(mesh.tail(MeshView::prev(h))) + mesh.V.row(mesh.tail(MeshView::prev(t)));
            V.row(n_v + e) = 0.375 * ends + 0.125 * opposite;
        }
    }
    return split_faces(mesh, std::move(V));
}

}  // namespace holoflow::kernels
