#pragma once
// A peer solver: Ceres Solver on the same residuals of the same approximation (inversion/solve/jacobian.h),
// with the same analytic Jacobian, Levenberg-Marquardt and a dense linear solver. Built only when CMake
// finds Ceres (Debian's libceres-dev); rig-bench reports null figures otherwise.

#include <memory>
#include <span>
#include <string>

#include "inversion/model/approximation.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"

namespace rig::bench {

enum class CeresLinearSolver { denseQr, denseNormalCholesky };
std::string ceresLinearSolverName(CeresLinearSolver solver);
std::string ceresVersion();

struct CeresSolve {
    bool converged = false;  // Ceres' termination type CONVERGENCE
    int iterations = 0;      // successful and unsuccessful steps
    double initialCost = 0.0;
    double finalCost = 0.0;  // 1/2 |r|^2, as SolveSummary counts it
};

// One whole problem (every parameter a column, the active targets' rows) per set of active outputs.
class CeresInverter {
public:
    // Iteration limit and rotation scale from `options`; the tolerances too (the same stopping rules as
    // ours) unless `ceresTolerances`, which keeps Ceres' own defaults (looser: function 1e-6, parameter
    // 1e-8, gradient 1e-10).
    CeresInverter(const Approximation& approximation, const SolverOptions& options, CeresLinearSolver linearSolver,
                  bool ceresTolerances = false);
    ~CeresInverter();
    CeresInverter(const CeresInverter&) = delete;
    CeresInverter& operator=(const CeresInverter&) = delete;

    // targets: one per Approximation::outputs; values: in, the warm start; out, the solution.
    // Throws rig::Error for an unusable active target.
    CeresSolve solve(std::span<const JointTarget> targets, std::span<double> values);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rig::bench
