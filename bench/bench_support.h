#pragma once

// Set-up shared by the benchmark executables: subdivided corpus meshes, the Laplacian and
// right-hand sides the conformal pipeline solves (built by its own stages), solve residuals.

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>

#include <Eigen/Core>
#include <Eigen/Sparse>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/harmonic.h"
#include "holoflow/kernels/subdivision.h"

namespace holoflow::bench {

//! MESH (a corpus name such as `eight`, or a mesh file) after LEVEL steps of SCHEME (`loop` or
//! `midpoint`). \throw std::runtime_error if the mesh is missing, std::invalid_argument on a bad
//! scheme or a level that would overflow 32-bit halfedge ids.
inline std::shared_ptr<const MeshView> subdivided(const std::string& mesh, const std::string& scheme, int level) {
    const std::string path = std::filesystem::is_regular_file(mesh)
                                 ? mesh
                                 : std::string(HOLOFLOW_CORPUS_DIR) + "/" + mesh + ".off";
    if (!std::filesystem::exists(path)) throw std::runtime_error("mesh missing: " + path);
    if (scheme != "loop" && scheme != "midpoint") throw std::invalid_argument("SCHEME must be loop or midpoint");
    std::shared_ptr<const MeshView> m = engine::load_mesh(path).mesh;
    // Each step makes 4x the faces; halfedge ids are 32-bit.
    if (level < 0 || 3.0 * m->n_faces() * std::pow(4.0, level) >= 2147483647.0)
        throw std::invalid_argument("LEVEL must be >= 0 and keep 3 x faces below 2^31");
    for (int l = 0; l < level; ++l)
        m = std::make_shared<const MeshView>(scheme == "loop" ? kernels::subdivide_loop(*m)
                                                              : kernels::subdivide_midpoint(*m));
    return m;
}

//! Turbine (genus 11, CAD triangles) after `level` Loop steps, made once per level.
inline std::shared_ptr<const MeshView> turbine_loop(int level) {
    static std::map<int, std::shared_ptr<const MeshView>> made;
    if (auto it = made.find(level); it != made.end()) return it->second;
    return made.emplace(level, subdivided("turbine", "loop", level)).first->second;
}

//! The conformal stages up to the Laplacian (`work.laplacian`, `work.weights`, `work.intrinsic`,
//! `work.result.homology`) and the 2g right-hand sides its factor solves.
struct PipelineLaplacian {
    engine::ConformalWork work;
    Eigen::MatrixXd rhs;
};

inline PipelineLaplacian pipeline_laplacian(std::shared_ptr<const MeshView> mesh,
                                            engine::LaplacianKind kind = engine::LaplacianKind::IntrinsicDelaunay) {
    engine::ConformalOptions options;
    options.laplacian = kind;
    PipelineLaplacian p{engine::conformal_stage::prepare(std::move(mesh), options), {}};
    engine::conformal_stage::laplacian(p.work);
    engine::conformal_stage::homology(p.work, p.work.result.timings_ms);
    const Eigen::MatrixXd& eta = p.work.intrinsic_laplacian() ? p.work.intrinsic.forms : p.work.closed_forms();
    p.rhs = kernels::harmonic_rhs(p.work.result.surface->n_vertices(), p.work.laplace_mesh().E, p.work.weights, eta,
                                  p.work.pinned);
    return p;
}

//! A LaplacianMatrix (upper triangle stored) as a full symmetric sparse matrix.
inline Eigen::SparseMatrix<double> full_matrix(const kernels::LaplacianMatrix& L) {
    const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::ColMajor, Index>> upper(
        L.n, L.n, L.nonzeros(), L.col_start.data(), L.row.data(), L.value.data());
    return upper.selfadjointView<Eigen::Upper>();
}

//! max |L x - b| / max |b|.
inline double relative_residual(const kernels::LaplacianMatrix& L, const Eigen::MatrixXd& x, const Eigen::MatrixXd& b) {
    const Eigen::MatrixXd r = full_matrix(L) * x - b;
    return r.cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff();
}

}  // namespace holoflow::bench
