// The one minimizer (inversion/solve/minimizer.h): its trust region, limits and continuity on a problem of the test's
// own, and the same on the real rig (solveOnRealRig), where the hybrid solve's second stage runs it.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <utility>

#include "inversion/clip/real_rig_solve.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/solve/minimizer.h"
#include "inversion/solve/step_strategy.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

// Two unknowns, three residuals: a problem of the test's own, its normal equations dense. A problem gives its
// residuals and their Jacobian at x.
class SmallProblem : public MinimizerProblem {
public:
    bool linearize(std::span<const double> x, bool, Eigen::VectorXd& r, Eigen::VectorXd& g) override
    {
        residuals(x, r);
        const Eigen::Matrix<double, 3, 2> J = jacobian(x);
        dense_.matrix() = J.transpose() * J;
        g = J.transpose() * r;
        return true;
    }
    double diagonal(Eigen::Index i) const override { return dense_.diagonal(i); }
    void hold(Eigen::Index i) override { dense_.hold(i); }
    bool solveStep(const Eigen::VectorXd& g, double mu, std::span<const char> fixed, Eigen::VectorXd& d) override
    {
        return dense_.solve(g, mu, fixed, d);
    }
    void multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out) override { dense_.multiply(v, out); }

private:
    virtual Eigen::Matrix<double, 3, 2> jacobian(std::span<const double> x) const = 0;
    DenseSystem dense_{2};
};

// Unknown 0 is an angle whose residual is a rotation's (sin, cos - 1 against angle a0: periodic, zero at a0 +
// whole turns); unknown 1 a distance with residual x1 - a1.
class AngleAndDistance final : public SmallProblem {
public:
    AngleAndDistance(double a0, double a1) : a0_(a0), a1_(a1) {}
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override
    {
        r.resize(3);
        r << std::sin(x[0] - a0_), std::cos(x[0] - a0_) - 1.0, x[1] - a1_;
    }

private:
    Eigen::Matrix<double, 3, 2> jacobian(std::span<const double> x) const override
    {
        Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
        J(0, 0) = std::cos(x[0] - a0_);
        J(1, 0) = -std::sin(x[0] - a0_);
        J(2, 1) = 1.0;
        return J;
    }
    double a0_, a1_;
};

// A curved valley with a miss: y = x^2 stiffly (weight 10), x = 1 along it by a slope `slope`, and a residual `miss`
// no unknown moves. Levenberg-Marquardt follows the curve in short steps, lowering the cost by little each.
class CurvedValley final : public SmallProblem {
public:
    CurvedValley(double slope, double miss) : slope_(slope), miss_(miss) {}
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override
    {
        r.resize(3);
        r << 10.0 * (x[1] - x[0] * x[0]), slope_ * (1.0 - x[0]), miss_;
    }

private:
    Eigen::Matrix<double, 3, 2> jacobian(std::span<const double> x) const override
    {
        Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
        J(0, 0) = -20.0 * x[0];
        J(0, 1) = 10.0;
        J(1, 0) = -slope_;
        return J;
    }
    double slope_, miss_;
};

// An angle whose residual barely moves with it at 0 and rises beyond (1 + x0 / 100 + x0^2), and a distance x1 - 2: the
// Gauss-Newton step turns the angle by -100, so that the trust region shortens it and its halvings alike. Every
// evaluation's point is kept.
class FlatThenSteep final : public SmallProblem {
public:
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override
    {
        evaluated.push_back({x[0], x[1]});
        r.resize(3);
        r << 1.0 + 0.01 * x[0] + x[0] * x[0], x[1] - 2.0, 0.0;
    }
    std::vector<std::array<double, 2>> evaluated;

private:
    Eigen::Matrix<double, 3, 2> jacobian(std::span<const double> x) const override
    {
        Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
        J(0, 0) = 0.01 + 2.0 * x[0];
        J(1, 1) = 1.0;
        return J;
    }
};

// A residual of 1 no unknown moves, a pull of the angle towards 100 radians with weight `pull`, and the distance to 0.
class FarPull final : public SmallProblem {
public:
    explicit FarPull(double pull) : pull_(pull) {}
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override
    {
        r.resize(3);
        r << 1.0, pull_ * (100.0 - x[0]), x[1];
    }

private:
    Eigen::Matrix<double, 3, 2> jacobian(std::span<const double>) const override
    {
        Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
        J(1, 0) = -pull_;
        J(2, 1) = 1.0;
        return J;
    }
    double pull_;
};

