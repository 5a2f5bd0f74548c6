#pragma once
// Classification of one parameter (section 3 of the talk): sample it alone, measure the world-space
// deltas D_k(a) = F_k(a) F_k(0)^-1 of the outputs it affects, and find the simplest operator form that
// validates: one analytic operator for all outputs (linear magnitude, then a curve), one per output,
// then sampled rigid or affine curves, refined where they miss. Internal to the learner.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "inversion/approximation.h"
#include "inversion/learner.h"
#include "inversion/rig_function.h"

namespace rig {

// Evaluates the rig with some parameters moved off their rest values, counting as it goes.
class RigProbe {
public:
    RigProbe(RigFunction& rig) : rig_(rig), values_(), defaults_()
    {
        for (const auto& p : rig.parameters()) defaults_.push_back(p.defaultValue);
        values_ = defaults_;
    }
    // World matrices with parameter i at default + a (and j at default + b when j >= 0).
    const std::vector<Eigen::Matrix4d>& at(int i, double a, int j = -1, double b = 0.0);
    const std::vector<Eigen::Matrix4d>& atRest() { return at(-1, 0.0); }
    // Any values of every parameter.
    const std::vector<Eigen::Matrix4d>& atValues(const std::vector<double>& values);
    const std::vector<double>& defaults() const { return defaults_; }
    RigFunction& rig() { return rig_; }

private:
    RigFunction& rig_;
    std::vector<double> values_;
    std::vector<double> defaults_;
    std::vector<Eigen::Matrix4d> worlds_;
};

struct Classification {
    int index = -1;  // the parameter's index in the rig
    bool modelled = false;
    ModelledParameter model;  // when modelled
    std::string reason;       // when not
    // For the order tests: a sample offset and the affected outputs' world matrices there.
    double orderOffset = 0.0;
    std::vector<Eigen::Matrix4d> orderWorlds;  // one per entry of model.outputs
    double effect = 0.0;                       // largest displacement over the samples, cm
};

// What the learner knows of the rig's state between parameters: the rest pose as last evaluated, and
// the outputs found to depend on earlier evaluations (a spring), which no parameter is modelled on.
struct RigState {
    std::vector<Eigen::Matrix4d> lastRest;
    std::vector<char> unreliable;  // per output
};

// Classifies one parameter. A parameter after whose samples some outputs do not come back to their
// rest pose marks them unreliable in `state`; it is modelled on its other outputs, if it moves any.
Classification classifyParameter(RigProbe& probe, int index, const std::vector<Eigen::Matrix4d>& rest, RigState& state,
                                 const LearnOptions& options);

}  // namespace rig
