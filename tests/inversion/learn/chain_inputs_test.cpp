// A planar chain's inputs as production rigs give them. An output turning as another does (ConstraintBase::orient):
// an IK hand orient-constrained to its IK control, which no product of operators reproduces: the base's velocity
// against differences, the hand learned as such a chain, its file round trip, the Jacobian through it, poses solved
// from rest on the real rig. And a Maya scene's chain read from the graph: the goal the ikHandle itself under a
// control, the pole a poleVectorConstraint's target, the root carried by a control through a pointConstraint.
#include <doctest/doctest.h>

#include <unistd.h>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <random>

#include "adapter/graph_rig_function.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/ik_arm.h"
#include "inversion/learn/learner.h"
#include "inversion/learn/maya_chain_scene.h"
#include "inversion/model/approximation.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/constraint.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

// tests/inversion/ik_arm.h's arm (a two-bone IK without stretch) whose wrist takes its IK control's rotation through
// an orientConstraint, with a finger below the wrist.
std::string orientArm()
{
    std::string rig = test::ikArm;
    rig.insert(rig.find("connections:\n"),
               "  - {name: finger, type: joint, parent: wrist, translate: [8, 1, 0]}\n"
               "  - {name: wrist_orient, type: orientConstraint}\n");
    return rig +
           "  - arm_ik_ctrl.worldMatrix -> wrist_orient.targetMatrix[0]\n"
           "  - elbow.worldInverseMatrix -> wrist_orient.constraintParentInverseMatrix\n"
           "  - wrist_orient.constraintRotate -> wrist.rotate\n";
}

struct LearnedOrientArm {
    std::filesystem::path file =
        test::writeFile(test::scratchDir(fmt::format("chain-inputs.{}", ::getpid())) / "orient_arm.yaml", orientArm());
    GraphRigFunction rig{file, [] {
                             GraphRigOptions options{{"root_ctrl.translate?", "arm_ik_ctrl.translate?",
                                                      "arm_ik_ctrl.rotate?", "arm_pole_ctrl.translate?"},
                                                     {"clavicle", "shoulder", "elbow", "wrist", "finger"},
                                                     {},
                                                     {}};
                             options.autoHelpers = true;
                             return options;
                         }()};
    Approximation approximation = learnApproximation(rig, LearnOptions{}, file.string());
};

LearnedOrientArm& learnedOrientArm()
{
    static LearnedOrientArm arm;
    return arm;
}

Eigen::Matrix4d randomRigid(std::mt19937& rng)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 3>(0, 0) =
        Eigen::AngleAxisd(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    m.block<3, 1>(0, 3) = 20.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    return m;
}

Eigen::Matrix<double, 3, 4> randomTwist(std::mt19937& rng)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Matrix<double, 3, 4> v;
    const Eigen::Vector3d w(u(rng), u(rng), u(rng));
    v.leftCols<3>() << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
    v.col(3) = 5.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    return v;
}

// (I + hV) M: moving at dM = V M, which central differences need to first order only.
Eigen::Matrix4d moved(const Eigen::Matrix<double, 3, 4>& v, double h, const Eigen::Matrix4d& m)
{
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    step.topRows<3>() += h * v;
    return step * m;
}

}  // namespace

