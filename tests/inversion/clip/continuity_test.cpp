// Curves without flips across restarts (inversion/clip/continuity.h): free rotate channels that wind past a
// half turn and a restart inside gimbal lock are shifted by equivalences to meet the frame before, the
// pose unchanged, and chunks continued from the frame before their lead-in equal one run bit for bit.
#include <doctest/doctest.h>

#include <numbers>

#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/continuity.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

RigParameter freeAngle(const std::string& name)
{
    RigParameter p = test::angle(name, -3.2, 3.2);
    p.limited = false;  // a free rotation: the range is only what it was learned on
    return p;
}

// A shoulder with free rotate channels (R = Rx Ry Rz, composed in the parameters' order) on a root that
// turns freely about Y, an elbow and a hand below.
test::LambdaRig turningShoulder()
{
    return test::LambdaRig(
        {freeAngle("root.rotateY"), freeAngle("shoulder.rotateX"), freeAngle("shoulder.rotateY"),
         freeAngle("shoulder.rotateZ")},
        {"root", "shoulder", "elbow", "hand"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
            w[0] = test::rotation(Eigen::Vector3d::UnitY(), v[0]);
            w[1] = w[0] * test::translation(0, 100, 0) * test::rotation(Eigen::Vector3d::UnitX(), v[1]) *
                   test::rotation(Eigen::Vector3d::UnitY(), v[2]) * test::rotation(Eigen::Vector3d::UnitZ(), v[3]);
            w[2] = w[1] * test::translation(10, 0, 0);
            w[3] = w[2] * test::translation(10, 2, 1);
        });
}

// The root turns two whole turns; the shoulder passes through gimbal lock (Y = 90 degrees) and back.
ClipTargets turningClip(const Approximation& a, int frames, double& largestTargetStep)
{
    ClipTargets clip;
    std::vector<double> previous;
    largestTargetStep = 0.0;
    for (int f = 0; f < frames; ++f) {
        std::vector<double> pose = a.defaults();
        const double t = static_cast<double>(f) / (frames - 1);
        pose[static_cast<std::size_t>(test::parameterIndex(a, "root.rotateY"))] = 4 * std::numbers::pi * t;
        pose[static_cast<std::size_t>(test::parameterIndex(a, "shoulder.rotateX"))] =
            20 * test::degree * std::sin(6 * std::numbers::pi * t);
        pose[static_cast<std::size_t>(test::parameterIndex(a, "shoulder.rotateY"))] =
            (90 - 30 * std::cos(6 * std::numbers::pi * t)) * test::degree;
        pose[static_cast<std::size_t>(test::parameterIndex(a, "shoulder.rotateZ"))] =
            30 * test::degree * std::cos(2 * std::numbers::pi * t);
        if (!previous.empty())
            for (std::size_t p = 0; p < pose.size(); ++p)
                largestTargetStep = std::max(largestTargetStep, std::abs(pose[p] - previous[p]));
        previous = pose;
        clip.frames.push_back(test::targetsAt(a, pose));
    }
    return clip;
}

double largestStep(const std::vector<std::vector<double>>& values)
{
    double largest = 0.0;
    for (std::size_t f = 1; f < values.size(); ++f)
        for (std::size_t p = 0; p < values[f].size(); ++p)
            largest = std::max(largest, std::abs(values[f][p] - values[f - 1][p]));
    return largest;
}

}  // namespace

