#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "holoflow/engine/stage_clock.h"
#include "holoflow/kernels/conformal_map.h"
#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/holomorphic.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/mesh_view.h"

namespace holoflow::engine {

enum class LaplacianKind { IntrinsicDelaunay, Extrinsic };

struct ConformalOptions {
    LaplacianKind laplacian = LaplacianKind::IntrinsicDelaunay;
    //! Closed input only: a cohomology basis (#E x 2g closed forms) to use instead of the
    //! tree-cotree one, e.g. carried from a coarser mesh so that period matrices compare.
    std::optional<Eigen::MatrixXd> closed_forms;
};


//! Everything the conformal stage computes for one mesh (DESIGN 2.2-2.4).
struct ConformalResult {
    int input_genus = 0;
    bool double_covered = false;
    std::shared_ptr<const MeshView> surface;       //!< the closed surface worked on
    std::shared_ptr<const kernels::DoubleCover> cover;  //!< set for open input
    kernels::HomologyBasis homology;
    Eigen::MatrixXd harmonic;                //!< #E x 2g omega_i on `surface`'s edges
    kernels::HodgeStar star;
    kernels::HolomorphicBasis basis;
    Eigen::VectorXd form_coefficients;       //!< the chosen tau = sum_i d_i (omega_i + i *omega_i)
    Eigen::VectorXcd tau;                    //!< #E chosen form
    kernels::ConformalMap map;
    //! Quality on the triangulation the Laplacian was built on (where the discrete map is
    //! harmonic: the intrinsic Delaunay one by default) and on the input mesh (uv.obj).
    kernels::MapQuality quality;
    kernels::MapQuality input_mesh_quality;
    double closedness_max = 0;               //!< of the harmonic forms (so of every holomorphic one)
    double coclosedness_max = 0;             //!< of the harmonic forms, relative to the rhs
    Index intrinsic_flips = 0;
    Index negative_weights = 0;              //!< cotan weights < 0 in the Laplacian used
    StageTimes timings_ms;
};

//! Runs the conformal stage on a validated mesh: double cover for open surfaces, tree-cotree,
//! closed forms, intrinsic Delaunay (or extrinsic cotan), ONE factorization for all 2g solves,
//! Hodge star, canonical basis, period matrix, integration of the chosen form.
//! \throw InvalidInput for closed genus 0, disks and several components; SolverFailure.
ConformalResult compute_conformal(const MeshView& mesh, const ConformalOptions& options = {});

//! The `conformal.json` object (keys documented in README).
nlohmann::json conformal_report(const ConformalResult& result);

}  // namespace holoflow::engine
