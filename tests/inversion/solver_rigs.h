#pragma once
// Rigs for the solver's tests: small RigFunctions with known answers, and a test-only adapter that
// makes a bundled rig file a RigFunction (the graph-backed RigFunction of nodes/ is not used here).

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>

#include <doctest/doctest.h>
#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/rotation_math.h"
#include "graph/plug_glob.h"
#include "graph/yaml_loader.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"
#include "nodes/builtin_nodes.h"
#include "test_rigs.h"
#include "test_support.h"

namespace rig::test {

inline constexpr double degree = std::numbers::pi / 180.0;

// A hand-made approximation's pieces: an output resting at `origin`, and a rotation operator about `axis` through
// `pivot` (slope 1).
inline ApproximationOutput restAt(const std::string& name, const Eigen::Vector3d& origin)
{
    ApproximationOutput out{name, Eigen::Matrix4d::Identity()};
    out.rest.block<3, 1>(0, 3) = origin;
    return out;
}

inline Operator rotationAbout(const Eigen::Vector3d& axis, const Eigen::Vector3d& pivot)
{
    Operator op;
    op.kind = OperatorKind::rotation;
    op.axis = axis.normalized();
    op.pivot = pivot;
    op.slope = 1.0;
    return op;
}

// Root translate X/Y/Z and rotate Y at the hips (1 m up); two arms hanging from the chest, each as
// fkArm: shoulder rotate X, Y, Z (R = Rx Ry Rz), elbow rotate Z after a 20 degree orient about Y,
// wrist rotate X; joints 25 cm apart, the left arm along +X, the right along -X. 14 parameters.
inline LambdaRig twoArms()
{
    std::vector<RigParameter> parameters{distance("root.translateX"), distance("root.translateY"),
                                         distance("root.translateZ"), angle("root.rotateY", -2.5, 2.5)};
    for (const char* side : {"L", "R"})
        for (const std::string name :
             {"shoulder.rotateX", "shoulder.rotateY", "shoulder.rotateZ", "elbow.rotateZ", "wrist.rotateX"}) {
            const bool elbow = name == "elbow.rotateZ";
            parameters.push_back(angle(std::string(side) + "_" + name, elbow ? 0.0 : -1.5, elbow ? 2.5 : 1.5));
        }
    return LambdaRig(
        std::move(parameters),
        {"hips", "L_shoulder", "L_elbow", "L_wrist", "L_hand", "R_shoulder", "R_elbow", "R_wrist", "R_hand"},
        [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
            const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                                  z = Eigen::Vector3d::UnitZ();
            w[0] = translation(v[0], 100 + v[1], v[2]) * rotation(y, v[3]);
            for (int side = 0; side < 2; ++side) {
                const double s = side == 0 ? 1.0 : -1.0;
                const std::size_t p = 4 + 5 * static_cast<std::size_t>(side);
                const std::size_t o = 1 + 4 * static_cast<std::size_t>(side);
                w[o] = w[0] * translation(s * 15, 40, 0) * rotation(x, v[p]) * rotation(y, v[p + 1]) *
                       rotation(z, v[p + 2]);
                w[o + 1] = w[o] * translation(s * 25, 0, 0) * rotation(y, 20 * degree) * rotation(z, v[p + 3]);
                w[o + 2] = w[o + 1] * translation(s * 25, 0, 0) * rotation(x, v[p + 4]);
                w[o + 3] = w[o + 2] * translation(s * 10, 0, 0);
            }
        });
}

// `count` copies of `one`, `spacing` cm apart along X and sharing nothing: a crowd of independent
// characters, whose parameters and outputs are one's prefixed "c0_", "c1_", ...
inline LambdaRig crowdOf(const LambdaRig& one, int count, double spacing)
{
    std::vector<RigParameter> parameters;
    std::vector<std::string> outputs;
    for (int c = 0; c < count; ++c) {
        for (RigParameter p : one.parameters()) {
            p.name = fmt::format("c{}_{}", c, p.name);
            parameters.push_back(p);
        }
        for (const std::string& o : one.outputs()) outputs.push_back(fmt::format("c{}_{}", c, o));
    }
    const std::size_t n = one.parameters().size(), m = one.outputs().size();
    return LambdaRig(parameters, outputs,
                     [one, n, m, count, spacing](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                         LambdaRig copy = one;
                         std::vector<Eigen::Matrix4d> member;
                         for (std::size_t c = 0; c < static_cast<std::size_t>(count); ++c) {
                             copy.evaluate(v.subspan(c * n, n), member);
                             for (std::size_t k = 0; k < m; ++k)
                                 w[c * m + k] = translation(spacing * static_cast<double>(c), 0, 0) * member[k];
                         }
                     });
}

// Two controls summed into one rotation (redundant), a rotation that saturates past +-0.5 rad
// (no effect there), and a plain hinge below the redundant joint.
inline LambdaRig redundantRig()
{
    return LambdaRig({angle("redundantA", -1.0, 1.0), angle("redundantB", -1.0, 1.0), angle("tip.rotateX"),
                      angle("saturated", -1.5, 1.5)},
                     {"joint", "tip", "end", "sat"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                         const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), z = Eigen::Vector3d::UnitZ();
                         w[0] = translation(0, 10, 0) * rotation(z, v[0] + v[1]);
                         w[1] = w[0] * translation(20, 0, 0) * rotation(x, v[2]);
                         w[2] = w[1] * translation(0, 0, 15);
                         w[3] =
                             translation(0, -10, 0) * rotation(z, std::clamp(v[3], -0.5, 0.5)) * translation(20, 0, 0);
                     });
}

