// Sparse keys on a small real rig (a chain turned at the root and the middle, a limited curl driving the
// tip through a set-driven key): the keyed curves keep every joint within the tolerance of the dense pose,
// measured here again from the keys alone; far fewer keys than frames; a constant curve keeps one key; a
// spline that would overshoot a control's limit gets the keys that keep it inside; the uniform step holds
// the tolerance too. Key values are fitted: a line under alternating noise is two keys on the line, jittery
// curves are keyed near the motion beneath (where keys on the values at the same frames are out of the
// tolerance), and where the prediction misses (a rig changed since it was learned) the real rig decides.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "adapter/graph_rig_function.h"
#include "adapter/key_reduction.h"
#include "core/rotation_math.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/solve/jacobian.h"
#include "test_support.h"

using namespace rig;

namespace {

constexpr const char* chainRig = R"(nodes:
  - {name: root, type: joint}
  - {name: a, type: joint, parent: root, translate: [30, 0, 0]}
  - {name: b, type: joint, parent: a, translate: [30, 0, 0]}
  - {name: tip, type: joint, parent: b, translate: [20, 0, 0]}
  - name: ctrl
    type: transform
    addAttr: [{name: curl, type: double, min: 0, max: 1, keyable: true}]
  - {name: curl_sdk, type: animCurveUA, keys: [[0, 0], [1, 90]], tangents: linear}
connections:
  - ctrl.curl -> curl_sdk.input
  - curl_sdk.output -> b.rotateZ
)";

struct Chain {
    std::unique_ptr<GraphRigFunction> rig;
    Approximation approximation;
};

// `name`: a scratch folder of the test case's own (CTest runs the cases of this file in parallel processes).
Chain chain(const std::string& name)
{
    const auto file = test::writeFile(test::scratchDir("key_reduction_" + name) / "chain.yaml", chainRig);
    Chain c;
    const GraphRigOptions options{{"root.rotate?", "a.rotateZ", "ctrl.curl"}, {}, {}};
    c.rig = std::make_unique<GraphRigFunction>(file, options);
    c.approximation = learnApproximation(*c.rig, LearnOptions{}, file.string());
    return c;
}

// Dense curves over `frames` frames: slow turns with a little jitter, a constant one, and a curl that rests at 0,
// rises and rests at 1 (where a spline between keys overshoots).
std::vector<std::vector<double>> denseCurves(const Approximation& a, int frames)
{
    std::vector<std::vector<double>> dense;
    for (int f = 0; f < frames; ++f) {
        auto& row = dense.emplace_back();
        for (const auto& m : a.parameters) {
            const std::string& name = m.parameter.name;
            const double t = f / 10.0;
            const double jitter = 0.002 * std::sin(7.3 * f);
            if (name == "ctrl.curl") row.push_back(std::clamp((f - 20) / 10.0, 0.0, 1.0));
            else if (name == "root.rotateX") row.push_back(0.25);
            else if (name == "root.rotateY") row.push_back(0.4 * std::sin(t) + jitter);
            else row.push_back(0.3 * std::cos(0.7 * t) + jitter);
        }
    }
    return dense;
}

double rotationDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
    return orientationAngle(a.topLeftCorner<3, 3>(), b.topLeftCorner<3, 3>()) * 180.0 / std::numbers::pi;
}

// The real rig driven by curves with these keys against it driven by the dense values: the worst joint.
struct RealError {
    double cm = 0.0;
    double deg = 0.0;
};
RealError realError(RigBinding& binding, const std::vector<double>& frames,
                    const std::vector<std::vector<double>>& dense, const std::vector<std::vector<AnimKey>>& keys)
{
    std::vector<AnimCurve> curves;
    for (const auto& k : keys) curves.push_back(AnimCurve::build(k));
    std::vector<Eigen::Matrix4d> denseWorlds, keyedWorlds;
    RealError e;
    for (std::size_t f = 0; f < frames.size(); ++f) {
        std::vector<double> values;
        for (const auto& curve : curves) values.push_back(curve.evaluate(frames[f]));
        binding.evaluate(dense[f], denseWorlds);
        binding.evaluate(values, keyedWorlds);
        for (std::size_t o = 0; o < denseWorlds.size(); ++o) {
            e.cm = std::max(e.cm, (denseWorlds[o].block<3, 1>(0, 3) - keyedWorlds[o].block<3, 1>(0, 3)).norm());
            e.deg = std::max(e.deg, rotationDeg(denseWorlds[o], keyedWorlds[o]));
        }
    }
    return e;
}

