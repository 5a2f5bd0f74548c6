// Approximation files: every field read back bit for bit, one-line errors with file:line:col, and the
// rig fingerprint check.
#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

using namespace rig;

namespace {

bool same(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

template <class M>
bool sameMatrix(const M& a, const M& b)
{
    if (a.size() != b.size()) return false;
    for (Eigen::Index i = 0; i < a.size(); ++i)
        if (!same(a.data()[i], b.data()[i])) return false;
    return true;
}

template <int D>
bool sameSpline(const CubicSpline<D>& a, const CubicSpline<D>& b)
{
    if (a.knots().size() != b.knots().size() || a.values().size() != b.values().size()) return false;
    for (std::size_t j = 0; j < a.knots().size(); ++j)
        if (!same(a.knots()[j], b.knots()[j]) || !sameMatrix(a.values()[j], b.values()[j])) return false;
    return true;
}

void checkSameParameter(const RigParameter& a, const RigParameter& b)
{
    CHECK(a.name == b.name);
    CHECK(same(a.defaultValue, b.defaultValue));
    CHECK(same(a.min, b.min));
    CHECK(same(a.max, b.max));
    CHECK(a.angular == b.angular);
    CHECK(a.limited == b.limited);
}

// Every field of two approximations, doubles compared by their bits (-0 is not 0).
void checkSame(const Approximation& a, const Approximation& b)
{
    CHECK(a.rigFile == b.rigFile);
    CHECK(a.rigFingerprint == b.rigFingerprint);
    REQUIRE(a.held.size() == b.held.size());
    for (std::size_t h = 0; h < a.held.size(); ++h) {
        CHECK(a.held[h].plug == b.held[h].plug);
        CHECK(same(a.held[h].value, b.held[h].value));
    }
    CHECK(same(a.epsilon, b.epsilon));
    REQUIRE(a.outputs.size() == b.outputs.size());
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        CHECK(a.outputs[k].name == b.outputs[k].name);
        CHECK(sameMatrix(a.outputs[k].rest, b.outputs[k].rest));
        CHECK(a.outputs[k].parent == b.outputs[k].parent);
        CHECK(same(a.outputs[k].validationError, b.outputs[k].validationError));
        CHECK(a.outputs[k].modelled == b.outputs[k].modelled);
        CHECK(a.outputs[k].helper == b.outputs[k].helper);
        CHECK(a.outputs[k].constraint == b.outputs[k].constraint);
    }
    REQUIRE(a.constraints.size() == b.constraints.size());
    for (std::size_t c = 0; c < a.constraints.size(); ++c) {
        const ConstraintBase &x = a.constraints[c], &y = b.constraints[c];
        CHECK(x.kind == y.kind);
        CHECK(x.anchor == y.anchor);
        CHECK(x.goal == y.goal);
        CHECK(x.pole == y.pole);
        CHECK(sameMatrix(x.root, y.root));
        CHECK(sameMatrix(x.restPole, y.restPole));
        // Derived on reading, to the same bits.
        CHECK(same(x.restReach, y.restReach));
        CHECK(sameMatrix(x.restFrame, y.restFrame));
        CHECK(sameMatrix(x.restFrameInverse, y.restFrameInverse));
        CHECK(x.shape.kind == y.shape.kind);
        CHECK(same(x.shape.low, y.shape.low));
        CHECK(same(x.shape.high, y.shape.high));
        CHECK(sameSpline(x.shape.rigid, y.shape.rigid));
    }
    REQUIRE(a.parameters.size() == b.parameters.size());
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        const ModelledParameter &x = a.parameters[p], &y = b.parameters[p];
        CAPTURE(x.parameter.name);
        checkSameParameter(x.parameter, y.parameter);
        CHECK(x.outputs == y.outputs);
        CHECK(x.unmodelledOutputs == y.unmodelledOutputs);
        CHECK(x.operatorOfOutput == y.operatorOfOutput);
        CHECK(x.form == y.form);
        CHECK(same(x.fitError, y.fitError));
        CHECK(x.samples == y.samples);
        CHECK(same(x.validationError, y.validationError));
        REQUIRE(x.noEffect.size() == y.noEffect.size());
        for (std::size_t r = 0; r < x.noEffect.size(); ++r) {
            CHECK(same(x.noEffect[r].first, y.noEffect[r].first));
            CHECK(same(x.noEffect[r].second, y.noEffect[r].second));
        }
        REQUIRE(x.operators.size() == y.operators.size());
        for (std::size_t o = 0; o < x.operators.size(); ++o) {
            const Operator &u = x.operators[o], &v = y.operators[o];
            CHECK(u.kind == v.kind);
            CHECK(sameMatrix(u.axis, v.axis));
            CHECK(sameMatrix(u.pivot, v.pivot));
            CHECK(same(u.slope, v.slope));
            CHECK(sameSpline(u.curve, v.curve));
            CHECK(sameSpline(u.rigid, v.rigid));
            CHECK(sameSpline(u.affine, v.affine));
        }
    }
    REQUIRE(a.discarded.size() == b.discarded.size());
    for (std::size_t d = 0; d < a.discarded.size(); ++d) {
        checkSameParameter(a.discarded[d].parameter, b.discarded[d].parameter);
        CHECK(a.discarded[d].reason == b.discarded[d].reason);
    }
    CHECK(a.validation.poses == b.validation.poses);
    CHECK(same(a.validation.maxPositionErrorCm, b.validation.maxPositionErrorCm));
    CHECK(same(a.validation.meanPositionErrorCm, b.validation.meanPositionErrorCm));
    CHECK(same(a.validation.maxRotationErrorDeg, b.validation.maxRotationErrorDeg));
    CHECK(same(a.validation.meanRotationErrorDeg, b.validation.meanRotationErrorDeg));
    CHECK(a.validation.worstOutput == b.validation.worstOutput);
    CHECK(a.validation.worstPose == b.validation.worstPose);
    CHECK(same(a.validation.maxRelativeError, b.validation.maxRelativeError));
    CHECK(a.validation.worstRelativeOutput == b.validation.worstRelativeOutput);
    CHECK(a.validation.worstParameter == b.validation.worstParameter);
    CHECK(a.validation.nonFinitePoses == b.validation.nonFinitePoses);
    CHECK(a.validation.singularPoses == b.validation.singularPoses);
    CHECK(a.validation.singularOutput == b.validation.singularOutput);
    CHECK(a.validation.withinEpsilon == b.validation.withinEpsilon);
    REQUIRE(a.droppedOutputs.size() == b.droppedOutputs.size());
    for (std::size_t d = 0; d < a.droppedOutputs.size(); ++d) {
        CHECK(a.droppedOutputs[d].name == b.droppedOutputs[d].name);
        CHECK(a.droppedOutputs[d].reason == b.droppedOutputs[d].reason);
    }
    CHECK(a.training.evaluations == b.training.evaluations);
    CHECK(a.training.orderEvaluations == b.training.orderEvaluations);
    CHECK(same(a.training.seconds, b.training.seconds));
    CHECK(a.training.orderer == b.training.orderer);
}

