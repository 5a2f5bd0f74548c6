#pragma once
// Learning a rig's approximation (sections 3 and 4 of the talk, and past them): classify each
// parameter by sampling it alone, order the parameters, validate on random poses.
//
// Errors between two world matrices are measured as the largest displacement of the output's frame
// points within `frameRadius` cm of the joint (its origin and the ends of its axes): a length in cm
// that covers rotation, scale and translation alike. A fit is valid when, at every sample a,
// error(P(a) F_k(0), F_k(a)) / |a| < epsilon on every affected output k (the talk's test).

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "inversion/model/approximation.h"
#include "inversion/model/rig_function.h"

namespace rig {

enum class Orderer {
    talk,        // every pair tested on the rig (the reference: what the talk does without structure)
    structured,  // only pairs sharing an output where their learned operators do not commute
};

std::string_view ordererName(Orderer orderer);

struct LearnOptions {
    // Validation threshold, cm of frame-point displacement per unit of the parameter (radian, cm).
    double epsilon = 1e-3;
    // Radius of the frame whose points measure an error, cm.
    double frameRadius = 10.0;
    // Samples of each parameter alone over its range, before any refinement (at least 2).
    int samples = 6;
    // Most samples a parameter may use when its magnitude curve or sampled operator is refined.
    int maxSamples = 64;
    // An output moving less than this (cm) is not affected by a parameter.
    double effectTolerance = 1e-7;
    Orderer orderer = Orderer::structured;
    // True: outputs with a parent output are learned relative to it where that validates (DESIGN:
    // frames). False: every output in world space, as in the talk.
    bool relativeFrames = true;
    // True: an output with a parent output (RigFunction::outputParents, relativeFrames) where a pair of parameters
    // has neither order, relative to its parent and in world space alike (a thigh under an IK goal and a moving
    // root: the rig says so, not a fit), is marked non-compositional (ApproximationOutput::modelled false), and
    // its parameters stay modelled on their other outputs. False, for an output without a parent, or in world
    // space (the talk's learning): the talk's behaviour, one parameter of such a pair is discarded.
    bool perOutput = true;
    // Random poses within the limits of the modelled parameters for the final validation.
    int validationPoses = 50;
    // Poses with every modelled parameter at its min or its max (chosen at random), validated as well.
    int limitPoses = 10;
    std::uint32_t seed = 1;
    // Rig instances evaluating the black box at the same time (RigFunction::instance; 0: all cores). The
    // approximation is the same for any count.
    int threads = 1;
    // Called with a stage name and the fraction done (0..1); may be empty.
    std::function<void(std::string_view stage, double fraction)> progress;

    // Throws rig::Error naming the field and its bad value.
    void validate() const;
};

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

// The error measure above, for two world matrices.
double matrixError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double frameRadius);

}  // namespace rig
