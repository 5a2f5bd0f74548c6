#pragma once
// Classification of one parameter (section 3 of the talk): sample it alone, measure the world-space
// deltas D_k(a) = F_k(a) F_k(0)^-1 of the outputs it affects, and find the simplest operator form that
// validates: one analytic operator for all outputs (linear magnitude, then a curve), one per output,
// then sampled rigid or affine curves, refined where they miss. Internal to the learner.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "inversion/learn/learn_options.h"
#include "inversion/model/approximation.h"
#include "inversion/model/constraint.h"
#include "inversion/model/rig_function.h"

namespace rig {

// Evaluates the rig, counting as it goes, and sees each output in its learning frame (DESIGN: frames):
// world space, or relative to its parent output, W'_k = F_p(0) W_p^-1 W_k, which is F_k(0) at rest and
// moves only with what changes the output's parent-relative transform.
class RigProbe {
public:
    explicit RigProbe(RigFunction& rig);
    // Raw world matrices of every output: with parameter i at default + a (every parameter at rest when
    // i < 0), or at any values of every parameter. Each call is one rig evaluation.
    const std::vector<Eigen::Matrix4d>& at(int i, double a);
    const std::vector<Eigen::Matrix4d>& atValues(const std::vector<double>& values);
    const std::vector<double>& defaults() const { return defaults_; }
    // Raw worlds at the rest values, as first evaluated.
    const std::vector<Eigen::Matrix4d>& rest() const { return rest_; }
    RigFunction& rig() { return rig_; }

    // Per output, the output its frame is relative to; -1: world space. Empty: every output in world space.
    std::vector<int> parents;
    int parentOf(int k) const { return parents.empty() ? -1 : parents[static_cast<std::size_t>(k)]; }
    // Outputs learned with a constraint operator (inversion/model/constraint.h; its inputs are rig outputs): their
    // frame is the base's, B^-1 W_k, whatever `parents` says.
    std::map<int, ConstraintBase> constraints;
    // The outputs output k's frame reads: its constraint's inputs, or its parent (none in world space).
    std::vector<int> frameInputs(int k) const;
    // Output k in its frame, from its raw world and its parent's.
    Eigen::Matrix4d inFrame(int k, const Eigen::Matrix4d& world, const Eigen::Matrix4d& parentWorld) const;
    Eigen::Matrix4d inFrame(int k, const std::vector<Eigen::Matrix4d>& worlds) const;
    // Output k in its frame, reading raw worlds through worldOf(j) (k's and its frameInputs').
    template <class WorldOf>
    Eigen::Matrix4d inFrame(int k, const WorldOf& worldOf) const
    {
        if (const auto c = constraints.find(k); c != constraints.end()) {
            const ConstraintBase& b = c->second;
            const auto [anchor, second, third, orient, unused] = b.frameInputs();
            const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
            return inConstraintFrame(b, worldOf(k), anchor < 0 ? identity : worldOf(anchor),
                                     second < 0 ? identity : worldOf(second), third < 0 ? identity : worldOf(third),
                                     orient < 0 ? identity : worldOf(orient));
        }
        const int p = parentOf(k);
        return p < 0 ? Eigen::Matrix4d(worldOf(k)) : inFrame(k, worldOf(k), worldOf(p));
    }
    // B^-1 W for a constraint's base at its inputs' raw worlds (ConstraintBase::frameInputs; the anchor's and the
    // orient output's motions from their rest worlds).
    Eigen::Matrix4d inConstraintFrame(const ConstraintBase& base, const Eigen::Matrix4d& world,
                                      const Eigen::Matrix4d& anchorWorld, const Eigen::Matrix4d& secondWorld,
                                      const Eigen::Matrix4d& thirdWorld, const Eigen::Matrix4d& orientWorld) const;

private:
    RigFunction& rig_;
    std::vector<double> values_;
    std::vector<double> defaults_;
    std::vector<Eigen::Matrix4d> worlds_;
    std::vector<Eigen::Matrix4d> rest_;
};

// The raw samples of one parameter alone, kept while the learner tries other frames: classifying it
// again then costs no rig evaluation.
struct ParameterSamples {
    bool taken = false;
    std::vector<int> moved;  // outputs whose raw world moves at a first sample, increasing
    std::map<double, std::vector<Eigen::Matrix4d>> worlds;  // offset -> raw world per `moved` entry
    // The outputs whose raw world did not come back to rest after the first samples (the rest pose evaluated again),
    // increasing, with how far they stayed away (cm): only these, not every output, since the learner keeps every
    // parameter's samples and a crowd's outputs grow with its parameters (issue #35: quadratic memory).
    std::vector<std::pair<int, double>> restMoved;
    std::string historyDependent;  // what its first samples showed, if it made an output history-dependent

    // Raw world of output k at a sampled offset (its rest world when k does not move).
    const Eigen::Matrix4d& world(int k, double a, const std::vector<Eigen::Matrix4d>& rest) const;
};

struct Classification {
    int index = -1;  // the parameter's index in the rig
    bool modelled = false;
    ModelledParameter model;  // when modelled
    std::string reason;       // when not
    int failedOutput = -1;    // when not: the output where no operator fits (rig index), or -1
    // For the order tests: a sample offset and the affected outputs' worlds there, in their frames.
    double orderOffset = 0.0;
    std::vector<Eigen::Matrix4d> orderWorlds;  // one per entry of model.outputs
    double effect = 0.0;                       // largest displacement of a raw world over the samples, cm
    int reach = 0;                             // outputs whose raw world it moves
};

// What the learner knows of the rig's state between parameters: the outputs found to depend on earlier
// evaluations (a spring) or singular at rest, which no parameter is modelled on, and the outputs found
// non-compositional (LearnOptions::perOutput), which stay in the approximation without operators.
struct RigState {
    std::vector<char> unreliable;        // per output
    std::vector<char> nonCompositional;  // per output
    // Per output: a helper frame no constraint reads (yet): left out of classification and of the approximation.
    std::vector<char> idle;
};

// The first samples of parameter `index` alone: at its initial offsets, then at rest again, on `rig` in a
// fresh state (RigPool), so that they depend on nothing evaluated before. `rest` is every output at the
// rest values. Nothing is taken for a parameter whose range is empty.
void takeFirstSamples(RigFunction& rig, int index, const std::vector<Eigen::Matrix4d>& rest,
                      const LearnOptions& options, ParameterSamples& samples);

// Classifies one parameter in the probe's frames from its first samples (taken: takeFirstSamples),
// sampling the rig again only where `samples` has no sample yet. A parameter after whose first samples
// some outputs do not come back to their rest pose marks them unreliable in `state`; it is modelled on
// its other outputs, if it moves any.
Classification classifyParameter(RigProbe& probe, int index, RigState& state, ParameterSamples& samples,
                                 const LearnOptions& options);

}  // namespace rig