TEST_CASE("continuity: the equivalences of a skeleton are its free channels' turns and its joints' Euler triples")
{
    auto rig = turningShoulder();
    const Approximation a = test::learn(rig, "turning shoulder");
    const Equivalences e(a);
    for (std::size_t p = 0; p < a.parameters.size(); ++p) CHECK(e.period[p] == doctest::Approx(2 * std::numbers::pi));
    REQUIRE(e.triples.size() == 1);
    const std::array<int, 3> shoulder{test::parameterIndex(a, "shoulder.rotateX"),
                                      test::parameterIndex(a, "shoulder.rotateY"),
                                      test::parameterIndex(a, "shoulder.rotateZ")};
    CHECK(e.triples[0] == shoulder);
    // Limited channels repeat nothing (a limit is not periodic), and the root alone is no triple.
    auto limited = test::fkArm();
    const Approximation arm = test::learn(limited, "arm");
    const Equivalences none(arm);
    CHECK(none.triples.empty());
    for (const double period : none.period) CHECK(period == 0.0);

    // A shift keeps the pose: the other Euler solution and whole turns.
    std::mt19937 rng(3);
    for (int trial = 0; trial < 20; ++trial) {
        const std::vector<double> first = test::randomValues(a, rng);
        std::vector<double> previous = first;
        for (double& v : previous) v += 2 * std::numbers::pi * static_cast<double>(trial % 3);
        previous[static_cast<std::size_t>(shoulder[0])] += std::numbers::pi;
        previous[static_cast<std::size_t>(shoulder[1])] = std::numbers::pi -
                                                          previous[static_cast<std::size_t>(shoulder[1])] +
                                                          2 * std::numbers::pi * static_cast<double>(trial % 3);
        previous[static_cast<std::size_t>(shoulder[2])] += std::numbers::pi;
        const ChunkShift shift = continuityShift(e, previous, first);
        std::vector<double> shifted(first.size());
        applyShift(e, shift, first, shifted);
        CHECK(shift.otherSolution[0] == 1);
        for (std::size_t p = 0; p < shifted.size(); ++p)
            CHECK(shifted[p] == doctest::Approx(previous[p]).epsilon(1e-12));
        std::vector<Eigen::Matrix4d> before, after;
        a.evaluate(first, before);
        a.evaluate(shifted, after);
        for (std::size_t k = 0; k < before.size(); ++k) CHECK((before[k] - after[k]).cwiseAbs().maxCoeff() < 1e-9);
    }
}

TEST_CASE(
    "continuity: restarts do not jump: a root turning twice and a shoulder through gimbal lock, restarted every 50 "
    "frames")
{
    auto rig = turningShoulder();
    const Approximation a = test::learn(rig, "turning shoulder");
    constexpr int frames = 301;
    double largestTargetStep = 0.0;
    const ClipTargets clip = turningClip(a, frames, largestTargetStep);
    RigBinding binding(a, rig);
    ClipInversionOptions options;
    options.restartInterval = 50;
    std::vector<std::vector<double>> values;
    const ClipInversionSummary s = invertClip(Solver(a, options.solver), binding, clip, 0, frames - 1, options, values);
    CHECK(s.count(FrameStatus::reached) == frames);
    CHECK(s.maxPositionErrorCm < 1e-6);
    CHECK(s.maxRotationErrorDeg < 1e-6);
    const double step = largestStep(values);
    MESSAGE("largest control step " << step / test::degree << " deg per frame; the pose's largest "
                                    << largestTargetStep / test::degree);
    CHECK(step < 1.5 * largestTargetStep);
    // The root has wound two whole turns, as the clip does.
    CHECK(values.back()[static_cast<std::size_t>(test::parameterIndex(a, "root.rotateY"))] ==
          doctest::Approx(4 * std::numbers::pi).epsilon(1e-6));

    // Chunks continued from the frame before their lead-in give one run's values, bit for bit.
    for (const int split : {50, 123, 250}) {
        CAPTURE(split);
        const Solver solver(a, options.solver);
        std::vector<std::vector<double>> head, tail;
        invertClip(solver, binding, clip, 0, split - 1, options, head);
        ClipInversionOptions continued = options;
        const int restart = split - split % options.restartInterval;
        continued.continueFrom = values[static_cast<std::size_t>(restart - 1)];
        invertClip(solver, binding, clip, split, frames - 1, continued, tail);
        REQUIRE(head.size() + tail.size() == values.size());
        for (std::size_t f = 0; f < values.size(); ++f) {
            const auto& chunk = f < head.size() ? head[f] : tail[f - head.size()];
            CHECK(chunk == values[f]);
        }
    }
    // Without the frame before, a chunk reports its chain as solved: the root within a half turn of
    // rest, whole turns from one run's.
    std::vector<std::vector<double>> alone;
    invertClip(Solver(a, options.solver), binding, clip, 250, frames - 1, options, alone);
    const std::size_t root = static_cast<std::size_t>(test::parameterIndex(a, "root.rotateY"));
    CHECK(std::abs(alone.front()[root]) < std::numbers::pi);
    const double turns = (values[250][root] - alone.front()[root]) / (2 * std::numbers::pi);
    CHECK(turns == doctest::Approx(2.0).epsilon(1e-9));
}
