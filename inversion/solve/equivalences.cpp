#include "inversion/solve/equivalences.h"

#include <cmath>
#include <numbers>
#include <random>

namespace rig {

double rotationPeriod(const ModelledParameter& m)
{
    double slope = 0.0;
    for (const Operator& op : m.operators) {
        if (!op.traits().angular || !op.linear() || op.slope == 0.0) return 0.0;
        if (slope != 0.0 && std::abs(op.slope) != slope) return 0.0;
        slope = std::abs(op.slope);
    }
    return slope > 0.0 ? 2.0 * std::numbers::pi / slope : 0.0;
}

bool eulerTriple(const ModelledParameter& a, const ModelledParameter& b, const ModelledParameter& c)
{
    if (a.outputs != b.outputs || a.outputs != c.outputs) return false;
    for (std::size_t i = 0; i < a.outputs.size(); ++i) {
        const Operator& p = a.operators[static_cast<std::size_t>(a.operatorOfOutput[i])];
        const Operator& q = b.operators[static_cast<std::size_t>(b.operatorOfOutput[i])];
        const Operator& r = c.operators[static_cast<std::size_t>(c.operatorOfOutput[i])];
        constexpr double orthogonal = 1e-9;
        if (std::abs(p.axis.dot(q.axis)) > orthogonal || std::abs(q.axis.dot(r.axis)) > orthogonal ||
            std::abs(p.axis.dot(r.axis)) > orthogonal)
            return false;
        const double scale = 1.0 + p.pivot.norm();
        if ((p.pivot - q.pivot).norm() > 1e-9 * scale || (p.pivot - r.pivot).norm() > 1e-9 * scale) return false;
    }
    return true;
}

void Equivalences::otherSolution(const std::array<int, 3>& t, std::span<double> values) const
{
    const auto half = [&](int p) { return 0.5 * period[static_cast<std::size_t>(p)]; };
    const std::size_t a = static_cast<std::size_t>(t[0]), b = static_cast<std::size_t>(t[1]),
                      c = static_cast<std::size_t>(t[2]);
    values[a] += half(t[0]);
    values[b] = 2.0 * defaults[b] + half(t[1]) - values[b];
    values[c] += half(t[2]);
}

bool sameWorlds(const std::vector<Eigen::Matrix4d>& a, const std::vector<Eigen::Matrix4d>& b)
{
    for (std::size_t k = 0; k < a.size(); ++k) {
        const double scale = 1.0 + a[k].cwiseAbs().maxCoeff();
        if (!((a[k] - b[k]).cwiseAbs().maxCoeff() <= 1e-9 * scale)) return false;
    }
    return true;
}

Equivalences::Equivalences(const Approximation& approximation) : defaults(approximation.defaults())
{
    const auto& parameters = approximation.parameters;
    for (const ModelledParameter& m : parameters) period.push_back(m.parameter.limited ? 0.0 : rotationPeriod(m));
    // Two generic poses (fixed, so that the result does not vary from run to run): an identity of the
    // three angles that holds at both holds everywhere; one that does not compose in a row fails there.
    // Every parameter moves, not only the periodic ones: a control that shares the triple's joint (a spine
    // bend under a chest control) can sit between its angles in the composition, and at rest it would hide that.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> angle(-2.0, 2.0), unit(0.0, 1.0);
    std::vector<std::vector<double>> poses(2, defaults);
    for (auto& pose : poses)
        for (std::size_t p = 0; p < pose.size(); ++p) {
            const RigParameter& r = parameters[p].parameter;
            if (period[p] > 0) pose[p] += angle(rng) * period[p] / (2.0 * std::numbers::pi);
            else if (r.max > r.min) pose[p] = r.min + unit(rng) * (r.max - r.min);
        }
    std::vector<std::vector<Eigen::Matrix4d>> worlds(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) approximation.evaluate(poses[i], worlds[i]);
    std::vector<char> used(parameters.size(), 0);
    std::vector<double> other;
    std::vector<Eigen::Matrix4d> otherWorlds;
    for (std::size_t i = 0; i < parameters.size(); ++i)
        for (std::size_t j = i + 1; j < parameters.size() && period[i] > 0 && !used[i]; ++j)
            for (std::size_t k = j + 1; k < parameters.size() && period[j] > 0 && !used[j]; ++k) {
                if (!(period[k] > 0) || used[k] || !eulerTriple(parameters[i], parameters[j], parameters[k])) continue;
                // Which of the three is in the middle of the composition: the one whose identity holds.
                const int a = static_cast<int>(i), b = static_cast<int>(j), c = static_cast<int>(k);
                for (const std::array<int, 3> t : {std::array{a, b, c}, std::array{b, a, c}, std::array{a, c, b}}) {
                    bool holds = true;
                    for (std::size_t s = 0; s < poses.size() && holds; ++s) {
                        other = poses[s];
                        otherSolution(t, other);
                        approximation.evaluate(other, otherWorlds);
                        holds = sameWorlds(worlds[s], otherWorlds);
                    }
                    if (!holds) continue;
                    triples.push_back(t);
                    used[i] = used[j] = used[k] = 1;
                    break;
                }
            }
}

}  // namespace rig
