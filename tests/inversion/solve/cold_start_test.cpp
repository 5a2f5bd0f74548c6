// Cold starts (docs/solver.md): random in-range poses solved from rest must be found, not a local
// minimum beside them. Targets are the approximation's own worlds at a random pose, so the answer is
// reachable exactly; a pose counts as recovered when every joint is within 1e-4 cm (rotations through
// rotationScaleCm). The same poses solved from rest without the initial guess are counted beside, as
// the figure the guess improves on.
#include <doctest/doctest.h>

#include <random>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "inversion/random_fk.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "learned_fixtures.h"
#include "test_support.h"

using namespace rig;

namespace {

constexpr double recovered = 1e-4;  // cm

struct Recovery {
    int poses = 0;
    int fromGuess = 0;  // recovered with Solver::initialGuess
    int fromRest = 0;   // recovered from rest alone
};

bool reached(const SolveSummary& s, double rotationScaleCm)
{
    return s.maxPositionErrorCm <= recovered && rotationScaleCm * s.maxRotationErrorDeg * test::degree <= recovered;
}

// `poses` random in-range poses of `a`, each solved from rest with and without the initial guess.
void recover(const Approximation& a, int poses, std::mt19937& rng, Recovery& recovery)
{
    const Solver solver(a, SolverOptions{});
    for (int pose = 0; pose < poses; ++pose) {
        const std::vector<double> known = test::randomValues(a, rng);
        const std::vector<JointTarget> targets = test::targetsAt(a, known);
        std::vector<double> values = a.defaults();
        REQUIRE(solver.initialGuess(targets, values) == TerminationType::converged);
        const SolveSummary guessed = solver.solve(targets, values);
        values = a.defaults();
        const SolveSummary rest = solver.solve(targets, values);
        ++recovery.poses;
        recovery.fromGuess += reached(guessed, solver.options().rotationScaleCm);
        recovery.fromRest += reached(rest, solver.options().rotationScaleCm);
        // What is not recovered is never called converged.
        if (!reached(guessed, solver.options().rotationScaleCm)) CHECK(!guessed.converged());
        if (!reached(rest, solver.options().rotationScaleCm)) CHECK(!rest.converged());
    }
}

// Three fingers of three phalanges, each curled by one control through a multiplyDivide (up to 270
// degrees summed along a finger), on a wrist whose own rotation is a control too.
constexpr const char* curlHand = R"(nodes:
  - name: hand_ctrl
    type: transform
    addAttr:
      - {name: curlIndex, unit: angle, min: 0, max: 90, keyable: true}
      - {name: curlMiddle, unit: angle, min: 0, max: 90, keyable: true}
      - {name: curlRing, unit: angle, min: 0, max: 90, keyable: true}
  - {name: wrist, type: joint, translate: [0, 100, 0]}
{fingers}connections:
{connections})";

std::string curlHandRig()
{
    std::string fingers, connections;
    const char* names[] = {"Index", "Middle", "Ring"};
    for (int f = 0; f < 3; ++f) {
        const std::string n = names[f];
        fingers += fmt::format(
            "  - {{name: {0}1, type: joint, parent: wrist, translate: [8, 0, {1}]}}\n"
            "  - {{name: {0}2, type: joint, parent: {0}1, translate: [3, 0, 0]}}\n"
            "  - {{name: {0}3, type: joint, parent: {0}2, translate: [2.5, 0, 0]}}\n"
            "  - {{name: {0}4, type: joint, parent: {0}3, translate: [2, 0, 0]}}\n"
            "  - {{name: curl{0}, type: multiplyDivide, input2: [1, 1, 1]}}\n",
            n, 2 - 2 * f);
        for (const char axis : {'X', 'Y', 'Z'})
            connections += fmt::format("  - hand_ctrl.curl{0} -> curl{0}.input1{1}\n", n, axis);
        connections += fmt::format(
            "  - curl{0}.outputX -> {0}1.rotateZ\n  - curl{0}.outputY -> {0}2.rotateZ\n"
            "  - curl{0}.outputZ -> {0}3.rotateZ\n",
            n);
    }
    std::string rig = curlHand;
    rig.replace(rig.find("{fingers}"), 9, fingers);
    rig.replace(rig.find("{connections}"), 13, connections);
    return rig;
}

}  // namespace

TEST_CASE("cold starts: random in-range poses of random FK rigs are recovered from rest")
{
    std::mt19937 rng(20261125);
    Recovery recovery;
    for (int trial = 0; trial < 40; ++trial) {
        CAPTURE(trial);
        test::LambdaRig rig = test::lambdaRig(test::randomFk(rng), true);
        LearnOptions options;
        options.validationPoses = 5;
        const Approximation a = learnApproximation(rig, options, "random");
        REQUIRE(a.discarded.empty());
        recover(a, 25, rng, recovery);
    }
    MESSAGE(fmt::format("random FK rigs: {} of {} poses recovered from the initial guess, {} from rest",
                        recovery.fromGuess, recovery.poses, recovery.fromRest));
    CHECK(recovery.poses == 1000);
    CHECK(recovery.fromGuess >= 999);  // 99.9%
}

