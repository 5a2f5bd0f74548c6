// Twist shares (inversion/model/constraint.h): the driver's twist and its gradient, the base's velocity against central
// differences with stretched inputs, random roll joints learned and solved, and the biped with every joint.
#include <doctest/doctest.h>

#include <unistd.h>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "core/rotation_math.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/constraint.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

constexpr std::array orders{RotateOrder::xyz, RotateOrder::yzx, RotateOrder::zxy,
                            RotateOrder::xzy, RotateOrder::yxz, RotateOrder::zyx};

Eigen::Matrix3d randomRotation(std::mt19937& rng)
{
    std::normal_distribution<double> n;
    return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

ConstraintBase randomTwistShare(std::mt19937& rng)
{
    std::uniform_int_distribution<int> order(0, 5), axis(0, 2);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    ConstraintBase base;
    base.kind = ConstraintKind::twistShare;
    base.readOrder = orders[static_cast<std::size_t>(order(rng))];
    base.twistOrder = orders[static_cast<std::size_t>(order(rng))];
    base.twistAxis = axis(rng);
    base.share = u(rng);
    base.axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    base.root = 10.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    base.driverRest = randomRotation(rng);
    return base;
}

// A world with a stretch along one of its axes (as a squash-stretch joint's), or rigid.
Eigen::Matrix4d randomWorld(std::mt19937& rng, bool stretched)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    const Eigen::Vector3d scale = stretched ? Eigen::Vector3d(1.5 + u(rng), 0.8, 0.8) : Eigen::Vector3d::Ones();
    m.block<3, 3>(0, 0) = randomRotation(rng) * scale.asDiagonal();
    m.block<3, 1>(0, 3) = 20.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    return m;
}

// A spatial velocity [L | v] and the motion exp(t [L v; 0 0]) it makes.
Eigen::Matrix<double, 3, 4> randomVelocity(std::mt19937& rng)
{
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Matrix<double, 3, 4> v;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j) v(i, j) = u(rng);
    return v;
}

Eigen::Matrix4d moved(const Eigen::Matrix<double, 3, 4>& velocity, double t, const Eigen::Matrix4d& m)
{
    Eigen::Matrix4d x = Eigen::Matrix4d::Zero();
    x.topRows<3>() = t * velocity;
    return Eigen::Matrix4d(x.exp()) * m;
}

}  // namespace

TEST_CASE("twist share: the driver's twist in closed form, and its gradient against central differences")
{
    std::mt19937 rng(11);
    ConstraintBase base = randomTwistShare(rng);
    base.driverRest.setIdentity();
    base.readOrder = base.twistOrder = RotateOrder::zxy;
    base.twistAxis = 0;
    // A turn about the twist axis is all twist, one across it none, whichever order reads it.
    CHECK(driverTwist(base, Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()).toRotationMatrix()) ==
          doctest::Approx(0.7));
    CHECK(driverTwist(base, Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitY()).toRotationMatrix()) ==
          doctest::Approx(0.0));
    // Read in another order: the angles of R in zxy taken as yzx, as a twist node reading a driver's rotate does.
    base.twistOrder = RotateOrder::yzx;
    const Eigen::Vector3d angles(0.4, -0.3, 0.9);
    const Eigen::Quaterniond q(eulerToMatrix(angles, RotateOrder::yzx));
    CHECK(driverTwist(base, eulerToMatrix(angles, RotateOrder::zxy)) ==
          doctest::Approx(2.0 * std::atan2(q.x(), q.w())).epsilon(1e-12));
    for (int trial = 0; trial < 200; ++trial) {
        CAPTURE(trial);
        const ConstraintBase b = randomTwistShare(rng);
        const Eigen::Matrix3d r = randomRotation(rng);
        if (twistSingular(b, r)) continue;
        Eigen::Vector3d gradient;
        driverTwist(b, r, &gradient);
        const double h = 1e-6;
        for (int i = 0; i < 3; ++i) {
            const Eigen::Matrix3d plus = r * Eigen::AngleAxisd(h, Eigen::Vector3d::Unit(i)).toRotationMatrix();
            const Eigen::Matrix3d minus = r * Eigen::AngleAxisd(-h, Eigen::Vector3d::Unit(i)).toRotationMatrix();
            const double numeric = nearestTurn(driverTwist(b, plus) - driverTwist(b, minus), 0.0) / (2.0 * h);
            CHECK(gradient[i] == doctest::Approx(numeric).epsilon(1e-5).scale(1.0));
        }
    }
}

