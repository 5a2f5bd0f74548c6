#pragma once
// Learning a rig's approximation (sections 3 and 4 of the talk, and past them): classify each
// parameter by sampling it alone, order the parameters, validate on random poses, every fit judged by the error
// measure of learn_options.h.

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "inversion/learn/learn_options.h"
#include "inversion/model/approximation.h"
#include "inversion/model/rig_function.h"

namespace rig {

// Why the learner left an output non-compositional (ApproximationOutput::modelled false): what failed
// relative to its parent output (a pair of parameters with neither order there, no operator fitting, a
// validation over epsilon, or its parent not modelled) and the pair with neither order in world space.
// For reports only: the approximation file does not hold it.
struct UnmodelledOutput {
    std::string name;
    std::string reason;
};

// Learns the approximation of `rig` (its parameters all at their rest values but the one sampled).
// `rigFile` is recorded in the approximation. Numerical outcomes (a parameter that fits nothing, a
// pair that cannot be ordered, a validation over epsilon) are recorded in the approximation
// (discarded, droppedOutputs, validation.withinEpsilon), not thrown.
//
// Frames: every output with a parent output (RigFunction::outputParents) is first learned relative to
// it; an output where that fails (no operator fits, a pair has neither order there, or its validation
// exceeds epsilon) is learned again in world space, from the samples already taken. Where world space
// fails too, the output is non-compositional (LearnOptions::perOutput); `unmodelled`, when given, is set
// to those outputs with their reasons, in the order of the approximation's outputs.
Approximation learnApproximation(RigFunction& rig, const LearnOptions& options, const std::string& rigFile,
                                 std::vector<UnmodelledOutput>* unmodelled = nullptr);

// Measures `approximation` against `rig` on the poses learnApproximation validates on (its `validation` and its
// outputs' and parameters' validation errors): parameters matched by name (each must be the rig's; the rig's others
// at their defaults), outputs by name, those the rig lacks (a blend's branch copies, measured through their blends)
// not measured. For an approximation assembled from learned ones (a switch's branches merged, blend_merge.h).
void validateApproximation(RigFunction& rig, Approximation& approximation, const LearnOptions& options);

// Pairs of modelled parameters (indices into approximation.parameters, first < second) with the same
// effect: the same outputs, moved alike at offsets across the range both share (within `tolerance` cm
// of the error measure). An inversion cannot tell them apart; it has to split their sum.
std::vector<std::pair<int, int>> redundantParameters(const Approximation& approximation, double tolerance = 1e-6,
                                                     double frameRadius = 10.0);

}  // namespace rig
