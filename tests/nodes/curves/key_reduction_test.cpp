// Sparse keys on a small real rig (a chain turned at the root and the middle, a limited curl driving the
// tip through a set-driven key): the keyed curves keep every joint within the tolerance of the dense pose,
// measured here again from the keys alone; far fewer keys than frames; a constant curve keeps one key; a
// spline that would overshoot a control's limit gets the keys that keep it inside; the uniform step holds
// the tolerance too.

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Geometry>

#include "core/rotation_math.h"
#include "inversion/jacobian.h"
#include "inversion/learner.h"
#include "inversion/rig_binding.h"
#include "nodes/curves/key_reduction.h"
#include "nodes/graph_rig_function.h"
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
    Chain c = chain("3");
    RigBinding binding(c.approximation, *c.rig);
    CHECK_THROWS_AS(reduceKeys(binding, frames, dense, KeyReductionOptions{}), rig::Error);
}