// Doubles that a careless writer loses: a third, -0, the smallest subnormal, the largest double, pi.
const std::vector<double> awkward{
    0.1 + 0.2, -0.0, 5e-324, std::numeric_limits<double>::max(), std::numbers::pi, 1e-300, -123456.78901234567};

double pick(std::size_t& i) { return awkward[i++ % awkward.size()]; }

// One of everything: each operator kind, a linear and a curve magnitude, per-output operators, strings
// that need quoting, a count past 2^63.
Approximation everything()
{
    std::size_t i = 0;
    Approximation a;
    a.rigFile = "rigs/odd \"name\": #1 \\ é.yaml";
    a.rigFingerprint = "00ff00ff00ff00ff";
    a.held = {{"L_leg_settings.ikFk", 1.0}, {"ctrl.\"odd\": #", 0.1 + 0.2}, {"hips.rotateX", -0.0}};
    a.epsilon = 1e-3;
    for (const char* name : {"root", "mid: #x", "tip", "ikThigh"}) {
        ApproximationOutput out{name, Eigen::Matrix4d::Identity()};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) out.rest(r, c) = pick(i);
        a.outputs.push_back(out);
    }
    a.outputs[3].modelled = false;  // non-compositional
    auto parameter = [&](const std::string& name, bool angular, bool limited) {
        return RigParameter{name, -0.0, -std::numbers::pi / 2, 1.0 / 3.0, angular, limited};
    };
    using V1 = CubicSpline<1>::Vector;
    ModelledParameter translation{parameter("root_ctrl.translateX", false, false),
                                  {0, 1, 2},
                                  {},
                                  {0, 0, 0},
                                  "translation",
                                  1e-17,
                                  6,
                                  2e-5,
                                  {{-1.5, -0.5}, {0.25, 1.0 / 3.0}},
                                  {3}};
    Operator t;
    t.kind = OperatorKind::translation;
    t.axis = Eigen::Vector3d(0.6, -0.0, 0.8);
    t.slope = 0.1 + 0.2;
    translation.operators.push_back(t);
    a.parameters.push_back(translation);

    ModelledParameter rotation{parameter("elbow.rotateZ", true, true),
                               {1, 2},
                               {},
                               {0, 1},
                               "per output: 1 rotation (curve) 1 axisScale",
                               3e-4,
                               17,
                               0.0,
                               {},
                               {}};
    Operator r;
    r.kind = OperatorKind::rotation;
    r.axis = Eigen::Vector3d(0, std::sqrt(0.5), -std::sqrt(0.5));
    r.pivot = Eigen::Vector3d(pick(i), pick(i), pick(i));
    r.curve = CubicSpline<1>({-1.0, 0.0, 0.1 + 0.2, 2.0}, {V1(-0.7), V1(0.0), V1(std::numbers::pi), V1(-0.0)});
    Operator s;
    s.kind = OperatorKind::axisScale;
    s.axis = Eigen::Vector3d(1, 0, 0);
    s.pivot = Eigen::Vector3d(1e-300, -0.0, 7);
    s.slope = -1.0 / 3.0;
    rotation.operators = {r, s};
    a.parameters.push_back(rotation);

    ModelledParameter sampled{parameter("spine_ctrl.bend", true, false),
                              {0, 1, 2},
                              {},
                              {0, 1, 2},
                              "per output: 1 sampledRigid 1 sampledAffine 1 uniformScale",
                              0.0,
                              64,
                              5e-324,
                              {},
                              {}};
    Operator rigid;
    rigid.kind = OperatorKind::sampledRigid;
    std::vector<CubicSpline<6>::Vector> six;
    for (int j = 0; j < 3; ++j) {
        CubicSpline<6>::Vector v;
        for (int d = 0; d < 6; ++d) v[d] = pick(i) * 1e-300 + 0.1 * d * j;
        six.push_back(v);
    }
    rigid.rigid = CubicSpline<6>({-0.5, 0.0, 1e-9}, six);
    Operator affine;
    affine.kind = OperatorKind::sampledAffine;
    std::vector<CubicSpline<12>::Vector> twelve;
    for (int j = 0; j < 2; ++j) {
        CubicSpline<12>::Vector v;
        for (int d = 0; d < 12; ++d) v[d] = pick(i);
        twelve.push_back(v);
    }
    affine.affine = CubicSpline<12>({0.0, 0.25}, twelve);
    Operator uniform;
    uniform.kind = OperatorKind::uniformScale;
    uniform.pivot = Eigen::Vector3d(1, 2, 3);
    uniform.slope = 5e-324;
    sampled.operators = {rigid, affine, uniform};
    a.parameters.push_back(sampled);
    // Effective on a non-compositional output only: no operator.
    ModelledParameter realRigOnly{parameter("leg_pole.translateZ", false, false),
                                  {},
                                  {},
                                  {},
                                  "non-compositional (real rig only)",
                                  0.0,
                                  6,
                                  0.0,
                                  {},
                                  {3}};
    a.parameters.push_back(realRigOnly);

    a.discarded.push_back(
        {parameter("nasty_ctrl.springy", false, true), "history-dependent: \"quoted\"\nsecond line\tand a tab"});
    a.discarded.push_back(
        {parameter("nasty_ctrl.coupledTurn", true, true), "coupled: it changes what others do; ünïcode"});
    a.validation = {50,   1e-13,     0.1 + 0.2,       180.0, -0.0,  "tip", 49,
                    7e-4, "mid: #x", "elbow.rotateZ", 2,     false, 3,     "twist: #1"};
    a.outputs[1].parent = 0;  // relative outputs, a parent listed after its child
    a.outputs[0].parent = 2;
    a.outputs[2].validationError = 0.1 + 0.2;
    a.droppedOutputs.push_back({"zero scale: \"x\"", "its rest world matrix is singular"});
    a.training = {std::uint64_t{1} << 63 | 5, 133, 0.0123456789, "structured (note: a fallback)"};
    return a;
}

