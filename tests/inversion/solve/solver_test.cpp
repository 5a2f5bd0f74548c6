// The solver on rigs whose answers are known: closed-form recoveries, limits, redundant and saturated
// parameters, invalid targets, partitioned against whole solves, thread counts, the polish on the real rig.
#include <doctest/doctest.h>

#include <algorithm>

#include <cstring>
#include <numbers>
#include <random>
#include <thread>

#include <Eigen/Geometry>

#include "inversion/clip/rig_binding.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

double worldError(const Approximation& a, std::span<const double> values, const std::vector<JointTarget>& targets)
{
    std::vector<Eigen::Matrix4d> worlds;
    a.evaluate(values, worlds);
    double worst = 0.0;
    for (std::size_t k = 0; k < worlds.size(); ++k)
        if (targets[k].active) worst = std::max(worst, (worlds[k] - targets[k].world).cwiseAbs().maxCoeff());
    return worst;
}

double maxDifference(std::span<const double> a, std::span<const double> b)
{
    double worst = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
    return worst;
}

bool bitIdentical(std::span<const double> a, std::span<const double> b)
{
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// `values` moved by up to `amount` in each parameter, within the limits: a previous frame.
std::vector<double> nearby(const Approximation& a, std::vector<double> values, double amount, std::mt19937& rng)
{
    for (std::size_t p = 0; p < values.size(); ++p) {
        const RigParameter& param = a.parameters[p].parameter;
        values[p] =
            std::clamp(values[p] + std::uniform_real_distribution<double>(-amount, amount)(rng), param.min, param.max);
    }
    return values;
}

}  // namespace

TEST_CASE("solver: an FK arm reaching a pose made from known parameters recovers them to 1e-9")
{
    auto rig = test::fkArm();
    const Approximation a = test::learn(rig, "arm");
    REQUIRE(a.parameters.size() == 6);
    std::mt19937 rng(1);
    int reachedFromRest = 0;
    for (JacobianMethod method : {JacobianMethod::analytic, JacobianMethod::finiteDifference}) {
        SolverOptions options;
        options.jacobian = method;
        const Solver solver(a, options);
        for (int pose = 0; pose < 20; ++pose) {
            CAPTURE(jacobianMethodName(method));
            CAPTURE(pose);
            const std::vector<double> known = test::randomValues(a, rng, 0.9);
            const std::vector<JointTarget> targets = test::targetsAt(a, known);
            // From the previous frame: the parameters themselves come back.
            std::vector<double> values = nearby(a, known, 0.3, rng);
            const SolveSummary summary = solver.solve(targets, values);
            CHECK(summary.converged());
            CHECK(maxDifference(values, known) < 1e-9);
            CHECK(summary.maxPositionErrorCm < 1e-9);
            CHECK(summary.maxRotationErrorDeg < 1e-7);
            CHECK(summary.finalCost < 1e-18);
            CHECK(summary.initialCost > summary.finalCost);
            // From the rest pose: the same joints, with the parameters up to equivalence, unless a
            // local minimum catches it (far poses can).
            values = a.defaults();
            const SolveSummary fromRest = solver.solve(targets, values);
            CHECK(fromRest.termination == TerminationType::converged);
            if (fromRest.finalCost < 1e-18) {
                ++reachedFromRest;
                CHECK(worldError(a, values, targets) < 1e-9);
            }
        }
    }
    CHECK(reachedFromRest >= 30);
}

TEST_CASE("solver: two arms, partitioned into root then arms, recover known poses and agree with the whole solve")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    REQUIRE(a.parameters.size() == 14);
    SolverOptions whole;
    whole.partition = false;
    const Solver partitioned(a, SolverOptions{}), single(a, whole);
    std::mt19937 rng(2);
    for (int pose = 0; pose < 20; ++pose) {
        CAPTURE(pose);
        const std::vector<double> known = test::randomValues(a, rng, 0.9);
        const std::vector<JointTarget> targets = test::targetsAt(a, known);
        const std::vector<double> start = nearby(a, known, 0.3, rng);
        std::vector<double> v1 = start, v2 = start;
        const SolveSummary s1 = partitioned.solve(targets, v1);
        const SolveSummary s2 = single.solve(targets, v2);
        CHECK(s1.blocks == 3);
        CHECK(s2.blocks == 1);
        CHECK(s1.converged());
        CHECK(s2.converged());
        CHECK(maxDifference(v1, known) < 1e-9);
        CHECK(maxDifference(v1, v2) < 1e-9);
        CHECK(s1.maxPositionErrorCm < 1e-9);
    }
}

