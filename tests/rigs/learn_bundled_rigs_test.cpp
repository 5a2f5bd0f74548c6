// Learning the bundled rigs: pure FK rigs are modelled exactly (true axes and pivots, exact order),
// the nasty rig concludes what docs/rigs.md's table says parameter by parameter, and the biped trains
// within the talk's budget of rig evaluations.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "adapter/graph_rig_function.h"
#include "inversion/learn/learner.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

using namespace rig;

namespace {

const double degree = std::numbers::pi / 180;

const ModelledParameter* findModelled(const Approximation& a, const std::string& name)
{
    for (const auto& p : a.parameters)
        if (p.parameter.name == name) return &p;
    return nullptr;
}

const ModelledParameter& modelled(const Approximation& a, const std::string& name)
{
    const ModelledParameter* p = findModelled(a, name);
    if (!p) FAIL("not modelled: " << name);
    return *p;
}

const DiscardedParameter* findDiscarded(const Approximation& a, const std::string& name)
{
    for (const auto& d : a.discarded)
        if (d.parameter.name == name) return &d;
    return nullptr;
}

int position(const Approximation& a, const std::string& name)
{
    for (std::size_t i = 0; i < a.parameters.size(); ++i)
        if (a.parameters[i].parameter.name == name) return static_cast<int>(i);
    return -1;
}

// The operator a parameter applies to one output.
const Operator& operatorOn(const Approximation& a, const ModelledParameter& m, const std::string& output)
{
    for (std::size_t e = 0; e < m.outputs.size(); ++e)
        if (a.outputs[static_cast<std::size_t>(m.outputs[e])].name == output)
            return m.operators[static_cast<std::size_t>(m.operatorOfOutput[e])];
    FAIL(m.parameter.name << " does not affect " << output);
    return m.operators.front();
}

// A rotation operator about `axis` (either sign, with a slope of that sign) through `pivot`, to 1e-9.
void checkRotation(const ModelledParameter& m, const Eigen::Vector3d& axis, const Eigen::Vector3d& pivot,
                   double slope = 1.0)
{
    CAPTURE(m.parameter.name);
    REQUIRE(m.operators.size() == 1);
    const Operator& op = m.operators[0];
    CHECK(op.kind == OperatorKind::rotation);
    CHECK(op.linear());
    const double sign = op.axis.dot(axis) < 0 ? -1.0 : 1.0;
    CHECK((sign * op.axis - axis).norm() < 1e-9);
    CHECK(std::abs(sign * op.slope - slope) < 1e-9);
    CHECK((op.pivot - pivot).norm() < 1e-9);
}

Eigen::Vector3d rotateY(double angle, const Eigen::Vector3d& v)
{
    return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()) * v;
}

}  // namespace

TEST_CASE("learning rigs/examples/arm.yaml: every rotation exact, with the rig's axes and pivots")
{
    // At frame 0 the shoulder's animated rotateY holds -20 degrees and the elbow's driven rotateZ 0;
    // the elbow's joint orient turns it -10 degrees more about Y. The free channels are parameters.
    for (Orderer orderer : {Orderer::talk, Orderer::structured}) {
        CAPTURE(ordererName(orderer));
        GraphRigFunction rig(test::sourceDir() / "rigs/examples/arm.yaml",
                             {{"shoulder.rotate?", "elbow.rotate?", "wrist.rotate?"}, {}, {}});
        LearnOptions options;
        options.orderer = orderer;
        const Approximation a = learnApproximation(rig, options, "rigs/examples/arm.yaml");
        CHECK(a.discarded.empty());
        REQUIRE(a.parameters.size() == 7);
        const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(), z = Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d shoulder(20, 150, 0);
        const Eigen::Vector3d elbow = shoulder + rotateY(-20 * degree, 30 * x);
        const Eigen::Vector3d wrist = elbow + rotateY(-30 * degree, 25 * x);
        // Rotate order xzy on the shoulder (X first), xyz below; at rest every other angle is zero.
        checkRotation(modelled(a, "shoulder.rotateX"), rotateY(-20 * degree, x), shoulder);
        checkRotation(modelled(a, "shoulder.rotateZ"), rotateY(-20 * degree, z), shoulder);
        checkRotation(modelled(a, "elbow.rotateX"), rotateY(-30 * degree, x), elbow);
        checkRotation(modelled(a, "elbow.rotateY"), y, elbow);
        checkRotation(modelled(a, "wrist.rotateX"), rotateY(-30 * degree, x), wrist);
        checkRotation(modelled(a, "wrist.rotateY"), y, wrist);
        checkRotation(modelled(a, "wrist.rotateZ"), rotateY(-30 * degree, z), wrist);
        // R = Ry Rz Rx on the shoulder: Z outer of X; R = Rz Ry Rx below.
        CHECK(position(a, "shoulder.rotateZ") < position(a, "shoulder.rotateX"));
        CHECK(position(a, "shoulder.rotateX") < position(a, "elbow.rotateY"));
        CHECK(position(a, "elbow.rotateY") < position(a, "elbow.rotateX"));
        CHECK(position(a, "elbow.rotateX") < position(a, "wrist.rotateZ"));
        CHECK(position(a, "wrist.rotateZ") < position(a, "wrist.rotateY"));
        CHECK(position(a, "wrist.rotateY") < position(a, "wrist.rotateX"));
        CHECK(a.validation.maxPositionErrorCm < 1e-6);
        CHECK(a.validation.maxRotationErrorDeg < 1e-6);
    }
}

