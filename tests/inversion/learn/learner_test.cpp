// The learner on rigs whose answers are known in closed form.
#include <doctest/doctest.h>

#include <limits>
#include <numbers>
#include <random>

#include <fmt/format.h>

#include "inversion/ik_arm.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "inversion/test_rigs.h"
#include "test_support.h"

using namespace rig;

namespace {

const ModelledParameter& find(const Approximation& a, const std::string& name)
{
    for (const auto& p : a.parameters)
        if (p.parameter.name == name) return p;
    FAIL("not modelled: " << name);
    return a.parameters.front();
}

int position(const Approximation& a, const std::string& name)
{
    for (std::size_t i = 0; i < a.parameters.size(); ++i)
        if (a.parameters[i].parameter.name == name) return static_cast<int>(i);
    return -1;
}

}  // namespace

TEST_CASE("learner: an FK arm is modelled exactly, axes and pivots to 1e-9, in composition order")
{
    for (Orderer orderer : {Orderer::talk, Orderer::structured}) {
        CAPTURE(ordererName(orderer));
        auto arm = test::fkArm();
        LearnOptions options;
        options.orderer = orderer;
        const Approximation a = learnApproximation(arm, options, "arm");
        REQUIRE(a.parameters.size() == 6);
        CHECK(a.discarded.empty());
        CHECK(find(a, "root.translateX").form == "translation");
        CHECK((find(a, "root.translateX").operators[0].axis - Eigen::Vector3d::UnitX()).norm() < 1e-9);
        CHECK(find(a, "root.translateX").operators[0].slope == doctest::Approx(1.0));
        for (const char* name :
             {"shoulder.rotateX", "shoulder.rotateY", "shoulder.rotateZ", "elbow.rotateZ", "wrist.rotateX"})
            CHECK(find(a, name).form == "rotation");
        const Operator& elbow = find(a, "elbow.rotateZ").operators[0];
        // The elbow's axis at rest: Z turned 20 degrees about Y; its pivot on that axis through (10, 100, 0).
        const double t = 20 * std::numbers::pi / 180;
        CHECK((elbow.axis - Eigen::Vector3d(std::sin(t), 0, std::cos(t))).norm() < 1e-9);
        CHECK((elbow.pivot - Eigen::Vector3d(10, 100, 0)).cross(elbow.axis).norm() < 1e-9);
        CHECK(elbow.slope == doctest::Approx(1.0));
        // Outer to inner: root, shoulder X, Y, Z, elbow, wrist.
        CHECK(position(a, "root.translateX") < position(a, "shoulder.rotateX"));
        CHECK(position(a, "shoulder.rotateX") < position(a, "shoulder.rotateY"));
        CHECK(position(a, "shoulder.rotateY") < position(a, "shoulder.rotateZ"));
        CHECK(position(a, "shoulder.rotateZ") < position(a, "elbow.rotateZ"));
        CHECK(position(a, "elbow.rotateZ") < position(a, "wrist.rotateX"));
        CHECK(a.validation.maxPositionErrorCm < 1e-6);
        CHECK(a.validation.maxRotationErrorDeg < 1e-6);
        MESSAGE(ordererName(orderer) << ": " << a.training.evaluations << " evaluations, "
                                     << a.training.orderEvaluations << " for the order");
    }
}

TEST_CASE("learner: rotations past half a turn are unwrapped along the samples")
{
    // spin turns its joint 1.5 times its value over +-200 degrees (up to 300 degrees each way); curl
    // turns a second joint by a + 0.1 a^2 over 0..300 degrees (past a full turn).
    const double degree = std::numbers::pi / 180;
    test::LambdaRig rig({test::angle("spin", -200 * degree, 200 * degree), test::angle("curl", 0.0, 300 * degree)},
                        {"spun", "curled", "tip"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                            const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
                            w[0] = test::translation(10, 0, 0) * test::rotation(z, 1.5 * v[0]);
                            w[1] = test::translation(0, 30, 0) * test::rotation(z, v[1] + 0.1 * v[1] * v[1]);
                            w[2] = w[1] * test::translation(8, 0, 0);
                        });
    const Approximation a = learnApproximation(rig, LearnOptions{}, "spin");
    CHECK(a.discarded.empty());
    const ModelledParameter& spin = find(a, "spin");
    CHECK(spin.form == "rotation");
    CHECK(spin.operators[0].axis.z() * spin.operators[0].slope == doctest::Approx(1.5).epsilon(1e-12));
    const ModelledParameter& curl = find(a, "curl");
    CHECK(curl.form == "rotation (curve)");
    const double end = 300 * degree;
    CHECK(curl.operators[0].axis.z() * curl.operators[0].magnitude(end) ==
          doctest::Approx(end + 0.1 * end * end).epsilon(1e-9));
    // Exact at the samples, a cubic spline in between.
    CHECK(a.validation.maxPositionErrorCm < 0.05);
}

