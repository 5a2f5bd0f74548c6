#include "inversion/approximation.h"

#include <algorithm>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

void Approximation::evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) const
{
    if (values.size() != parameters.size())
        throw internalError("Approximation::evaluate: one value per modelled parameter");
    worlds.resize(outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k) worlds[k].setIdentity();
    // Walking the parameters outermost first and multiplying on the right composes each output's own
    // operators in order (M_k); then each output's product is its parent's followed by M_k, and the
    // rest matrix goes last.
    std::vector<Eigen::Matrix4d> matrices;
    for (std::size_t p = 0; p < parameters.size(); ++p) {
        const ModelledParameter& m = parameters[p];
        const double a = values[p] - m.parameter.defaultValue;
        matrices.clear();
        for (const Operator& op : m.operators) matrices.push_back(op.matrix(a));
        for (std::size_t e = 0; e < m.outputs.size(); ++e)
            worlds[static_cast<std::size_t>(m.outputs[e])] *= matrices[static_cast<std::size_t>(m.operatorOfOutput[e])];
    }
    for (const int k : outputOrder()) {
        const int p = outputs[static_cast<std::size_t>(k)].parent;
        if (p >= 0)
            worlds[static_cast<std::size_t>(k)] =
                worlds[static_cast<std::size_t>(p)] * worlds[static_cast<std::size_t>(k)];
    }
    for (std::size_t k = 0; k < outputs.size(); ++k) worlds[k] *= outputs[k].rest;
}

std::vector<int> Approximation::outputOrder() const
{
    const int n = static_cast<int>(outputs.size());
    std::vector<int> order;
    std::vector<char> state(outputs.size(), 0);  // 0 new, 1 on the current walk, 2 placed
    std::vector<int> walk;
    for (int k = 0; k < n; ++k) {
        for (int u = k; u >= 0 && state[static_cast<std::size_t>(u)] == 0;
             u = outputs[static_cast<std::size_t>(u)].parent) {
            const int p = outputs[static_cast<std::size_t>(u)].parent;
            if (p < -1 || p >= n)
                throw internalError(fmt::format("Approximation: output {} has parent index {} of {}",
                                                outputs[static_cast<std::size_t>(u)].name, p, n));
            state[static_cast<std::size_t>(u)] = 1;
            walk.push_back(u);
            if (p >= 0 && state[static_cast<std::size_t>(p)] == 1)
                throw internalError(fmt::format("Approximation: the parents of output {} form a cycle",
                                                outputs[static_cast<std::size_t>(u)].name));
        }
        for (auto it = walk.rbegin(); it != walk.rend(); ++it) {
            state[static_cast<std::size_t>(*it)] = 2;
            order.push_back(*it);
        }
        walk.clear();
    }
    return order;
}

std::vector<std::vector<int>> Approximation::reach() const
{
    std::vector<std::vector<int>> children(outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k)
        if (outputs[k].parent >= 0)
            children[static_cast<std::size_t>(outputs[k].parent)].push_back(static_cast<int>(k));
    std::vector<std::vector<int>> result;
    result.reserve(parameters.size());
    std::vector<char> seen(outputs.size(), 0);
    for (const ModelledParameter& m : parameters) {
        std::vector<int> reached, stack(m.outputs.begin(), m.outputs.end());
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

}  // namespace rig