using test::restAt;
using test::rotationAbout;

Operator translationAlong(const Eigen::Vector3d& axis)
{
    Operator op;
    op.kind = OperatorKind::translation;
    op.axis = axis.normalized();
    op.slope = 1.0;
    return op;
}

// A leg as the learner models a two-bone IK chain (docs/rig-learn.md, Constraint operators): a hip, a goal and a
// pole helper, a knee on a planar chain read from them (its shape held past a reach), a foot relative to the knee,
// and a second chain in world space without a pole output.
Approximation chain()
{
    Approximation a;
    a.rigFile = "rigs/leg.yaml";
    a.rigFingerprint = "0123456789abcdef";
    a.epsilon = 1e-3;
    a.outputs = {restAt("hip", {0, 100, 0}),         restAt("goal", {0, 10, 20}), restAt("pole", {0, 55, 40}),
                 restAt("knee", {0, 55, 0.1 + 0.2}), restAt("foot", {0, 10, 20}), restAt("shin", {1, 60, 5})};
    a.outputs[1].helper = a.outputs[2].helper = true;
    a.outputs[3].constraint = 0;
    a.outputs[4].parent = 3;
    a.outputs[5].constraint = 1;

    ConstraintBase knee;
    knee.anchor = 0;
    knee.goal = 1;
    knee.pole = 2;
    knee.root = {0, 100, 0};
    knee.restPole = {0, 55, 40};
    knee.shape.kind = OperatorKind::sampledRigid;
    knee.shape.low = -25.0;
    knee.shape.high = 4.0;
    std::vector<CubicSpline<6>::Vector> values;
    const std::vector<double> knots{-30.0, -10.0, 0.0, 5.0};
    for (const double d : knots) {
        CubicSpline<6>::Vector v;
        v << 0.0, 0.0, -0.01 * d, 0.1 * d, 0.3 * d + 1e-3 * d * d, std::numbers::pi * 1e-3 * d;
        values.push_back(v);
    }
    knee.shape.rigid = CubicSpline<6>(knots, values);
    ConstraintBase shin = knee;
    shin.anchor = shin.pole = -1;
    shin.restPole = {30, 50, 0.1 + 0.2};
    shin.shape.low = -std::numeric_limits<double>::infinity();
    REQUIRE(knee.prepare(a.outputs[1].rest.block<3, 1>(0, 3)));
    REQUIRE(shin.prepare(a.outputs[1].rest.block<3, 1>(0, 3)));
    a.constraints = {knee, shin};

    // One operator on one output, unlimited in -1..1.
    const auto add = [&](const std::string& name, int output, const Operator& op) {
        ModelledParameter m;
        m.parameter = RigParameter{name, 0.0, -1.0, 1.0, op.kind == OperatorKind::rotation, false};
        m.outputs = {output};
        m.operators = {op};
        m.operatorOfOutput = {0};
        m.form = std::string(operatorKindName(op.kind));
        a.parameters.push_back(m);
    };
    add("hip_ctrl.rotateX", 0, rotationAbout({1, 0, 0}, {0, 100, 0}));
    add("goal_ctrl.translateY", 1, translationAlong({0, 1, 0}));
    add("goal_ctrl.translateZ", 1, translationAlong({0, 0, 1}));
    add("pole_ctrl.translateX", 2, translationAlong({1, 0, 0}));
    add("knee_ctrl.twist", 3, rotationAbout({0, -45, 0.3}, {0, 100, 0}));
    add("foot_ctrl.rotateX", 4, rotationAbout({1, 0, 0}, {0, 10, 20}));
    return a;
}

// The minimal valid file the error cases below damage one line of.
const std::string minimal = R"(format: rigInversionApproximation
version: 1
rigFile: "r.yaml"
rigFingerprint: "00"
epsilon: 0.001
training: {evaluations: 1, orderEvaluations: 0, seconds: 0.5, orderer: "talk"}
validation: {poses: 0, maxPositionErrorCm: 0, meanPositionErrorCm: 0, maxRotationErrorDeg: 0, )"
                            R"(meanRotationErrorDeg: 0, worstOutput: "", worstPose: -1}
outputs:
  - {name: "a", rest: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}
parameters:
  - name: "p"
    default: 0
    min: -1
    max: 1
    limited: true
    angular: true
    form: "rotation"
    fitError: 0
    samples: 6
    outputs: ["a"]
    operatorOfOutput: [0]
    operators:
      - {kind: rotation, axis: [0, 0, 1], pivot: [0, 0, 0], slope: 1}
discarded: []
)";

// The minimal version 3 file with a constraint: a hip, a goal helper and a knee on a chain read from them.
const std::string minimalChain = R"(format: rigInversionApproximation
version: 3
rigFile: "r.yaml"
rigFingerprint: "00"
epsilon: 0.001
training: {evaluations: 1, orderEvaluations: 0, seconds: 0.5, orderer: "talk"}
validation: {poses: 0, maxPositionErrorCm: 0, meanPositionErrorCm: 0, maxRotationErrorDeg: 0, )"
                                 R"(meanRotationErrorDeg: 0, worstOutput: "", worstPose: -1}