TEST_CASE("learner: a pair that cannot be ordered loses only one of its parameters")
{
    // A bend (X) and a side bend (Z) each shared half and half by two joints, as a spine's: on the first
    // joint the bend is outer, on the second neither order holds. A third parameter elsewhere commutes.
    for (Orderer orderer : {Orderer::talk, Orderer::structured}) {
        CAPTURE(ordererName(orderer));
        test::LambdaRig rig(
            {test::angle("bend", -1, 1), test::angle("side", -0.5, 0.5), test::angle("other")},
            {"lower", "upper", "elsewhere"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), z = Eigen::Vector3d::UnitZ();
                const Eigen::Matrix4d share = test::rotation(x, 0.5 * v[0]) * test::rotation(z, 0.5 * v[1]);
                w[0] = test::translation(0, 100, 0) * share;
                w[1] = w[0] * test::translation(0, 20, 0) * share;
                w[2] = test::translation(50, 0, 0) * test::rotation(z, v[2]);
            });
        LearnOptions options;
        options.orderer = orderer;
        const Approximation a = learnApproximation(rig, options, "spine");
        REQUIRE(a.discarded.size() == 1);
        CHECK(a.discarded[0].parameter.name == "side");  // the smaller effect
        CHECK(a.discarded[0].reason.starts_with("cannot be ordered with bend: neither order holds on upper"));
        CHECK(position(a, "bend") >= 0);
        CHECK(position(a, "other") >= 0);
        // The bend of the upper joint is a sampled operator: exact at the samples, a spline between.
        CHECK(a.validation.maxPositionErrorCm < 0.01);
        // The structured orderer never tests "other" against the others: they share no output.
        if (orderer == Orderer::structured) CHECK(a.training.orderEvaluations == 1);
    }
}

TEST_CASE("learner: outputs found history-dependent are dropped, the parameters learned on the others")
{
    // springy follows its parameter one step per evaluation that changes it (a spring), so after its
    // samples the rest pose has moved; root, classified after it, still moves both joints.
    double state = 0.0, last = 0.0;
    test::LambdaRig rig({test::angle("arm"), test::distance("springy"), test::distance("root")}, {"arm", "springy"},
                        [&](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                            if (v[1] != last) state += 0.5 * (v[1] - state);
                            last = v[1];
                            w[0] = test::translation(v[2], 0, 0) * test::rotation(Eigen::Vector3d::UnitZ(), v[0]);
                            w[1] = test::translation(v[2] + state, 10, 0);
                        });
    const Approximation a = learnApproximation(rig, LearnOptions{}, "springy");
    REQUIRE(a.outputs.size() == 1);
    CHECK(a.outputs[0].name == "arm");
    REQUIRE(a.discarded.size() == 1);
    CHECK(a.discarded[0].parameter.name == "springy");
    CHECK(a.discarded[0].reason.starts_with("history-dependent: after sampling it, the rest pose of springy moved"));
    CHECK(find(a, "root").form == "translation");
    CHECK(find(a, "root").outputs == std::vector<int>{0});
    CHECK(a.validation.maxPositionErrorCm < 1e-9);
}

TEST_CASE("learner: a parameter spends at most maxSamples rig samples, however many outputs it moves")
{
    // One parameter bends a chain of 40 joints about 40 pivots by different amounts: every output needs
    // a sampled operator of its own, and each used to sample midpoints again.
    constexpr int joints = 40;
    std::vector<std::string> names;
    for (int j = 0; j < joints; ++j) names.push_back(fmt::format("j{}", j));
    test::LambdaRig rig({test::angle("bend", -1.5, 1.5)}, names,
                        [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
                            for (int j = 0; j < joints; ++j) {
                                m = m * test::translation(0, 3, 0) *
                                    test::rotation(Eigen::Vector3d(1, 0.1 * j, 0), v[0] * (0.02 + 0.001 * j * j));
                                w[static_cast<std::size_t>(j)] = m;
                            }
                        });
    LearnOptions options;
    options.validationPoses = 0;
    options.limitPoses = 0;
    const Approximation a = learnApproximation(rig, options, "chain");
    REQUIRE(a.parameters.size() == 1);
    CHECK(a.parameters[0].samples <= options.maxSamples);
    // The samples, the rest pose, and the check that the rest pose comes back.
    CHECK(a.training.evaluations <= static_cast<std::uint64_t>(options.maxSamples) + 2);
}