TEST_CASE("solver: prepare builds the plan a solve uses, and the solves after it are the same to the bit")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    const Solver prepared(a, SolverOptions{}), plain(a, SolverOptions{});
    std::mt19937 rng(4);
    const std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng, 0.9));
    prepared.prepare(targets);
    prepared.prepare(targets);  // once built, kept
    CHECK(prepared.partition(targets).describe(a) == plain.partition(targets).describe(a));
    std::vector<double> v1 = a.defaults(), v2 = a.defaults();
    prepared.initialGuess(targets, v1);
    plain.initialGuess(targets, v2);
    const SolveSummary s1 = prepared.solve(targets, v1), s2 = plain.solve(targets, v2);
    CHECK(std::memcmp(v1.data(), v2.data(), v1.size() * sizeof(double)) == 0);
    CHECK(s1.iterations == s2.iterations);
    const std::vector<JointTarget> fewer(targets.begin(), targets.end() - 1);
    CHECK_THROWS_WITH(prepared.prepare(fewer), "Solver::prepare: 8 targets for 9 outputs");
}

TEST_CASE("solver: limits are respected, and a target past a limit ends on it")
{
    auto rig = test::fkArm();
    const Approximation a = test::learn(rig, "arm");
    const int elbow = test::parameterIndex(a, "elbow.rotateZ");
    const int shoulderY = test::parameterIndex(a, "shoulder.rotateY");
    REQUIRE(elbow >= 0);
    std::vector<double> known = a.defaults();
    known[static_cast<std::size_t>(elbow)] = -0.6;     // below its minimum 0
    known[static_cast<std::size_t>(shoulderY)] = 1.8;  // above its maximum 1.5
    const std::vector<JointTarget> targets = test::targetsAt(a, known);
    for (int gaussNewton : {30, 0}) {
        SolverOptions options;
        options.gaussNewtonIterations = gaussNewton;
        const Solver solver(a, options);
        std::vector<double> values = a.defaults();
        values[static_cast<std::size_t>(elbow)] = 1.0;
        const SolveSummary summary = solver.solve(targets, values);
        CAPTURE(summary.briefReport());
        for (std::size_t p = 0; p < values.size(); ++p) {
            CHECK(values[p] >= a.parameters[p].parameter.min);
            CHECK(values[p] <= a.parameters[p].parameter.max);
        }
        CHECK(values[static_cast<std::size_t>(elbow)] == 0.0);
        CHECK(values[static_cast<std::size_t>(shoulderY)] == 1.5);
        CHECK(summary.finalCost > 1.0);  // unreachable within the limits
        CHECK(summary.finalCost < summary.initialCost);
        // Stationary with a residual: stuck, not converged to the targets.
        CHECK(summary.termination == TerminationType::stuck);
        CHECK(!summary.missedOutputs.empty());
        if (gaussNewton == 0) CHECK(summary.gaussNewtonIterations == 0);
    }
    // A warm start outside the limits is moved onto them.
    const Solver solver(a, SolverOptions{});
    std::vector<double> values = known;
    solver.solve(targets, values);
    CHECK(values[static_cast<std::size_t>(elbow)] == 0.0);
}