outputs:
  - {name: "hip", rest: [[1, 0, 0, 0], [0, 1, 0, 100], [0, 0, 1, 0], [0, 0, 0, 1]]}
  - {name: "goal", helper: true, rest: [[1, 0, 0, 0], [0, 1, 0, 10], [0, 0, 1, 20], [0, 0, 0, 1]]}
  - {name: "knee", constraint: 0, rest: [[1, 0, 0, 0], [0, 1, 0, 55], [0, 0, 1, 0], [0, 0, 0, 1]]}
constraints:
  - kind: planarChain
    anchor: "hip"
    goal: "goal"
    root: [0, 100, 0]
    restPole: [0, 55, 40]
    shape: {kind: sampledRigid, knots: [-1, 1], values: [[0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]]}
parameters:
  - name: "p"
    default: 0
    min: -1
    max: 1
    limited: true
    angular: false
    form: "translation"
    fitError: 0
    samples: 6
    outputs: ["goal"]
    operatorOfOutput: [0]
    operators:
      - {kind: translation, axis: [0, 0, 1], pivot: [0, 0, 0], slope: 1}
discarded: []
)";

// The message for `text` with `from` replaced by `to`.
std::string errorIn(std::string text, const std::string& from, const std::string& to)
{
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
    try {
        approximationFromYaml(text, "f.yaml");
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

// The message for `minimal` with `from` replaced by `to`.
std::string errorWith(const std::string& from, const std::string& to) { return errorIn(minimal, from, to); }

// The message for `minimalChain` with `from` replaced by `to`.
std::string chainErrorWith(const std::string& from, const std::string& to) { return errorIn(minimalChain, from, to); }

}  // namespace

TEST_CASE("approximation files: every field of every operator kind reads back bit for bit")
{
    const Approximation a = everything();
    const std::string text = approximationToYaml(a);
    const Approximation b = approximationFromYaml(text, "everything.yaml");
    checkSame(a, b);
    // Writing what was read gives the same text.
    CHECK(approximationToYaml(b) == text);

    // Through a file.
    const auto file = test::scratchDir("approximation-io") / "everything.yaml";
    test::writeFile(file, text);
    checkSame(a, readApproximationFile(file));
}

TEST_CASE("approximation files: constraint operators and helper outputs read back bit for bit (version 3)")
{
    const Approximation a = chain();
    const std::string text = approximationToYaml(a);
    CHECK(text.find("version: 3\n") != std::string::npos);
    CHECK(text.find("  - name: \"goal\"\n    helper: true") != std::string::npos);
    CHECK(text.find("  - name: \"knee\"\n    constraint: 0\n") != std::string::npos);
    CHECK(text.find("  - name: \"foot\"\n    parent: \"knee\"\n") != std::string::npos);
    CHECK(text.find("constraints:  # constraint operators, indexed by the outputs' `constraint`\n"
                    "  - kind: planarChain\n    anchor: \"hip\"\n    goal: \"goal\"\n    pole: \"pole\"\n"
                    "    root: [0, 100, 0]\n    restPole: [0, 55, 40]\n    shape:\n      kind: sampledRigid\n"
                    "      held: [-25, 4]\n      knots: [-30, -10, 0, 5]\n") != std::string::npos);
    // Without anchor and pole outputs, the fixed pole in world space; an open end of the held range is null.
    CHECK(text.find("  - kind: planarChain\n    goal: \"goal\"\n    root: [0, 100, 0]\n"
                    "    restPole: [30, 50, 0.30000000000000004]\n    shape:\n      kind: sampledRigid\n"
                    "      held: [null, 4]\n") != std::string::npos);
    // What `prepare` derives is not written; an output that is neither helper nor constrained says nothing of it.
    CHECK(text.find("restReach") == std::string::npos);
    CHECK(text.find("restFrame") == std::string::npos);
    CHECK(text.find("  - name: \"hip\"\n    validationError: 0\n") != std::string::npos);

    const Approximation b = approximationFromYaml(text, "chain.yaml");
    checkSame(a, b);
    CHECK(approximationToYaml(b) == text);

    // The same bits from both, and the chain really read: moving the goal moves the knee, the foot below it and the
    // second chain's output, and nothing is lost to a degenerate plane.
    std::mt19937 rng(11);
    std::vector<Eigen::Matrix4d> wa, wb, rest;
    a.evaluate(a.defaults(), rest);
    for (std::size_t k = 0; k < rest.size(); ++k) CHECK(rest[k].isApprox(a.outputs[k].rest, 1e-12));
    for (int pose = 0; pose < 20; ++pose) {
        std::vector<double> values;
        for (const auto& p : a.parameters)
            values.push_back(std::uniform_real_distribution<double>(p.parameter.min, p.parameter.max)(rng));
        a.evaluate(values, wa);
        b.evaluate(values, wb);
        for (std::size_t k = 0; k < wa.size(); ++k) {
            CHECK(wa[k].allFinite());
            CHECK(sameMatrix(wa[k], wb[k]));
        }
    }
    std::vector<double> goalMoved = a.defaults();
    goalMoved[1] = 0.5;
    a.evaluate(goalMoved, wa);
    for (const std::size_t k : {3, 4, 5}) CHECK_FALSE(wa[k].isApprox(a.outputs[k].rest, 1e-6));
    CHECK(wa[0].isApprox(a.outputs[0].rest, 1e-12));

    // Version 2 files still read, as they were: everything() has neither constraints nor helpers.
    std::string version2 = approximationToYaml(everything());
    version2.replace(version2.find("version: 3"), 10, "version: 2");
    checkSame(everything(), approximationFromYaml(version2, "v2.yaml"));
    CHECK(errorWith("version: 1", "version: 2") == "(no error)");
}

TEST_CASE("approximation files: a learned approximation evaluates identically after a round trip")
{
    // The nasty rig has curve magnitudes, per-output operators, sampled rigid and affine ones.
    GraphRigFunction rig(test::sourceDir() / "rigs/nasty.yaml",
                         {{"arm_ctrl.rotate?", "nasty_ctrl.elbowBend", "nasty_ctrl.wristTwist", "nasty_ctrl.spineBend",
                           "nasty_ctrl.kneeBend", "nasty_ctrl.stretch"},
                          {},
                          {}});
    LearnOptions options;
    options.validationPoses = 5;
    const Approximation a = learnApproximation(rig, options, "rigs/nasty.yaml");
    REQUIRE(a.parameters.size() == 8);
    const Approximation b = approximationFromYaml(approximationToYaml(a), "nasty.yaml");
    checkSame(a, b);
    std::mt19937 rng(7);
    std::vector<Eigen::Matrix4d> wa, wb;
    for (int pose = 0; pose < 20; ++pose) {
        std::vector<double> values;
        for (const auto& p : a.parameters)
            values.push_back(std::uniform_real_distribution<double>(p.parameter.min, p.parameter.max)(rng));
        a.evaluate(values, wa);
        b.evaluate(values, wb);
        for (std::size_t k = 0; k < wa.size(); ++k) CHECK(sameMatrix(wa[k], wb[k]));
    }
}

TEST_CASE("approximation files: what cannot be written is refused, naming the field")
{
    Approximation a = everything();
    a.parameters[1].operators[0].pivot.y() = std::nan("");
    CHECK_THROWS_WITH_AS(approximationToYaml(a),
                         "approximationToYaml: parameters[1].operators[0].pivot is nan, not a finite number", Error);
    a = everything();
    a.parameters[0].outputs[2] = 4;
    CHECK_THROWS_WITH_AS(approximationToYaml(a), "approximationToYaml: parameters[0].outputs: index 4 out of range",
                         Error);
    a = chain();
    a.outputs[3].constraint = 2;
    CHECK_THROWS_WITH_AS(approximationToYaml(a), "approximationToYaml: outputs[3].constraint: index 2 out of range",
                         Error);
    a = chain();
    a.constraints[0].goal = -1;
    CHECK_THROWS_WITH_AS(approximationToYaml(a), "approximationToYaml: constraints[0].goal: index -1 out of range",
                         Error);
    a = chain();
    a.constraints[1].shape.kind = OperatorKind::sampledAffine;
    CHECK_THROWS_WITH_AS(approximationToYaml(a),
                         "approximationToYaml: constraints[1].shape is sampledAffine, not sampledRigid", Error);
    a = chain();
    a.constraints[0].restPole.z() = std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH_AS(approximationToYaml(a),
                         "approximationToYaml: constraints[0].restPole is inf, not a finite number", Error);
}

TEST_CASE("approximation files: a knot given twice is a curve's break, read and written back bit for bit")
{
    Approximation a = everything();
    using V1 = CubicSpline<1>::Vector;
    bool broken = false;
    for (ModelledParameter& p : a.parameters)
        for (Operator& op : p.operators)
            if (!broken && op.kind == OperatorKind::rotation && !op.linear()) {
                op.curve = CubicSpline<1>({-1.0, 0.0, 0.5, 0.5, 2.0}, {V1(-0.7), V1(0.0), V1(0.0), V1(0.0), V1(0.9)});
                broken = true;
            }
    REQUIRE(broken);
    const std::string text = approximationToYaml(a);
    CHECK(text.find("knots: [-1, 0, 0.5, 0.5, 2]") != std::string::npos);
    const Approximation b = approximationFromYaml(text, "broken.yaml");
    checkSame(a, b);
    CHECK(approximationToYaml(b) == text);
}

TEST_CASE("approximation files: a curve's knots increase but for a break, one inner knot twice with one value")
{
    const std::string at = "f.yaml:23:76: parameters[0].operators[0].curve.knots: ";
    CHECK(errorWith("slope: 1", "curve: {knots: [-1, 0, 0, 1], values: [-1, 0, 0, 2]}") == "(no error)");
    CHECK(errorWith("slope: 1", "curve: {knots: [-1, 0, 0, 0, 1], values: [-1, 0, 0, 0, 2]}") ==
          at + "the knot 0 is repeated more than once; a break is a knot twice");
    CHECK(errorWith("slope: 1", "curve: {knots: [-1, -1, 0, 1], values: [-1, -1, 0, 2]}") ==
          at + "the first knot -1 is repeated; a break (a knot twice) is inside the curve");
    CHECK(errorWith("slope: 1", "curve: {knots: [-1, 0, 1, 1], values: [-1, 0, 2, 2]}") ==
          at + "the last knot 1 is repeated; a break (a knot twice) is inside the curve");
    CHECK(errorWith("slope: 1", "curve: {knots: [-1, 0, 2, 1], values: [-1, 0, 2, 3]}") ==
          at + "the knots must increase (1 after 2)");
    CHECK(errorWith("slope: 1", "curve: {knots: [-1, 0, 0, 1], values: [-1, 0, 0.5, 2]}") ==
          "f.yaml:23:99: parameters[0].operators[0].curve.values: the two values at the break 0 differ; a curve is "
          "continuous at its breaks");
}

TEST_CASE("approximation files: a damaged file is one line naming file:line:col and the field")
{
    CHECK(errorWith("", "") == "(no error)");
    CHECK(errorWith("format: rigInversionApproximation", "format: rig") ==
          "f.yaml:1:9: format: not an approximation file (expected format: rigInversionApproximation)");
    CHECK(errorWith("version: 1", "version: 4") ==
          "f.yaml:2:10: version: version 4 is not supported; this program reads versions 1 to 3 (re-run rig-learn)");
    CHECK(errorWith("rigFile:", "rigFiles:") ==
          "f.yaml:3:1: file: unknown field 'rigFiles'; the fields are format, version, rigFile, rigFingerprint, "
          "epsilon, training, validation, outputs, parameters, discarded, droppedOutputs, held, constraints");
    CHECK(errorWith("    samples: 6\n", "") == "f.yaml:11:5: parameters[0]: the field 'samples' is missing");
    CHECK(errorWith("min: -1", "min: abc") == "f.yaml:13:10: parameters[0].min: 'abc' is not a number");
    CHECK(errorWith("max: 1", "max: inf") == "f.yaml:14:10: parameters[0].max: 'inf' is not a finite number");
    CHECK(errorWith("default: 0", "default: 5") ==
          "f.yaml:11:5: parameters[0]: the default 5 is not within min -1 and max 1");
    CHECK(errorWith("limited: true", "limited: 1") == "f.yaml:15:14: parameters[0].limited: expected true or false");
    CHECK(errorWith("outputs: [\"a\"]", "outputs: [\"b\"]") ==
          "f.yaml:20:15: parameters[0].outputs: 'b' is not one of the outputs");
    CHECK(errorWith("{name: \"a\", ", "{name: \"a\", modelled: false, ") ==
          "f.yaml:20:15: parameters[0].outputs: 'a' is not modelled (its outputs entry says modelled: false); list it "
          "under unmodelledOutputs");
    CHECK(errorWith("outputs: [\"a\"]", "outputs: []\n    unmodelledOutputs: [\"a\"]") ==
          "f.yaml:21:25: parameters[0].unmodelledOutputs: 'a' is modelled (its outputs entry says modelled: true); "
          "list it under outputs");
    CHECK(errorWith("outputs: [\"a\"]", "outputs: []") ==
          "f.yaml:20:14: parameters[0].outputs: a parameter affects at least one output");
    CHECK(errorWith("operatorOfOutput: [0]", "operatorOfOutput: [3]") ==
          "f.yaml:21:24: parameters[0].operatorOfOutput: 3 is not an operator index (0..0)");
    CHECK(errorWith("operatorOfOutput: [0]", "operatorOfOutput: [0, 0]") ==
          "f.yaml:21:23: parameters[0].operatorOfOutput: expected 1 entries, found 2");
    CHECK(errorWith("axis: [0, 0, 1]", "axis: [0, 0, 2]") ==
          "f.yaml:23:32: parameters[0].operators[0].axis: not a unit vector");
    CHECK(errorWith("kind: rotation", "kind: twist") ==
          "f.yaml:23:16: parameters[0].operators[0].kind: unknown operator 'twist'; the operators are translation, "
          "rotation, axisScale, uniformScale, sampledRigid, sampledAffine");
    CHECK(errorWith("slope: 1", "curve: {knots: [0, 0], values: [0, 0]}") ==
          "f.yaml:23:76: parameters[0].operators[0].curve.knots: the first knot 0 is repeated; a break (a knot twice) "
          "is inside the curve");
    CHECK(errorWith("slope: 1", "slope: 1, curve: {knots: [0, 1], values: [0, 1]}") ==
          "f.yaml:23:9: parameters[0].operators[0]: give either slope (linear) or curve, not both");
    CHECK(errorWith("rest: [[1, 0, 0, 0], ", "rest: [") == "f.yaml:9:23: outputs[0].rest: expected 4 entries, found 3");
    CHECK(errorWith("discarded: []", "discarded: [") ==
          "f.yaml:25:1: YAML syntax error: end of sequence flow not found");
    // Strict: one document, nothing negative that counts or measures, whole numbers in their range.
    CHECK(errorWith("discarded: []\n", "discarded: []\n---\nformat: other\n") ==
          "f.yaml:25:1: file: '---' ends the YAML document; an approximation file is one document: remove it and "
          "what follows, or re-run rig-learn");
    CHECK(errorWith("discarded: []\n", "discarded: []\n...\n") ==
          "f.yaml:25:1: file: '...' ends the YAML document; an approximation file is one document: remove it and what "
          "follows, or re-run rig-learn");
    CHECK(errorWith("seconds: 0.5", "seconds: -0.5") ==
          "f.yaml:6:58: training.seconds: -0.5 is negative; errors and times are not");
    CHECK(errorWith("poses: 0", "poses: -3") ==
          "f.yaml:7:21: validation.poses: -3 is below 0; a count is not negative");
    CHECK(errorWith("maxPositionErrorCm: 0", "maxPositionErrorCm: -1") ==
          "f.yaml:7:44: validation.maxPositionErrorCm: -1 is negative; errors and times are not");
    CHECK(errorWith("worstPose: -1", "worstPose: -2") ==
          "f.yaml:7:148: validation.worstPose: -2 is below -1; a count is not negative");
    CHECK(errorWith("samples: 6", "samples: -6") ==
          "f.yaml:19:14: parameters[0].samples: -6 is below 0; a count is not negative");
    CHECK(errorWith("fitError: 0", "fitError: -1e-9") ==
          "f.yaml:18:15: parameters[0].fitError: -1e-09 is negative; errors and times are not");
    CHECK(errorWith("evaluations: 1,", "evaluations: 99999999999999999999,") ==
          "f.yaml:6:25: training.evaluations: 99999999999999999999 is out of range (0 to 18446744073709551615)");
    CHECK(errorWith("evaluations: 1,", "evaluations: -1,") ==
          "f.yaml:6:25: training.evaluations: '-1' is not a whole number");

    // Held plugs: a list of {plug, value}, each plug once and not also a parameter, values finite numbers.
    const std::string held = "held:\n  - {plug: \"s.ikFk\", value: 1}\n";
    CHECK(errorWith("discarded: []\n", "discarded: []\n" + held) == "(no error)");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld: {s.ikFk: 1}\n") == "f.yaml:25:7: held: expected a list");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: \"s.ikFk\"}\n") ==
          "f.yaml:26:5: held[0]: the field 'value' is missing");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: \"s.ikFk\", value: 1, unit: deg}\n") ==
          "f.yaml:26:32: held[0]: unknown field 'unit'; the fields are plug, value");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: \"s.ikFk\", value: .nan}\n") ==
          "f.yaml:26:29: held[0].value: '.nan' is not a number");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: \"s.ikFk\", value: 1e999}\n") ==
          "f.yaml:26:29: held[0].value: '1e999' is not a number");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: \"\", value: 1}\n") ==
          "f.yaml:26:12: held[0].plug: a held plug needs a name");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: [a], value: 1}\n") ==
          "f.yaml:26:12: held[0].plug: expected a string");
    CHECK(errorWith("discarded: []\n", "discarded: []\n" + held + "  - {plug: \"s.ikFk\", value: 0}\n") ==
          "f.yaml:27:12: held[1].plug: the plug 's.ikFk' is held twice");
    CHECK(errorWith("discarded: []\n", "discarded: []\nheld:\n  - {plug: \"p\", value: 0}\n") ==
          "f.yaml:26:12: held[0].plug: 'p' is also a parameter; a plug is inverted or held, not both: re-run "
          "rig-learn");

    try {
        readApproximationFile("no/such/approximation.yaml");
        FAIL("no error");
    }
    catch (const Error& e) {
        CHECK(std::string(e.what()) ==
              "no/such/approximation.yaml: cannot read it (No such file or directory); check the name (rig-learn -o "
              "writes one)");
    }
}