// The same key frames with values placed on the dense curves.
std::vector<std::vector<AnimKey>> placedOnDense(const std::vector<std::vector<AnimKey>>& keys,
                                                const std::vector<double>& frames,
                                                const std::vector<std::vector<double>>& dense)
{
    auto placed = keys;
    for (std::size_t p = 0; p < placed.size(); ++p)
        for (AnimKey& k : placed[p]) {
            const auto f =
                static_cast<std::size_t>(std::lower_bound(frames.begin(), frames.end(), k.x) - frames.begin());
            k.y = dense[f][p];
        }
    return placed;
}

std::size_t parameterIndex(const Approximation& a, const std::string& name)
{
    std::size_t p = 0;
    while (a.parameters[p].parameter.name != name) ++p;
    return p;
}

}  // namespace

TEST_CASE("key reduction: the keys alone keep the real rig within the tolerance of the dense pose, with few keys")
{
    Chain c = chain("1");
    REQUIRE(c.approximation.parameters.size() == 5);
    RigBinding binding(c.approximation, *c.rig);
    const int n = 60;
    const auto dense = denseCurves(c.approximation, n);
    std::vector<double> frames;
    for (int f = 0; f < n; ++f) frames.push_back(101.0 + f);
    KeyReductionOptions options;
    options.toleranceCm = 0.05;
    options.toleranceDeg = 0.2;
    const KeyedCurves keyed = reduceKeys(binding, frames, dense, options);

    CHECK(keyed.error.maxPositionCm <= options.toleranceCm);
    CHECK(keyed.error.maxRotationDeg <= options.toleranceDeg);
    CHECK(keyed.keyCount() < static_cast<std::size_t>(n * 5) / 3);
    CHECK(keyed.rigEvaluations > n);
    // Measured again from the keys alone, through the curves an animCurve node builds.
    std::vector<AnimCurve> curves;
    for (std::size_t p = 0; p < keyed.keys.size(); ++p) {
        const auto& keys = keyed.keys[p];
        REQUIRE(!keys.empty());
        CHECK(keys.front().x == frames.front());
        if (c.approximation.parameters[p].parameter.name == "root.rotateX") CHECK(keys.size() == 1);
        else CHECK(keys.back().x == frames.back());
        curves.push_back(AnimCurve::build(keys));
    }
    std::vector<Eigen::Matrix4d> denseWorlds, keyedWorlds;
    double worstCm = 0.0, worstDeg = 0.0;
    for (int f = 0; f < n; ++f) {
        std::vector<double> values;
        for (const auto& curve : curves) values.push_back(curve.evaluate(frames[static_cast<std::size_t>(f)]));
        CHECK(values == keyed.values[static_cast<std::size_t>(f)]);
        binding.evaluate(dense[static_cast<std::size_t>(f)], denseWorlds);
        binding.evaluate(values, keyedWorlds);
        for (std::size_t o = 0; o < denseWorlds.size(); ++o) {
            worstCm = std::max(worstCm, (denseWorlds[o].block<3, 1>(0, 3) - keyedWorlds[o].block<3, 1>(0, 3)).norm());
            worstDeg = std::max(worstDeg, rotationDeg(denseWorlds[o], keyedWorlds[o]));
        }
    }
    CHECK(worstCm <= options.toleranceCm);
    CHECK(worstDeg <= options.toleranceDeg);
    CHECK(worstCm == doctest::Approx(keyed.error.maxPositionCm));

    const UniformKeys uniform = uniformKeys(binding, frames, dense, options);
    CHECK(uniform.step >= 1);
    CHECK(uniform.error.maxPositionCm <= options.toleranceCm);
    CHECK(uniform.error.maxRotationDeg <= options.toleranceDeg);
    CHECK(uniform.keyCount >= keyed.keyCount());
}