TEST_CASE(
    "solver: a redundant pair splits the change evenly, closest to the warm start, and a saturated control stays "
    "finite")
{
    auto rig = test::redundantRig();
    const Approximation a = test::learn(rig, "redundant");
    const int ia = test::parameterIndex(a, "redundantA"), ib = test::parameterIndex(a, "redundantB");
    const int tip = test::parameterIndex(a, "tip.rotateX"), sat = test::parameterIndex(a, "saturated");
    REQUIRE(ia >= 0);
    REQUIRE(ib >= 0);
    REQUIRE(tip >= 0);
    const Solver solver(a, SolverOptions{});
    std::vector<double> known = a.defaults();
    known[static_cast<std::size_t>(ia)] = 0.3;
    known[static_cast<std::size_t>(ib)] = 0.2;
    known[static_cast<std::size_t>(tip)] = -0.4;
    std::vector<JointTarget> targets = test::targetsAt(a, known);
    std::vector<double> values = a.defaults();
    values[static_cast<std::size_t>(ia)] = 0.2;
    values[static_cast<std::size_t>(ib)] = -0.1;
    const SolveSummary summary = solver.solve(targets, values);
    CAPTURE(summary.briefReport());
    CHECK(summary.converged());
    // The sum goes from 0.1 to 0.5: each moves by 0.2.
    CHECK(values[static_cast<std::size_t>(ia)] == doctest::Approx(0.4).epsilon(1e-9));
    CHECK(values[static_cast<std::size_t>(ib)] == doctest::Approx(0.1).epsilon(1e-9));
    CHECK(values[static_cast<std::size_t>(tip)] == doctest::Approx(-0.4).epsilon(1e-9));
    CHECK(worldError(a, values, targets) < 1e-9);

    if (sat >= 0) {
        // Asking the saturated joint for more than it can turn, starting where it has no effect.
        const int out = test::outputIndex(a, "sat");
        REQUIRE(out >= 0);
        targets[static_cast<std::size_t>(out)].world =
            test::rotation(Eigen::Vector3d::UnitZ(), 0.8) * test::translation(20, 0, 0);
        targets[static_cast<std::size_t>(out)].world(1, 3) -= 10;
        values[static_cast<std::size_t>(sat)] = 1.2;
        const SolveSummary s = solver.solve(targets, values);
        CAPTURE(s.briefReport());
        for (const double v : values) CHECK(std::isfinite(v));
        CHECK(values[static_cast<std::size_t>(sat)] >= -1.5);
        CHECK(values[static_cast<std::size_t>(sat)] <= 1.5);
        CHECK(s.worstOutput == "sat");
    } else {
        MESSAGE("the learner discarded `saturated`: " << a.discarded.size() << " discards");
    }
}

TEST_CASE(
    "solver: NaN, infinite, negative-weight and singular targets give invalidTargets and leave the values untouched")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(3);
    const std::vector<double> start = test::randomValues(a, rng);
    const std::vector<JointTarget> good = test::targetsAt(a, test::randomValues(a, rng));
    for (int c = 0; c < 5; ++c) {
        CAPTURE(c);
        std::vector<JointTarget> targets = good;
        JointTarget& t = targets[3];
        if (c == 0) t.world(1, 3) = std::numeric_limits<double>::quiet_NaN();
        if (c == 1) t.world(0, 0) = std::numeric_limits<double>::infinity();
        if (c == 2) t.positionWeight = -1.0;
        if (c == 3) t.rotationWeight = std::numeric_limits<double>::quiet_NaN();
        if (c == 4) t.world.block<3, 1>(0, 2).setZero();  // no orientation
        std::vector<double> values = start;
        const SolveSummary summary = solver.solve(targets, values);
        CHECK(summary.termination == TerminationType::invalidTargets);
        CHECK(terminationName(summary.termination) == "invalidTargets");
        CHECK(bitIdentical(values, start));
        CHECK(summary.iterations == 0);
    }
    // An inactive target may hold anything.
    std::vector<JointTarget> targets = good;
    targets[3].active = false;
    targets[3].world(1, 3) = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> values = start;
    CHECK(solver.solve(targets, values).converged());
    // No active target at all.
    for (auto& t : targets) t.active = false;
    values = start;
    const SolveSummary none = solver.solve(targets, values);
    CHECK(none.termination == TerminationType::noTargets);
    CHECK(bitIdentical(values, start));
    // Wrong sizes and a non-finite warm start are the caller's bugs.
    CHECK_THROWS_WITH_AS(solver.solve(std::span(good).first(3), values), "Solver::solve: 3 targets for 9 outputs",
                         Error);
    values[5] = std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH_AS(solver.solve(good, values), "Solver::solve: the value of L_shoulder.rotateY is inf", Error);
}

