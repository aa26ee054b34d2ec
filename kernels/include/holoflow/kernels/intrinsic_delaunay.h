#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! How one flip moves closed 1-form values: eta(edge) = sign_a eta(from_a) + sign_b eta(from_b),
//! on the input's edge numbering (a flipped edge keeps its index).
struct FormFlip {
    Index edge, from_a, from_b;
    double sign_a, sign_b;
};

//! A triangulation of the input surface by geodesic edges: same vertices and geometry, new
//! connectivity and edge lengths, with closed 1-forms carried over.
struct IntrinsicTriangulation {
    //! Same vertices (V copied for reference only: the geometry is edge_length), flipped
    //! connectivity built by make_mesh_view(V, F, twin); two edges may join one vertex pair and a
    //! face may repeat a vertex, which flips can produce.
    MeshView mesh;
    std::vector<double> edge_length;  //!< #E of `mesh`
    //! #E x k: the input forms carried through every flip, measured along E(e,0) -> E(e,1)
    //! (empty unless forms were given).
    Eigen::MatrixXd forms;
    //! Every flip in order, and where each final edge's value sits (input edge slot, sign): what
    //! carry_forms replays.
    std::vector<FormFlip> form_flips;
    std::vector<Index> form_slot;
    std::vector<double> form_sign;
    Index flips = 0;
    bool hit_flip_limit = false;  //!< the flip cap stopped the algorithm before it finished
    //! Interior edges whose opposite-angle test still fails at the end (final pass): nonzero only
    //! when hit_flip_limit, or when a flip would have made a numerically degenerate triangle.
    Index non_delaunay_edges = 0;
};

struct IntrinsicDelaunayOptions {
    //! Cap on the number of flips; -1: only a safety bound of 100 #E + 1000 (hitting either sets
    //! hit_flip_limit).
    Index max_flips = -1;
};

//! \brief Flips edges of the intrinsic metric (the input's edge lengths) until every interior
//! edge is Delaunay: cot a + cot b >= 0 for the angles a, b opposite it, i.e. nonnegative cotan
//! weights, up to a tolerance of 1e-12 times the cotangent scale (a^2 + b^2 + c^2) / (4 area) of
//! its two triangles (the rounding error of the test itself). Boundary edges never flip (an
//! obtuse angle opposite one keeps its negative weight). Closed 1-forms follow exactly (carry_forms): flipping
//! edge ab of triangles abc, bad to edge cd sets eta(c->d) = eta(c->a) + eta(a->d), so
//! integer-valued forms stay integer and closed. Serial FIFO over the edges in index order;
//! deterministic.
//! \pre every face has a positive area.  \throw InvalidInput.
//! \cite bobenko_springborn_2007, fisher_springborn_schroeder_sullivan_2007
IntrinsicTriangulation intrinsic_delaunay(const MeshView& mesh, const IntrinsicDelaunayOptions& options = {});

//! The #E x k closed forms on the input's edges carried through the triangulation's flips onto
//! its edges; the same arithmetic in the same order, whoever calls it (bit-identical).
//! \pre forms has #E rows, all finite.  \throw InvalidInput.
Eigen::MatrixXd carry_forms(const IntrinsicTriangulation& triangulation, const Eigen::MatrixXd& forms);

//! The same for column-compressed forms: the dense overload's nonzero values, bit for bit, with
//! no #E x k dense matrix (HomologyOptions::sparse_forms).
Eigen::SparseMatrix<double> carry_forms(const IntrinsicTriangulation& triangulation,
                                        const Eigen::SparseMatrix<double>& forms);

//! intrinsic_delaunay, then carry_forms into `forms` of the result.
IntrinsicTriangulation intrinsic_delaunay(const MeshView& mesh, const Eigen::MatrixXd& forms,
                                          const IntrinsicDelaunayOptions& options = {});

}  // namespace holoflow::kernels