// Two unknowns each in a residual that Gauss-Newton meets quadratically (sin x0, sinh x1: zero at 0), and a miss no
// unknown moves.
class SineWithMiss final : public SmallProblem {
public:
    explicit SineWithMiss(double miss) : miss_(miss) {}
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override
    {
        r.resize(3);
        r << std::sin(x[0]), std::sinh(x[1]), miss_;
    }

private:
    Eigen::Matrix<double, 3, 2> jacobian(std::span<const double> x) const override
    {
        Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
        J(0, 0) = std::cos(x[0]);
        J(1, 1) = std::cosh(x[1]);
        return J;
    }
    double miss_;
};

// An approximation of two distance controls, unlimited: unknowns for problems of two translations.
Approximation twoDistances()
{
    Approximation a;
    for (const char* name : {"a.translateX", "a.translateY"}) {
        ModelledParameter m;
        m.parameter = test::distance(name);
        a.parameters.push_back(m);
    }
    return a;
}

// Unknowns for AngleAndDistance: the angle periodic (a turn) and free, the distance within [lo, hi].
Unknowns angleAndDistance(double lo, double hi)
{
    Approximation a;
    for (const RigParameter& p : {test::angle("spin", -10, 10), test::distance("slide", lo, hi)}) {
        ModelledParameter m;
        m.parameter = p;
        a.parameters.push_back(m);
    }
    a.parameters[0].parameter.limited = false;
    Unknowns u(a, nullptr, {0, 1});
    u.period = {2.0 * std::numbers::pi, 0.0};
    return u;
}

// A roll at its lower limit and a distance: r = (x0 + x1 - 1, x1 - 2). At the start (0, 0) the roll's gradient points
// in (-1), but the Gauss-Newton step of both (to (-1, 2)) pushes it out. Every evaluation's point is kept.
class RollAtLimit final : public SmallProblem {
public:
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override
    {
        evaluated.push_back({x[0], x[1]});
        r.resize(3);
        r << x[0] + x[1] - 1.0, x[1] - 2.0, 0.0;
    }
    std::vector<std::array<double, 2>> evaluated;

private:
    Eigen::Matrix<double, 3, 2> jacobian(std::span<const double>) const override
    {
        Eigen::Matrix<double, 3, 2> J = Eigen::Matrix<double, 3, 2>::Zero();
        J(0, 0) = J(0, 1) = J(1, 1) = 1.0;
        return J;
    }
};

// The roll limited to [0, 1], the distance free.
Unknowns rollAndDistance()
{
    Approximation a;
    for (const RigParameter& p : {test::distance("roll", 0.0, 1.0), test::distance("slide")}) {
        ModelledParameter m;
        m.parameter = p;
        a.parameters.push_back(m);
    }
    a.parameters[0].parameter.limited = true;
    a.parameters[1].parameter.limited = false;
    return Unknowns(a, nullptr, {0, 1});
}

}  // namespace

TEST_CASE("minimizer: a column at its limit that the step pushes out is held, and the step solved again")
{
    // Held, the distance's own Gauss-Newton step lands on the optimum within the limit, (0, 1.5), at once; the step
    // cut at the limit would land at (0, 2) and take a second.
    RollAtLimit problem;
    const Unknowns u = rollAndDistance();
    MinimizerState state(3, 2);
    state.x = {0.0, 0.0};
    const MinimizerResult result = minimize(problem, u, SolverOptions{}, state, std::vector<double>{0.0, 0.0});
    CHECK(result.converged);
    REQUIRE(problem.evaluated.size() >= 2);
    CHECK(problem.evaluated[1][0] == 0.0);  // the first trial (the start's evaluation before it)
    CHECK(problem.evaluated[1][1] == doctest::Approx(1.5).epsilon(1e-15));
    CHECK(state.x[0] == 0.0);
    CHECK(state.x[1] == doctest::Approx(1.5).epsilon(1e-15));
    CHECK(result.gaussNewton == 1);
    CHECK(result.cost == doctest::Approx(0.25).epsilon(1e-15));
}