TEST_CASE("solver: parameters that reach no active target keep their values, bit for bit")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(4);
    const std::vector<double> known = test::randomValues(a, rng, 0.9);
    std::vector<JointTarget> targets = test::targetsAt(a, known);
    for (std::size_t k = 0; k < targets.size(); ++k) targets[k].active = a.outputs[k].name.starts_with("L_");
    const std::vector<double> start = nearby(a, known, 0.2, rng);
    std::vector<double> values = start;
    const SolveSummary summary = solver.solve(targets, values);
    CHECK(summary.converged());
    CHECK(summary.maxPositionErrorCm < 1e-8);
    int untouched = 0;
    for (std::size_t p = 0; p < a.parameters.size(); ++p)
        if (a.parameters[p].parameter.name.starts_with("R_")) {
            CHECK(std::memcmp(&values[p], &start[p], sizeof(double)) == 0);
            ++untouched;
        }
    CHECK(untouched == 5);
}

TEST_CASE("solver: rotation parameters stay continuous from the warm start past half a turn")
{
    test::LambdaRig spinner({test::angle("spin", -10.0, 10.0)}, {"arm", "hand"},
                            [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                                w[0] = test::rotation(Eigen::Vector3d::UnitY(), v[0]);
                                w[1] = w[0] * test::translation(10, 0, 0);
                            });
    const Approximation a = test::learn(spinner, "spinner");
    REQUIRE(a.parameters.size() == 1);
    const Solver solver(a, SolverOptions{});
    std::vector<double> values = a.defaults();
    for (int frame = 1; frame <= 60; ++frame) {
        const double angle = 0.17 * frame;  // to 10.2 rad: past pi, 2 pi and 3 pi
        if (angle > 9.9) break;
        const std::vector<double> truth{angle};
        const SolveSummary summary = solver.solve(test::targetsAt(a, truth), values);
        REQUIRE(summary.converged());
        CHECK(values[0] == doctest::Approx(angle).epsilon(1e-10));
    }
}

TEST_CASE("solver: thread counts 0, 1, 2 and 8 give bit-identical values on the biped, analytic and finite differences")
{
    test::GraphRig rig("rigs/biped.yaml", test::bipedInversionGlobs(), test::bipedCmuJoints());
    const Approximation a = test::learn(rig, "biped");
    std::mt19937 rng(5);
    for (JacobianMethod method : {JacobianMethod::analytic, JacobianMethod::finiteDifference}) {
        std::vector<std::vector<double>> results;
        std::vector<SolveSummary> summaries;
        const std::vector<double> start = test::randomValues(a, rng, 0.5);
        // Not exactly reachable: targets from the approximation at another pose, rotated and moved.
        std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng, 0.5));
        for (std::size_t k = 0; k < targets.size(); ++k)
            targets[k].world =
                test::rotation(Eigen::Vector3d(1, 0, 1), 0.05 * static_cast<double>(k % 5)) * targets[k].world;
        for (int threads : {1, 2, 8, 0}) {
            SolverOptions options;
            options.threads = threads;
            options.jacobian = method;
            const Solver solver(a, options);
            std::vector<double> values = start;
            summaries.push_back(solver.solve(targets, values));
            results.push_back(values);
        }
        CAPTURE(summaries[0].briefReport());
        CHECK(summaries[0].blocks > 3);
        CHECK(summaries[0].finalCost < summaries[0].initialCost);
        for (std::size_t i = 1; i < results.size(); ++i) {
            CHECK(bitIdentical(results[i], results[0]));
            CHECK(summaries[i].iterations == summaries[0].iterations);
            CHECK(summaries[i].finalCost == summaries[0].finalCost);
        }
    }
}