// A hip (rotate X, Z) and a knee whose hinge pivot slides down the shin as it bends (0.8 cm per
// radian squared): rotation-like, so a fitted rotation is close but not exact.
inline LambdaRig slidingKnee()
{
    return LambdaRig({angle("hip.rotateX", -1.0, 1.0), angle("hip.rotateZ", -1.0, 1.0), angle("knee.bend", 0.0, 2.0)},
                     {"hip", "knee", "ankle", "toe"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                         const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), z = Eigen::Vector3d::UnitZ();
                         w[0] = translation(10, 90, 0) * rotation(x, v[0]) * rotation(z, v[1]);
                         const double slide = 0.8 * v[2] * v[2];
                         w[1] = w[0] * translation(0, -45 - slide, 0) * rotation(x, v[2]) * translation(0, slide, 0);
                         w[2] = w[1] * translation(0, -42, 0);
                         w[3] = w[2] * translation(0, -5, 12);
                     });
}

// A bundled rig file as a RigFunction: the parameters are plugs matched by globs (limits from the
// attribute, else +-120 degrees or +-30 cm about the current value; a connected one is disconnected),
// the outputs the world matrices of the named joints (all joints when none are named).
class GraphRig : public RigFunction {
public:
    GraphRig(const std::string& relativeFile, const std::vector<std::string>& parameterGlobs,
             const std::vector<std::string>& outputs = {})
        : graph_(loadGraphFile(sourceDir() / relativeFile, makeBuiltinRegistry())), file_(relativeFile)
    {
        for (const auto& glob : parameterGlobs)
            for (const Plug& plug : matchPlugs(*graph_, glob)) {
                if (graph_->plugType(plug) != ValueType::Double || !graph_->spec(plug).input) continue;
                // An animated control becomes a free one, as a rigger would disconnect it to invert it.
                if (const Connection* c = graph_->incomingConnection(plug)) graph_->disconnect(c->source, plug);
                const AttributeSpec& spec = graph_->spec(plug);
                RigParameter p;
                p.name = graph_->plugName(plug);
                p.defaultValue = std::get<double>(graph_->getValue(plug));
                p.angular = spec.unit == Unit::Angle;
                p.min = spec.min ? *spec.min : p.defaultValue - (p.angular ? 120 * degree : 30.0);
                p.max = spec.max ? *spec.max : p.defaultValue + (p.angular ? 120 * degree : 30.0);
                parameters_.push_back(p);
                parameterPlugs_.push_back(plug);
            }
        for (NodeId n = 0; n < graph_->nodeCount(); ++n)
            if (graph_->nodeType(n).name() == "joint" &&
                (outputs.empty() || std::find(outputs.begin(), outputs.end(), graph_->nodeName(n)) != outputs.end())) {
                outputs_.push_back(graph_->nodeName(n));
                outputPlugs_.push_back(graph_->plug(graph_->nodeName(n) + ".worldMatrix"));
            }
    }
    const std::vector<RigParameter>& parameters() const override { return parameters_; }
    const std::vector<std::string>& outputs() const override { return outputs_; }
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) override
    {
        ++count_;
        for (std::size_t i = 0; i < parameterPlugs_.size(); ++i) graph_->setValue(parameterPlugs_[i], values[i]);
        graph_->evaluate(outputPlugs_);
        worlds.resize(outputPlugs_.size());
        for (std::size_t k = 0; k < outputPlugs_.size(); ++k)
            worlds[k] = std::get<Eigen::Matrix4d>(graph_->getValue(outputPlugs_[k]));
    }
    std::uint64_t evaluationCount() const override { return count_; }
    std::string fingerprint() const override { return file_; }