TEST_CASE("minimizer: a step longer than maxAngularStep is shortened whole, direction kept")
{
    AngleAndDistance problem(1.2, 2.0);
    const Unknowns u = angleAndDistance(-100, 100);
    SolverOptions options;
    options.maxIterations = 1;
    options.maxAngularStep = 0.3;
    MinimizerState state(3, 2);
    state.x = {0.0, 0.0};
    const std::vector<double> near{0.0, 0.0};
    const MinimizerResult result = minimize(problem, u, options, state, near);
    CHECK(result.gaussNewton == 1);
    CHECK(result.longFirstStep);
    // Gauss-Newton's step at 0 is (sin 1.2, 2): the angle's part is capped at 0.3, the distance's scaled alike.
    CHECK(state.x[0] == doctest::Approx(0.3).epsilon(1e-14));
    CHECK(state.x[1] == doctest::Approx(2.0 * 0.3 / std::sin(1.2)).epsilon(1e-12));
}

TEST_CASE("minimizer: a halved step the trust region shortens to the last trial is not evaluated again")
{
    // Gauss-Newton's step from 0, shortened to turn the angle by 0.3, raises the cost; its four halvings are shortened
    // to the same point (halving is exact), which is not evaluated again: the next evaluation is the damped step's.
    FlatThenSteep problem;
    const Unknowns u = angleAndDistance(-100, 100);
    SolverOptions options;
    options.maxAngularStep = 0.3;
    MinimizerState state(3, 2);
    state.x = {0.0, 0.0};
    const std::vector<double> near{0.0, 0.0};
    minimize(problem, u, options, state, near);
    REQUIRE(problem.evaluated.size() >= 3);
    const std::array<double, 2> first = problem.evaluated[1];  // [0]: the start, linearized
    CHECK(first[0] == doctest::Approx(-0.3).epsilon(1e-14));
    CHECK(first[1] == doctest::Approx(0.006).epsilon(1e-12));
    CHECK(std::count(problem.evaluated.begin(), problem.evaluated.end(), first) == 1);
    // The damped step, (J^T J + 1e-4 I) d = -g, shortened alike: the angle by 0.3 again, the distance by 2 / 1.0001 of
    // it over 50.
    CHECK(problem.evaluated[2][0] == doctest::Approx(-0.3).epsilon(1e-14));
    CHECK(problem.evaluated[2][1] == doctest::Approx(0.006 * 2.0 / 1.0001).epsilon(1e-12));
}

TEST_CASE("minimizer: a limit holds its unknown, and the solve converges there")
{
    AngleAndDistance problem(0.4, 5.0);
    const Unknowns u = angleAndDistance(-1.0, 3.0);
    MinimizerState state(3, 2);
    state.x = {0.0, 0.0};
    const std::vector<double> near{0.0, 0.0};
    const MinimizerResult result = minimize(problem, u, SolverOptions{}, state, near);
    CHECK(result.converged);
    CHECK_FALSE(result.longFirstStep);  // 0.4 radians: within the default 0.5
    CHECK(state.x[1] == 3.0);
    CHECK(state.x[0] == doctest::Approx(0.4).epsilon(1e-6));
    CHECK(result.cost == doctest::Approx(0.5 * 2.0 * 2.0).epsilon(1e-12));
}

TEST_CASE("minimizer: a periodic unknown ends at the equivalent value nearest the reference")
{
    // The answer 0.2 + whole turns; started a turn and a bit up, the solve lands on 0.2 + 2 pi, which is taken
    // back to the value nearest the reference 0.1.
    AngleAndDistance problem(0.2, 0.0);
    const Unknowns u = angleAndDistance(-1.0, 1.0);
    MinimizerState state(3, 2);
    const double turn = 2.0 * std::numbers::pi;
    state.x = {turn + 0.1, 0.0};
    const std::vector<double> near{0.1, 0.0};
    const MinimizerResult result = minimize(problem, u, SolverOptions{}, state, near);
    CHECK(result.converged);
    CHECK(state.x[0] == doctest::Approx(0.2).epsilon(1e-9));
    CHECK_FALSE(result.evaluatedAtEnd);  // moved after its last evaluation
}

