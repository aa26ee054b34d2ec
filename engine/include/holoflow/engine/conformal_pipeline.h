#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "holoflow/engine/stage_clock.h"
#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/holomorphic.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/mesh_view.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::engine {

class FactorizationCache;

enum class LaplacianKind { IntrinsicDelaunay, Extrinsic };

//! How the coefficients of the chosen form tau = sum_i d_i (omega_i + i *omega_i) are picked:
//! generic reals (no special symmetry; vertical leaves are generically dense on a closed
//! surface), or small integers (kernels::integer_form_coefficients: u has integer periods, so
//! every vertical leaf closes and the vertical trajectories cut the surface into cylinders).
enum class FormChoice { Generic, IntegerPeriods };

//! A model needs more memory than the caller allows (exit status 7, kind `resource_limit`).
struct ResourceLimit : std::runtime_error {
    using std::runtime_error::runtime_error;
};

//! The 2g harmonic right-hand sides are solved in blocks of at most this many columns, as equal
//! as the count allows, each block one task. Each solve call streams the whole factor and its
//! BLAS calls gain with the width, so wide blocks are cheaper per column (the `solves` of cheese,
//! 266 columns: 1655 ms in blocks of 8, 1168 in blocks of 32, 1478 in blocks of 64); several
//! blocks still keep the cores busy. Derived from the column count only, never from the thread
//! count, so the bits do not depend on it.
constexpr Eigen::Index kSolveBlockColumns = 32;

//! Columns per solve block for `columns` right-hand sides (the last block may have fewer).
Eigen::Index solve_block_width(Eigen::Index columns);

struct ConformalOptions {
    LaplacianKind laplacian = LaplacianKind::IntrinsicDelaunay;
    FormChoice form = FormChoice::Generic;
    //! Closed input only: a cohomology basis (#E x 2g closed forms) to use instead of the
    //! tree-cotree one, e.g. carried from a coarser mesh so that period matrices compare.
    std::optional<Eigen::MatrixXd> closed_forms;
    //! Refuse (ResourceLimit) when the conformal stage's estimated memory (the factor and the
    //! dense 2g-column forms) exceeds this many bytes: checked before the homology allocates the
    //! forms and again before factorizing; 0: no limit.
    std::size_t max_solver_bytes = 0;
    //! Compute the chosen form alone: two solves of a few columns (its real part, then its
    //! conjugate) for each phase tried instead of 2g columns for the harmonic basis, and the
    //! closed forms kept sparse. No Hodge star, period matrix or basis checks (`harmonic`, `star`
    //! and `basis` stay empty but for basis.genus). What the segmentation needs: its refinement
    //! tries always, its first solve from 64 forms on (on a double cover of genus 100 and more
    //! the 2g solves were most of its time).
    bool chosen_form_only = false;
};


//! Everything the conformal stage computes for one mesh (DESIGN 2.2-2.4).
struct ConformalResult {
    int input_genus = 0;
    bool double_covered = false;
    std::shared_ptr<const MeshView> surface;       //!< the closed surface worked on
    std::shared_ptr<const kernels::DoubleCover> cover;  //!< set for open input
    //! The cut graph and loops; its closed forms become `harmonic` (empty once the solves begin).
    kernels::HomologyBasis homology;
    Eigen::MatrixXd harmonic;                //!< #E x 2g omega_i on `surface`'s edges (none: chosen_form_only)
    kernels::HodgeStar star;
    kernels::HolomorphicBasis basis;
    FormChoice form = FormChoice::Generic;
    Eigen::VectorXd form_coefficients;       //!< the chosen tau = sum_i d_i (omega_i + i *omega_i)
    //! The generic coefficients' phase (kernels::generic_form_coefficients): 1, or where its
    //! image folds on over 1 % of the triangles, the one of phases 1-8 with fewest flips if that
    //! has under half the first's. Always 1 for the integer-period form.
    int form_phase = 1;
    Eigen::VectorXcd tau;                    //!< #E chosen form
    kernels::ConformalMap map;
    //! Quality on the triangulation the Laplacian was built on (where the discrete map is
    //! harmonic: the intrinsic Delaunay one by default) and on the input mesh (uv.obj).
    kernels::MapQuality quality;
    kernels::MapQuality input_mesh_quality;
    double closedness_max = 0;               //!< of the harmonic forms (so of every holomorphic one)
    double coclosedness_max = 0;             //!< of the harmonic forms, relative to the rhs
    Index intrinsic_flips = 0;
    //! The intrinsic Delaunay triangulation of `surface` the Laplacian was built on (without
    //! forms; null with LaplacianKind::Extrinsic): zero finding replays its flips on tau.
    std::shared_ptr<const kernels::IntrinsicTriangulation> intrinsic;
    //! The Laplacian's cotan weights (on `intrinsic`'s edges, or the surface's with the extrinsic
    //! Laplacian): zero finding's harmonicity test reuses them.
    std::vector<double> laplace_weights;
    Index negative_weights = 0;              //!< cotan weights < 0 in the Laplacian used
    StageTimes timings_ms;
};

//! \throw InvalidInput naming the count unless the mesh is one connected component.
void require_connected(const kernels::Topology& topology);