TEST_CASE("cold starts: a hand whose fingers curl up to 270 degrees is recovered from rest, not left straight")
{
    const auto dir = test::scratchDir("cold-start-hand");
    const auto file = test::writeFile(dir / "hand.yaml", curlHandRig());
    GraphRigFunction rig(file, {{"hand_ctrl.curl*", "wrist.rotate?"}, {}, {}});
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    REQUIRE(a.discarded.empty());
    REQUIRE(a.validation.withinEpsilon);
    std::mt19937 rng(17);
    Recovery recovery;
    recover(a, 1000, rng, recovery);
    MESSAGE(fmt::format("curl hand: {} of {} poses recovered from the initial guess, {} from rest", recovery.fromGuess,
                        recovery.poses, recovery.fromRest));
    CHECK(recovery.fromGuess >= 999);
    CHECK(recovery.fromRest < recovery.fromGuess);  // rest alone is stuck on some: the case the guess is for

    // The fist: every finger curled fully, from rest.
    std::vector<double> fist = a.defaults();
    for (std::size_t p = 0; p < fist.size(); ++p)
        if (a.parameters[p].parameter.name.starts_with("hand_ctrl.curl")) fist[p] = a.parameters[p].parameter.max;
    const std::vector<JointTarget> targets = test::targetsAt(a, fist);
    const Solver solver(a, SolverOptions{});
    std::vector<double> values = a.defaults();
    solver.initialGuess(targets, values);
    const SolveSummary s = solver.solve(targets, values);
    CAPTURE(s.briefReport());
    CHECK(s.converged());
    CHECK(s.maxPositionErrorCm < recovered);
}

TEST_CASE("cold starts: a crowd's guess is each member's own guess, bit for bit")
{
    // Three characters sharing nothing: the guess of the whole crowd must be, member by member, the guess made
    // with only that member's targets active (the others' parameters then keep their values), and recover
    // every member's pose.
    test::LambdaRig crowd = test::crowdOf(test::twoArms(), 3, 60.0);
    const Approximation a = test::learn(crowd, "crowd");
    const Solver solver(a, SolverOptions{});
    // The member of a parameter or an output, from its prefix ("c1_...").
    const auto member = [](const std::string& name) { return static_cast<std::size_t>(name[1] - '0'); };
    std::mt19937 rng(17);
    for (int pose = 0; pose < 5; ++pose) {
        CAPTURE(pose);
        const std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng));
        std::vector<double> all = a.defaults();
        REQUIRE(solver.initialGuess(targets, all) == TerminationType::converged);
        for (std::size_t c = 0; c < 3; ++c) {
            CAPTURE(c);
            std::vector<JointTarget> alone = targets;
            for (std::size_t k = 0; k < alone.size(); ++k) alone[k].active = member(a.outputs[k].name) == c;
            std::vector<double> values = a.defaults();
            REQUIRE(solver.initialGuess(alone, values) == TerminationType::converged);
            for (std::size_t p = 0; p < values.size(); ++p)
                CHECK(values[p] == (member(a.parameters[p].parameter.name) == c ? all[p] : a.defaults()[p]));
        }
        const SolveSummary s = solver.solve(targets, all);
        CHECK(reached(s, solver.options().rotationScaleCm));
    }
}

TEST_CASE("cold starts: random poses of the biped's modelled parameters are recovered from rest")
{
    const Approximation a = readApproximationFile(test::bipedApproximation());
    std::mt19937 rng(5);
    Recovery recovery;
    recover(a, 300, rng, recovery);
    MESSAGE(fmt::format("biped: {} of {} poses recovered from the initial guess, {} from rest", recovery.fromGuess,
                        recovery.poses, recovery.fromRest));
    CHECK(recovery.fromGuess == recovery.poses);
}

TEST_CASE("cold starts: a cut in a clip, an open hand then curled fingers, is caught by retrying the stuck frame")
{
    const auto dir = test::scratchDir("cold-start-cut");
    const auto file = test::writeFile(dir / "hand.yaml", curlHandRig());
    GraphRigFunction rig(file, {{"hand_ctrl.curl*", "wrist.rotate?"}, {}, {}});
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    // The first random pose that a solve warm-started from the open hand misses.
    std::mt19937 rng(23);
    std::vector<double> curled;
    for (int pose = 0; pose < 100 && curled.empty(); ++pose) {
        std::vector<double> known = test::randomValues(a, rng), values = a.defaults();
        if (Solver(a, SolverOptions{}).solve(test::targetsAt(a, known), values).termination == TerminationType::stuck)
            curled = known;
    }
    REQUIRE(!curled.empty());
    ClipTargets clip;
    clip.frames = {test::targetsAt(a, a.defaults()), test::targetsAt(a, curled)};
    RigBinding binding(a, rig);
    for (const bool retry : {false, true}) {
        CAPTURE(retry);
        ClipInversionOptions options;
        options.retryStuck = retry;
        std::vector<std::vector<double>> values;
        const ClipInversionSummary s = invertClip(Solver(a, options.solver), binding, clip, 0, 1, options, values);
        if (!retry) {
            // Warm-started from the open hand, the curled frame stops in another basin: stuck.
            CHECK(s.perFrame[1].solve.termination == TerminationType::stuck);
            CHECK(s.retriedFrames == 0);
            continue;
        }
        CHECK(s.retriedFrames == 1);
        CHECK(s.retriesKept == 1);
        CHECK(s.count(FrameStatus::reached) == 2);
        CHECK(s.maxPositionErrorCm < recovered);
    }
}
