#include "inversion/learner.h"

#include <chrono>
#include <map>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "inversion/classifier.h"
#include "inversion/ordering.h"

namespace rig {

std::string_view ordererName(Orderer orderer) { return orderer == Orderer::talk ? "talk" : "structured"; }

void LearnOptions::validate() const
{
    auto fail = [](std::string_view field, auto value, std::string_view rule) {
        throw std::invalid_argument(fmt::format("LearnOptions::{} = {}: {}", field, value, rule));
    };
    if (!(epsilon > 0) || !std::isfinite(epsilon)) fail("epsilon", epsilon, "must be a positive number");
    if (!(frameRadius > 0) || !std::isfinite(frameRadius)) fail("frameRadius", frameRadius, "must be a positive number");
    if (samples < 2) fail("samples", samples, "must be at least 2");
    if (maxSamples < samples) fail("maxSamples", maxSamples, "must be at least `samples`");
    if (!(effectTolerance > 0) || !std::isfinite(effectTolerance))
        fail("effectTolerance", effectTolerance, "must be a positive number");
    if (validationPoses < 0) fail("validationPoses", validationPoses, "must not be negative");
}

double matrixError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double frameRadius)
{
    const Eigen::Matrix4d d = a - b;
    const Eigen::Vector3d origin = d.block<3, 1>(0, 3);
    double worst = origin.norm();
    for (int c = 0; c < 3; ++c) worst = std::max(worst, (origin + frameRadius * d.block<3, 1>(0, c)).norm());
    return worst;
}

std::vector<std::pair<int, int>> redundantParameters(const Approximation& approximation, double tolerance, double frameRadius)
{
    std::vector<std::pair<int, int>> pairs;
    const auto& ps = approximation.parameters;
    for (std::size_t i = 0; i < ps.size(); ++i)
        for (std::size_t j = i + 1; j < ps.size(); ++j) {
            if (ps[i].outputs != ps[j].outputs) continue;
            const double lo = std::max(ps[i].parameter.min - ps[i].parameter.defaultValue, ps[j].parameter.min - ps[j].parameter.defaultValue);
            const double hi = std::min(ps[i].parameter.max - ps[i].parameter.defaultValue, ps[j].parameter.max - ps[j].parameter.defaultValue);
            if (!(hi > lo)) continue;
            bool same = true;
            for (int s = 0; s <= 4 && same; ++s) {
                const double a = lo + (hi - lo) * s / 4.0;
                for (std::size_t e = 0; e < ps[i].outputs.size() && same; ++e) {
                    const Eigen::Matrix4d& rest = approximation.outputs[static_cast<std::size_t>(ps[i].outputs[e])].rest;
                    const Operator& u = ps[i].operators[static_cast<std::size_t>(ps[i].operatorOfOutput[e])];
                    const Operator& v = ps[j].operators[static_cast<std::size_t>(ps[j].operatorOfOutput[e])];
                    same = matrixError(u.matrix(a) * rest, v.matrix(a) * rest, frameRadius) <= tolerance;
                }
            }
            if (same) pairs.emplace_back(static_cast<int>(i), static_cast<int>(j));
        }
    return pairs;
}

namespace {

// Angle between the orientations of two world matrices (scale removed), degrees.
double rotationErrorDegrees(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
    auto orientation = [](const Eigen::Matrix4d& m) {
        Eigen::Matrix3d r = m.block<3, 3>(0, 0);
        const Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
        return Eigen::Quaterniond(Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose()));
    };
    // atan2 of the relative rotation's halves stays accurate near zero, where acos does not.
    const Eigen::Quaterniond relative = orientation(a).conjugate() * orientation(b);
    return 2.0 * std::atan2(relative.vec().norm(), std::abs(relative.w())) * 180.0 / std::numbers::pi;
}

