#pragma once
// What learning is asked (LearnOptions) and the error measure every learning step judges by, apart from the learner
// (learner.h) so that its steps (classifier.h, ordering.h, constraint_fit.h) read them without it.
//
// Errors between two world matrices are measured as the largest displacement of the output's frame
// points within `frameRadius` cm of the joint (its origin and the ends of its axes): a length in cm
// that covers rotation, scale and translation alike. A fit is valid when, at every sample a,
// error(P(a) F_k(0), F_k(a)) / |a| < epsilon on every affected output k (the talk's test).

#include <cstdint>
#include <functional>
#include <string_view>

#include <Eigen/Core>

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
    // A magnitude curve or sampled operator is refined, while its sample budget allows, until its frame error at
    // every check is under this too (cm), wherever its range is: epsilon bounds an error per unit moved, which a long
    // range turns into more than the solver's target tolerance (1e-3 cm, what every frame is judged by); a tenth of it.
    double absoluteTolerance = 1e-4;
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

// The error measure above, for two world matrices.
double matrixError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double frameRadius);

// The share of epsilon per unit moved that a constraint's shape may miss by at the midpoints of its knots; the
// classifier takes what a constraint's frame moves within it for no effect.
inline constexpr double constraintFitShare = 0.5;

}  // namespace rig
