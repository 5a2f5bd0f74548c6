#include "inversion/solve/continuity.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>

#include "core/error.h"
#include "inversion/clip/rig_binding.h"

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

namespace {

void otherSolution(const Equivalences& e, const std::array<int, 3>& t, std::span<double> values)
{
    const auto half = [&](int p) { return 0.5 * e.period[static_cast<std::size_t>(p)]; };
    const std::size_t a = static_cast<std::size_t>(t[0]), b = static_cast<std::size_t>(t[1]),
                      c = static_cast<std::size_t>(t[2]);
    values[a] += half(t[0]);
    values[b] = 2.0 * e.defaults[b] + half(t[1]) - values[b];
    values[c] += half(t[2]);
}

bool samePose(const std::vector<Eigen::Matrix4d>& a, const std::vector<Eigen::Matrix4d>& b)
{
    for (std::size_t k = 0; k < a.size(); ++k) {
        const double scale = 1.0 + a[k].cwiseAbs().maxCoeff();
        if (!((a[k] - b[k]).cwiseAbs().maxCoeff() <= 1e-9 * scale)) return false;
    }
    return true;
}

}  // namespace

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
                        otherSolution(*this, t, other);
                        approximation.evaluate(other, otherWorlds);
                        holds = samePose(worlds[s], otherWorlds);
                    }
                    if (!holds) continue;
                    triples.push_back(t);
                    used[i] = used[j] = used[k] = 1;
                    break;
                }
            }
}

ChunkShift noShift(const Equivalences& equivalences)
{
    ChunkShift shift;
    shift.otherSolution.assign(equivalences.triples.size(), 0);
    shift.turns.assign(equivalences.period.size(), 0.0);
    return shift;
}

namespace {

ChunkShift shiftToward(const Equivalences& e, std::span<const double> previous, std::span<const double> first,
                       bool eulerSolutions)
{
    if (previous.size() != e.period.size() || first.size() != e.period.size())
        throw internalError(fmt::format("continuityShift: {} and {} values for {} parameters", previous.size(),
                                        first.size(), e.period.size()));
    ChunkShift shift = noShift(e);
    const auto turnsToward = [&](std::size_t p, double value) {
        return e.period[p] > 0 ? std::round((previous[p] - value) / e.period[p]) : 0.0;
    };
    const auto gap = [&](std::size_t p, double value) {
        const double d = value + turnsToward(p, value) * e.period[p] - previous[p];
        return d * d;
    };
    std::vector<double> other(first.begin(), first.end());
    for (std::size_t t = 0; t < e.triples.size(); ++t) {
        otherSolution(e, e.triples[t], other);
        double now = 0.0, alternative = 0.0;
        for (const int p : e.triples[t]) {
            const std::size_t i = static_cast<std::size_t>(p);
            now += gap(i, first[i]);
            alternative += gap(i, other[i]);
        }
        shift.otherSolution[t] = eulerSolutions && alternative < now;
    }
    std::vector<double> carried(first.begin(), first.end());
    applyShift(e, shift, carried, carried);  // the Euler solutions chosen, no turns yet
    for (std::size_t p = 0; p < carried.size(); ++p) shift.turns[p] = turnsToward(p, carried[p]);
    return shift;
}

bool isIdentity(const ChunkShift& shift)
{
    return std::all_of(shift.otherSolution.begin(), shift.otherSolution.end(), [](char c) { return c == 0; }) &&
           std::all_of(shift.turns.begin(), shift.turns.end(), [](double t) { return t == 0.0; });
}

}  // namespace

ChunkShift continuityShift(const Equivalences& e, std::span<const double> previous, std::span<const double> first)
{
    return shiftToward(e, previous, first, true);
}

PoseCheck::PoseCheck(const Approximation& approximation, RigBinding* rig) : approximation_(approximation), rig_(rig) {}

bool PoseCheck::operator()(std::span<const double> a, std::span<const double> b)
{
    const auto& parameters = approximation_.parameters;
    for (std::size_t p = 0; p < parameters.size() && !rig_; ++p)
        if (a[p] != b[p] && !parameters[p].unmodelledOutputs.empty()) return false;
    approximation_.evaluate(a, first_);
    approximation_.evaluate(b, second_);
    for (std::size_t k = 0; k < first_.size(); ++k)
        if (!approximation_.outputs[k].modelled) first_[k] = second_[k];  // its matrix there is not meaningful
    if (!samePose(first_, second_)) return false;
    if (!rig_) return true;
    rig_->evaluate(a, first_);
    rig_->evaluate(b, second_);
    realRigEvaluations_ += 2;
    return samePose(first_, second_);
}

ChunkShift checkedContinuityShift(const Equivalences& e, std::span<const double> previous,
                                  std::span<const double> first, PoseCheck* check)
{
    ChunkShift shift = continuityShift(e, previous, first);
    if (!check || isIdentity(shift)) return shift;
    std::vector<double> shifted(first.size());
    for (const bool eulerSolutions : {true, false}) {
        if (!eulerSolutions) shift = shiftToward(e, previous, first, false);
        applyShift(e, shift, first, shifted);
        if ((*check)(first, shifted)) return shift;
    }
    return noShift(e);
}

void applyShift(const Equivalences& e, const ChunkShift& shift, std::span<const double> in, std::span<double> out)
{
    if (in.size() != e.period.size() || out.size() != in.size())
        throw internalError(
            fmt::format("applyShift: {} and {} values for {} parameters", in.size(), out.size(), e.period.size()));
    if (out.data() != in.data()) std::copy(in.begin(), in.end(), out.begin());
    for (std::size_t t = 0; t < e.triples.size(); ++t)
        if (shift.otherSolution[t]) otherSolution(e, e.triples[t], out);
    for (std::size_t p = 0; p < out.size(); ++p)
        if (shift.turns[p] != 0.0) out[p] += shift.turns[p] * e.period[p];
}

ChainContinuity::ChainContinuity(const Equivalences& equivalences, std::span<const double> before, PoseCheck* check)
    : equivalences_(equivalences),
      check_(check),
      shift_(noShift(equivalences)),
      reported_(before.begin(), before.end()),
      continuing_(!before.empty())
{
    if (continuing_ && before.size() != equivalences.period.size())
        throw Error(
            fmt::format("the frame before has {} values for {} parameters", before.size(), equivalences.period.size()));
    reported_.resize(equivalences.period.size());
}

std::span<const double> ChainContinuity::next(std::span<const double> solved, bool restart)
{
    if (restart)
        shift_ =
            continuing_ ? checkedContinuityShift(equivalences_, reported_, solved, check_) : noShift(equivalences_);
    applyShift(equivalences_, shift_, solved, reported_);
    continuing_ = true;
    return reported_;
}

bool ChainContinuity::shifted() const { return !isIdentity(shift_); }

}  // namespace rig