ValidationSummary validate(RigProbe& probe, const Approximation& approximation, const std::vector<int>& indices,
                           const std::vector<int>& rigOutput, const LearnOptions& options)
{
    ValidationSummary summary;
    summary.poses = options.validationPoses;
    std::mt19937 rng(options.seed);
    std::vector<Eigen::Matrix4d> approximated;
    double positionSum = 0.0, rotationSum = 0.0;
    std::size_t count = 0;
    const auto& parameters = probe.rig().parameters();
    for (int pose = 0; pose < options.validationPoses; ++pose) {
        // A value for every parameter in rig order, whether modelled or not, so that the poses do not
        // depend on the composition order (two orderers are compared on the same poses).
        std::vector<double> drawn;
        for (const RigParameter& param : parameters) drawn.push_back(std::uniform_real_distribution<double>(param.min, param.max)(rng));
        std::vector<double> values = probe.defaults();
        std::vector<double> modelled;
        for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
            const auto i = static_cast<std::size_t>(indices[p]);
            values[i] = drawn[i];
            modelled.push_back(drawn[i]);
        }
        const std::vector<Eigen::Matrix4d> real = probe.atValues(values);
        approximation.evaluate(modelled, approximated);
        for (std::size_t k = 0; k < approximated.size(); ++k) {
            const Eigen::Matrix4d& truth = real[static_cast<std::size_t>(rigOutput[k])];
            const double position = (truth.block<3, 1>(0, 3) - approximated[k].block<3, 1>(0, 3)).norm();
            const double rotation = rotationErrorDegrees(truth, approximated[k]);
            positionSum += position;
            rotationSum += rotation;
            ++count;
            if (position > summary.maxPositionErrorCm || summary.worstPose < 0) {
                summary.maxPositionErrorCm = std::max(summary.maxPositionErrorCm, position);
                if (position >= summary.maxPositionErrorCm) {
                    summary.worstOutput = approximation.outputs[k].name;
                    summary.worstPose = pose;
                }
            }
            summary.maxRotationErrorDeg = std::max(summary.maxRotationErrorDeg, rotation);
        }
        if (options.progress) options.progress("validating", static_cast<double>(pose + 1) / options.validationPoses);
    }
    if (count > 0) {
        summary.meanPositionErrorCm = positionSum / static_cast<double>(count);
        summary.meanRotationErrorDeg = rotationSum / static_cast<double>(count);
    }
    return summary;
}

// A parameter with no effect on its own may still change what others do (the axis of a bend that
// turns with it): move it at a few random poses of the modelled parameters and look.
std::string couplingReason(RigProbe& probe, const RigParameter& parameter, int index, const Approximation& approximation,
                           const std::vector<int>& indices, const std::vector<int>& rigOutput, const LearnOptions& options)
{
    std::mt19937 rng(options.seed + 7919u * static_cast<std::uint32_t>(index));
    for (int pose = 0; pose < 3; ++pose) {
        std::vector<double> values = probe.defaults();
        for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
            const RigParameter& param = approximation.parameters[p].parameter;
            values[static_cast<std::size_t>(indices[p])] = std::uniform_real_distribution<double>(param.min, param.max)(rng);
        }
        const std::vector<Eigen::Matrix4d> held = probe.atValues(values);
        values[static_cast<std::size_t>(index)] = parameter.max != parameter.defaultValue ? parameter.max : parameter.min;
        const std::vector<Eigen::Matrix4d>& moved = probe.atValues(values);
        for (std::size_t o = 0; o < rigOutput.size(); ++o) {
            const auto k = static_cast<std::size_t>(rigOutput[o]);
            const double change = matrixError(held[k], moved[k], options.frameRadius);
            if (change > options.effectTolerance)
                return fmt::format("no effect on its own, but it changes what other parameters do (coupled: {} moved by "
                                   "{:.3g} cm at a random pose); it is held at its rest value",
                                   approximation.outputs[o].name, change);
        }
    }
    return {};
}