TEST_CASE("approximation files: a damaged constraint or helper field is one line naming file:line:col and the field")
{
    CHECK(chainErrorWith("", "") == "(no error)");
    // Version 3 fields in older files.
    CHECK(chainErrorWith("version: 3", "version: 2") ==
          "f.yaml:10:28: outputs[1].helper: version 3 added this field, but the file says version 2; re-run rig-learn, "
          "or write version: 3");
    CHECK(errorWith("discarded: []\n", "discarded: []\nconstraints: []\n") ==
          "f.yaml:25:14: constraints: version 3 added this field, but the file says version 1; re-run rig-learn, or "
          "write version: 3");
    CHECK(errorWith("{name: \"a\", ", "{name: \"a\", constraint: 0, ") ==
          "f.yaml:9:29: outputs[0].constraint: version 3 added this field, but the file says version 1; re-run "
          "rig-learn, or write version: 3");
    // The constraint entry.
    CHECK(chainErrorWith("kind: planarChain", "kind: twoBone") ==
          "f.yaml:13:11: constraints[0].kind: unknown constraint 'twoBone'; the constraints are planarChain, "
          "twistShare, blend and oriented");
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    restReach: 3\n") ==
          "f.yaml:18:5: constraints[0]: unknown field 'restReach'; the fields are kind, goal, root, restPole, shape, "
          "anchor, pole, restNormal, worldUp, poleTurns, minimalTurn, goalTurns, lineTurn, orient, origin");
    // An output turning as another: the orient output and the origin come together.
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n",
                         "    restPole: [0, 55, 40]\n    orient: \"goal\"\n    origin: [0, 1, 2]\n") == "(no error)");
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    orient: \"goal\"\n") ==
          "f.yaml:13:5: constraints[0]: the field 'origin' is missing");
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    origin: [0, 1, 2]\n") ==
          "f.yaml:18:13: constraints[0].origin: an origin belongs to a chain with an orient output; remove it");
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    orient: \"elbow\"\n") ==
          "f.yaml:18:13: constraints[0].orient: 'elbow' is not one of the outputs");
    // A chain without a pole output may keep its up in the world's axes: a boolean.
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    worldUp: true\n") ==
          "(no error)");
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    worldUp: 2\n")
              .find("f.yaml:18:14: constraints[0].worldUp") == 0);
    CHECK(chainErrorWith("    goal: \"goal\"\n", "") == "f.yaml:13:5: constraints[0]: the field 'goal' is missing");
    // A chain without a pole may keep its rest plane: its normal is a unit vector.
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    restNormal: [0, 0, 2]\n")
              .ends_with("constraints[0].restNormal: must be a unit vector (re-run rig-learn)"));
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    restNormal: [0, 0, 1]\n") ==
          "(no error)");
    // The ikSCsolver's plane: a rest plane turned minimally, with its line's turn (a rotation operator).
    const std::string normal = "    restPole: [0, 55, 40]\n    restNormal: [0, 0, 1]\n";
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n",
                         normal + "    minimalTurn: true\n    lineTurn: {kind: rotation, axis: "
                                  "[0, 0, 1], pivot: [0, 0, 0], slope: 0}\n") == "(no error)");
    // Maya's own ikSCsolver: the plane turned by the goal's rotation, a minimalTurn plane's.
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n",
                         normal + "    minimalTurn: true\n    goalTurns: true\n    lineTurn: {kind: rotation, axis: "
                                  "[0, 0, 1], pivot: [0, 0, 0], slope: 0}\n") == "(no error)");
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", normal + "    goalTurns: true\n")
              .ends_with("constraints[0].goalTurns: a plane the goal turns is a minimalTurn plane's; add minimalTurn"));
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", "    restPole: [0, 55, 40]\n    minimalTurn: true\n")
              .ends_with("constraints[0].minimalTurn: a plane turned minimally is a rest plane's; add restNormal"));
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", normal + "    minimalTurn: true\n")
              .ends_with("constraints[0]: minimalTurn needs its lineTurn (re-run rig-learn)"));
    CHECK(chainErrorWith("    restPole: [0, 55, 40]\n", normal +
                                                            "    minimalTurn: true\n    lineTurn: {kind: translation, "
                                                            "axis: [0, 0, 1], pivot: [0, 0, 0], slope: 0}\n")
              .ends_with("constraints[0].lineTurn: must be a rotation operator (re-run rig-learn)"));
    CHECK(chainErrorWith("goal: \"goal\"", "goal: \"ankle\"") ==
          "f.yaml:15:11: constraints[0].goal: 'ankle' is not one of the outputs");
    CHECK(chainErrorWith("anchor: \"hip\"", "anchor: [hip]") ==
          "f.yaml:14:13: constraints[0].anchor: expected a string");
    CHECK(chainErrorWith("{name: \"hip\", ", "{name: \"hip\", modelled: false, ") ==
          "f.yaml:14:13: constraints[0].anchor: 'hip' is not modelled (modelled: false); a constraint reads outputs "
          "the approximation predicts: re-run rig-learn");
    CHECK(chainErrorWith("kind: sampledRigid", "kind: sampledAffine") ==
          "f.yaml:18:19: constraints[0].shape.kind: 'sampledAffine' is not sampledRigid; a chain's shape is a "
          "sampledRigid operator (re-run rig-learn)");
    CHECK(chainErrorWith("shape: {kind: sampledRigid, ", "shape: {kind: sampledRigid, slope: 1, ") ==
          "f.yaml:18:33: constraints[0].shape: unknown field 'slope'; the fields are kind, knots, values, held");
    CHECK(chainErrorWith("root: [0, 100, 0]", "root: [0, 100]") ==
          "f.yaml:16:11: constraints[0].root: expected 3 entries, found 2");
    CHECK(chainErrorWith("restPole: [0, 55, 40]", "restPole: [0, 55, 10]") ==
          "f.yaml:13:5: constraints[0]: the rest points span no plane (the goal's rest origin on `root`, or `restPole` "
          "on the line through them); re-run rig-learn");
    CHECK(chainErrorWith("root: [0, 100, 0]", "root: [0, 10, 20]") ==
          "f.yaml:13:5: constraints[0]: the rest points span no plane (the goal's rest origin on `root`, or `restPole` "
          "on the line through them); re-run rig-learn");
    // The outputs' side.
    CHECK(chainErrorWith("constraint: 0", "constraint: 1") ==
          "f.yaml:11:32: outputs[2].constraint: 1 is not a constraint index (0..0)");
    CHECK(chainErrorWith("constraint: 0", "constraint: -1") ==
          "f.yaml:11:32: outputs[2].constraint: -1 is not a constraint index (0..0)");
    CHECK(chainErrorWith("constraint: 0", "constraint: first") ==
          "f.yaml:11:32: outputs[2].constraint: 'first' is not a whole number");
    std::string version3 = minimal;
    version3.replace(version3.find("version: 1"), 10, "version: 3");
    CHECK(errorIn(version3, "{name: \"a\", ", "{name: \"a\", constraint: 0, ") ==
          "f.yaml:9:29: outputs[0].constraint: 0 is not a constraint index: the file has no constraints list");
    CHECK(chainErrorWith("helper: true", "helper: yes") == "f.yaml:10:28: outputs[1].helper: expected true or false");
    CHECK(chainErrorWith("{name: \"knee\", ", "{name: \"knee\", parent: \"hip\", ") ==
          "f.yaml:11:47: outputs[2].constraint: a constraint output has no parent (its constraint's inputs move it); "
          "remove `parent` or `constraint`");
    CHECK(chainErrorWith("{name: \"knee\", ", "{name: \"knee\", modelled: false, ") ==
          "f.yaml:11:49: outputs[2].constraint: a non-compositional output (modelled: false) has no constraint");
    CHECK(chainErrorWith("goal: \"goal\"", "goal: \"knee\"") ==
          "f.yaml:11:32: outputs[2].constraint: constraints[0] reads 'knee' itself; a constraint reads outputs learned "
          "before its output");
    CHECK(chainErrorWith("{name: \"goal\", ", "{name: \"goal\", parent: \"knee\", ") ==
          "f.yaml:11:32: outputs[2].constraint: the frames form a cycle ('goal' reads 'knee' reads 'goal'); a "
          "constraint reads outputs learned before its output, never one that moves with it");
    CHECK(chainErrorWith("{name: \"hip\", ", "{name: \"hip\", parent: \"hip\", ") ==
          "f.yaml:9:3: outputs: the outputs' parents form a cycle; an output's parent is an ancestor joint");
}