TEST_CASE("chain inputs: the oriented base's velocity is the derivative of the base it builds")
{
    std::mt19937 rng(17);
    ConstraintBase base;
    base.orient = 0;
    for (int trial = 0; trial < 20; ++trial) {
        CAPTURE(trial);
        base.origin = randomRigid(rng).block<3, 1>(0, 3);
        const Eigen::Matrix4d chain = randomRigid(rng), orient = randomRigid(rng);
        const Eigen::Matrix<double, 3, 4> vChain = randomTwist(rng), vOrient = randomTwist(rng);
        const Eigen::Matrix4d b = orientedBase(base, chain, orient);
        // The output's rest origin goes where the chain takes it; the rotation is the orient output's.
        CHECK((b.block<3, 3>(0, 0) - orient.block<3, 3>(0, 0)).norm() < 1e-12);
        CHECK((b * base.origin.homogeneous() - chain * base.origin.homogeneous()).norm() < 1e-10);
        const double h = 1e-6;
        const Eigen::Matrix4d numeric = (orientedBase(base, moved(vChain, h, chain), moved(vOrient, h, orient)) -
                                         orientedBase(base, moved(vChain, -h, chain), moved(vOrient, -h, orient))) /
                                        (2.0 * h) * b.inverse();
        const Eigen::Vector3d centre = chain.block<3, 3>(0, 0) * base.origin + chain.block<3, 1>(0, 3);
        const Eigen::Vector3d orientOmega(vOrient(2, 1), vOrient(0, 2), vOrient(1, 0));
        const Eigen::Matrix<double, 6, 1> analytic =
            orientedVelocity(vChain.leftCols<3>() * centre + vChain.col(3), orientOmega, centre);
        Eigen::Matrix<double, 6, 1> expected;
        expected << numeric(2, 1), numeric(0, 2), numeric(1, 0), numeric.block<3, 1>(0, 3);
        CHECK((analytic - expected).cwiseAbs().maxCoeff() < 1e-6 * std::max(1.0, analytic.norm()));
        // d B' B'^-1 is a twist: its rotation part is skew.
        CHECK((numeric.block<3, 3>(0, 0) + numeric.block<3, 3>(0, 0).transpose()).norm() < 1e-6);
    }
    // Without an orient output, the chain's base is the base.
    base.orient = -1;
    const Eigen::Matrix4d chain = randomRigid(rng);
    CHECK(orientedBase(base, chain, randomRigid(rng)) == chain);
}

TEST_CASE("chain inputs: an IK hand orient-constrained to its control is a planar chain turning as the control")
{
    const Approximation& a = learnedOrientArm().approximation;
    CHECK_FALSE(a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
    const ApproximationOutput& hand = a.outputs[static_cast<std::size_t>(test::outputIndex(a, "wrist"))];
    REQUIRE(hand.constraint >= 0);
    const ConstraintBase& c = a.constraints[static_cast<std::size_t>(hand.constraint)];
    CHECK(c.kind == ConstraintKind::planarChain);
    CHECK(a.outputs[static_cast<std::size_t>(c.orient)].name == "arm_ik_ctrl");
    CHECK(a.outputs[static_cast<std::size_t>(c.goal)].name == "arm_ik_ctrl");
    CHECK((c.origin - hand.rest.block<3, 1>(0, 3)).norm() < 1e-12);
    // The finger is the wrist's child again once the wrist is modelled.
    const ApproximationOutput& finger = a.outputs[static_cast<std::size_t>(test::outputIndex(a, "finger"))];
    CHECK(finger.parent == test::outputIndex(a, "wrist"));

    // The file keeps the orient output and the origin: the same worlds after a round trip.
    const Approximation back = approximationFromYaml(approximationToYaml(a), "orient_arm.approx.yaml");
    const ConstraintBase& read = back.constraints[static_cast<std::size_t>(hand.constraint)];
    CHECK(read.orient == c.orient);
    CHECK(read.origin == c.origin);
    std::mt19937 rng(7);
    const std::vector<double> values = test::randomValues(a, rng, 0.8);
    std::vector<Eigen::Matrix4d> before, after;
    a.evaluate(values, before);
    back.evaluate(values, after);
    CHECK(before == after);
}

TEST_CASE("chain inputs: the analytic Jacobian through a turning chain equals central differences")
{
    LearnedOrientArm& arm = learnedOrientArm();
    const Approximation& a = arm.approximation;
    RigBinding binding(a, arm.rig);
    std::mt19937 rng(11);
    for (int pose = 0; pose < 10; ++pose) {
        CAPTURE(pose);
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.8));
        const std::vector<double> values = test::randomValues(a, rng, 0.8);
        JacobianEvaluator evaluator(a, targets, 10.0);
        REQUIRE(evaluator.structure().hasBases());
        Eigen::MatrixXd analytic, numeric;
        Eigen::VectorXd r1, r2;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, analytic, r1);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-5, numeric, r2);
        CHECK((r1 - r2).norm() == doctest::Approx(0.0));
        CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-5 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
    }
}