TEST_CASE("solver: on the biped, partitioned and whole solves reach exactly reachable poses and agree")
{
    test::GraphRig rig("rigs/biped.yaml", test::bipedInversionGlobs(), test::bipedCmuJoints());
    const Approximation a = test::learn(rig, "biped");
    SolverOptions whole;
    whole.partition = false;
    const Solver partitioned(a, SolverOptions{}), single(a, whole);
    std::mt19937 rng(6);
    for (int pose = 0; pose < 5; ++pose) {
        CAPTURE(pose);
        const std::vector<double> known = test::randomValues(a, rng, 0.6);
        const std::vector<JointTarget> targets = test::targetsAt(a, known);
        const std::vector<double> start = nearby(a, known, 0.15, rng);
        std::vector<double> v1 = start, v2 = start;
        const SolveSummary s1 = partitioned.solve(targets, v1);
        const SolveSummary s2 = single.solve(targets, v2);
        CAPTURE(s1.briefReport());
        CAPTURE(s2.briefReport());
        CHECK(s1.converged());
        CHECK(s2.converged());
        CHECK(s1.blocks > 3);
        CHECK(s1.maxPositionErrorCm < 1e-6);
        CHECK(s2.maxPositionErrorCm < 1e-6);
        CHECK(s1.maxRotationErrorDeg < 1e-5);
        CHECK(worldError(a, v1, targets) < 1e-6);
        CHECK(worldError(a, v2, targets) < 1e-6);
        CHECK(maxDifference(v1, v2) < 1e-6);
    }
}

TEST_CASE("solver: one solver used by many threads at once gives what it gives alone")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(7);
    constexpr int cases = 32;
    std::vector<std::vector<JointTarget>> targets;
    std::vector<std::vector<double>> starts, alone(cases), together(cases);
    for (int i = 0; i < cases; ++i) {
        targets.push_back(test::targetsAt(a, test::randomValues(a, rng, 0.9)));
        if (i % 4 == 0) targets.back()[i % 9].active = false;  // several partitions at once
        starts.push_back(test::randomValues(a, rng, 0.9));
    }
    for (int i = 0; i < cases; ++i) {
        alone[static_cast<std::size_t>(i)] = starts[static_cast<std::size_t>(i)];
        solver.solve(targets[static_cast<std::size_t>(i)], alone[static_cast<std::size_t>(i)]);
    }
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            for (int i = t; i < cases; i += 4) {
                together[static_cast<std::size_t>(i)] = starts[static_cast<std::size_t>(i)];
                solver.solve(targets[static_cast<std::size_t>(i)], together[static_cast<std::size_t>(i)]);
            }
        });
    for (auto& t : threads) t.join();
    for (int i = 0; i < cases; ++i)
        CHECK(bitIdentical(alone[static_cast<std::size_t>(i)], together[static_cast<std::size_t>(i)]));
}