TEST_CASE(
    "learner: a rig that gives a non-finite matrix within a parameter's range discards it with the value, never a NaN")
{
    // past 1.2 the joint's matrix is NaN (a rig dividing by zero); `fine` moves another joint.
    test::LambdaRig rig({test::angle("broken"), test::angle("fine")}, {"a", "b"},
                        [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                            w[0] = test::rotation(Eigen::Vector3d::UnitZ(), v[0]);
                            if (v[0] > 1.2) w[0](0, 3) = std::numeric_limits<double>::quiet_NaN();
                            w[1] = test::translation(10, 0, 0) * test::rotation(Eigen::Vector3d::UnitX(), v[1]);
                        });
    const Approximation a = learnApproximation(rig, LearnOptions{}, "broken");
    REQUIRE(a.discarded.size() == 1);
    CHECK(a.discarded[0].parameter.name == "broken");
    CHECK(a.discarded[0].reason ==
          "the rig gives a non-finite matrix for a at broken = 85.9437 degrees (a zero scale or a singular matrix?); "
          "give it a range where the rig is defined");
    REQUIRE(a.parameters.size() == 1);
    CHECK(a.validation.withinEpsilon);
    CHECK(std::isfinite(a.validation.maxRelativeError));
}

TEST_CASE("learner: a curve over epsilon between its samples gets more samples until the validation holds")
{
    // A driven rotation whose angle wiggles: a curve magnitude, exact at its samples; with a budget of 8
    // samples it misses between them, and the repair doubles the budget (to at most 8 x 8).
    test::LambdaRig rig({test::angle("wiggle", -1.5, 1.5)}, {"a"},
                        [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                            w[0] = test::translation(0, 10, 0) *
                                   test::rotation(Eigen::Vector3d::UnitZ(), v[0] + 0.05 * std::sin(4.0 * v[0]));
                        });
    LearnOptions options;
    options.maxSamples = 8;
    options.epsilon = 0.01;
    const Approximation a = learnApproximation(rig, options, "wiggle");
    REQUIRE(a.parameters.size() == 1);
    CHECK(a.parameters[0].form == "rotation (curve)");
    CHECK(a.parameters[0].samples > 8);
    CHECK(a.parameters[0].samples <= 64);
    CHECK(a.validation.withinEpsilon);
}

TEST_CASE("learner: where operators that commute alone do not compose, the validation hands the order to the rig")
{
    // Alone, each turns the joint about Z through one pivot: their operators commute. Together they
    // also turn it about X by a * b, which no order of the two models. The structured orderer, trusting
    // the operators, keeps both; the validation finds the joint over epsilon, the rig is asked, neither
    // order holds, and one is discarded, as the talk's orderer does at once.
    for (const Orderer orderer : {Orderer::structured, Orderer::talk}) {
        CAPTURE(ordererName(orderer));
        test::LambdaRig rig({test::angle("a", -1, 1), test::angle("b", -0.5, 0.5)}, {"joint"},
                            [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                                w[0] = test::translation(0, 10, 0) *
                                       test::rotation(Eigen::Vector3d::UnitZ(), v[0] + v[1]) *
                                       test::rotation(Eigen::Vector3d::UnitX(), v[0] * v[1]);
                            });
        LearnOptions options;
        options.orderer = orderer;
        const Approximation a = learnApproximation(rig, options, "coupled");
        REQUIRE(a.discarded.size() == 1);
        CHECK(a.discarded[0].parameter.name == "b");  // the smaller effect
        CHECK(a.discarded[0].reason.starts_with("cannot be ordered with a: neither order holds on joint"));
        CHECK(a.validation.withinEpsilon);
    }
}

