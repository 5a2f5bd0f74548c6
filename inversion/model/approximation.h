#pragma once
// The learned approximation of a rig (the talk's F~): for every modelled parameter, its operators on
// the outputs it affects, in composition order. Stateless and cheap: evaluate() is const and safe to
// call from many threads, which is what makes a parallel Jacobian possible.
//
// An output is learned in world space (the talk) or relative to its parent output (DESIGN: frames):
//
//   world:     F~_k(beta) = M_k(beta) * F_k(0)
//   relative:  F~_k(beta) = F~_p(beta) * F_p(0)^-1 * M_k(beta) * F_k(0)        p = parent of k
//   M_k(beta)  = P_s1(a_s1) * ... * P_sm(a_sm),   a_i = beta_i - default_i,
//
// over the parameters that affect output k directly, s1 outermost (a root before a shoulder before an
// elbow). A relative output's operators act on its parent-relative transform, written in world
// coordinates at rest (conjugated by F_p(0)), so every operator of the file reads in one frame and an
// output's whole product is its ancestors' operators followed by its own.

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "inversion/model/constraint.h"
#include "inversion/model/operators.h"
#include "inversion/model/rig_function.h"

namespace rig {

struct ApproximationOutput {
    std::string name;                                    // the rig's joint
    Eigen::Matrix4d rest = Eigen::Matrix4d::Identity();  // F_k(0): world matrix at the rest values
    int parent = -1;  // the output it is learned relative to (index into Approximation::outputs); -1: world space
    double validationError = 0.0;  // its worst relative validation error (ValidationSummary), cm per unit
    // False: non-compositional. Some parameter moves it in a way no product of operators reproduces (a thigh
    // under an IK goal and a moving root): no operator acts on it, evaluate() does not predict it (its world
    // there is not meaningful), the solver does not count its target, and a hybrid solve (real_rig_solve.h)
    // fits it on the real rig. Always in world space (parent -1), and no output is relative to it.
    bool modelled = true;
    // A helper frame (RigFunction::helperOutputs): learned like a joint, read by constraint operators, never a
    // target (a clip's joint of the same name is not matched to it).
    bool helper = false;
    // Learned with a constraint operator (an index into Approximation::constraints): F~_k = B_k M_k F_k(0), its
    // base B_k read from other outputs instead of a parent's motion (parent -1). -1: none.
    int constraint = -1;
};

struct ModelledParameter {
    RigParameter parameter;
    // Outputs it affects directly (indices into Approximation::outputs), increasing: the outputs of
    // relative outputs below them move with them (Approximation::reach).
    std::vector<int> outputs;
    std::vector<Operator> operators;    // one shared by all its outputs, or one per output
    std::vector<int> operatorOfOutput;  // for each entry of `outputs`, its operator
    std::string form;                   // how it was modelled, for reports: "rotation", "per-output sampledRigid", ...
    double fitError = 0.0;              // worst validation error of its operators, cm per unit of the parameter
    int samples = 0;                    // rig samples of this parameter alone that the fit used
    double validationError = 0.0;       // worst relative validation error of the outputs it reaches, cm per unit
    // Ranges of its value (absolute, internal units) over which it moves nothing: a saturated control
    // (a clamp, a remap that flattens). An inversion cannot tell values inside one apart.
    std::vector<std::pair<double, double>> noEffect;
    // Outputs it moves where it is not modelled (non-compositional outputs, ApproximationOutput::modelled),
    // increasing. A parameter with no `outputs` but some of these is effective on the real rig only (an IK
    // goal, a pole vector): its operators are empty and only a hybrid solve moves it.
    std::vector<int> unmodelledOutputs;
};

struct DiscardedParameter {
    RigParameter parameter;
    std::string reason;
};

// A rig output the approximation leaves out: singular or not finite at rest, or history-dependent.
struct DroppedOutput {
    std::string name;
    std::string reason;
};

// Random poses within the limits of the modelled parameters, real rig against approximation.
struct ValidationSummary {
    int poses = 0;
    double maxPositionErrorCm = 0.0;
    double meanPositionErrorCm = 0.0;
    double maxRotationErrorDeg = 0.0;
    double meanRotationErrorDeg = 0.0;
    std::string worstOutput;  // where the largest position error is
    int worstPose = -1;       // and in which pose (0-based)
    // What epsilon bounds, over every pose and output: the output's frame error (learner.h) divided by
    // the sum of |offset| of the parameters that reach it, cm per unit of a parameter.
    double maxRelativeError = 0.0;
    std::string worstRelativeOutput;  // where it is
    std::string worstParameter;       // the parameter moved furthest there
    int nonFinitePoses = 0;           // poses where the real rig gave a non-finite matrix (not measured)
    bool withinEpsilon = true;        // maxRelativeError <= epsilon and every pose measured
    // (output, pose) pairs not measured because the output's twist share is undefined there (twistSingular: its
    // driver's angles at gimbal lock, or its swing or twist a half turn), and the first such output.
    int singularPoses = 0;
    std::string singularOutput;
};

struct TrainingSummary {
    std::uint64_t evaluations = 0;       // rig evaluations, all steps
    std::uint64_t orderEvaluations = 0;  // of which for the composition order
    double seconds = 0.0;
    std::string orderer;  // "talk" or "structured"
};

// A plug that was not inverted but held at a value while learning (a mode switch such as ikFk, a space
// switch, a rig setting): the rig is in that state wherever the approximation is used.
struct HeldPlug {
    std::string plug;    // the rig's plug, as the rig names it
    double value = 0.0;  // in the rig file's units (degrees for angles), as the user gives it
};

struct Approximation {
    std::string rigFile;         // as given when learning
    std::string rigFingerprint;  // RigFunction::fingerprint() of the rig it was learned from
    std::vector<HeldPlug> held;  // by plug name; the fingerprint covers them
    double epsilon = 0.0;        // the validation threshold used (cm per unit of a parameter)
    std::vector<ApproximationOutput> outputs;
    std::vector<ModelledParameter> parameters;  // composition order: outermost first
    std::vector<ConstraintBase> constraints;    // the outputs' constraint operators (ApproximationOutput::constraint)
    std::vector<DiscardedParameter> discarded;
    std::vector<DroppedOutput> droppedOutputs;
    ValidationSummary validation;
    TrainingSummary training;

