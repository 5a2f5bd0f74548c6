#pragma once
// Fitting constraint operators (inversion/model/constraint.h) to the outputs the learner found non-compositional:
// internal to the learner. For an output k, the planar chain is tried with every pair of candidate inputs:
//
//   anchor  the nearest ancestor of k (RigFunction::outputParents) modelled by operators alone, or else a helper
//           whose motion carries the root (an IK start joint point-constrained to a control);
//   root    the origin of the topmost output between the anchor and k (k itself when it hangs from the anchor);
//   goal    a helper moved by some parameter that moves k but not the anchor (an IK goal);
//   pole    another such helper, or none (a pole carried by the anchor: the rotate-plane default);
//   orient  where no chain reproduces k, a helper whose rotation k's follows (an IK hand orient-constrained to its
//           control): the chain then gives k's position alone.
//
// Before it, the twist share: every output moved with k (and its parent output) as the driver, each of its axes, and
// its angles read in each pair of rotate orders; the share is the least-squares ratio of k's turn about its own axis
// to the driver's twist on random poses, and the best one is checked like a chain.
//
// Its shape G is sampled on random poses of the parameters that move k through those inputs (the others at rest),
// a spline over the reach through every sample, and it is kept when fresh random poses agree within epsilon per
// unit moved (LearnOptions::epsilon, the learner's measure), samples doubling up to LearnOptions::maxSamples.

#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "inversion/learn/classifier.h"
#include "inversion/learn/learn_options.h"
#include "inversion/model/constraint.h"

namespace rig {

// What fitting needs to know of the learner's state, and the rig evaluations it shares between outputs.
class ConstraintFitter {
public:
    // `samples`: every parameter's first samples (which outputs each moves); `hierarchy`: the rig's output
    // parents; `helper`: RigFunction::helperOutputs.
    ConstraintFitter(RigProbe& probe, const std::vector<ParameterSamples>& samples, std::vector<int> hierarchy,
                     std::vector<char> helper, const LearnOptions& options);

    // The twist share or planar chain for rig output k in the learner's current state, or nullopt with `why` set (the
    // family that came closest and its error).
    std::optional<ConstraintBase> fit(int k, const RigState& state, std::string& why);

    // The twist share alone, its anchor, driver and driver's parent outputs learned by operators or by a constraint
    // (fit reads operator outputs only): a roll joint under an IK forearm turns with the forearm by a share of the
    // hand's twist, both planar chain outputs, the hand fitted after the roll joint. Nullopt when none is within
    // epsilon.
    std::optional<ConstraintBase> twistShare(int k, const RigState& state);

    // Parameters held at their rest value, each with why: a constraint cannot carry what they do to an output it
    // frames. The learner models them nowhere; fitting leaves them at rest.
    const std::map<int, std::string>& held() const { return held_; }
    void hold(int parameter, std::string why) { held_.try_emplace(parameter, std::move(why)); }
    // Output k's movers that move none of the base's inputs (its own operators, composed after the base).
    std::vector<int> ownMovers(int k, const ConstraintBase& base) const;

