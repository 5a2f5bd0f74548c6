#include "inversion/model/approximation.h"

#include <algorithm>

#include <fmt/format.h>
#include <Eigen/LU>

#include "core/error.h"

namespace rig {

void Approximation::evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) const
{
    ApproximationEvaluator(*this).evaluate(values, worlds);
}

ApproximationEvaluator::ApproximationEvaluator(const Approximation& approximation)
    : approximation_(&approximation), order_(approximation.outputOrder())
{
}

void ApproximationEvaluator::evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds)
{
    const std::vector<ApproximationOutput>& outputs = approximation_->outputs;
    const std::vector<ModelledParameter>& parameters = approximation_->parameters;
    const std::vector<ConstraintBase>& constraints = approximation_->constraints;
    if (values.size() != parameters.size())
        throw internalError("Approximation::evaluate: one value per modelled parameter");
    worlds.resize(outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k) worlds[k].setIdentity();
    // Walking the parameters outermost first and multiplying on the right composes each output's own
    // operators in order (M_k); then each output's product is its parent's followed by M_k (or its base's), and
    // the rest matrix goes last.
    for (std::size_t p = 0; p < parameters.size(); ++p) {
        const ModelledParameter& m = parameters[p];
        const double a = values[p] - m.parameter.defaultValue;
        matrices_.clear();
        for (const Operator& op : m.operators) matrices_.push_back(op.matrix(a));
        for (std::size_t e = 0; e < m.outputs.size(); ++e)
            worlds[static_cast<std::size_t>(m.outputs[e])] *=
                matrices_[static_cast<std::size_t>(m.operatorOfOutput[e])];
    }
    const auto world = [&](int i) -> Eigen::Matrix4d {
        return worlds[static_cast<std::size_t>(i)] * outputs[static_cast<std::size_t>(i)].rest;
    };
    for (const int k : order_) {
        const ApproximationOutput& output = outputs[static_cast<std::size_t>(k)];
        Eigen::Matrix4d& product = worlds[static_cast<std::size_t>(k)];
        if (output.constraint >= 0 &&
            constraints[static_cast<std::size_t>(output.constraint)].kind == ConstraintKind::blend) {
            // The parent's world times the blend of the branches' locals; the rest matrix goes last, as for any.
            const ConstraintBase& base = constraints[static_cast<std::size_t>(output.constraint)];
            const auto input = [&](int i) { return i < 0 ? Eigen::Matrix4d(Eigen::Matrix4d::Identity()) : world(i); };
            const Eigen::Matrix4d local = blendLocal(base.blend, values[static_cast<std::size_t>(base.weight)],
                                                     input(base.ikParent).inverse() * input(base.ik),
                                                     input(base.fkParent).inverse() * input(base.fk));
            product = input(base.anchor) * local * output.rest.inverse() * product;
        } else if (output.constraint >= 0) {
            const ConstraintBase& base = constraints[static_cast<std::size_t>(output.constraint)];
            const Eigen::Matrix4d anchor =
                base.anchor < 0 ? Eigen::Matrix4d::Identity() : worlds[static_cast<std::size_t>(base.anchor)];
            const std::array<int, 3> in = base.inputs();
            const auto input = [&](int i) { return i < 0 ? Eigen::Matrix4d(Eigen::Matrix4d::Identity()) : world(i); };
            const Eigen::Matrix4d orient =
                base.orient < 0 ? Eigen::Matrix4d::Identity() : worlds[static_cast<std::size_t>(base.orient)];
            product = constraintBase(base, anchor, input(in[1]), input(in[2]), orient) * product;
        } else if (output.parent >= 0) {
            product = worlds[static_cast<std::size_t>(output.parent)] * product;
        }
    }
    for (std::size_t k = 0; k < outputs.size(); ++k) worlds[k] *= outputs[k].rest;
}

std::vector<int> Approximation::frameInputs(int k) const
{
    const ApproximationOutput& output = outputs[static_cast<std::size_t>(k)];
    if (output.constraint < 0) return output.parent < 0 ? std::vector<int>{} : std::vector<int>{output.parent};
    if (output.constraint >= static_cast<int>(constraints.size()))
        throw internalError(fmt::format("Approximation: output {} has constraint index {} of {}", output.name,
                                        output.constraint, constraints.size()));
    const ConstraintBase& base = constraints[static_cast<std::size_t>(output.constraint)];
    std::vector<int> inputs;
    for (const int i : base.frameInputs())
        if (i >= 0) inputs.push_back(i);
    return inputs;
}

