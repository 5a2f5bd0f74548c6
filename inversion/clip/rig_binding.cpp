#include "inversion/clip/rig_binding.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "core/error.h"
#include "core/rotation_math.h"

namespace rig {

RigBinding::RigBinding(const Approximation& approximation, RigFunction& rig) : approximation_(approximation), rig_(rig)
{
    const auto& parameters = rig.parameters();
    for (const auto& m : approximation.parameters) {
        const auto found = std::find_if(parameters.begin(), parameters.end(),
                                        [&](const RigParameter& p) { return p.name == m.parameter.name; });
        if (found == parameters.end())
            throw Error(fmt::format("RigBinding: the rig has no parameter {}", m.parameter.name));
        parameterIndex_.push_back(static_cast<int>(found - parameters.begin()));
    }
    const auto& outputs = rig.outputs();
    for (const auto& o : approximation.outputs) {
        // A blend's branch copy (a helper, never a target) reads the joint it copies: its frame at its branch's end.
        const std::string name = o.helper ? rigOutputName(o.name) : o.name;
        const auto found = std::find(outputs.begin(), outputs.end(), name);
        if (found == outputs.end()) throw Error(fmt::format("RigBinding: the rig has no output {}", name));
        outputIndex_.push_back(static_cast<int>(found - outputs.begin()));
    }
    for (const auto& p : parameters) rigValues_.push_back(p.defaultValue);
}

void RigBinding::evaluate(std::span<const double> approxValues, std::vector<Eigen::Matrix4d>& worlds)
{
    if (approxValues.size() != parameterIndex_.size())
        throw internalError(fmt::format("RigBinding::evaluate: {} values for {} parameters", approxValues.size(),
                                        parameterIndex_.size()));
    for (std::size_t p = 0; p < parameterIndex_.size(); ++p)
        rigValues_[static_cast<std::size_t>(parameterIndex_[p])] = approxValues[p];
    rig_.evaluate(rigValues_, rigWorlds_);
    worlds.resize(outputIndex_.size());
    for (std::size_t k = 0; k < outputIndex_.size(); ++k)
        worlds[k] = rigWorlds_[static_cast<std::size_t>(outputIndex_[k])];
}

namespace {

struct RealError {
    double cost = 0.0;
    double positionCm = 0.0;
    double rotationDeg = 0.0;
    std::string worst;
};

RealError measure(const Approximation& approximation, const std::vector<Eigen::Matrix4d>& worlds,
                  std::span<const JointTarget> targets, const std::vector<PreparedTarget>& prepared,
                  double rotationScaleCm)
{
    RealError error;
    double worst = -1.0;
    for (std::size_t k = 0; k < targets.size(); ++k) {
        if (!targets[k].active || (targets[k].positionWeight <= 0 && targets[k].rotationWeight <= 0)) continue;
        const TargetError e = targetError(worlds[k], prepared[k]);
        error.cost += 0.5 * (std::pow(prepared[k].positionWeight * e.positionCm, 2) +
                             std::pow(prepared[k].rotationWeight * e.rotationRad, 2));
        const double position = targets[k].positionWeight > 0 ? e.positionCm : 0.0;
        const double rotation = targets[k].rotationWeight > 0 ? e.rotationRad : 0.0;
        error.positionCm = std::max(error.positionCm, position);
        error.rotationDeg = std::max(error.rotationDeg, rotation * 180.0 / std::numbers::pi);
        const double combined = std::max(position, rotationScaleCm * rotation);
        if (combined > worst) {
            worst = combined;
            error.worst = approximation.outputs[k].name;
        }
    }
    return error;
}

}  // namespace

PolishSummary polish(const Solver& solver, RigBinding& binding, std::span<const JointTarget> targets,
                     std::span<double> values, int corrections)
{
    const Approximation& approximation = solver.approximation();
    if (&binding.approximation() != &approximation)
        throw internalError("polish: the binding is for another approximation than the solver's");
    if (targets.size() != approximation.outputs.size() || values.size() != approximation.parameters.size())
        throw internalError(fmt::format("polish: {} targets and {} values for {} outputs and {} parameters",
                                        targets.size(), values.size(), approximation.outputs.size(),
                                        approximation.parameters.size()));
    if (corrections < 0) throw Error(fmt::format("polish: corrections = {}: must not be negative", corrections));

    PolishSummary summary;
    const double scale = solver.options().rotationScaleCm;
    std::vector<PreparedTarget> prepared(targets.size());
    bool any = false;
    for (std::size_t k = 0; k < targets.size(); ++k) {
        if (!targets[k].active) continue;
        if (!prepareTarget(targets[k], scale, prepared[k])) {
            summary.termination = TerminationType::invalidTargets;
            return summary;
        }
        any = any || targets[k].positionWeight > 0 || targets[k].rotationWeight > 0;
    }
    if (!any) {
        summary.termination = TerminationType::noTargets;
        return summary;
    }

    std::vector<Eigen::Matrix4d> real, approximated;
    binding.evaluate(values, real);
    summary.evaluations = 1;
    RealError best = measure(approximation, real, targets, prepared, scale);
    summary.positionErrorBeforeCm = best.positionCm;
    summary.rotationErrorBeforeDeg = best.rotationDeg;
    summary.costBefore = best.cost;

    std::vector<double> bestValues(values.begin(), values.end());
    std::vector<JointTarget> corrected(targets.begin(), targets.end());
    for (int c = 0; c < corrections && best.cost > 0; ++c) {
        // The mismatch at the current solution, assumed to change slowly: aim the approximation past
        // the target by it.
        approximation.evaluate(values, approximated);
        for (std::size_t k = 0; k < targets.size(); ++k) {
            if (!targets[k].active) continue;
            const Eigen::Matrix3d qa = polarRotation(approximated[k].block<3, 3>(0, 0));
            const Eigen::Matrix3d qr = polarRotation(real[k].block<3, 3>(0, 0));
            Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
            world.block<3, 3>(0, 0) = prepared[k].rotation * qr.transpose() * qa;
            world.block<3, 1>(0, 3) =
                prepared[k].position - (real[k].block<3, 1>(0, 3) - approximated[k].block<3, 1>(0, 3));
            corrected[k].world = world;
        }
        summary.termination = solver.solve(corrected, values).termination;
        binding.evaluate(values, real);
        ++summary.evaluations;
        const RealError now = measure(approximation, real, targets, prepared, scale);
        if (!(now.cost < best.cost)) {
            std::copy(bestValues.begin(), bestValues.end(), values.begin());
            break;
        }
        best = now;
        std::copy(values.begin(), values.end(), bestValues.begin());
        ++summary.corrections;
    }
    summary.positionErrorAfterCm = best.positionCm;
    summary.rotationErrorAfterDeg = best.rotationDeg;
    summary.costAfter = best.cost;
    summary.worstOutput = best.worst;
    return summary;
}

}  // namespace rig