//! One model between the conformal stages. The flow graph's nodes hand it from stage to stage;
//! compute_conformal runs the same stages in sequence. Each stage appends its wall time to
//! result.timings_ms and drops what later stages no longer need.
struct ConformalWork {
    std::shared_ptr<const MeshView> input;
    ConformalOptions options;
    ConformalResult result;
    kernels::IntrinsicTriangulation intrinsic;  //!< with LaplacianKind::IntrinsicDelaunay
    std::vector<double> weights;                //!< cotan weights on laplace_mesh()'s edges
    Eigen::MatrixXd wedge;                      //!< 2g x 2g wedge matrix of the closed forms
    Eigen::MatrixXi involution;                 //!< 2g x 2g action of the cover's involution (open input)
    std::vector<Index> pinned;
    kernels::LaplacianMatrix laplacian;
    std::shared_ptr<const kernels::CholeskyFactor> factor;
    //! The closed forms on laplace_mesh()'s edges, sparse (the intrinsic ones become harmonic in
    //! place): what the Hodge star's inner products need.
    Eigen::SparseMatrix<double> laplace_closed_forms;
    std::chrono::steady_clock::time_point solves_started;

    bool intrinsic_laplacian() const { return options.laplacian == LaplacianKind::IntrinsicDelaunay; }
    //! The triangulation the Laplacian is built on.
    const MeshView& laplace_mesh() const { return intrinsic_laplacian() ? intrinsic.mesh : *result.surface; }
    //! The closed forms on `surface`'s edges: given ones, or the homology's until begin_solves
    //! turns them into the harmonic forms.
    const Eigen::MatrixXd& closed_forms() const {
        return options.closed_forms ? *options.closed_forms : result.homology.closed_forms;
    }
    //! 2g, known before the homology basis: 2 - Euler characteristic of the closed surface.
    Index form_count() const {
        const MeshView& s = *result.surface;
        return 2 - (s.n_vertices() - s.n_edges() + s.n_faces());
    }
};

//! The conformal stages in order (DESIGN 2.2-2.4); each throws as compute_conformal does.
namespace conformal_stage {
//! Topology checks, double cover for open input. `topology`: the input's, when the caller has
//! it already (computed here otherwise).
ConformalWork prepare(std::shared_ptr<const MeshView> input, ConformalOptions options,
                      const kernels::Topology* topology = nullptr);
//! Intrinsic Delaunay flips (or the mesh itself), cotan weights, the Laplacian with one vertex
//! pinned.
void laplacian(ConformalWork& work);
//! Tree-cotree cut graph, homology loops, closed forms, their wedge matrix (and the involution's
//! action on them, for open input); the forms carried onto the intrinsic triangulation (so after
//! `laplacian`). Stage times go to `times`.
void homology(ConformalWork& work, StageTimes& times);
//! Symbolic analysis (from `cache` when given and its pattern was seen), memory check, numeric
//! factor. Stage times go to `times`.
void factorise(ConformalWork& work, FactorizationCache* cache, StageTimes& times);
//! homology and factorise at once (they are independent); their times, then `overlap`: the
//! wall time minus their sum (negative when they overlapped), so the stage times add up to wall
//! time. Homology's error is thrown first when both fail.
void homology_and_factorise(ConformalWork& work, FactorizationCache* cache = nullptr);
//! Starts the `solves` clock, keeps the closed forms on laplace_mesh() for the Hodge star, and
//! moves the closed forms into the harmonic forms (copies given ones): the blocks turn both those
//! and the carried ones harmonic in place. Returns the number of solve blocks: 0 with
//! chosen_form_only, where end_solves and hodge_star do nothing either.
int begin_solves(ConformalWork& work);
//! Solves block `block`'s columns and adds the potential's gradient to those columns of the
//! harmonic forms (and of the carried forms); blocks write disjoint columns, so they may run at
//! once.
void solve_block(ConformalWork& work, int block);
//! Drops the factor; co-closedness check of the harmonic forms.
void end_solves(ConformalWork& work);
//! Hodge star, canonical basis, period matrix, closedness.
void hodge_star(ConformalWork& work);
//! The chosen form, its integration and map quality. With chosen_form_only, the form's own solves
//! too (after homology_and_factorise, with no begin_solves ... hodge_star): they count as
//! `integration`.
void integrate(ConformalWork& work);
//! Every stage after prepare, in order, in one call: homology beside the factorisation and the
//! solve blocks side by side, as the flow graph runs them.
void run_after_prepare(ConformalWork& work, FactorizationCache* cache = nullptr);
}  // namespace conformal_stage

//! Runs the conformal stage on a validated mesh: double cover for open surfaces, tree-cotree,
//! closed forms, intrinsic Delaunay (or extrinsic cotan), ONE factorization for all 2g solves,
//! Hodge star, canonical basis, period matrix, integration of the chosen form.
//! \throw InvalidInput for closed genus 0, disks and several components; SolverFailure.
ConformalResult compute_conformal(const MeshView& mesh, const ConformalOptions& options = {},
                                  FactorizationCache* cache = nullptr);

//! `generic` or `integer_periods` (the reports' `form` key).
const char* form_name(FormChoice form);

//! The `conformal.json` object (keys documented in README).
nlohmann::json conformal_report(const ConformalResult& result);

}  // namespace holoflow::engine
