#include "inversion/solve/solver_options.h"

#include <cmath>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

std::string_view jacobianMethodName(JacobianMethod method)
{
    return method == JacobianMethod::analytic ? "analytic" : "finiteDifference";
}

std::string_view terminationName(TerminationType termination)
{
    switch (termination) {
        case TerminationType::converged:
            return "converged";
        case TerminationType::stuck:
            return "stuck";
        case TerminationType::noConvergence:
            return "noConvergence";
        case TerminationType::invalidTargets:
            return "invalidTargets";
        case TerminationType::noTargets:
            return "noTargets";
    }
    return "?";
}

void SolverOptions::validate() const
{
    auto fail = [](std::string_view field, auto value, std::string_view rule) {
        throw Error(fmt::format("SolverOptions::{} = {}: {}", field, value, rule));
    };
    auto nonNegative = [&](std::string_view field, double value) {
        if (!(value >= 0) || !std::isfinite(value)) fail(field, value, "must be a finite number, 0 or more");
    };
    auto positive = [&](std::string_view field, double value) {
        if (!(value > 0) || !std::isfinite(value)) fail(field, value, "must be a positive number");
    };
    if (gaussNewtonIterations < 0) fail("gaussNewtonIterations", gaussNewtonIterations, "must not be negative");
    if (maxIterations < 1) fail("maxIterations", maxIterations, "must be at least 1");
    positive("rotationScaleCm", rotationScaleCm);
    nonNegative("functionTolerance", functionTolerance);
    nonNegative("parameterTolerance", parameterTolerance);
    nonNegative("gradientTolerance", gradientTolerance);
    nonNegative("targetTolerance", targetTolerance);
    if (jacobian != JacobianMethod::analytic && jacobian != JacobianMethod::finiteDifference)
        fail("jacobian", static_cast<int>(jacobian), "must be analytic or finiteDifference");
    positive("finiteDifferenceStep", finiteDifferenceStep);
    positive("maxAngularStep", maxAngularStep);
    positive("realRigMaxAngularStep", realRigMaxAngularStep);
    if (threads < 0) fail("threads", threads, "must not be negative (0: all cores)");
}

std::string SolveSummary::briefReport() const
{
    std::string report = fmt::format("{}: {} iterations ({} Gauss-Newton, {} Levenberg-Marquardt), {} block{}",
                                     terminationName(termination), iterations, gaussNewtonIterations,
                                     levenbergMarquardtIterations, blocks, blocks == 1 ? "" : "s");
    if (termination == TerminationType::invalidTargets) return report;
    report += fmt::format(", cost {:.6g} -> {:.6g}, worst {:.3g} cm, {:.3g} deg", initialCost, finalCost,
                          maxPositionErrorCm, maxRotationErrorDeg);
    if (!worstOutput.empty()) report += fmt::format(" (worst output {})", worstOutput);
    return report;
}

}  // namespace rig