TEST_CASE("learning a bvh2rig rig of a CMU clip: every rotation exact against the BVH's own kinematics")
{
    const std::filesystem::path clipFile = "/usr/share/assimp/models/BVH/01_01.bvh";
    if (!std::filesystem::exists(clipFile)) {
        MESSAGE("[skipped] " << clipFile.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("learn-cmu");
    const auto rigFile = dir / "cmu.yaml";
    const auto made =
        test::run(fmt::format("{} '{}' -o '{}'", test::tool("bvh2rig"), clipFile.string(), rigFile.string()));
    REQUIRE(made.exitCode == 0);

    // The true axes and pivots from the BVH reader's independent forward kinematics at the rest pose.
    const BvhClip clip = readBvhFile(clipFile);
    const std::vector<double> zeros(static_cast<std::size_t>(clip.channelCount), 0.0);
    const std::vector<Eigen::Matrix4d> restWorlds = bvhWorldMatrices(clip, zeros);
    std::vector<std::string> globs{"Hips.translate?"};
    for (const auto& joint : clip.joints) globs.push_back(joint.name + ".rotate?");
    GraphRigFunction rig(rigFile, {globs, {}, {}});
    REQUIRE(rig.parameters().size() == 96);
    const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string());
    CHECK(a.discarded.empty());
    REQUIRE(a.parameters.size() == 96);
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        // At rest a joint's local rotation is the identity: its channels turn about its parent's axes.
        const Eigen::Matrix3d frame = restWorlds[j].block<3, 3>(0, 0);
        const Eigen::Vector3d pivot = restWorlds[j].block<3, 1>(0, 3);
        for (int c = 0; c < 3; ++c)
            checkRotation(modelled(a, clip.joints[j].name + ".rotate" + "XYZ"[c]), frame.col(c), pivot);
    }
    for (const char* t : {"Hips.translateX", "Hips.translateY", "Hips.translateZ"})
        CHECK(modelled(a, t).form == "translation");
    MESSAGE(fmt::format(
        "01_01.bvh rig: {} parameters, {} rig evaluations ({} for the order), validation {:.3g} cm, {:.3g} deg",
        a.parameters.size(), a.training.evaluations, a.training.orderEvaluations, a.validation.maxPositionErrorCm,
        a.validation.maxRotationErrorDeg));
    CHECK(a.validation.maxPositionErrorCm < 1e-6);
    CHECK(a.validation.maxRotationErrorDeg < 1e-6);
}