private:
    std::unique_ptr<Graph> graph_;
    std::string file_;
    std::vector<RigParameter> parameters_;
    std::vector<Plug> parameterPlugs_;
    std::vector<std::string> outputs_;
    std::vector<Plug> outputPlugs_;
    std::uint64_t count_ = 0;
};

// The inversion parameters of rigs/biped.yaml (docs/rigs.md).
inline std::vector<std::string> bipedInversionGlobs()
{
    return {"root_ctrl.translate?",       "root_ctrl.rotate?",          "[LR]_hip_ctrl.rotate?",
            "[LR]_upLeg_fk_ctrl.rotate?", "[LR]_knee_fk_ctrl.rotateX",  "[LR]_foot_fk_ctrl.rotate?",
            "[LR]_toe_ctrl.rotate?",      "spine_ctrl.bend*",           "spine_ctrl.twist",
            "lowerBack_ctrl.rotate?",     "chest_ctrl.rotate?",         "neck_ctrl.rotate?",
            "head_ctrl.rotate?",          "[LR]_clavicle_ctrl.rotate?", "[LR]_arm_fk_ctrl.rotate?",
            "[LR]_elbow_ctrl.rotate?",    "[LR]_wrist_ctrl.rotate?",    "[LR]_hand_ctrl.fist",
            "[LR]_thumb_ctrl.rotate?"};
}

// The joints of rigs/biped.yaml that a CMU clip has (docs/rigs.md): no eyes (aimed at a world-space
// control), jaw, twist or finger joints.
inline std::vector<std::string> bipedCmuJoints()
{
    return {"Hips",
            "LHipJoint",
            "LeftUpLeg",
            "LeftLeg",
            "LeftFoot",
            "LeftToeBase",
            "LeftToeBase_end",
            "RHipJoint",
            "RightUpLeg",
            "RightLeg",
            "RightFoot",
            "RightToeBase",
            "RightToeBase_end",
            "LowerBack",
            "Spine",
            "Spine1",
            "Neck",
            "Neck1",
            "Head",
            "Head_end",
            "LeftShoulder",
            "LeftArm",
            "LeftForeArm",
            "LeftHand",
            "LeftFingerBase",
            "LFingers",
            "LFingers_end",
            "LThumb",
            "LThumb_end",
            "RightShoulder",
            "RightArm",
            "RightForeArm",
            "RightHand",
            "RightFingerBase",
            "RFingers",
            "RFingers_end",
            "RThumb",
            "RThumb_end"};
}

// Every animator parameter of rigs/nasty.yaml that docs/rigs.md lists.
inline std::vector<std::string> nastyGlobs()
{
    std::vector<std::string> globs{"root_ctrl.translate?", "arm_ctrl.rotate?"};
    for (const char* name : {"elbowBend", "kneeBend", "wristTwist", "spineBend", "coupledBend", "coupledTurn",
                             "saturated", "redundantA", "redundantB", "springy", "stretch"})
        globs.push_back(std::string("nasty_ctrl.") + name);
    return globs;
}