// Removes the unreliable outputs from a classification (with their operators when no output is left
// using them); a parameter left with no output is no longer modelled.
void dropOutputs(Classification& c, const std::vector<char>& unreliable)
{
    ModelledParameter& m = c.model;
    std::vector<int> outputs, operatorOfOutput;
    std::vector<Eigen::Matrix4d> orderWorlds;
    std::vector<std::string> lost;
    for (std::size_t e = 0; e < m.outputs.size(); ++e) {
        if (unreliable[static_cast<std::size_t>(m.outputs[e])]) continue;
        outputs.push_back(m.outputs[e]);
        operatorOfOutput.push_back(m.operatorOfOutput[e]);
        orderWorlds.push_back(c.orderWorlds[e]);
    }
    if (outputs.size() == m.outputs.size()) return;
    if (outputs.empty()) {
        c.modelled = false;
        c.reason = "its only effect is on outputs found history-dependent (they do not come back to their rest pose)";
        return;
    }
    // Keep only the operators still used, renumbered.
    std::vector<int> renumber(m.operators.size(), -1);
    std::vector<Operator> operators;
    for (int& o : operatorOfOutput) {
        auto& r = renumber[static_cast<std::size_t>(o)];
        if (r < 0) {
            r = static_cast<int>(operators.size());
            operators.push_back(m.operators[static_cast<std::size_t>(o)]);
        }
        o = r;
    }
    m.outputs = std::move(outputs);
    m.operatorOfOutput = std::move(operatorOfOutput);
    m.operators = std::move(operators);
    c.orderWorlds = std::move(orderWorlds);
}

}  // namespace

Approximation learnApproximation(RigFunction& rig, const LearnOptions& options, const std::string& rigFile)
{
    options.validate();
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t evaluationsBefore = rig.evaluationCount();
    RigProbe probe(rig);
    const std::vector<Eigen::Matrix4d> rest = probe.atRest();
    const auto& parameters = rig.parameters();

    std::vector<Classification> classes;
    RigState state{rest, std::vector<char>(rest.size(), 0)};
    for (std::size_t i = 0; i < parameters.size(); ++i) {
        classes.push_back(classifyParameter(probe, static_cast<int>(i), rest, state, options));
        if (options.progress) options.progress("classifying", static_cast<double>(i + 1) / static_cast<double>(parameters.size()));
    }
    // Outputs found history-dependent are dropped from what was learned before they were found.
    std::vector<int> modelled;
    for (Classification& c : classes) {
        if (c.modelled) dropOutputs(c, state.unreliable);
        if (c.modelled) modelled.push_back(c.index);
    }
    const OrderResult order = orderParameters(probe, rest, classes, modelled, options);

    // The approximation's outputs are the reliable ones; `rigOutput` maps them back to the rig's.
    Approximation result;
    result.rigFile = rigFile;
    result.rigFingerprint = rig.fingerprint();
    result.epsilon = options.epsilon;
    std::vector<int> rigOutput, outputIndex(rest.size(), -1);
    for (std::size_t k = 0; k < rest.size(); ++k)
        if (!state.unreliable[k]) {
            outputIndex[k] = static_cast<int>(rigOutput.size());
            rigOutput.push_back(static_cast<int>(k));
            result.outputs.push_back({rig.outputs()[k], rest[k]});
        }
    std::vector<int> indices;
    for (int p : order.order) {
        ModelledParameter m = classes[static_cast<std::size_t>(p)].model;
        for (int& k : m.outputs) k = outputIndex[static_cast<std::size_t>(k)];
        result.parameters.push_back(std::move(m));
        indices.push_back(p);
    }
    result.validation = validate(probe, result, indices, rigOutput, options);

    std::map<int, std::string> reasons;
    for (const auto& c : classes)
        if (!c.modelled) {
            const bool noEffect = c.reason.starts_with("no effect");
            const std::string coupled = noEffect ? couplingReason(probe, c.model.parameter, c.index, result, indices,
                                                                  rigOutput, options)
                                                 : std::string();
            reasons[c.index] = coupled.empty() ? c.reason : coupled;
        }
    for (const auto& [p, reason] : order.discards) reasons[p] = reason;
    for (const auto& [p, reason] : reasons) result.discarded.push_back({parameters[static_cast<std::size_t>(p)], reason});
    result.training.evaluations = rig.evaluationCount() - evaluationsBefore;
    result.training.orderEvaluations = order.evaluations;
    result.training.orderer = std::string(ordererName(options.orderer));
    if (!order.note.empty()) result.training.orderer += " (" + order.note + ")";
    result.training.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

}  // namespace rig