TEST_CASE("learning rigs/nasty.yaml: every parameter concludes what docs/rigs.md's table says")
{
    const std::vector<std::string> parameters{
        "root_ctrl.translate?", "arm_ctrl.rotate?",      "nasty_ctrl.elbowBend",   "nasty_ctrl.wristTwist",
        "nasty_ctrl.kneeBend",  "nasty_ctrl.spineBend",  "nasty_ctrl.coupledTurn", "nasty_ctrl.coupledBend",
        "nasty_ctrl.saturated", "nasty_ctrl.redundant?", "nasty_ctrl.springy",     "nasty_ctrl.stretch"};
    GraphRigFunction rig(test::sourceDir() / "rigs/nasty.yaml", {parameters, {}, {}});
    LearnOptions options;
    options.validationPoses = 10;
    const Approximation a = learnApproximation(rig, options, "rigs/nasty.yaml");
    const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(), z = Eigen::Vector3d::UnitZ();

    SUBCASE("exact: the root's translations, the shoulder's rotations in the order X, Z, Y")
    {
        const std::vector<std::pair<std::string, Eigen::Vector3d>> translations{
            {"root_ctrl.translateX", x}, {"root_ctrl.translateY", y}, {"root_ctrl.translateZ", z}};
        for (const auto& [name, axis] : translations) {
            const ModelledParameter& m = modelled(a, name);
            CHECK(m.form == "translation");
            CHECK((m.operators[0].axis - axis).norm() < 1e-9);
            CHECK(std::abs(m.operators[0].slope - 1.0) < 1e-9);
        }
        const Eigen::Vector3d shoulder(20, 150, 0);
        checkRotation(modelled(a, "arm_ctrl.rotateX"), x, shoulder);
        checkRotation(modelled(a, "arm_ctrl.rotateY"), y, shoulder);
        checkRotation(modelled(a, "arm_ctrl.rotateZ"), z, shoulder);
        CHECK(position(a, "arm_ctrl.rotateX") < position(a, "arm_ctrl.rotateZ"));
        CHECK(position(a, "arm_ctrl.rotateZ") < position(a, "arm_ctrl.rotateY"));
    }
    SUBCASE("exact: the driven-key elbow, a rotation about Z through the elbow with a curve magnitude")
    {
        const ModelledParameter& m = modelled(a, "nasty_ctrl.elbowBend");
        CHECK(m.form == "rotation (curve)");
        const Operator& op = m.operators[0];
        CHECK(std::abs(std::abs(op.axis.z()) - 1.0) < 1e-9);
        CHECK((op.pivot - Eigen::Vector3d(50, 150, 0)).norm() < 1e-9);
        // The key at 60 degrees: the elbow at 45 (a sample of the curve).
        CHECK(std::abs(op.axis.z() * op.magnitude(60 * degree)) == doctest::Approx(45 * degree).epsilon(1e-3));
    }
    SUBCASE(
        "exact per output: the wrist's roll, 1 on the wrist, 0.33 and 0.66 on the roll joints; the hand follows the "
        "wrist")
    {
        const ModelledParameter& m = modelled(a, "nasty_ctrl.wristTwist");
        CHECK(m.form == "per output: 3 rotation");
        // The hand is learned relative to the wrist: the roll moves it through its parent.
        const auto hand =
            std::find_if(a.outputs.begin(), a.outputs.end(), [](const auto& o) { return o.name == "hand"; });
        REQUIRE(hand != a.outputs.end());
        REQUIRE(hand->parent >= 0);
        CHECK(a.outputs[static_cast<std::size_t>(hand->parent)].name == "wrist");
        const auto reach = a.reach()[static_cast<std::size_t>(position(a, "nasty_ctrl.wristTwist"))];
        CHECK(std::count(reach.begin(), reach.end(), static_cast<int>(hand - a.outputs.begin())) == 1);
        const std::vector<std::pair<std::string, double>> shares{
            {"wrist", 1.0}, {"forearm_roll1", 0.33}, {"forearm_roll2", 0.66}};
        for (const auto& [output, share] : shares) {
            CAPTURE(output);
            const Operator& op = operatorOn(a, m, output);
            CHECK(op.kind == OperatorKind::rotation);
            CHECK(std::abs(std::abs(op.axis.x()) - 1.0) < 1e-9);
            CHECK(op.axis.x() * op.slope == doctest::Approx(share).epsilon(1e-9));
        }
    }
    SUBCASE("within epsilon: the sliding-pivot knee is a sampled rigid curve, a rotation only with a generous epsilon")
    {
        const ModelledParameter& m = modelled(a, "nasty_ctrl.kneeBend");
        CHECK(m.form == "per output: 1 sampledRigid");  // on the knee; the ankle follows it, relative to it
        CHECK(operatorOn(a, m, "knee").kind == OperatorKind::sampledRigid);
        GraphRigFunction knee(test::sourceDir() / "rigs/nasty.yaml", {{"nasty_ctrl.kneeBend"}, {"knee", "ankle"}, {}});
        LearnOptions generous;
        generous.epsilon = 5.0;
        generous.validationPoses = 0;
        CHECK(learnApproximation(knee, generous, "rigs/nasty.yaml").parameters.at(0).form == "rotation");
    }
    SUBCASE("exact: one parameter bending a chain of joints is a rotation on each, relative to its parent")
    {
        // In world space the composite of rotations about three pivots is no rotation about one pivot (it
        // was sampled); in each joint's parent-relative frame it is the joint's own rotation.
        const ModelledParameter& m = modelled(a, "nasty_ctrl.spineBend");
        CHECK(m.form == "per output: 3 rotation");
        for (const char* output : {"spine1", "spine2", "spine3"})
            CHECK(operatorOn(a, m, output).kind == OperatorKind::rotation);
        CHECK(m.validationError <= options.epsilon);
    }
    SUBCASE("coupled: coupledTurn is discarded as coupled, coupledBend is an exact rotation about X")
    {
        const DiscardedParameter* turn = findDiscarded(a, "nasty_ctrl.coupledTurn");
        REQUIRE(turn != nullptr);
        CHECK(turn->reason.starts_with("no effect on its own, but it changes what other parameters do (coupled"));
        checkRotation(modelled(a, "nasty_ctrl.coupledBend"), x, Eigen::Vector3d(-20, 150, 0));
    }
    SUBCASE("saturated: a rotation held past 30 degrees, with its flat ranges reported")
    {
        const ModelledParameter& m = modelled(a, "nasty_ctrl.saturated");
        CHECK(m.form == "rotation");  // linear where it acts, held beyond: exact, no spline round the kink
        const Operator& op = m.operators[0];
        const double sign = op.axis.z() < 0 ? -1.0 : 1.0;
        CHECK(sign * op.magnitude(90 * degree) == doctest::Approx(30 * degree).epsilon(1e-9));
        CHECK(sign * op.magnitude(-90 * degree) == doctest::Approx(-30 * degree).epsilon(1e-9));
        CHECK(sign * op.magnitude(20 * degree) == doctest::Approx(20 * degree).epsilon(1e-9));
        CHECK(op.magnitudeDerivative(80 * degree) == 0.0);
        CHECK(op.derivative(-80 * degree).isZero());
        CHECK(op.low == doctest::Approx(-30 * degree).epsilon(1e-6));
        CHECK(op.high == doctest::Approx(30 * degree).epsilon(1e-6));
        // Where it does nothing is reported: past +-30 degrees, to the bisection's resolution.
        REQUIRE(m.noEffect.size() == 2);
        CHECK(m.noEffect[0].first == doctest::Approx(-90 * degree));
        CHECK(m.noEffect[0].second == doctest::Approx(-30 * degree).epsilon(0.01));
        CHECK(m.noEffect[1].first == doctest::Approx(30 * degree).epsilon(0.01));
        CHECK(m.noEffect[1].second == doctest::Approx(90 * degree));
        CHECK(m.validationError <= options.epsilon);
    }
    SUBCASE("redundant: redundantA and redundantB, the same exact rotation")
    {
        const ModelledParameter& ra = modelled(a, "nasty_ctrl.redundantA");
        const ModelledParameter& rb = modelled(a, "nasty_ctrl.redundantB");
        checkRotation(ra, x, Eigen::Vector3d(-20, 90, 0));
        checkRotation(rb, x, Eigen::Vector3d(-20, 90, 0));
        CHECK(ra.outputs == rb.outputs);
        // Reported as a redundant pair, and the only one.
        const std::vector<std::pair<int, int>> pairs{
            std::minmax(position(a, "nasty_ctrl.redundantA"), position(a, "nasty_ctrl.redundantB"))};
        CHECK(redundantParameters(a) == pairs);
    }
    SUBCASE("history-dependent: springy cannot be modelled")
    {
        const DiscardedParameter* d = findDiscarded(a, "nasty_ctrl.springy");
        REQUIRE(d != nullptr);
        CHECK(d->reason.starts_with("history-dependent: after sampling it, the rest pose of springy moved"));
        for (const auto& out : a.outputs) CHECK(out.name.find("springy") == std::string::npos);
    }
    SUBCASE("not a talk operator: the volume-preserving stretch is a sampled affine curve on its joint")
    {
        const ModelledParameter& m = modelled(a, "nasty_ctrl.stretch");
        CHECK(m.form.starts_with("per output:"));
        CHECK(operatorOn(a, m, "stretchy").kind == OperatorKind::sampledAffine);
    }
    SUBCASE("nothing else is discarded")
    {
        CHECK(a.discarded.size() == 2);
        CHECK(a.parameters.size() == 15);
    }
}

