#include "inversion/clip/continuity.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/error.h"
#include "inversion/clip/rig_binding.h"

namespace rig {

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
        e.otherSolution(e.triples[t], other);
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

PoseCheck::PoseCheck(const Approximation& approximation, RigBinding* rig)
    : approximation_(approximation), evaluator_(approximation), rig_(rig)
{
}

bool PoseCheck::operator()(std::span<const double> a, std::span<const double> b)
{
    const auto& parameters = approximation_.parameters;
    for (std::size_t p = 0; p < parameters.size() && !rig_; ++p)
        if (a[p] != b[p] && !parameters[p].unmodelledOutputs.empty()) return false;
    evaluator_.evaluate(a, first_);
    evaluator_.evaluate(b, second_);
    for (std::size_t k = 0; k < first_.size(); ++k)
        if (!approximation_.outputs[k].modelled) first_[k] = second_[k];  // its matrix there is not meaningful
    if (!sameWorlds(first_, second_)) return false;
    if (!rig_) return true;
    rig_->evaluate(a, first_);
    rig_->evaluate(b, second_);
    realRigEvaluations_ += 2;
    return sameWorlds(first_, second_);
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
        if (shift.otherSolution[t]) e.otherSolution(e.triples[t], out);
    for (std::size_t p = 0; p < out.size(); ++p)
        if (shift.turns[p] != 0.0) out[p] += shift.turns[p] * e.period[p];
}

ChainContinuity::ChainContinuity(const Equivalences& equivalences, std::span<const double> before, bool beforeWarm,
                                 PoseCheck* check)
    : equivalences_(equivalences),
      check_(check),
      shift_(noShift(equivalences)),
      reported_(before.begin(), before.end()),
      afterWarm_(!before.empty() && beforeWarm)
{
    if (!before.empty() && before.size() != equivalences.period.size())
        throw Error(
            fmt::format("the frame before has {} values for {} parameters", before.size(), equivalences.period.size()));
    reported_.resize(equivalences.period.size());
}

std::span<const double> ChainContinuity::next(std::span<const double> solved, bool restart)
{
    if (restart)
        shift_ = afterWarm_ ? checkedContinuityShift(equivalences_, reported_, solved, check_) : noShift(equivalences_);
    applyShift(equivalences_, shift_, solved, reported_);
    afterWarm_ = !restart;
    return reported_;
}

std::span<const double> ChainContinuity::again(std::span<const double> solved)
{
    applyShift(equivalences_, shift_, solved, reported_);
    return reported_;
}

bool ChainContinuity::shifted() const { return !isIdentity(shift_); }

}  // namespace rig