std::vector<std::vector<int>> Approximation::dependents() const
{
    std::vector<std::vector<int>> result(outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k)
        for (const int i : frameInputs(static_cast<int>(k)))
            if (i >= 0 && static_cast<std::size_t>(i) < outputs.size())
                result[static_cast<std::size_t>(i)].push_back(static_cast<int>(k));
    return result;
}

std::vector<int> Approximation::outputOrder() const
{
    // Depth first over what each output's frame reads, each output placed after its inputs; with an explicit stack,
    // since a rope's chain of parents may be deeper than the call stack.
    const int n = static_cast<int>(outputs.size());
    std::vector<int> order;
    std::vector<char> state(outputs.size(), 0);          // 0 new, 1 on the current walk, 2 placed
    std::vector<std::pair<int, std::vector<int>>> walk;  // an output and its inputs left to visit
    for (int k = 0; k < n; ++k) {
        if (state[static_cast<std::size_t>(k)] != 0) continue;
        state[static_cast<std::size_t>(k)] = 1;
        walk.emplace_back(k, frameInputs(k));
        while (!walk.empty()) {
            auto& [u, inputs] = walk.back();
            if (inputs.empty()) {
                state[static_cast<std::size_t>(u)] = 2;
                order.push_back(u);
                walk.pop_back();
                continue;
            }
            const int i = inputs.back();
            inputs.pop_back();
            if (i < 0 || i >= n)
                throw internalError(fmt::format("Approximation: output {} reads output index {} of {}",
                                                outputs[static_cast<std::size_t>(u)].name, i, n));
            if (state[static_cast<std::size_t>(i)] == 1)
                throw internalError(fmt::format("Approximation: the frames of output {} form a cycle",
                                                outputs[static_cast<std::size_t>(u)].name));
            if (state[static_cast<std::size_t>(i)] == 0) {
                state[static_cast<std::size_t>(i)] = 1;
                walk.emplace_back(i, frameInputs(i));
            }
        }
    }
    return order;
}

std::vector<std::vector<int>> Approximation::reach() const
{
    const std::vector<std::vector<int>> children = dependents();
    std::vector<std::vector<int>> result;
    result.reserve(parameters.size());
    std::vector<char> seen(outputs.size(), 0);
    for (std::size_t p = 0; p < parameters.size(); ++p) {
        const ModelledParameter& m = parameters[p];
        std::vector<int> reached, stack(m.outputs.begin(), m.outputs.end());
        // A blend's weight moves its output with no operator of its own.
        for (std::size_t k = 0; k < outputs.size(); ++k)
            if (const int c = outputs[k].constraint;
                c >= 0 && constraints[static_cast<std::size_t>(c)].kind == ConstraintKind::blend &&
                constraints[static_cast<std::size_t>(c)].weight == static_cast<int>(p))
                stack.push_back(static_cast<int>(k));
        while (!stack.empty()) {
            const int k = stack.back();
            stack.pop_back();
            if (k < 0 || static_cast<std::size_t>(k) >= outputs.size() || seen[static_cast<std::size_t>(k)]) continue;
            seen[static_cast<std::size_t>(k)] = 1;
            reached.push_back(k);
            for (int c : children[static_cast<std::size_t>(k)]) stack.push_back(c);
        }
        for (int k : reached) seen[static_cast<std::size_t>(k)] = 0;
        std::sort(reached.begin(), reached.end());
        result.push_back(std::move(reached));
    }
    return result;
}

bool Approximation::hasUnmodelledOutputs() const
{
    return std::any_of(outputs.begin(), outputs.end(), [](const ApproximationOutput& o) { return !o.modelled; });
}

std::vector<double> Approximation::defaults() const
{
    std::vector<double> values;
    for (const auto& m : parameters) values.push_back(m.parameter.defaultValue);
    return values;
}

std::string rigOutputName(const std::string& name)
{
    if (name.size() > 3 && (name.ends_with("@ik") || name.ends_with("@fk"))) return name.substr(0, name.size() - 3);
    return name;
}

}  // namespace rig