TEST_CASE("minimizer on the real rig: the trust region, the limits and the answer of solveOnRealRig")
{
    test::LambdaRig rig = test::twoArms();
    const Approximation a = test::learn(rig, "twoArms");
    RigBinding binding(a, rig);
    const int elbow = test::parameterIndex(a, "L_elbow.rotateZ");
    REQUIRE(elbow >= 0);
    std::mt19937 rng(3);
    std::vector<double> truth = test::randomValues(a, rng, 0.5);
    std::vector<Eigen::Matrix4d> worlds;
    binding.evaluate(truth, worlds);
    std::vector<JointTarget> targets(worlds.size());
    for (std::size_t k = 0; k < worlds.size(); ++k) targets[k] = {true, worlds[k], 1.0, 1.0};
    RealRigProblem problem(binding, 10.0);
    problem.setTargets(targets);
    const std::vector<double> start = a.defaults();

    SUBCASE("one iteration moves no angle further than realRigMaxAngularStep, and the largest exactly that far")
    {
        SolverOptions options;
        options.maxIterations = 1;
        options.realRigMaxAngularStep = 0.05;
        std::vector<double> x = start;
        solveOnRealRig(problem, x, options);
        double largest = 0.0;
        for (std::size_t p = 0; p < x.size(); ++p)
            if (a.parameters[p].parameter.angular) largest = std::max(largest, std::abs(x[p] - start[p]));
        CHECK(largest == doctest::Approx(0.05).epsilon(1e-12));
    }
    SUBCASE("a reachable pose is reached on the real rig")
    {
        std::vector<double> x = start;
        const RealRigSolve s = solveOnRealRig(problem, x, SolverOptions{}, nullptr);
        CHECK(s.converged);
        CHECK(s.finalCost < 1e-16);
        CHECK(s.evaluations > 0);
        for (std::size_t p = 0; p < x.size(); ++p) CHECK(x[p] == doctest::Approx(truth[p]).epsilon(1e-6));
    }
    SUBCASE("a target past a limit: the control stays at the limit")
    {
        truth[static_cast<std::size_t>(elbow)] = -0.6;  // the elbow's limits are 0 .. 2.5
        binding.evaluate(truth, worlds);
        for (std::size_t k = 0; k < worlds.size(); ++k) targets[k].world = worlds[k];
        problem.setTargets(targets);
        std::vector<double> x = start;
        const RealRigSolve s = solveOnRealRig(problem, x, SolverOptions{});
        CHECK(s.converged);
        CHECK(x[static_cast<std::size_t>(elbow)] == 0.0);
        CHECK(s.finalCost > 1.0);
    }
}

TEST_CASE("step policies: a failed Gauss-Newton step is halved, then damped, the approximation's within its budget")
{
    const SolverOptions options;
    const auto never = [] { return 1.0; };
    StepControl approximation(options, StepPolicy::approximation());
    CHECK(approximation.gaussNewton());
    for (int halving = 1; halving <= 4; ++halving) {
        CAPTURE(halving);
        CHECK_FALSE(approximation.accept(1.0, 2.0, false, never));
        CHECK(approximation.gaussNewton());
        CHECK(approximation.scale() == std::ldexp(1.0, -halving));
    }
    CHECK_FALSE(approximation.accept(1.0, 2.0, false, never));  // the 5th failure: damped
    CHECK_FALSE(approximation.gaussNewton());
    CHECK(approximation.damping(10.0) == doctest::Approx(initialDamping * 10.0));
    // A damped step taken within Gauss-Newton's budget: the next one is Gauss-Newton again, undamped.
    CHECK(approximation.accept(1.0, 0.5, false, [] { return 0.5; }));
    approximation.accepted();
    CHECK(approximation.gaussNewton());
    CHECK(approximation.damping(10.0) == 0.0);
    // The budget counts Gauss-Newton steps taken: spent, Levenberg-Marquardt to the end, its damping kept from step to
    // step.
    for (int step = 1; step <= options.gaussNewtonIterations; ++step) {
        CAPTURE(step);
        CHECK(approximation.gaussNewton());
        CHECK(approximation.accept(1.0, 0.5, false, never));
        approximation.accepted();
    }
    CHECK_FALSE(approximation.gaussNewton());
    const double damping = approximation.damping(10.0);
    CHECK(damping == doctest::Approx(initialDamping * 10.0));
    CHECK(approximation.accept(1.0, 0.5, false, [] { return 0.5; }));
    approximation.accepted();
    CHECK_FALSE(approximation.gaussNewton());
    CHECK(approximation.damping(10.0) < damping);  // Nielsen's rule on a good step, not afresh
    // No budget (gaussNewtonIterations 0): Levenberg-Marquardt from the start to the end.
    SolverOptions dampedOnly;
    dampedOnly.gaussNewtonIterations = 0;
    StepControl damped(dampedOnly, StepPolicy::approximation());
    CHECK_FALSE(damped.gaussNewton());
    CHECK(damped.accept(1.0, 0.5, false, [] { return 0.5; }));
    damped.accepted();
    CHECK_FALSE(damped.gaussNewton());

    StepControl realRig(options, StepPolicy::realRig());
    for (int halving = 1; halving <= 10; ++halving) {
        CAPTURE(halving);
        CHECK_FALSE(realRig.accept(1.0, 2.0, false, never));
        CHECK(realRig.gaussNewton());
        CHECK(realRig.scale() == std::ldexp(1.0, -halving));
    }
    CHECK_FALSE(realRig.accept(1.0, 2.0, false, never));  // the 11th failure: damping from now on
    CHECK_FALSE(realRig.gaussNewton());
    CHECK(realRig.scale() == 1.0);
    CHECK(realRig.damping(10.0) == doctest::Approx(initialDamping * 10.0));
    // A damped step taken: the next one is Gauss-Newton again, undamped.
    CHECK(realRig.accept(1.0, 0.5, false, [] { return 0.5; }));
    realRig.accepted();
    CHECK(realRig.gaussNewton());
    CHECK(realRig.damping(10.0) == 0.0);
    // Rejected damped steps raise the damping until it passes 1e8 of the diagonal: exhausted.
    CHECK_FALSE(realRig.accept(1.0, 2.0, false, never));
    for (int i = 0; i < 10; ++i) realRig.accept(1.0, 2.0, false, never);
    CHECK_FALSE(realRig.gaussNewton());
    realRig.damping(10.0);
    int rejections = 0;
    while (!realRig.exhausted() && rejections < 100) {
        realRig.accept(1.0, 2.0, false, never);
        ++rejections;
    }
    CHECK(realRig.exhausted());
    CHECK(rejections < 20);
}

