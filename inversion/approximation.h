#pragma once
// The learned approximation of a rig (the talk's F~): for every modelled parameter, its operators on
// the outputs it affects, in composition order. Stateless and cheap: evaluate() is const and safe to
// call from many threads, which is what makes a parallel Jacobian possible.
//
//   F~_k(beta) = P_s1(a_s1) * ... * P_sm(a_sm) * F_k(0),   a_i = beta_i - default_i,
//
// over the parameters that affect output k, s1 outermost (a root before a shoulder before an elbow).

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "inversion/operators.h"
#include "inversion/rig_function.h"

namespace rig {

struct ApproximationOutput {
    std::string name;                                // the rig's joint
    Eigen::Matrix4d rest = Eigen::Matrix4d::Identity();  // F_k(0): world matrix at the rest values
};

struct ModelledParameter {
    RigParameter parameter;
    std::vector<int> outputs;           // outputs it affects (indices into Approximation::outputs), increasing
    std::vector<Operator> operators;    // one shared by all its outputs, or one per output
    std::vector<int> operatorOfOutput;  // for each entry of `outputs`, its operator
    std::string form;                   // how it was modelled, for reports: "rotation", "per-output sampledRigid", ...
    double fitError = 0.0;              // worst validation error of its operators, cm per unit of the parameter
    int samples = 0;                    // rig samples of this parameter alone that the fit used
};

struct DiscardedParameter {
    RigParameter parameter;
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
};

struct TrainingSummary {
    std::uint64_t evaluations = 0;       // rig evaluations, all steps
    std::uint64_t orderEvaluations = 0;  // of which for the composition order
    double seconds = 0.0;
    std::string orderer;                 // "talk" or "structured"
};

struct Approximation {
    std::string rigFile;         // as given when learning
    std::string rigFingerprint;  // RigFunction::fingerprint() of the rig it was learned from
    double epsilon = 0.0;        // the validation threshold used (cm per unit of a parameter)
    std::vector<ApproximationOutput> outputs;
    std::vector<ModelledParameter> parameters;  // composition order: outermost first
    std::vector<DiscardedParameter> discarded;
    ValidationSummary validation;
    TrainingSummary training;

    // World matrices of every output for these parameter values (one per entry of `parameters`,
    // absolute, internal units). `worlds` is resized.
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) const;
    // The rest values of `parameters`.
    std::vector<double> defaults() const;
};

}  // namespace rig
