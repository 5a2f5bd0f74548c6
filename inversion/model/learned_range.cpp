#include "inversion/model/learned_range.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace rig {

void RangeLeft::cover(double value)
{
    low = std::min(low, value);
    high = std::max(high, value);
}

RangeLeft rangeLeft(const Approximation& approximation, std::span<const double> values, int output)
{
    RangeLeft blamed;
    if (output < 0) return blamed;
    const std::vector<std::vector<int>> reach = approximation.reach();
    bool blamedSampled = false;
    double blamedOut = 0.0;  // how far out, in widths of its range
    for (std::size_t p = 0; p < approximation.parameters.size() && p < values.size(); ++p) {
        const ModelledParameter& m = approximation.parameters[p];
        const RigParameter& parameter = m.parameter;
        const double v = values[p];
        if (parameter.limited || !(parameter.max > parameter.min) || (v >= parameter.min && v <= parameter.max))
            continue;
        if (!std::binary_search(reach[p].begin(), reach[p].end(), output)) continue;
        const bool sampled = std::any_of(m.operators.begin(), m.operators.end(),
                                         [](const Operator& op) { return op.traits().sampled || !op.linear(); });
        const double out =
            (v < parameter.min ? parameter.min - v : v - parameter.max) / (parameter.max - parameter.min);
        const bool better =
            !blamed.found() || (sampled && !blamedSampled) || (sampled == blamedSampled && out > blamedOut);
        if (!better) continue;
        const double unit = parameter.angular ? 180.0 / std::numbers::pi : 1.0;
        blamed = {parameter.name, parameter.angular, parameter.min * unit, parameter.max * unit, v * unit, v * unit};
        blamedSampled = sampled;
        blamedOut = out;
    }
    return blamed;
}

std::pair<double, double> widenedRange(double learnedMin, double learnedMax, double low, double high)
{
    const double margin = rangeMargin * (learnedMax - learnedMin);
    // Two significant digits of the margin: 18 degrees widens to whole degrees, 0.2 (a unitless +-1) to 0.01.
    const double step = std::pow(10.0, std::floor(std::log10(margin)) - 1.0);
    const double min = low < learnedMin ? std::floor((low - margin) / step) * step : learnedMin;
    const double max = high > learnedMax ? std::ceil((high + margin) / step) * step : learnedMax;
    return {min, max};
}

std::string exactGlob(std::string_view name)
{
    std::string glob;
    for (const char c : name) {
        if (c == '*' || c == '?' || c == '[' || c == '\\') glob += '\\';
        glob += c;
    }
    return glob;
}

}  // namespace rig