    // World matrices of every output for these parameter values (one per entry of `parameters`,
    // absolute, internal units). `worlds` is resized. A caller that evaluates every frame keeps an
    // ApproximationEvaluator instead.
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) const;
    // The rest values of `parameters`.
    std::vector<double> defaults() const;
    // Per parameter, every output it moves: those it affects directly and the relative outputs below
    // them, increasing (its unmodelled outputs are not listed).
    std::vector<std::vector<int>> reach() const;
    // Whether some output is not modelled (a hybrid solve is needed to fit every target).
    bool hasUnmodelledOutputs() const;
    // The outputs with parents before children and a constraint's inputs before its output. Throws an internal
    // rig::Error for an index out of range or a cycle.
    std::vector<int> outputOrder() const;
    // What output k's frame reads: its parent, or its constraint's inputs (none: world space).
    std::vector<int> frameInputs(int k) const;
    // The outputs that move when output k does (its children, and the outputs whose constraint reads it),
    // per output.
    std::vector<std::vector<int>> dependents() const;
};

// Approximation::evaluate again and again without allocating (a player's frame, a crowd member's): the output order
// found once, the operators' matrices reused. Made for one approximation, which must outlive it and keep its outputs
// and constraints.
class ApproximationEvaluator {
public:
    explicit ApproximationEvaluator(const Approximation& approximation);
    const Approximation& approximation() const { return *approximation_; }
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds);

private:
    const Approximation* approximation_;
    std::vector<int> order_;  // Approximation::outputOrder()
    std::vector<Eigen::Matrix4d> matrices_;
};

// The rig output a blend's branch copy stands for ("LeftUpLeg" for "LeftUpLeg@ik" or "LeftUpLeg@fk", the copies
// inversion/learn/blend_merge.h makes); any other name as it is. A copy is never a target, and the real rig has no
// such joint: rig-invert reads the joint in its place.
std::string rigOutputName(const std::string& name);

}  // namespace rig
