// Property tests on random forward-kinematics hierarchies: random trees, pivots (the origin included),
// rotate orders, joint orients, translation controls on the root and on inner joints, parameters
// listed in random order. Every one must be learned exactly, in parent-relative frames and in world
// space (the talk), with nothing discarded; its Jacobian follows the output tree.
#include <doctest/doctest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include <fmt/format.h>

#include "inversion/learn/learner.h"
#include "inversion/random_fk.h"
#include "inversion/solve/jacobian.h"

using namespace rig;
using rig::test::lambdaRig;
using rig::test::randomFk;
using rig::test::RandomFk;

TEST_CASE(
    "random FK hierarchies are learned exactly in parent-relative frames and in world space, whatever the parameter "
    "order")
{
    std::mt19937 rng(20261124);
    int rigs = 0;
    for (int trial = 0; trial < 40; ++trial) {
        const RandomFk fk = randomFk(rng);
        for (const bool relative : {true, false})
            for (const Orderer orderer : {Orderer::structured, Orderer::talk}) {
                CAPTURE(trial);
                CAPTURE(relative);
                CAPTURE(ordererName(orderer));
                test::LambdaRig rig = lambdaRig(fk, true);
                LearnOptions options;
                options.relativeFrames = relative;
                options.orderer = orderer;
                options.validationPoses = 20;
                const Approximation a = learnApproximation(rig, options, "random");
                CHECK(a.discarded.empty());
                CHECK(a.parameters.size() == fk.channels.size());
                CHECK(a.validation.maxPositionErrorCm < 1e-9);
                CHECK(a.validation.maxRotationErrorDeg < 1e-9);
                CHECK(a.validation.withinEpsilon);
                for (const auto& o : a.outputs) CHECK((o.parent >= 0) == (relative && o.name != "j0"));
                ++rigs;
            }
    }
    MESSAGE(rigs << " random FK rigs learned exactly");
}

TEST_CASE("relative outputs: the analytic Jacobian follows the output tree, against central differences")
{
    std::mt19937 rng(7);
    for (int trial = 0; trial < 10; ++trial) {
        CAPTURE(trial);
        const RandomFk fk = randomFk(rng);
        test::LambdaRig rig = lambdaRig(fk, true);
        LearnOptions options;
        options.validationPoses = 5;
        const Approximation a = learnApproximation(rig, options, "random");
        REQUIRE(a.discarded.empty());
        // Targets: the rig at a random pose; evaluate at another.
        std::vector<double> values(a.parameters.size()), pose(a.parameters.size());
        std::uniform_real_distribution<double> unit(-1.0, 1.0);
        for (std::size_t p = 0; p < values.size(); ++p) {
            values[p] = unit(rng);
            pose[p] = unit(rng);
        }
        std::vector<Eigen::Matrix4d> worlds;
        a.evaluate(pose, worlds);
        std::vector<JointTarget> targets(a.outputs.size());
        for (std::size_t k = 0; k < targets.size(); ++k) targets[k] = {true, worlds[k], 1.0, 1.0};
        JacobianEvaluator evaluator(a, targets, 10.0);
        Eigen::MatrixXd analytic, numeric, suffixes;
        Eigen::VectorXd r;
        evaluator.jacobian(values, JacobianMethod::analytic, 1e-6, analytic, r);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, numeric, r);
        evaluator.jacobianFromSuffixes(values, suffixes, r);
        CHECK((analytic - numeric).cwiseAbs().maxCoeff() < 1e-5 * std::max(1.0, numeric.cwiseAbs().maxCoeff()));
        CHECK((analytic - suffixes).cwiseAbs().maxCoeff() < 1e-9 * std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        // The approximation is the rig: its residuals vanish at the pose the targets came from.
        evaluator.residuals(pose, r);
        CHECK(r.cwiseAbs().maxCoeff() < 1e-9);
    }
}
