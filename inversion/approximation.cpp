#include "inversion/approximation.h"

#include <stdexcept>

namespace rig {

void Approximation::evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) const
{
    if (values.size() != parameters.size())
        throw std::invalid_argument("Approximation::evaluate: one value per modelled parameter");
    worlds.resize(outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k) worlds[k].setIdentity();
    // Walking the parameters outermost first and multiplying on the right composes each output's
    // operators in order; the rest matrix goes last.
    std::vector<Eigen::Matrix4d> matrices;
    for (std::size_t p = 0; p < parameters.size(); ++p) {
        const ModelledParameter& m = parameters[p];
        const double a = values[p] - m.parameter.defaultValue;
        matrices.clear();
        for (const Operator& op : m.operators) matrices.push_back(op.matrix(a));
        for (std::size_t e = 0; e < m.outputs.size(); ++e)
            worlds[static_cast<std::size_t>(m.outputs[e])] *= matrices[static_cast<std::size_t>(m.operatorOfOutput[e])];
    }
    for (std::size_t k = 0; k < outputs.size(); ++k) worlds[k] *= outputs[k].rest;
}

std::vector<double> Approximation::defaults() const
{
    std::vector<double> values;
    for (const auto& m : parameters) values.push_back(m.parameter.defaultValue);
    return values;
}

}  // namespace rig