TEST_CASE("learning rigs/biped.yaml: the 79 inversion parameters within the talk's budget of rig evaluations")
{
    // Globs of docs/rigs.md: the inversion parameters, and the CMU joints as outputs.
    const std::vector<std::string> parameters{
        "root_ctrl.translate?",       "root_ctrl.rotate?",          "[LR]_hip_ctrl.rotate?",
        "[LR]_upLeg_fk_ctrl.rotate?", "[LR]_knee_fk_ctrl.rotateX",  "[LR]_foot_fk_ctrl.rotate?",
        "[LR]_toe_ctrl.rotate?",      "spine_ctrl.bend*",           "spine_ctrl.twist",
        "lowerBack_ctrl.rotate?",     "chest_ctrl.rotate?",         "neck_ctrl.rotate?",
        "head_ctrl.rotate?",          "[LR]_clavicle_ctrl.rotate?", "[LR]_arm_fk_ctrl.rotate?",
        "[LR]_elbow_ctrl.rotate?",    "[LR]_wrist_ctrl.rotate?",    "[LR]_hand_ctrl.fist",
        "[LR]_thumb_ctrl.rotate?"};
    const std::vector<std::string> outputs{"Hips",      "[LR]HipJoint", "*Leg",        "*Foot",       "*ToeBase",
                                           "LowerBack", "Spine*",       "Neck*",       "Head",        "*Shoulder",
                                           "*Arm",      "*Hand",        "*FingerBase", "[LR]Fingers", "[LR]Thumb"};
    Approximation learned[2];
    for (Orderer orderer : {Orderer::talk, Orderer::structured}) {
        CAPTURE(ordererName(orderer));
        GraphRigFunction rig(test::sourceDir() / "rigs/biped.yaml", {parameters, outputs, {}});
        REQUIRE(rig.parameters().size() == 79);
        REQUIRE(rig.outputs().size() == 31);
        LearnOptions options;
        options.orderer = orderer;
        const Approximation a = learnApproximation(rig, options, "rigs/biped.yaml");
        MESSAGE(fmt::format(
            "biped, {} orderer: {} modelled, {} discarded, {} rig evaluations ({} for the order), {:.2f} s; "
            "validation on {} poses: position worst {:.3g} cm ({}, pose {}), mean {:.3g} cm; rotation worst {:.3g} deg",
            ordererName(orderer), a.parameters.size(), a.discarded.size(), a.training.evaluations,
            a.training.orderEvaluations, a.training.seconds, a.validation.poses, a.validation.maxPositionErrorCm,
            a.validation.worstOutput, a.validation.worstPose, a.validation.meanPositionErrorCm,
            a.validation.maxRotationErrorDeg));
        // The talk's orderer tests every pair on the rig; the structured one only pairs sharing an output
        // whose operators do not commute, within 1 300 evaluations for the whole training (the talk's is about 3 000):
        // 1 240 measured, the sliding knees' sampled operators refined to the absolute tolerance (LearnOptions;
        // before it, under 1 000).
        if (orderer == Orderer::talk) CHECK(a.training.orderEvaluations == 79 * 78 / 2);
        if (orderer == Orderer::structured) CHECK(a.training.evaluations <= 1300);
        CHECK(a.discarded.empty());
        CHECK(a.validation.withinEpsilon);
        CHECK(a.validation.poses == 60);
        CHECK(a.validation.maxPositionErrorCm < 0.05);
        CHECK(a.validation.maxRotationErrorDeg < 0.05);
        // The spine, chest and neck controls spread over several joints are exact in their joints'
        // parent-relative frames (they were discarded in world space).
        for (const char* name :
             {"spine_ctrl.bendForward", "spine_ctrl.twist", "chest_ctrl.rotateX", "neck_ctrl.rotateZ"})
            CHECK(findModelled(a, name) != nullptr);
        learned[orderer == Orderer::structured] = a;
    }
    // The structured orderer reaches the same approximation with fewer evaluations.
    CHECK(learned[1].training.orderEvaluations < learned[0].training.orderEvaluations);
    CHECK(learned[1].parameters.size() == learned[0].parameters.size());
    CHECK(learned[1].validation.maxPositionErrorCm ==
          doctest::Approx(learned[0].validation.maxPositionErrorCm).epsilon(1e-6));
}