    std::uint64_t evaluations() const { return evaluations_; }
    double epsilon() const { return options_.epsilon; }

private:
    struct Closest {  // the nearest miss so far: its error per unit moved, and what it was
        double error = std::numeric_limits<double>::infinity();
        std::string what;
    };
    struct Pose {
        std::vector<double> offsets;          // per varied parameter
        std::vector<Eigen::Matrix4d> worlds;  // every rig output
    };
    bool modelled(int a, const RigState& state) const;      // learned: by operators or a constraint
    bool usableAnchor(int a, const RigState& state) const;  // learned by operators alone
    // Whether h is below k in the rig's output hierarchy: its frame follows k's, so no constraint of k reads it (a
    // control chain's knee is no goal of its thigh).
    bool below(int h, int k) const;
    // The output whose orientation a chain's goal took at rest (an ikSCsolver's effector joint, below the chain's
    // root output or the root itself), or `root` where none did.
    int effectorOf(int goal, int root) const;
    // Whether `base` turns with its goal and its effector is the root itself: one bone, which does not bend.
    bool oneBoneTurnedByGoal(const ConstraintBase& base, int root) const;
    std::vector<int> moversOf(int k) const;  // parameters whose first samples moved output k, but the held ones
    bool turnedBy(int i, int o) const;       // whether parameter i's first samples turn output o
    // The parameters of `varied` that move the anchor and change k's world apart from a rigid motion (its scale or
    // shear: a control's non-uniform scale that the legs' scale constraints turn into sheared chains), which no base
    // can carry: each a rotation and a translation.
    std::vector<int> stretchingAnchorMovers(int k, const std::vector<int>& varied, int anchor) const;
    const std::vector<Pose>& poses(const std::vector<int>& varied, int set, int count);
    // The goal's sweep: its free parameters (without limits: the goal's translations) moved together so that the goal
    // moves along the chain's line at rest by t (to first order), the rig's worlds there kept by t. False when no
    // such parameter moves the goal apart from the anchor.
    struct Sweep {
        std::vector<int> parameters;
        Eigen::VectorXd direction;  // per parameter, its offset per unit of t
        std::map<double, std::vector<Eigen::Matrix4d>> worlds;
    };
    bool sweepFor(const ConstraintBase& base, const std::vector<int>& varied, int anchorOrPole, Sweep*& sweep);
    const std::vector<Eigen::Matrix4d>& sweepAt(Sweep& sweep, double t);
    // The base's shape from the sweep over reaches [lo, hi] (offsets from the rest reach): knots where the goal
    // sits, halved where a midpoint misses; false when no shape can be made (a degenerate pose).
    // A minimalTurn base's line turn is fitted there too, from the turns of the chain's start joint `rootOutput`.
    bool makeBase(int k, int rootOutput, Sweep& sweep, double lo, double hi, ConstraintBase& base);
    // G = C^-1 W_k W_k(0)^-1 C0 at one set of worlds, with its reach offset; false where the points span no plane.
    bool shapeAt(int k, const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds, double& x,
                 Eigen::Matrix4d& g) const;
    // A candidate's shape (swept, or constant for a fixed goal) and its worst error per unit moved on random poses;
    // infinite where it cannot be made.
    double tryCandidate(int k, int rootOutput, const std::vector<int>& varied, bool fixedGoal, ConstraintBase& base);
    // The twist share of k that the poses of `movers` fit best, if within epsilon: its anchor the nearest usable
    // ancestor, its driver and the driver's parent usable outputs, where `constraintInputs` makes outputs learned
    // with a constraint usable too (else operators alone: what fit tries first, before the other chains are fitted).
    std::optional<ConstraintBase> fitTwist(int k, const std::vector<int>& movers, const RigState& state,
                                           bool constraintInputs, Closest& closest);
    // k's turns about its own axis relative to its anchor's rotation on the poses (radians), with the base's axis and
    // centre; false when k does not turn on them.
    bool turnsOf(int k, const std::vector<Pose>& poses, ConstraintBase& base, std::vector<double>& theta) const;
    // The best share of one driver (over its axes and reading orders) for k's turns `theta` about its own axis;
    // false when the driver does not twist on these poses.
    bool bestShare(const std::vector<Pose>& poses, const std::vector<double>& theta, ConstraintBase& base) const;
    // The planar chain of k under `anchor` (its root output `root`) on poses of `varied`, over the goals and the poles
    // the helpers and the anchor give: the first within rounding (exactShare of epsilon), else the closest within
    // epsilon.
    // The planar chain of k with this anchor (its root output `root`), over the helpers its movers move apart from the
    // anchor and the fixed ones; `candidates` set when there was any.
    std::optional<ConstraintBase> fitAnchored(int k, int anchor, int root, const RigState& state, Closest& closest,
                                              bool& candidates);
    // The chain of k on poses of `varied`, with the pole and goal candidates given, or with k turning as an orient
    // source.
    std::optional<ConstraintBase> fitVaried(int k, int anchor, int root, const std::vector<int>& varied,
                                            const std::vector<int>& helpers, const std::vector<int>& goals,
                                            Closest& closest);
    // What an output carried by its nearest modelled ancestor reads: that ancestor (-1: the world), the modelled
    // helpers that what moves k moves (and, with fixedHelpers, those nothing moves), and k's movers that move either.
    struct Carried {
        int anchor = -1;
        std::vector<int> helpers, varied;
    };
    Carried carried(int k, const RigState& state, bool fixedHelpers) const;
    // k's oriented base (ConstraintKind::oriented): carried by its nearest modelled ancestor, turning as a helper
    // whose rotation k's follows on the poses of what moves k through either, if within epsilon.
    std::optional<ConstraintBase> fitOriented(int k, const RigState& state, Closest& closest);
    // k as a one-bone ikSCsolver chain: carried by its nearest modelled ancestor (operators or a constraint), its
    // rest line to a helper turned minimally onto that helper's origin (minimalTurn, a constant shape), if within
    // epsilon.
    std::optional<ConstraintBase> fitAimed(int k, const RigState& state, Closest& closest);
    // The helpers other than `anchor` whose motion carries the chain root's origin on the poses of k's movers (an IK
    // start joint point-constrained to a control), where the root moves.
    std::vector<int> rootCarriers(int k, int anchor, int root, const RigState& state);
    // With `orient` (an output, else -1), k's rotation is that output's motion's (ConstraintBase::orient).
    std::optional<ConstraintBase> fitChain(int k, int anchor, int root, const std::vector<int>& varied,
                                           const std::vector<int>& helpers, const std::vector<int>& goals,
                                           Closest& closest, int orient = -1);
    // The pole candidates of one pass of fitChain for k's chain on `goal` (without their anchor, goal and orient).
    std::vector<ConstraintBase> poleCandidates(int pass, int k, int anchor, int root, int goal,
                                               const std::vector<int>& varied, const std::vector<int>& helpers);
    // The outputs whose turns may carry a chain's pole vector (poleTurns): the goal and the other helpers that the
    // poses of `varied` turn and that no parameter turns without moving k.
    std::vector<int> poleCarriers(int k, int goal, const std::vector<int>& varied,
                                  const std::vector<int>& helpers) const;
    // The helpers whose rotation k's follows on the poses of `varied` (R_k R_k(0)^T = R_h R_h(0)^T, k turning on
    // some of them): an IK end orient-constrained to its control.
    std::vector<int> orientSources(int k, const std::vector<int>& varied, const std::vector<int>& helpers);
    // The up direction (unit, world at rest) that the output's turns on the poses carry with the plane through the
    // root, the goal and it, in the axes of output `carrier` (its turn from rest: the anchor's, a helper's; -1 the
    // world's); false when none does.
    bool fittedUp(int k, int anchor, const Eigen::Vector3d& root, int goal, const std::vector<Pose>& poses, int carrier,
                  Eigen::Vector3d& up) const;
    // Normals of the chain's rest plane: through its line and each joint off it below the chain's root output.
    std::vector<Eigen::Vector3d> restNormals(int chainRoot, const Eigen::Vector3d& root,
                                             const Eigen::Vector3d& goal) const;
    // Rest points of a pole carried by the anchor: along its axes at rest, and one more off the chain's line.
    std::vector<Eigen::Vector3d> fixedPoles(int anchor, const Eigen::Vector3d& root, const Eigen::Vector3d& goal) const;
    // The worst error per unit moved of the base's prediction of k on the poses.
    double error(int k, const ConstraintBase& base, const std::vector<Pose>& poses) const;
    Eigen::Matrix4d predicted(int k, const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds) const;
    // B at a pose's raw worlds (the anchor's motion from its rest world).
    Eigen::Matrix4d baseAt(const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds) const;
    // The chain's points at a pose's raw worlds.
    ChainPoints pointsAt(const ConstraintBase& base, const std::vector<Eigen::Matrix4d>& worlds) const;

