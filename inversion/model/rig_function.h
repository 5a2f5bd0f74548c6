#pragma once
// The rig as the learner sees it: a black box F(beta) from parameter values to the world matrices of
// its outputs (the talk's rig function). It may be slow and one object is not thread-safe (a production
// rig is a stateful graph), but a rig may offer independent instances of itself, one per thread.
// inversion/ never sees how it is computed.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace rig {

struct RigParameter {
    std::string name;           // e.g. "L_arm_fk_ctrl.rotateX"
    double defaultValue = 0.0;  // the rest value, internal units (radians for angles, cm)
    double min = 0.0;           // the range sampled while learning (and validated on)
    double max = 0.0;
    bool angular = false;  // radians inside, degrees in files and reports
    // True: min and max are the control's own limits, which the solver keeps. False: the control has
    // none (a free rotation or translation) and min..max is only a range to learn from: the solver
    // may go past it, as an animator may.
    bool limited = true;
    // A transform's scale channel (Maya's scaleX, scaleY, scaleZ). A joint target never says how a control was
    // scaled, so where such a channel cannot be ordered with another the learner holds it at its rest value
    // (inversion/learn/ordering.h) instead of giving up the joints it moves. Read while learning; not in files.
    bool scale = false;
};

class RigFunction {
public:
    virtual ~RigFunction() = default;
    virtual const std::vector<RigParameter>& parameters() const = 0;
    // Names of the outputs (joints), in the order evaluate() writes them.
    virtual const std::vector<std::string>& outputs() const = 0;
    // For each output, its parent output: the nearest ancestor in the rig's joint hierarchy that is
    // itself an output (a joint's: a joint; a helper joint's: a joint or a helper), or -1 (none, a helper that is
    // not a joint, or a rig without a hierarchy). The learner may model an output relative to it (docs/rig-learn.md).
    virtual std::vector<int> outputParents() const { return std::vector<int>(outputs().size(), -1); }
    // For each output, whether it is a helper frame: a transform that is not a joint to invert (an IK goal, a pole
    // object, an aim target, a space-switch parent) but that outputs which do not compose are functions of. The
    // learner learns helpers like joints and reads them in constraint operators; a helper is never a target.
    // Helpers come after the joints in outputs().
    virtual std::vector<char> helperOutputs() const { return std::vector<char>(outputs().size(), 0); }
    // World matrices of every output for these values of every parameter (internal units).
    virtual void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) = 0;
    // Rig evaluations so far: the training cost the talk counts.
    virtual std::uint64_t evaluationCount() const = 0;
    // Identifies the rig (its files' contents), so an approximation can tell it was made for another.
    virtual std::string fingerprint() const = 0;
    // Another instance of the same rig, with its own state, to evaluate on another thread at the same
    // time as this one; it starts fresh (resetState) and counts its own evaluations. Null when the rig
    // cannot make one: work meant for instances then runs on this object, one item after another.
    virtual std::unique_ptr<RigFunction> instance() const { return nullptr; }
    // Forgets the evaluation history (history-dependent parts start again), as a fresh instance would.
    virtual void resetState() {}
};

}  // namespace rig