TEST_CASE("solver: options validate() names the field and the value")
{
    auto expect = [](auto change, const char* message) {
        SolverOptions options;
        change(options);
        CHECK_THROWS_WITH_AS(options.validate(), message, Error);
    };
    CHECK_NOTHROW(SolverOptions{}.validate());
    expect([](SolverOptions& o) { o.gaussNewtonIterations = -1; },
           "SolverOptions::gaussNewtonIterations = -1: must not be negative");
    expect([](SolverOptions& o) { o.maxIterations = 0; }, "SolverOptions::maxIterations = 0: must be at least 1");
    expect([](SolverOptions& o) { o.rotationScaleCm = 0; },
           "SolverOptions::rotationScaleCm = 0: must be a positive number");
    expect([](SolverOptions& o) { o.rotationScaleCm = std::numeric_limits<double>::infinity(); },
           "SolverOptions::rotationScaleCm = inf: must be a positive number");
    expect([](SolverOptions& o) { o.functionTolerance = -1e-3; },
           "SolverOptions::functionTolerance = -0.001: must be a finite number, 0 or more");
    expect([](SolverOptions& o) { o.parameterTolerance = std::nan(""); },
           "SolverOptions::parameterTolerance = nan: must be a finite number, 0 or more");
    expect([](SolverOptions& o) { o.gradientTolerance = -1; },
           "SolverOptions::gradientTolerance = -1: must be a finite number, 0 or more");
    expect([](SolverOptions& o) { o.jacobian = static_cast<JacobianMethod>(7); },
           "SolverOptions::jacobian = 7: must be analytic or finiteDifference");
    expect([](SolverOptions& o) { o.finiteDifferenceStep = 0; },
           "SolverOptions::finiteDifferenceStep = 0: must be a positive number");
    expect([](SolverOptions& o) { o.threads = -2; },
           "SolverOptions::threads = -2: must not be negative (0: all cores)");
    // The constructor validates too.
    auto rig = test::fkArm();
    const Approximation a = test::learn(rig, "arm");
    SolverOptions bad;
    bad.maxIterations = 0;
    CHECK_THROWS_WITH_AS(Solver(a, bad), "SolverOptions::maxIterations = 0: must be at least 1", Error);
}

TEST_CASE("solver: the summary reports termination, iterations, costs and the worst output")
{
    auto rig = test::fkArm();
    const Approximation a = test::learn(rig, "arm");
    const Solver solver(a, SolverOptions{});
    std::vector<double> known = a.defaults();
    known[1] = 0.4;
    known[4] = 1.0;
    std::vector<JointTarget> targets = test::targetsAt(a, known);
    targets[3].world(0, 3) += 50;  // the hand out of reach
    std::vector<double> values = a.defaults();
    const SolveSummary summary = solver.solve(targets, values);
    CHECK(summary.termination == TerminationType::stuck);  // stationary, with the hand left short
    CHECK(std::find(summary.missedOutputs.begin(), summary.missedOutputs.end(), 3) != summary.missedOutputs.end());
    CHECK(summary.iterations == summary.gaussNewtonIterations + summary.levenbergMarquardtIterations);
    CHECK(summary.iterations > 0);
    CHECK(summary.worstOutput == "hand");
    CHECK(summary.maxPositionErrorCm > 1.0);
    CHECK(summary.blocks == 1);
    const std::string report = summary.briefReport();
    CHECK(report.starts_with("stuck: "));
    CHECK(report.find("(worst output hand)") != std::string::npos);
    CHECK(terminationName(TerminationType::noConvergence) == "noConvergence");
    CHECK(terminationName(TerminationType::converged) == "converged");
    CHECK(terminationName(TerminationType::noTargets) == "noTargets");
    // One iteration is not enough from the rest pose.
    SolverOptions once;
    once.maxIterations = 1;
    values = a.defaults();
    const SolveSummary short_ = Solver(a, once).solve(targets, values);
    CHECK(short_.termination == TerminationType::noConvergence);
    CHECK(short_.iterations == 1);
}

TEST_CASE("solver: near the optimum the step's model decrease stops the solve, and the step is not evaluated")
{
    // An out-of-reach hand: a stationary point with a residual, which Gauss-Newton approaches linearly. From
    // near it, the first step's model decrease (-g.s / 2, half the squared Newton decrement) is a few 1e-9 of
    // the cost: within a function tolerance of 1e-6 the solve ends there, its values and cost bit for bit those
    // it started from; with none, the step is evaluated and taken.
    auto rig = test::fkArm();
    const Approximation a = test::learn(rig, "arm");
    std::vector<double> known = a.defaults();
    known[1] = 0.4;
    known[4] = 1.0;
    std::vector<JointTarget> targets = test::targetsAt(a, known);
    targets[3].world(0, 3) += 50;
    std::vector<double> values = a.defaults();
    REQUIRE(Solver(a, SolverOptions{}).solve(targets, values).termination == TerminationType::stuck);
    const std::vector<double> near = values;
    SolverOptions loose;
    loose.functionTolerance = 1e-6;
    const SolveSummary stopped = Solver(a, loose).solve(targets, values);
    CHECK(stopped.termination == TerminationType::stuck);
    CHECK(stopped.iterations == 1);
    CHECK(stopped.gaussNewtonIterations == 1);
    CHECK(stopped.finalCost == stopped.initialCost);
    CHECK(values == near);
    SolverOptions exact;
    exact.functionTolerance = 0.0;
    const SolveSummary evaluated = Solver(a, exact).solve(targets, values);
    CHECK(evaluated.iterations >= 1);
    CHECK(evaluated.finalCost < evaluated.initialCost);
    CHECK(evaluated.initialCost - evaluated.finalCost < 1e-6 * evaluated.initialCost);
    CHECK(values != near);
}