TEST_CASE("twist share: the base's velocity equals central differences, stretched anchors and drivers included")
{
    std::mt19937 rng(5);
    for (int trial = 0; trial < 100; ++trial) {
        CAPTURE(trial);
        const ConstraintBase base = randomTwistShare(rng);
        const std::array<Eigen::Matrix4d, 3> worlds{randomWorld(rng, trial % 2 == 0), randomWorld(rng, trial % 3 == 0),
                                                    randomWorld(rng, false)};
        const TwistLinearization at = linearizeTwist(base, worlds[0], worlds[1], worlds[2]);
        if (twistSingular(base, polarRotation(worlds[2].block<3, 3>(0, 0)).transpose() *
                                    polarRotation(worlds[1].block<3, 3>(0, 0))))
            continue;
        const std::array<Eigen::Matrix<double, 3, 4>, 3> velocities{randomVelocity(rng), randomVelocity(rng),
                                                                    randomVelocity(rng)};
        const Eigen::Matrix<double, 3, 4> analytic = twistVelocity(at, velocities[0], velocities[1], velocities[2]);
        const double h = 1e-6;
        const auto baseAt = [&](double t) {
            return constraintBase(base, moved(velocities[0], t, worlds[0]), moved(velocities[1], t, worlds[1]),
                                  moved(velocities[2], t, worlds[2]), Eigen::Matrix4d::Identity());
        };
        const Eigen::Matrix4d numeric = (baseAt(h) - baseAt(-h)) / (2.0 * h) * at.base.inverse();
        CHECK((analytic - numeric.topRows<3>()).cwiseAbs().maxCoeff() < 1e-6 * std::max(1.0, analytic.norm()));
        // The base is rigid, turning about the axis through c0 as the anchor carries it.
        CHECK((at.base.block<3, 3>(0, 0).transpose() * at.base.block<3, 3>(0, 0) - Eigen::Matrix3d::Identity()).norm() <
              1e-12);
    }
}