TEST_CASE("step policies: a Gauss-Newton step taken only after halvings leaves the failures counted")
{
    // Failed whole (5 trials), damped, taken at half, failed whole again, damped: two failures with only damped and
    // halved steps between, so Levenberg-Marquardt to the end. Taken whole in the middle instead, Gauss-Newton goes on.
    const SolverOptions options;
    const auto never = [] { return 1.0; };
    const auto good = [] { return 0.5; };
    for (const bool halvedInTheMiddle : {true, false}) {
        CAPTURE(halvedInTheMiddle);
        StepControl control(options, StepPolicy::approximation());
        const auto failWhole = [&] {
            for (int trial = 0; trial < 5; ++trial) CHECK_FALSE(control.accept(1.0, 2.0, false, never));
            CHECK_FALSE(control.gaussNewton());
            CHECK(control.accept(1.0, 0.5, false, good));
            control.accepted();
        };
        failWhole();
        REQUIRE(control.gaussNewton());
        if (halvedInTheMiddle) CHECK_FALSE(control.accept(1.0, 2.0, false, never));
        CHECK(control.accept(1.0, 0.9, false, never));
        control.accepted();
        REQUIRE(control.gaussNewton());
        failWhole();
        CHECK(control.gaussNewton() == !halvedInTheMiddle);
    }
}

TEST_CASE("minimizer: given up where the cost stalls above the tolerance and the caller's bound")
{
    // Along the valley from x = -3 the damped steps lower a cost of about 0.5 (the miss's) by a fraction of a percent
    // each: given up after the window's ten iterations, not converged; with the caller's bound above that cost, never,
    // to maxIterations.
    const Approximation a = twoDistances();
    const Unknowns u(a, nullptr, {0, 1});
    const auto run = [&](GiveUp giveUp) {
        CurvedValley problem(1e-2, 1.0);
        MinimizerState state(3, 2);
        state.x = {-3.0, 9.0};
        const std::vector<double> near{-3.0, 9.0};
        return minimize(problem, u, SolverOptions{}, state, near, StepPolicy::approximation(), giveUp);
    };
    const MinimizerResult stalled = run(GiveUp{10, 0.0});
    CHECK(stalled.stalled);
    CHECK_FALSE(stalled.converged);
    CHECK(stalled.gaussNewton + stalled.levenbergMarquardt == 10);
    CHECK(stalled.cost > 0.5);
    for (const GiveUp never : {GiveUp{10, 1e3}, GiveUp{}}) {
        const MinimizerResult r = run(never);
        CHECK_FALSE(r.stalled);
        CHECK(r.gaussNewton + r.levenbergMarquardt == SolverOptions{}.maxIterations);
    }
}