TEST_CASE("chain inputs: poses of the arm whose hand turns with its control are reached from rest on the real rig")
{
    LearnedOrientArm& arm = learnedOrientArm();
    const Approximation& a = arm.approximation;
    RigBinding binding(a, arm.rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(5);
    const int poses = 20;
    CHECK(test::posesReachedFromRest(a, solver, binding, rng, poses, 0.6) >= poses * 95 / 100);
}

}  // namespace rig

namespace rig {
namespace {

// A two-bone chain j1 -> j2 -> j3 whose ikHandle is parented under hand_ctrl (the goal is the handle's own world
// position), its pole vector constrained to pole_ctrl, and its start joint point-constrained to shoulder_ctrl: Maya's
// own inputs throughout (the constraints read their targets' translate, pivots and parent matrix apart).
const std::string mayaChain = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "shoulder_ctrl";
	setAttr ".t" -type "double3" 0 10 0 ;
createNode transform -n "hand_ctrl";
	setAttr ".t" -type "double3" 7 13.9 0.1 ;
createNode transform -n "pole_ctrl";
	setAttr ".t" -type "double3" 4 14 -6 ;
createNode joint -n "root_jnt";
createNode joint -n "j1" -p "root_jnt";
	setAttr ".t" -type "double3" 0 10 0 ;
createNode joint -n "j2" -p "j1";
	setAttr ".t" -type "double3" 5 0 0 ;
	setAttr ".r" -type "double3" 0 0 90 ;
createNode joint -n "j3" -p "j2";
	setAttr ".t" -type "double3" 4 0 0 ;
createNode ikEffector -n "effector1" -p "j2";
createNode ikHandle -n "ikHandle1" -p "hand_ctrl";
	setAttr ".t" -type "double3" -2 0.1 -0.1 ;
	setAttr ".roc" yes;
)" + test::mayaChainConnections;

}  // namespace

TEST_CASE("chain inputs: a Maya chain's goal is its ikHandle, its pole the constraint's target, its root a control's")
{
    const auto file =
        test::writeFile(test::scratchDir(fmt::format("chain-inputs-maya.{}", ::getpid())) / "chain.ma", mayaChain);
    GraphRigOptions options{{"shoulder_ctrl.translate?", "hand_ctrl.translate?", "pole_ctrl.translate?"},
                            {"root_jnt", "j1", "j2", "j3"},
                            {},
                            {}};
    options.autoHelpers = true;
    GraphRigFunction rig(file, options);
    // The helper frames: the handle (a transform whose world position its solver reads inside the node) and the
    // constraints' targets (read through their channels, not a world matrix).
    std::vector<std::string> helpers;
    for (std::size_t k = 0; k < rig.outputs().size(); ++k)
        if (rig.helperOutputs()[k]) helpers.push_back(rig.outputs()[k]);
    CHECK(helpers == std::vector<std::string>{"hand_ctrl", "ikHandle1", "pole_ctrl", "shoulder_ctrl"});
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    CHECK_FALSE(a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
    const auto name = [&](int k) { return k < 0 ? std::string("-") : a.outputs[static_cast<std::size_t>(k)].name; };
    for (const char* joint : {"j1", "j2"}) {
        CAPTURE(joint);
        const ApproximationOutput& o = a.outputs[static_cast<std::size_t>(test::outputIndex(a, joint))];
        REQUIRE(o.constraint >= 0);
        const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
        CHECK(name(c.anchor) == "shoulder_ctrl");
        CHECK(name(c.goal) == "ikHandle1");
        CHECK(name(c.pole) == "pole_ctrl");
    }
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(3);
    const int poses = 20;
    CHECK(test::posesReachedFromRest(a, solver, binding, rng, poses, 0.5) >= poses * 95 / 100);
}

}  // namespace rig