TEST_CASE("key reduction: spline keys keep a limited control inside its limits")
{
    Chain c = chain("2");
    RigBinding binding(c.approximation, *c.rig);
    const int n = 50;
    const auto dense = denseCurves(c.approximation, n);
    std::vector<double> frames;
    for (int f = 0; f < n; ++f) frames.push_back(f);
    KeyReductionOptions options;
    options.tangent = TangentType::spline;
    options.toleranceCm = 2.0;  // loose: the spline's overshoot is what adds keys
    options.toleranceDeg = 5.0;
    const KeyedCurves keyed = reduceKeys(binding, frames, dense, options);
    std::size_t curl = 0;
    while (c.approximation.parameters[curl].parameter.name != "ctrl.curl") ++curl;
    for (const auto& row : keyed.values) {
        CHECK(row[curl] >= 0.0);
        CHECK(row[curl] <= 1.0);
    }
    CHECK(keyed.error.maxPositionCm <= options.toleranceCm);
}

TEST_CASE("key reduction: dense keys are one per frame, and bad inputs are refused")
{
    const std::vector<double> frames{1, 2, 3};
    const std::vector<std::vector<double>> dense{{0, 5}, {1, 5}, {2, 6}};
    const auto keys = denseKeys(frames, dense, TangentType::linear);
    REQUIRE(keys.size() == 2);
    CHECK(keys[1].size() == 3);
    CHECK(keys[1][2].y == 6.0);
    CHECK(keys[0][1].inTangent == TangentType::linear);
    KeyReductionOptions options;
    options.toleranceCm = 0.0;
    CHECK_THROWS_AS(options.validate(), rig::Error);
    // Under the floor the dense pose's own round-off (1.8e-12 degrees on the biped) could be over the tolerance.
    options.toleranceCm = KeyReductionOptions::minToleranceCm;
    options.toleranceDeg = 1e-20;
    CHECK_THROWS_WITH_AS(options.validate(), "toleranceDeg must be a number of at least 1e-09, got 1e-20", rig::Error);
    options.toleranceDeg = KeyReductionOptions::minToleranceDeg;
    CHECK_NOTHROW(options.validate());
    Chain c = chain("3");
    RigBinding binding(c.approximation, *c.rig);
    CHECK_THROWS_AS(reduceKeys(binding, frames, dense, KeyReductionOptions{}), rig::Error);
}

TEST_CASE("key reduction: a straight line under alternating noise within the tolerance is two keys on the line")
{
    Chain c = chain("4");
    RigBinding binding(c.approximation, *c.rig);
    // The tip is about 70 cm from root.rotateY's axis: noise of 0.001 rad moves it 0.07 cm, within 0.1 cm,
    // but keys placed on two noisy values miss by twice that.
    const int n = 61;
    const double noise = 0.001, slope = 0.005;
    std::vector<double> frames;
    std::vector<std::vector<double>> dense;
    for (int f = 0; f < n; ++f) {
        frames.push_back(f);
        auto& row = dense.emplace_back();
        for (const auto& m : c.approximation.parameters) {
            const std::string& name = m.parameter.name;
            if (name == "root.rotateY") row.push_back(0.2 + slope * f + (f % 2 == 0 ? noise : -noise));
            else if (name == "ctrl.curl") row.push_back(0.5);
            else row.push_back(0.25);
        }
    }
    KeyReductionOptions options;
    options.tangent = TangentType::linear;
    const KeyedCurves keyed = reduceKeys(binding, frames, dense, options);
    CHECK(keyed.keyCount() == 2 + 4);  // the other curves are constant: a key each
    const auto& line = keyed.keys[parameterIndex(c.approximation, "root.rotateY")];
    REQUIRE(line.size() == 2);
    // On the line the noise is drawn around, not on the noisy ends.
    CHECK(std::abs(line[0].y - 0.2) < 0.25 * noise);
    CHECK(std::abs(line[1].y - (0.2 + slope * (n - 1))) < 0.25 * noise);
    const RealError fitted = realError(binding, frames, dense, keyed.keys);
    CHECK(fitted.cm <= options.toleranceCm);
    CHECK(fitted.deg <= options.toleranceDeg);
    CHECK(fitted.cm == doctest::Approx(keyed.error.maxPositionCm));
    CHECK(realError(binding, frames, dense, placedOnDense(keyed.keys, frames, dense)).cm > options.toleranceCm);
}