namespace {

// A random roll joint under a forearm, turned by a twistDistribute reading the hand control's rotate in some order
// (its own or another), about some axis, by some weight; the forearm and hand with random joint orients, and a
// stretch on the forearm that the roll joint does not inherit.
std::string randomRollRig(std::mt19937& rng, std::string& twistAxis, double& weight)
{
    std::uniform_int_distribution<int> order(0, 5), axis(0, 2);
    std::uniform_real_distribution<double> u(-1.0, 1.0), angle(-60.0, 60.0);
    const auto name = [](RotateOrder o) { return std::string(rotateOrderName(o)); };
    const std::string handOrder = name(orders[static_cast<std::size_t>(order(rng))]);
    const std::string readOrder = rng() % 2 ? handOrder : name(orders[static_cast<std::size_t>(order(rng))]);
    twistAxis = std::string(1, "xyz"[axis(rng)]);
    weight = 0.2 + 0.6 * std::abs(u(rng));
    if (rng() % 2) weight = -weight;
    const auto v3 = [](double a, double b, double c) { return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", a, b, c); };
    std::string yaml = "nodes:\n";
    yaml += "  - {name: root_ctrl, type: transform}\n";
    yaml +=
        "  - {name: elbow_ctrl, type: transform, addAttr: [{name: stretch, min: 0.5, max: 2, keyable: true, "
        "default: 1}]}\n";
    yaml += fmt::format("  - {{name: hand_ctrl, type: transform, rotateOrder: {}}}\n", handOrder);
    yaml += "  - {name: root, type: joint}\n";
    yaml += fmt::format("  - {{name: forearm, type: joint, parent: root, translate: {}, jointOrient: {}}}\n",
                        v3(10 * u(rng), 10 * u(rng), 10 * u(rng)), v3(angle(rng), angle(rng), angle(rng)));
    yaml += "  - {name: forearm_stretch, type: squashStretch, axis: x}\n";
    const double length = 15.0 + 10.0 * std::abs(u(rng));
    yaml += fmt::format(
        "  - {{name: hand, type: joint, parent: forearm, rotateOrder: {}, translate: {}, jointOrient: "
        "{}}}\n",
        handOrder, v3(length, 0, 0), v3(angle(rng), angle(rng), angle(rng)));
    yaml += fmt::format("  - {{name: roll, type: joint, parent: forearm, translate: {}}}\n", v3(0.5 * length, 0, 0));
    yaml +=
        fmt::format("  - {{name: twist, type: twistDistribute, rotateOrder: {}, twistAxis: {}, weight: [{:.9g}]}}\n",
                    readOrder, twistAxis, weight);
    yaml += "connections:\n";
    yaml += "  - root_ctrl.rotate -> root.rotate\n  - hand_ctrl.rotate -> hand.rotate\n";
    yaml += "  - elbow_ctrl.rotate -> forearm.rotate\n  - forearm_stretch.outScale -> forearm.scale\n";
    yaml += "  - elbow_ctrl.stretch -> forearm_stretch.stretch\n  - hand_ctrl.rotate -> twist.rotate\n";
    yaml += fmt::format("  - twist.outTwist[0] -> roll.rotate{}\n", char(std::toupper(twistAxis[0])));
    return yaml;
}

}  // namespace

TEST_CASE("twist share: random roll joints are learned as shares of their driver's twist and solved from rest")
{
    std::mt19937 rng(2027);
    const auto dir = test::scratchDir(fmt::format("twist-share.{}", ::getpid()));
    int learned = 0, reached = 0, posesTried = 0;
    const int rigs = 8;
    for (int r = 0; r < rigs; ++r) {
        CAPTURE(r);
        std::string axis;
        double weight = 0.0;
        const auto file = test::writeFile(dir / fmt::format("roll{}.yaml", r), randomRollRig(rng, axis, weight));
        GraphRigOptions options;
        options.parameterGlobs = {"root_ctrl.rotate?", "elbow_ctrl.rotate?", "elbow_ctrl.stretch", "hand_ctrl.rotate?"};
        GraphRigFunction rig(file, options);
        const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
        const auto roll = static_cast<std::size_t>(
            std::find_if(a.outputs.begin(), a.outputs.end(), [](const auto& o) { return o.name == "roll"; }) -
            a.outputs.begin());
        REQUIRE(roll < a.outputs.size());
        if (a.hasUnmodelledOutputs() || !a.validation.withinEpsilon || a.outputs[roll].constraint < 0) continue;
        const ConstraintBase& c = a.constraints[static_cast<std::size_t>(a.outputs[roll].constraint)];
        CHECK(c.kind == ConstraintKind::twistShare);
        CHECK(std::abs(c.share) == doctest::Approx(std::abs(weight)).epsilon(1e-6));
        ++learned;
        // Random poses, solved from rest through the share, judged on the real rig.
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        for (int pose = 0; pose < 10; ++pose) {
            const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.5));
            const double worst = test::solvedFromRest(a, solver, binding, targets, 10.0);
            ++posesTried;
            reached += worst < 1e-3 ? 1 : 0;
        }
    }
    MESSAGE("random roll joints learned as twist shares: " << learned << " of " << rigs << "; poses reached from rest "
                                                           << reached << " of " << posesTried);
    CHECK(learned == rigs);
    CHECK(reached >= posesTried * 9 / 10);
}

