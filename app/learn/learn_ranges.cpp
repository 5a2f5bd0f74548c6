#include "app/learn/learn_ranges.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <tuple>

#include <fmt/format.h>

#include "app/invert/invert_run.h"
#include "inversion/model/learned_range.h"

namespace rig::app {
namespace {

// The ranges of `approximation`'s parameters without declared limits that `values` (the clip's frames, internal
// units) leave, widened to cover them, in the rig file's units.
std::vector<WidenedRange> rangesToWiden(const Approximation& approximation,
                                        const std::vector<std::vector<double>>& values)
{
    std::vector<WidenedRange> widened;
    for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
        const RigParameter& parameter = approximation.parameters[p].parameter;
        if (parameter.limited) continue;  // the solver keeps it within its limits, which learning uses
        double low = std::numeric_limits<double>::infinity(), high = -low;
        for (const std::vector<double>& frame : values)
            if (std::isfinite(frame[p])) {  // a non-finite frame reached nowhere
                low = std::min(low, frame[p]);
                high = std::max(high, frame[p]);
            }
        if (!(low < parameter.min || high > parameter.max)) continue;
        WidenedRange w{parameter.name,
                       parameter.angular,
                       parameterUserValue(parameter, parameter.min),
                       parameterUserValue(parameter, parameter.max),
                       parameterUserValue(parameter, low),
                       parameterUserValue(parameter, high)};
        std::tie(w.min, w.max) = widenedRange(w.learnedMin, w.learnedMax, w.low, w.high);
        widened.push_back(w);
    }
    return widened;
}

}  // namespace

LearnOutcome learnCoveringClip(const LearnJob& job, const RangesFrom& from)
{
    LearnOutcome first = learn(job);
    InvertJob invertJob;
    invertJob.approximation = fmt::format("the first approximation of {}", job.rig);
    invertJob.loadedApproximation = std::make_shared<const Approximation>(first.approximation);
    invertJob.rig = job.rig;
    invertJob.plugins = job.plugins;
    invertJob.map = from.map;
    invertJob.take = from.take;
    invertJob.clip = from.clip;
    invertJob.frames = from.frames;
    const InvertOutcome inverted = invert(invertJob);
    ClipRanges ranges{from.clip, from.frames.value_or(""), statusCountsText(inverted.summary),
                      rangesToWiden(first.approximation, inverted.values)};
    if (ranges.widened.empty()) {
        first.clipRanges = std::move(ranges);
        return first;
    }
    // The widened ranges first: the first glob that matches a parameter gives its range.
    LearnJob again = job;
    again.ranges.clear();
    for (const WidenedRange& w : ranges.widened) again.ranges.push_back({exactGlob(w.parameter), w.min, w.max});
    again.ranges.insert(again.ranges.end(), job.ranges.begin(), job.ranges.end());
    LearnOutcome second = learn(again);
    second.clipRanges = std::move(ranges);
    return second;
}

}  // namespace rig::app
