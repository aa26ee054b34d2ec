#pragma once

#include <span>
#include <vector>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! \brief Cotangent weight w_e = (cot a + cot b) / 2 of every edge, a and b the angles opposite e
//! (one term on boundary edges), from the vertex positions. Negative on obtuse configurations.
//! \throw InvalidInput naming a face with zero area (its cotangents are infinite).
std::vector<double> cotan_weights(const MeshView& mesh);

//! \brief Same from intrinsic edge lengths on any triangle connectivity: `halfedge_edge` has 3
//! entries per face, halfedge 3f+k joining corners k and k+1 of face f (so it is opposite corner
//! k+2); every halfedge of an edge adds half the cotangent of its opposite angle.
//! \throw InvalidInput on out-of-range edges, non-positive lengths or a violated triangle
//! inequality (degenerate faces included).
std::vector<double> cotan_weights_from_lengths(std::span<const Index> halfedge_edge,
                                               std::span<const double> edge_length, Index n_edges);

//! Symmetric matrix of the quadratic form sum_e w_e (x_i - x_j)^2, stored as CSC upper triangle
//! (diagonal included, rows sorted within each column, each column ending with its diagonal).
//! The pattern is built once from an edge list; `edge_slot` and `diagonal_slot` let new weights
//! refill `value` in O(E) without touching the pattern (same symbolic factorization).
struct LaplacianMatrix {
    Index n = 0;
    std::vector<Index> col_start;  //!< n + 1 column starts
    std::vector<Index> row;        //!< row index of every stored entry
    std::vector<double> value;     //!< value of every stored entry
    std::vector<Index> edge_slot;  //!< #E: slot of the off-diagonal entry of edge e, -1 for loops
    std::vector<Index> diagonal_slot;  //!< #V: slot of the diagonal entry of every vertex
    //! Vertices whose row and column are replaced by the identity (one per component makes the
    //! Laplacian of a closed surface positive definite; the solution there is 0).
    std::vector<Index> pinned;

    Index n_edges() const { return static_cast<Index>(edge_slot.size()); }
    Index nonzeros() const { return static_cast<Index>(row.size()); }
};

//! \brief Sparsity pattern (values zero) of the Laplacian of the #E x 2 edge list E on n vertices.
//! Repeated vertex pairs share one entry (their weights add); loops i == i contribute nothing.
//! O(V + E), deterministic.
//! \throw InvalidInput on vertex indices out of range, including pinned ones.
LaplacianMatrix laplacian_pattern(Index n_vertices, const EdgeMatrix& E, std::vector<Index> pinned);

//! \brief Writes the values of L for the weights w (one per edge of the pattern), then replaces
//! the pinned rows and columns by the identity. O(V + E), same bits as a fresh assembly.
//! Non-finite weights are not rejected here; CholeskyFactor::factorize reports them.
//! \throw InvalidInput if w does not have one entry per edge.
void fill_laplacian(LaplacianMatrix& L, std::span<const double> edge_weight);

//! \brief laplacian_pattern followed by fill_laplacian.
//! \throw InvalidInput.
LaplacianMatrix assemble_laplacian(Index n_vertices, const EdgeMatrix& E,
                                   std::span<const double> edge_weight, std::vector<Index> pinned);

}  // namespace holoflow::kernels