TEST_CASE("key reduction: fitted keys keep to the middle of jittery curves, where keys on the values cannot")
{
    Chain c = chain("5");
    RigBinding binding(c.approximation, *c.rig);
    // Two turns, still at both ends, with jitter of random sign that moves the tip by up to 0.05 cm, half the
    // tolerance.
    const int n = 120;
    const double jitter = 0.0005;
    unsigned seed = 12345;
    const auto randomSign = [&] {
        seed = seed * 1103515245u + 12345u;
        return (seed >> 16) % 2 == 0 ? 1.0 : -1.0;
    };
    std::vector<double> frames;
    std::vector<std::vector<double>> smooth, jittery;
    for (int f = 0; f < n; ++f) {
        frames.push_back(1.0 + f);
        auto& row = smooth.emplace_back();
        auto& noisy = jittery.emplace_back();
        const double t = std::numbers::pi * f / (n - 1);
        for (const auto& m : c.approximation.parameters) {
            const std::string& name = m.parameter.name;
            const bool turning = name == "root.rotateY" || name == "a.rotateZ";
            if (name == "root.rotateY") row.push_back(0.2 * (1.0 - std::cos(2.0 * t)));
            else if (name == "a.rotateZ") row.push_back(0.3 * std::cos(t));
            else if (name == "ctrl.curl") row.push_back(0.5);
            else row.push_back(0.25);
            noisy.push_back(row.back() + (turning ? jitter * randomSign() : 0.0));
        }
    }
    KeyReductionOptions options;
    const KeyedCurves clean = reduceKeys(binding, frames, smooth, options);
    const KeyedCurves keyed = reduceKeys(binding, frames, jittery, options);
    const RealError fitted = realError(binding, frames, jittery, keyed.keys);
    CHECK(fitted.cm <= options.toleranceCm);
    CHECK(fitted.deg <= options.toleranceDeg);
    // The keyed curves run nearer the motion than the values they were fitted to (all a jitter away from it).
    for (const char* name : {"root.rotateY", "a.rotateZ"}) {
        const std::size_t p = parameterIndex(c.approximation, name);
        double mean = 0.0;
        for (std::size_t f = 0; f < frames.size(); ++f) mean += std::abs(keyed.values[f][p] - smooth[f][p]) / n;
        CHECK(mean < 0.75 * jitter);
    }
    // Jitter within the tolerance costs few keys more than none.
    CHECK(keyed.keyCount() <= clean.keyCount() + clean.keyCount() / 2);
    // The same frames keyed on the jittery values are out of the tolerance.
    CHECK(realError(binding, frames, jittery, placedOnDense(keyed.keys, frames, jittery)).cm > options.toleranceCm);
    // Uniform keys are fitted too, and need more.
    const UniformKeys uniform = uniformKeys(binding, frames, jittery, options);
    CHECK(uniform.step > 1);
    CHECK(uniform.error.maxPositionCm <= options.toleranceCm);
    CHECK(uniform.keyCount > keyed.keyCount());
}

TEST_CASE("key reduction: where the prediction misses, the real rig decides")
{
    Chain c = chain("6");
    // The real rig is no longer the one the approximation was learned on: its middle bone is longer, so the
    // approximation's Jacobian understates how far the tip moves.
    std::string longer = chainRig;
    const std::string bone = "{name: b, type: joint, parent: a, translate: [30, 0, 0]}";
    longer.replace(longer.find(bone), bone.size(), "{name: b, type: joint, parent: a, translate: [45, 0, 0]}");
    const auto file = test::writeFile(test::scratchDir("key_reduction_6") / "longer.yaml", longer);
    GraphRigFunction real(file, GraphRigOptions{{"root.rotate?", "a.rotateZ", "ctrl.curl"}, {}, {}});
    RigBinding binding(c.approximation, real);
    const int n = 60;
    const auto dense = denseCurves(c.approximation, n);
    std::vector<double> frames;
    for (int f = 0; f < n; ++f) frames.push_back(f);
    KeyReductionOptions options;
    const KeyedCurves keyed = reduceKeys(binding, frames, dense, options);
    // More than the dense pose and one pass over the keyed frames: frames measured again after keys were put back.
    CHECK(keyed.rigEvaluations > 2 * n);
    const RealError e = realError(binding, frames, dense, keyed.keys);
    CHECK(e.cm <= options.toleranceCm);
    CHECK(e.deg <= options.toleranceDeg);
    CHECK(keyed.keyCount() < static_cast<std::size_t>(n * 5) / 2);
}