TEST_CASE("approximation files: a rig that changed since learning is a warning, or an error when strict")
{
    Approximation a;
    a.rigFile = "rigs/biped.yaml";
    a.rigFingerprint = "0123456789abcdef";
    CHECK(checkFingerprint(a, "0123456789abcdef", false).empty());
    CHECK(checkFingerprint(a, "0123456789abcdef", true).empty());
    const std::string message =
        "the rig changed since the approximation was learned from rigs/biped.yaml (fingerprint "
        "0123456789abcdef, now fedcba9876543210); re-run rig-learn";
    CHECK(checkFingerprint(a, "fedcba9876543210", false) == message);
    CHECK_THROWS_WITH_AS(checkFingerprint(a, "fedcba9876543210", true), message.c_str(), Error);

    // The real thing: a rig file edited after learning.
    const auto dir = test::scratchDir("approximation-fingerprint");
    const std::string rigText =
        "nodes:\n  - {name: j, type: joint}\n  - {name: k, type: joint, parent: j, translate: [5, 0, 0]}\n";
    test::writeFile(dir / "rig.yaml", rigText);
    const GraphRigOptions options{{"j.rotateZ"}, {}, {}};
    GraphRigFunction before(dir / "rig.yaml", options);
    LearnOptions learn;
    learn.validationPoses = 2;
    const Approximation learned = learnApproximation(before, learn, "rig.yaml");
    CHECK(checkFingerprint(learned, GraphRigFunction(dir / "rig.yaml", options).fingerprint(), true).empty());
    test::writeFile(dir / "rig.yaml", rigText + "  - {name: l, type: joint, parent: k}\n");
    const std::string now = GraphRigFunction(dir / "rig.yaml", options).fingerprint();
    CHECK(checkFingerprint(learned, now, false)
              .starts_with("the rig changed since the approximation was learned from rig.yaml"));
    CHECK_THROWS_AS(checkFingerprint(learned, now, true), Error);
}
