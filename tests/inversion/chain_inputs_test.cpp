// A planar chain's inputs as production rigs give them. An output turning as another does (ConstraintBase::orient):
// an IK hand orient-constrained to its IK control, which no product of operators reproduces: the base's velocity
// against differences, the hand learned as such a chain, its file round trip, the Jacobian through it, poses solved
// from rest on the real rig.
#include <doctest/doctest.h>

#include <unistd.h>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <random>

#include "inversion/approximation.h"
#include "inversion/approximation_io.h"
#include "inversion/constraint.h"
#include "inversion/jacobian.h"
#include "inversion/learner.h"
#include "inversion/rig_binding.h"
#include "inversion/solver.h"
#include "nodes/graph_rig_function.h"
#include "solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

// A two-bone IK arm without stretch whose hand takes its IK control's rotation (an orientConstraint with the control
// aligned to the hand at rest), with a finger below the hand.
const std::string orientArm = R"(nodes:
  - {name: root_ctrl, type: transform, translate: [0, 140, 0]}
  - {name: clavicle, type: joint, parent: root_ctrl, translate: [5, 0, 0]}
  - {name: shoulder, type: joint, parent: clavicle, translate: [15, 0, 0]}
  - {name: elbow, type: joint, parent: shoulder}
  - {name: hand, type: joint, parent: elbow, rotateOrder: zxy}
  - {name: finger, type: joint, parent: hand, translate: [8, 1, 0]}
  - {name: arm_ik_ctrl, type: transform, translate: [65, 130, 0], rotate: [0, 0, -11.3], rotateOrder: zxy}
  - {name: arm_pole_ctrl, type: transform, translate: [45, 140, -40]}
  - {name: arm_ik, type: ikHandle, startTranslate: [15, 0, 0], midTranslate: [30, 0, 0], endTranslate: [28, 0, -0.01]}
  - {name: arm_pv, type: poleVectorConstraint, constraintRotatePivot: [15, 0, 0]}
  - {name: hand_orient, type: orientConstraint, constraintRotateOrder: zxy}
connections:
  - clavicle.worldMatrix -> arm_ik.startParentMatrix
  - clavicle.scale -> arm_ik.startInverseScale
  - arm_ik_ctrl.worldMatrix -> arm_ik.goalMatrix
  - arm_pole_ctrl.worldMatrix -> arm_pv.targetMatrix[0]
  - clavicle.worldMatrix -> arm_pv.pivotSpace
  - arm_pv.constraintTranslate -> arm_ik.poleVector
  - arm_ik.startRotate -> shoulder.rotate
  - arm_ik.midRotate -> elbow.rotate
  - arm_ik.outMidTranslate -> elbow.translate
  - arm_ik.outEndTranslate -> hand.translate
  - arm_ik_ctrl.worldMatrix -> hand_orient.targetMatrix[0]
  - elbow.worldInverseMatrix -> hand_orient.constraintParentInverseMatrix
  - hand_orient.constraintRotate -> hand.rotate
)";

struct LearnedOrientArm {
    std::filesystem::path file =
        test::writeFile(test::scratchDir(fmt::format("chain-inputs.{}", ::getpid())) / "orient_arm.yaml", orientArm);
    GraphRigFunction rig{file, [] {
                             GraphRigOptions options{{"root_ctrl.translate?", "arm_ik_ctrl.translate?",
                                                      "arm_ik_ctrl.rotate?", "arm_pole_ctrl.translate?"},
                                                     {"clavicle", "shoulder", "elbow", "hand", "finger"},
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
        const Eigen::Matrix<double, 3, 4> analytic = orientedVelocity(vChain, vOrient, centre);
        CHECK((analytic - numeric.topRows<3>()).cwiseAbs().maxCoeff() < 1e-6 * std::max(1.0, analytic.norm()));
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
    const ApproximationOutput& hand = a.outputs[static_cast<std::size_t>(test::outputIndex(a, "hand"))];
    REQUIRE(hand.constraint >= 0);
    const ConstraintBase& c = a.constraints[static_cast<std::size_t>(hand.constraint)];
    CHECK(c.kind == ConstraintKind::planarChain);
    CHECK(a.outputs[static_cast<std::size_t>(c.orient)].name == "arm_ik_ctrl");
    CHECK(a.outputs[static_cast<std::size_t>(c.goal)].name == "arm_ik_ctrl");
    CHECK((c.origin - hand.rest.block<3, 1>(0, 3)).norm() < 1e-12);
    // The finger is the hand's child again once the hand is modelled.
    const ApproximationOutput& finger = a.outputs[static_cast<std::size_t>(test::outputIndex(a, "finger"))];
    CHECK(finger.parent == test::outputIndex(a, "hand"));

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
    int reached = 0;
    const int poses = 20;
    for (int pose = 0; pose < poses; ++pose) {
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.6));
        const double worst = test::solvedFromRest(a, solver, binding, targets);
        if (worst < 1e-3) ++reached;
        else MESSAGE("pose " << pose << " missed by " << worst << " cm");
    }
    CHECK(reached >= poses * 95 / 100);
}

}  // namespace rig
