#pragma once
// The real rig behind an approximation, and the polish on it (past the talk; docs/solver.md).

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "inversion/model/approximation.h"
#include "inversion/model/rig_function.h"
#include "inversion/solve/solver.h"

namespace rig {

// Binds an approximation to a real rig by names (a blend's branch copy, NAME@ik or NAME@fk, to the joint NAME:
// blend_merge.h). Keeps references to both; not thread-safe (the rig is not).
class RigBinding {
public:
    // Throws rig::Error naming the first approximation parameter or output the rig lacks.
    RigBinding(const Approximation& approximation, RigFunction& rig);

    // Evaluates the real rig with the approximation's parameters at `approxValues` (one per
    // Approximation::parameters) and every other rig parameter at its default; `worlds` receives the
    // world matrices of Approximation::outputs, in that order.
    void evaluate(std::span<const double> approxValues, std::vector<Eigen::Matrix4d>& worlds);

    const Approximation& approximation() const { return approximation_; }
    RigFunction& rig() { return rig_; }

private:
    const Approximation& approximation_;
    RigFunction& rig_;
    std::vector<int> parameterIndex_;  // per approximation parameter: its index in the rig
    std::vector<int> outputIndex_;     // per approximation output: its index in the rig
    std::vector<double> rigValues_;
    std::vector<Eigen::Matrix4d> rigWorlds_;
};

struct PolishSummary {
    int corrections = 0;  // corrections kept (each one lowered the real rig's cost)
    int evaluations = 0;  // real-rig evaluations: one per correction tried, plus the first measurement
    // Largest errors on the real rig over the active targets (as SolveSummary counts them), before the
    // first correction and after the last one kept.
    double positionErrorBeforeCm = 0.0;
    double positionErrorAfterCm = 0.0;
    double rotationErrorBeforeDeg = 0.0;
    double rotationErrorAfterDeg = 0.0;
    double costBefore = 0.0;  // 1/2 |r|^2 on the real rig, the solver's weights
    double costAfter = 0.0;
    std::string worstOutput;  // on the real rig, after
    // invalidTargets or noTargets: nothing was done (no evaluation); otherwise the last re-solve's
    // termination (converged when no correction was tried).
    TerminationType termination = TerminationType::converged;
};

// Polish on the real rig: with `values` a solution on the approximation, evaluate the real rig there,
// move each target by the approximation's mismatch at that solution (position: minus the offset
// real - approximation; rotation: times the inverse of the rotation taking the approximation's
// orientation to the real one) and re-solve from `values`, up to `corrections` times. A correction that
// does not lower the real rig's cost is undone and ends the polish. Where the mismatch changes slowly
// with the parameters (rotation-like deformers), the real rig's error goes to zero.
PolishSummary polish(const Solver& solver, RigBinding& binding, std::span<const JointTarget> targets,
                     std::span<double> values, int corrections);

}  // namespace rig