inline Approximation learn(RigFunction& rig, const std::string& name)
{
    LearnOptions options;
    options.validationPoses = 5;
    return learnApproximation(rig, options, name);
}

// Uniform values within each modelled parameter's limits.
inline std::vector<double> randomValues(const Approximation& a, std::mt19937& rng, double fraction = 1.0)
{
    std::vector<double> values;
    for (const auto& m : a.parameters) {
        const RigParameter& p = m.parameter;
        const double lo = p.defaultValue + fraction * (p.min - p.defaultValue);
        const double hi = p.defaultValue + fraction * (p.max - p.defaultValue);
        values.push_back(std::uniform_real_distribution<double>(lo, hi)(rng));
    }
    return values;
}

// Targets on every output: the approximation's own worlds at `values` (reachable exactly).
inline std::vector<JointTarget> targetsAt(const Approximation& a, std::span<const double> values)
{
    std::vector<Eigen::Matrix4d> worlds;
    a.evaluate(values, worlds);
    std::vector<JointTarget> targets(worlds.size());
    for (std::size_t k = 0; k < worlds.size(); ++k) {
        targets[k].active = true;
        targets[k].world = worlds[k];
    }
    return targets;
}

inline int parameterIndex(const Approximation& a, const std::string& name)
{
    for (std::size_t i = 0; i < a.parameters.size(); ++i)
        if (a.parameters[i].parameter.name == name) return static_cast<int>(i);
    return -1;
}

inline int outputIndex(const Approximation& a, const std::string& name)
{
    for (std::size_t i = 0; i < a.outputs.size(); ++i)
        if (a.outputs[i].name == name) return static_cast<int>(i);
    return -1;
}

// The real rig's worlds at `truth` as targets for every joint output (helper frames are never targets).
inline std::vector<JointTarget> realTargetsAt(const Approximation& a, RigBinding& binding,
                                              const std::vector<double>& truth)
{
    std::vector<Eigen::Matrix4d> worlds;
    binding.evaluate(truth, worlds);
    std::vector<JointTarget> targets(a.outputs.size());
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        targets[k].active = !a.outputs[k].helper;
        targets[k].world = worlds[k];
    }
    return targets;
}

// A cold start and a solve from rest, judged on the real rig: the largest distance of a targeted joint from its
// target, cm, plus `radiusCm` times its orientation error in radians (0: positions alone).
inline double solvedFromRest(const Approximation& a, const Solver& solver, RigBinding& binding,
                             const std::vector<JointTarget>& targets, double radiusCm = 0.0)
{
    std::vector<double> values = a.defaults();
    solver.initialGuess(targets, values);
    solver.solve(targets, values);
    std::vector<Eigen::Matrix4d> worlds;
    binding.evaluate(values, worlds);
    double worst = 0.0;
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        if (!targets[k].active) continue;
        double e = (worlds[k].block<3, 1>(0, 3) - targets[k].world.block<3, 1>(0, 3)).norm();
        if (radiusCm > 0.0)
            e += radiusCm * orientationAngle(worlds[k].block<3, 3>(0, 0), targets[k].world.block<3, 3>(0, 0));
        worst = std::max(worst, e);
    }
    return worst;
}

// How many of `poses` random poses of the real rig (each parameter within `fraction` of its range) a cold start and
// a solve from rest reach within 1e-3 cm of every target; each miss is reported.
inline int posesReachedFromRest(const Approximation& a, const Solver& solver, RigBinding& binding, std::mt19937& rng,
                                int poses, double fraction)
{
    int reached = 0;
    for (int pose = 0; pose < poses; ++pose) {
        const std::vector<JointTarget> targets = realTargetsAt(a, binding, randomValues(a, rng, fraction));
        const double worst = solvedFromRest(a, solver, binding, targets);
        if (worst < 1e-3) ++reached;
        else MESSAGE("pose " << pose << " missed by " << worst << " cm");
    }
    return reached;
}

}  // namespace rig::test
