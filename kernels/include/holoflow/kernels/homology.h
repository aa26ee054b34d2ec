#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <span>
#include <vector>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Tree-cotree decomposition of a closed surface and everything read off it: homology
//! generators, the dual closed 1-forms, the cut graph and the fundamental domain.
struct HomologyBasis {
    int genus = 0;
    Index root = 0;                           //!< root vertex of the primal tree
    std::vector<Index> tree_parent_halfedge;  //!< #V: halfedge parent -> v (kNoHalfedge at root)
    std::vector<Index> generator_edges;       //!< 2g edges in neither tree, ascending
    //! Per generator: a closed halfedge loop (tree path to the generator edge's tail, the edge
    //! along its orientation, tree path back; the common stem of both paths cancelled).
    std::vector<std::vector<Index>> loops;
    //! #E x 2g: eta_i measured along E(e,0) -> E(e,1); 0 on the tree, delta_ij on generator j,
    //! fixed on the cotree by closedness. Integer-valued, so every face sum is exactly 0.
    //! Empty with HomologyOptions::sparse_forms.
    Eigen::MatrixXd closed_forms;
    //! The same forms column-compressed: with HomologyOptions::sparse_forms only, else empty.
    Eigen::SparseMatrix<double> sparse_closed_forms;
    std::vector<char> cut_edge;       //!< #E: tree + generators pruned of dangling branches
    std::vector<Index> corner_wedge;  //!< #H: fundamental-domain vertex of corner h (at tail(h))
    Index n_wedges = 0;               //!< vertices of the fundamental domain
};

struct HomologyOptions {
    //! Root of the shortest-path tree; -1 picks the vertex nearest the vertex centroid (smallest
    //! index on ties, distances compared to 2^-30 of the largest), which keeps the tree shallow
    //! and the loops short on most shapes.
    Index root = -1;
    //! The closed forms as `sparse_closed_forms` instead of `closed_forms`: dual to a tree-cotree
    //! basis they live on dual paths (a fraction of a percent of the #E x 2g entries), so at high
    //! genus the dense matrix costs far more to allocate than the forms to compute. The same values.
    bool sparse_forms = false;
};

//! The vertex nearest the centroid of the vertices, smallest index on ties (distances compared
//! to 2^-30 of the largest, so a moved, turned or scaled copy picks the same): the default root.
Index central_vertex(const MeshView& mesh);

//! \brief Tree-cotree homology basis, dual closed 1-forms, cut graph and fundamental domain.
//! Shortest-path tree by Dijkstra on edge lengths rounded to 2^-30 of the longest (exact sums:
//! equal paths tie, to the smaller vertex, then the first halfedge found, the same for a moved,
//! turned or scaled copy), dual tree by BFS over faces from face 0; linear time apart from Dijkstra.
//! Genus 0 is a value: no generators, empty cut graph, one wedge per vertex.
//! \pre closed, connected.  \throw InvalidInput.
HomologyBasis compute_homology_basis(const MeshView& mesh, const HomologyOptions& options = {});

//! Integral of each column of `forms` (#E x k) along a halfedge path (e.g. a loop of the basis).
//! \throw InvalidInput on a bad halfedge index or a row count other than #E.
Eigen::VectorXd integrate_along(const MeshView& mesh, const Eigen::MatrixXd& forms,
                                std::span<const Index> loop);

//! The same over several paths at once: column j of the k x #paths result is integrate_along
//! over paths[j] (the same bits), each form's column read once (forms in parallel).
//! \throw InvalidInput as integrate_along.
Eigen::MatrixXd integrate_along_paths(const MeshView& mesh, const Eigen::MatrixXd& forms,
                                      std::span<const std::vector<Index>> paths);

//! The same for column-compressed forms (HomologyOptions::sparse_forms), as one product of the
//! paths' signed edges with the forms: other summation orders, so the same bits for
//! integer-valued forms such as the closed ones.  \throw InvalidInput as integrate_along.
Eigen::MatrixXd integrate_along_paths(const MeshView& mesh, const Eigen::SparseMatrix<double>& forms,
                                      std::span<const std::vector<Index>> paths);

//! A_ij = integral over the surface of forms_i ^ forms_j (closed forms): per face (a d - b c)/2
//! with a = f_i(v0->v1), b = f_i(v0->v2), c = f_j(v0->v1), d = f_j(v0->v2), assembled as the
//! sparse product Omega^T S Omega (S skew, two entries per face) and skew-symmetrised.
//! \throw InvalidInput if forms has a row count other than #E.
Eigen::MatrixXd wedge_matrix(const MeshView& mesh, const Eigen::MatrixXd& forms);

//! The same for column-compressed forms (HomologyOptions::sparse_forms); the dense overload's
//! value for sparse enough forms, bit for bit.
Eigen::MatrixXd wedge_matrix(const MeshView& mesh, const Eigen::SparseMatrix<double>& forms);

//! \brief Canonical basis: integer unimodular P with P^T J P = [[0, I], [-I, 0]] (columns
//! a_1..a_g, b_1..b_g), by symplectic Gram-Schmidt with Euclid over the integers.
//! For J = rounded wedge_matrix(closed_forms): closed_forms * P are the forms dual to the
//! canonical cycles whose coefficients in the generator loops are the rows of P^{-1}.
//! \throw InvalidInput if J is not square, even-sized, skew, integral and unimodular.
Eigen::MatrixXi symplectic_basis(const Eigen::MatrixXi& J);

//! Euler characteristic and boundary-loop count of the mesh cut open along cut_edge.
struct CutTopology {
    int euler_characteristic = 0;
    int boundary_loops = 0;
};

//! \brief Topology of the fundamental domain: vertices are the wedges actually used in
//! corner_wedge, edges E + #cut edges, faces F; boundary loops by walking the cut sides.
//! \throw InvalidInput if corner_wedge splits a vertex across an uncut edge or disagrees with
//! n_wedges, or the arrays do not match the mesh.
CutTopology fundamental_domain_topology(const MeshView& mesh, const HomologyBasis& basis);

}  // namespace holoflow::kernels