    RigProbe& probe_;
    const std::vector<ParameterSamples>& samples_;
    std::vector<int> hierarchy_;
    std::vector<char> helper_;
    const LearnOptions& options_;
    std::map<std::pair<std::vector<int>, int>, std::vector<Pose>> poses_;  // (varied, set) -> poses
    std::map<std::pair<int, int>, Sweep> sweeps_;                          // (goal, anchor) -> its sweep
    std::uint64_t evaluations_ = 0;
    std::map<int, std::string> held_;
};

// The blend of an animated switch (constraint.h, BlendRule), found from samples: each the switch's weight, both
// branches' locals (the output relative to its parent output, read with the switch held at 1 and at 0) and the
// rig's local at that weight.
struct BlendSample {
    double weight = 0.0;
    Eigen::Matrix4d ik, fk, blended;
};

struct BlendFit {
    BlendRule rule;
    double error = 0.0;  // the worst matrixError over the samples, cm
};

// The blend that reproduces every sample within `tolerance` (matrixError at `frameRadius`), tried in turn: the Euler
// channels in each rotate order (Maya's order of the enum) with the translation and stretch linear, then the slerp;
// the first that does. None: no blend does (`closest`, when given, gets the nearest miss).
std::optional<BlendFit> fitBlendRule(const std::vector<BlendSample>& samples, double tolerance, double frameRadius,
                                     BlendFit* closest = nullptr);

}  // namespace rig