TEST_CASE("learner: an IK arm's non-compositional outputs, each with its parent output and the pair with neither order")
{
    const auto file = test::writeFile(test::scratchDir("learner-ik-arm") / "arm.yaml", test::ikArm);
    GraphRigFunction rig(file, test::ikArmOptions());
    std::vector<UnmodelledOutput> unmodelled{{"stale", "from before"}};
    Approximation a = learnApproximation(rig, LearnOptions{}, "arm.yaml", &unmodelled);
    // The outputs the approximation leaves unmodelled, in its order, and no others.
    std::vector<std::string> names, expected;
    for (const UnmodelledOutput& u : unmodelled) names.push_back(u.name);
    for (const ApproximationOutput& o : a.outputs)
        if (!o.modelled) expected.push_back(o.name);
    CHECK(names == expected);
    REQUIRE(names == std::vector<std::string>{"shoulder", "elbow", "wrist"});
    // The thigh of the arm: the root's X and Y translations compose neither way, relative to the clavicle or in
    // world space (the IK goal stays put in world space while the root moves the shoulder).
    const std::string pair =
        "root_ctrl.translateX and root_ctrl.translateY have neither order (the rig with both moved is ";
    CHECK(unmodelled[0].reason.starts_with("relative to its parent output clavicle, " + pair));
    CHECK(unmodelled[0].reason.find(" cm from the two products of their operators, tolerance 0.1 cm); in world "
                                    "space, " +
                                    pair) != std::string::npos);
    // Below it, relative to an unmodelled parent the validation failed first.
    CHECK(unmodelled[1].reason.starts_with("relative to its parent output shoulder, its validation error "));
    CHECK(unmodelled[2].reason.starts_with("relative to its parent output elbow, its validation error "));
    for (std::size_t k = 1; k < unmodelled.size(); ++k) {
        CAPTURE(unmodelled[k].name);
        CHECK(unmodelled[k].reason.find(" exceeds epsilon 0.001; in world space, " + pair) != std::string::npos);
    }

    // Asking for the reasons changes nothing learned.
    Approximation b = learnApproximation(rig, LearnOptions{}, "arm.yaml");
    a.training.seconds = b.training.seconds = 0.0;
    CHECK(approximationToYaml(a) == approximationToYaml(b));
    // The talk's behaviour: a parameter discarded instead, no output unmodelled, no reasons.
    LearnOptions talk;
    talk.perOutput = false;
    learnApproximation(rig, talk, "arm.yaml", &unmodelled);
    CHECK(unmodelled.empty());
}

TEST_CASE("learner: a driven-key roll that does nothing in the middle of its range keeps its kinks (curve breaks)")
{
    // A reverse foot's roll: the heel keyed from -10 to 0, the toe from 5 to 10, nothing moves between. Its first
    // samples (-10, -6.7, -3.3, 3.3, 6.7, 10) lie on both sides of the flat stretch: a natural spline through them
    // rounds the kinks at 0 and 5, which the learner now keeps as breaks of the ankle's curve.
    const std::string foot = R"(nodes:
  - {name: foot_ctrl, type: transform, translate: [0, 10, 0], addAttr: [{name: roll, min: -10, max: 10, keyable: true}]}
  - {name: heel_pivot, type: transform, parent: foot_ctrl, translate: [0, -10, -5]}
  - {name: toe_pivot, type: transform, parent: heel_pivot, translate: [0, 0, 20]}
  - {name: ankle, type: joint, parent: toe_pivot, translate: [0, 10, -15]}
  - {name: heel_roll_sdk, type: animCurveUA, keys: [[-10, -30], [0, 0]], tangents: linear}
  - {name: toe_roll_sdk, type: animCurveUA, keys: [[5, 0], [10, 45]], tangents: linear}
connections:
  - foot_ctrl.roll -> heel_roll_sdk.input
  - foot_ctrl.roll -> toe_roll_sdk.input
  - heel_roll_sdk.output -> heel_pivot.rotateX
  - toe_roll_sdk.output -> toe_pivot.rotateX
)";
    const auto file = test::writeFile(test::scratchDir("learner-roll-breaks") / "foot.yaml", foot);
    GraphRigFunction rig(file, GraphRigOptions{{"foot_ctrl.roll"}, {"ankle"}, {}, {}});
    const Approximation a = learnApproximation(rig, LearnOptions{}, "foot.yaml");
    REQUIRE(a.parameters.size() == 1);
    REQUIRE(a.parameters[0].noEffect.size() == 1);
    CHECK(a.parameters[0].noEffect[0].first == 0.0);
    CHECK(a.parameters[0].noEffect[0].second == doctest::Approx(5.0).epsilon(1e-6));
    std::vector<Eigen::Matrix4d> model, real;
    double worst = 0.0;
    for (const double roll : {-1.0, -0.01, -1e-4, 1e-4, 0.01, 2.5, 4.99, 4.9999, 5.0001, 5.01, 6.0}) {
        CAPTURE(roll);
        const std::vector<double> values{roll};
        a.evaluate(values, model);
        rig.evaluate(values, real);
        REQUIRE(model.size() == 1);
        const double error = (model[0].block<3, 1>(0, 3) - real[0].block<3, 1>(0, 3)).norm();
        CHECK(error < 1e-4);
        worst = std::max(worst, error);
    }
    MESSAGE("worst model error beside the flat stretch: " << worst << " cm; " << a.training.evaluations
                                                          << " training evaluations");
    // The flat stretch itself is flat exactly: the piece between the breaks goes through samples at rest alone.
    for (const double roll : {0.7, 2.5, 4.3}) {
        a.evaluate(std::vector<double>{roll}, model);
        a.evaluate(std::vector<double>{0.0}, real);
        CHECK(model[0] == real[0]);
    }
}