TEST_CASE(
    "twist share: the biped with every joint as an output is modelled whole, its twist joints at the rig's "
    "fractions, and solved through them")
{
    // rigs/biped_inversion.yaml's parameters, every joint an output (its spec's outputs are the CMU joints).
    InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs" / "biped_inversion.yaml");
    GraphRigOptions options{spec.params, {}, {}, spec.set, spec.ranges};
    options.autoHelpers = true;
    GraphRigFunction rig(test::sourceDir() / "rigs" / "biped.yaml", options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, "rigs/biped.yaml");
    CHECK(!a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
    std::map<std::string, double> shares;
    for (const ApproximationOutput& o : a.outputs)
        if (o.constraint >= 0 &&
            a.constraints[static_cast<std::size_t>(o.constraint)].kind == ConstraintKind::twistShare)
            shares[o.name] = std::abs(a.constraints[static_cast<std::size_t>(o.constraint)].share);
    REQUIRE(shares.size() == 8);
    for (const std::string side : {"Left", "Right"}) {
        CHECK(shares[side + "Arm_twist1"] == doctest::Approx(0.5).epsilon(1e-6));
        CHECK(shares[side + "Arm_twist2"] == doctest::Approx(0.25).epsilon(1e-6));
        CHECK(shares[side + "ForeArm_twist1"] == doctest::Approx(1.0 / 3.0).epsilon(1e-6));
        CHECK(shares[side + "ForeArm_twist2"] == doctest::Approx(2.0 / 3.0).epsilon(1e-6));
    }
    // The analytic Jacobian through the shares against central differences, and poses solved from rest.
    std::mt19937 rng(9);
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    int reached = 0;
    const int poses = 20;
    for (int pose = 0; pose < poses; ++pose) {
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.5));
        if (pose < 3) {
            JacobianEvaluator evaluator(a, targets, 10.0);
            Eigen::MatrixXd analytic, numeric;
            Eigen::VectorXd r1, r2;
            const std::vector<double> at = test::randomValues(a, rng, 0.5);
            evaluator.jacobian(at, JacobianMethod::analytic, 0.0, analytic, r1);
            evaluator.jacobian(at, JacobianMethod::finiteDifference, 1e-6, numeric, r2);
            CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-5 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        }
        const double worst = test::solvedFromRest(a, solver, binding, targets);
        reached += worst < 1e-3 ? 1 : 0;
    }
    MESSAGE("random poses of the biped with every joint reached from rest on the real rig: " << reached << " of "
                                                                                             << poses);
    CHECK(reached >= poses - 1);
}

TEST_CASE("twist share: an approximation file keeps it bit for bit, and a damaged twist share field is one line")
{
    std::mt19937 rng(404);
    std::string axis;
    double weight = 0.0;
    const auto file = test::writeFile(test::scratchDir(fmt::format("twist-share-io.{}", ::getpid())) / "roll.yaml",
                                      randomRollRig(rng, axis, weight));
    GraphRigOptions options;
    options.parameterGlobs = {"root_ctrl.rotate?", "elbow_ctrl.rotate?", "elbow_ctrl.stretch", "hand_ctrl.rotate?"};
    GraphRigFunction rig(file, options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    REQUIRE(a.constraints.size() == 1);
    REQUIRE(a.constraints[0].kind == ConstraintKind::twistShare);
    const std::string text = approximationToYaml(a);
    const Approximation b = approximationFromYaml(text, "roll.approx.yaml");
    CHECK(approximationToYaml(b) == text);
    CHECK(b.constraints[0].driverRest == a.constraints[0].driverRest);
    std::vector<Eigen::Matrix4d> wa, wb;
    for (int pose = 0; pose < 5; ++pose) {
        const std::vector<double> values = test::randomValues(a, rng);
        a.evaluate(values, wa);
        b.evaluate(values, wb);
        for (std::size_t k = 0; k < wa.size(); ++k) CHECK(wa[k] == wb[k]);
    }
    // A damaged field: the one line names it, with its place in the file.
    const auto errorWith = [&](const std::string& from, const std::string& to) -> std::string {
        std::string damaged = text;
        const auto at = damaged.find(from);
        REQUIRE(at != std::string::npos);
        damaged.replace(at, from.size(), to);
        return test::errorOf([&] { approximationFromYaml(damaged, "f.yaml"); });
    };
    const std::string twistAxis = fmt::format("twistAxis: {}", "xyz"[a.constraints[0].twistAxis]);
    CHECK(errorWith(twistAxis, "twistAxis: w")
              .ends_with("constraints[0].twistAxis: 'w' is not an axis; it is x, y or z"));
    const std::string readOrder = fmt::format("readOrder: {}", rotateOrderName(a.constraints[0].readOrder));
    CHECK(errorWith(readOrder, "readOrder: xxy")
              .ends_with("constraints[0].readOrder: not a rotate order; it is one of xyz, yzx, zxy, xzy, yxz, zyx"));
    CHECK(errorWith("    share:", "    shares:").find("constraints[0]") != std::string::npos);
    CHECK(errorWith("driver: \"hand\"", "driver: \"nobody\"")
              .ends_with("constraints[0].driver: 'nobody' is not one of the outputs"));
}

}  // namespace rig