TEST_CASE("minimizer: ten accepted steps that lower the cost by a millionth of it end the solve, above the tolerance")
{
    // A miss of 1 no unknown moves, and a faint pull (weight 2.2e-5) of the angle towards 100 radians: each step the
    // trust region lets through (0.5) lowers a cost of 0.5 by 5e-8 of it, more than the function tolerance's 1e-8, for
    // the 200 steps to 100. A stationary point for any purpose: converged after ten such steps, not at maxIterations.
    const Unknowns u = angleAndDistance(-100, 100);
    const auto run = [&](bool faint) {
        FarPull problem(faint ? std::sqrt(5e-10) : 1e-2);
        MinimizerState state(3, 2);
        state.x = {0.0, 0.0};
        const std::vector<double> near{0.0, 0.0};
        SolverOptions options;
        options.maxAngularStep = 0.5;
        return std::pair{minimize(problem, u, options, state, near), state.x[0]};
    };
    const auto [faint, angle] = run(true);
    CHECK(faint.converged);
    CHECK(faint.gaussNewton + faint.levenbergMarquardt == 10);
    CHECK(std::remainder(angle - 5.0, 2.0 * std::numbers::pi) == doctest::Approx(0.0).scale(1.0).epsilon(1e-12));
    CHECK(faint.cost == doctest::Approx(0.5).epsilon(1e-5));
    // Pulled by 1e-2, each step gains 1e-2 of the cost: on to maxIterations (50 radians by then). The angle is a turn's
    // period: it ends at the equivalent value nearest its start.
    const auto [pulled, far] = run(false);
    CHECK(pulled.gaussNewton + pulled.levenbergMarquardt == SolverOptions{}.maxIterations);
    CHECK(std::remainder(far - 50.0, 2.0 * std::numbers::pi) == doctest::Approx(0.0).scale(1.0).epsilon(1e-12));
}

TEST_CASE("minimizer: a whole step that lands where its model said, on a floor within the tolerance, ends the solve")
{
    // A miss no unknown moves, the floor a frame's cost falls to where the approximation misses targets from the real
    // rig by a little. A step that lands on the model's minimum to a thousandth of the cost ends the solve there, the
    // other residuals then within about sqrt(2e-3) of the miss; without a miss, or with one below 1e-2 of the
    // tolerance, the solve converges on, its other residuals to rounding.
    const Approximation a = twoDistances();
    const Unknowns u(a, nullptr, {0, 1});
    struct Run {
        MinimizerResult result;
        double moved;  // the norm of the residuals the unknowns move, at the end
    };
    const auto run = [&](double miss) {
        SineWithMiss problem(miss);
        MinimizerState state(3, 2);
        state.x = {0.9, -0.8};
        const std::vector<double> near{0.9, -0.8};
        const MinimizerResult result = minimize(problem, u, SolverOptions{}, state, near);
        Eigen::VectorXd r;
        problem.residuals(state.x, r);
        return Run{result, r.head<2>().norm()};
    };
    const double tolerance = SolverOptions{}.targetTolerance;
    const Run floor = run(0.2 * tolerance), exact = run(0.0), below = run(1e-3 * tolerance);
    MESSAGE("on the floor: " << floor.result.gaussNewton << " iterations, the moved residuals " << floor.moved
                             << "; without a miss: " << exact.result.gaussNewton << ", " << exact.moved
                             << "; a miss of 1e-6 cm: " << below.result.gaussNewton << ", " << below.moved);
    CHECK(floor.result.converged);
    CHECK(floor.result.cost <= (1.0 + 1e-3) * 0.5 * std::pow(0.2 * tolerance, 2));
    CHECK(floor.moved <= std::sqrt(2e-3) * 0.2 * tolerance);
    CHECK(exact.result.converged);
    CHECK(exact.moved < 1e-12);
    CHECK(below.result.converged);
    CHECK(below.moved < 1e-12);
    CHECK(floor.result.gaussNewton < exact.result.gaussNewton);
}