TEST_CASE("polish: corrections on the real rig take a rotation-like knee's error towards zero")
{
    auto rig = test::slidingKnee();
    LearnOptions learnOptions;
    learnOptions.epsilon = 3.0;  // generous: the sliding knee is taken as a rotation
    learnOptions.validationPoses = 5;
    const Approximation a = learnApproximation(rig, learnOptions, "knee");
    REQUIRE(a.parameters.size() == 3);
    REQUIRE(a.parameters[2].form == "rotation");
    CHECK(a.parameters[2].fitError > 0.1);  // not exact
    RigBinding binding(a, rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(8);
    for (int pose = 0; pose < 5; ++pose) {
        CAPTURE(pose);
        const std::vector<double> known = test::randomValues(a, rng, 0.9);
        std::vector<Eigen::Matrix4d> real;
        binding.evaluate(known, real);
        std::vector<JointTarget> targets(real.size());
        for (std::size_t k = 0; k < real.size(); ++k) {
            targets[k].active = true;
            targets[k].world = real[k];
        }
        std::vector<double> values = a.defaults();
        const SolveSummary summary = solver.solve(targets, values);
        CHECK(summary.termination == TerminationType::stuck);  // the real rig's pose is not the approximation's
        const std::uint64_t before = rig.evaluationCount();
        const PolishSummary p = polish(solver, binding, targets, values, 4);
        CAPTURE(p.positionErrorBeforeCm);
        CAPTURE(p.positionErrorAfterCm);
        CHECK(p.evaluations == static_cast<int>(rig.evaluationCount() - before));
        CHECK(p.evaluations <= 5);
        CHECK(p.corrections >= 1);
        CHECK(p.positionErrorBeforeCm > 1e-3);
        CHECK(p.positionErrorAfterCm < 0.05 * p.positionErrorBeforeCm);
        CHECK(p.costAfter < p.costBefore);
        // The figures are the real rig's at the values left behind.
        binding.evaluate(values, real);
        double worst = 0.0;
        for (std::size_t k = 0; k < real.size(); ++k)
            worst = std::max(worst, (real[k].block<3, 1>(0, 3) - targets[k].world.block<3, 1>(0, 3)).norm());
        CHECK(worst == doctest::Approx(p.positionErrorAfterCm).epsilon(1e-12));
    }
}

TEST_CASE("rig binding: evaluates the real rig in the approximation's order and names what the rig lacks")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    RigBinding binding(a, rig);
    std::mt19937 rng(9);
    const std::vector<double> values = test::randomValues(a, rng);
    std::vector<Eigen::Matrix4d> bound, approximated;
    binding.evaluate(values, bound);
    a.evaluate(values, approximated);
    REQUIRE(bound.size() == a.outputs.size());
    for (std::size_t k = 0; k < bound.size(); ++k) CHECK((bound[k] - approximated[k]).cwiseAbs().maxCoeff() < 1e-9);

    auto other = test::fkArm();
    CHECK_THROWS_WITH_AS(RigBinding(a, other), "RigBinding: the rig has no parameter root.translateY", Error);
    test::LambdaRig noHand(rig.parameters(), {"hips"}, [](std::span<const double>, std::vector<Eigen::Matrix4d>&) {});
    CHECK_THROWS_WITH_AS(RigBinding(a, noHand), "RigBinding: the rig has no output L_shoulder", Error);
}
