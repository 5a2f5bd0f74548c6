// Checked mode over the whole built-in library: for every type, every input in turn gets a new valid
// value and Graph::checkEvaluation (recompute from scratch, compare) must find nothing, which proves
// the type's affects table misses no entry. Also: every type and attribute is documented.

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"

namespace {

constexpr double pi = std::numbers::pi;

bool inRange(const rig::AttributeSpec& spec, double x)
{
    return (!spec.min || x >= *spec.min) && (!spec.max || x <= *spec.max);
}

// A number `offset` away from `base` within the spec's limits (the other side if one side is out), or
// a point inside [min, max] when neither is.
double shifted(const rig::AttributeSpec& spec, double base, double offset, int pass)
{
    if (inRange(spec, base + offset)) return base + offset;
    if (inRange(spec, base - offset)) return base - offset;
    REQUIRE((spec.min && spec.max));
    return *spec.min + (*spec.max - *spec.min) * (0.2 + 0.3 * pass);
}

// A valid value of `spec`'s type, unlike its default and unlike the other passes' values. The offset
// from the default changes sign between passes and size with the attribute (`attr`), so that two
// inputs compared by a node (condition's terms, clamp's min and max) are not always in the same order.
rig::Value testValue(const rig::AttributeSpec& spec, int pass, int attr)
{
    const double k = std::array{1.0, -1.5, 2.0}[static_cast<std::size_t>(pass)] * (1.0 + 0.125 * (attr % 4));
    switch (spec.type) {
        case rig::ValueType::Double:
            return shifted(spec, rig::toDouble(spec.defaultValue), spec.unit == rig::Unit::Angle ? 0.4 * k : 0.375 * k,
                           pass);
        case rig::ValueType::Int: {
            const int base = std::get<int>(spec.defaultValue);
            for (int step : {1 + pass, -1 - pass})
                if (inRange(spec, base + step)) return base + step;
            FAIL("no valid int near the default");
            return base;
        }
        case rig::ValueType::Vector3: {
            const Eigen::Vector3d base = std::get<Eigen::Vector3d>(spec.defaultValue);
            // Angles: (17, -11.5, 29) degrees times k, other units the same numbers; components rotate
            // with the attribute.
            const std::array<double, 3> c{0.3, -0.2, 0.5};
            const Eigen::Vector3d offset =
                Eigen::Vector3d(c[static_cast<std::size_t>(attr % 3)], c[static_cast<std::size_t>((attr + 1) % 3)],
                                c[static_cast<std::size_t>((attr + 2) % 3)]) *
                k;
            Eigen::Vector3d v;
            for (int i = 0; i < 3; ++i) v[i] = shifted(spec, base[i], offset[i], pass);
            return v;
        }
        case rig::ValueType::Matrix4: {
            // A rotation and a translation.
            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
            m.topLeftCorner<3, 3>() =
                Eigen::AngleAxisd(0.3 * k, Eigen::Vector3d(1, 2, -0.5 * pass).normalized()).toRotationMatrix();
            m.col(3) << 1.5 * k, -2.0, 0.25 * pass, 1.0;
            return m;
        }
        case rig::ValueType::DoubleArray:
            // remapValue's ramp: (position, value) pairs, an even count.
            return std::vector<double>{0.0, 0.1, 0.4, 0.8 + 0.1 * pass, 1.0, 0.3};
        case rig::ValueType::Matrix4Array: {
            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
            m.col(3) << k, 0, -k, 1;
            return rig::Matrix4Array{m, m.transpose()};
        }
        case rig::ValueType::Bool:
        case rig::ValueType::Enum:
        case rig::ValueType::String:
            break;  // handled by the caller
    }
    FAIL("no test value for an attribute of type " << rig::valueTypeName(spec.type));
    return spec.defaultValue;
}

// The types whose every input this test's values are known to make matter.
const std::vector<std::string> knownTypes{
    "transform",       "joint",       "time",        "animCurveTU",    "animCurveTA",      "animCurveTL",
    "animCurveUU",     "animCurveUA", "animCurveUL", "multiplyDivide", "plusMinusAverage", "blendTwoAttr",
    "clamp",           "reverse",     "remapValue",  "condition",      "multMatrix",       "composeMatrix",
    "decomposeMatrix", "lookAt",      "offsetLayer", "blendClips"};

bool isAnimCurve(const std::string& type) { return type.starts_with("animCurve"); }

// The names checkEvaluation reports, joined, so a failure shows them.
std::string check(rig::Graph& graph)
{
    const std::vector<std::string> mismatches = graph.checkEvaluation();
    return fmt::format("{}", fmt::join(mismatches, ", "));
}

}  // namespace

TEST_CASE("checked mode: every built-in type and attribute is documented")
{
    const auto registry = rig::makeBuiltinRegistry();
    const std::vector<std::string> names = registry->typeNames();
    CHECK(names.size() >= 19);
    for (const std::string& name : names) {
        CAPTURE(name);
        const rig::NodeType* type = registry->find(name);
        REQUIRE(type != nullptr);
        CHECK(type->name() == name);
        CHECK_FALSE(type->description().empty());
        for (const rig::AttributeSpec& spec : type->attributes()) {
            CAPTURE(spec.name);
            CHECK_FALSE(spec.description.empty());
        }
    }
}

TEST_CASE("checked mode: every input of every built-in type is in its affects table")
{
    const auto registry = rig::makeBuiltinRegistry();
    for (const std::string& typeName : registry->typeNames()) {
        CAPTURE(typeName);
        rig::Graph graph(registry);
        const rig::NodeId node = graph.addNode(typeName, "n");
        CHECK(check(graph) == "");
        const auto& specs = graph.attributes(node);

        // Every output value, to tell whether a change mattered (a change that moves no output would
        // make its checkEvaluation vacuous).
        auto outputs = [&] {
            std::vector<rig::Value> values;
            for (std::size_t o = 0; o < specs.size(); ++o) {
                if (specs[o].input) continue;
                const auto attr = static_cast<rig::AttrId>(o);
                if (!specs[o].array) values.push_back(graph.getValue({node, attr, -1, -1}));
                else
                    for (int i : graph.elementIndices(node, attr))
                        values.push_back(graph.getValue({node, attr, i, -1}));
            }
            return values;
        };
        std::vector<char> mattered(specs.size(), 0);
        // Sets `value` (after `first`, if given: a change made of two values) and runs checked mode.
        auto setAndCheck = [&](const rig::Plug& plug, const rig::Value& value,
                               const std::optional<std::pair<rig::Plug, rig::Value>>& first = std::nullopt) {
            try {
                const std::vector<rig::Value> before = outputs();
                if (first) graph.setValue(first->first, first->second);
                graph.setValue(plug, value);
                CHECK(check(graph) == "");
                const std::vector<rig::Value> after = outputs();
                bool changed = before.size() != after.size();
                for (std::size_t i = 0; !changed && i < after.size(); ++i)
                    changed = !rig::bitEqual(before[i], after[i]);
                mattered[static_cast<std::size_t>(plug.attr)] |= changed;
            }
            catch (const std::exception& e) {
                FAIL_CHECK("a valid value made the node fail: " << e.what());
            }
        };

        // Three passes, so that an input set early (an animation curve's input before it has keys)
        // is changed again once the rest makes it matter; the curve's input also visits the keyed
        // range, before it and after it (keys end at x = 14 in the last pass), so both infinity modes matter.
        for (int pass = 0; pass < 3; ++pass) {
            CAPTURE(pass);
            for (std::size_t a = 0; a < specs.size(); ++a) {
                const rig::AttributeSpec& spec = specs[a];
                if (!spec.input) continue;
                const std::string attrName = spec.name;
                CAPTURE(attrName);
                const auto attr = static_cast<rig::AttrId>(a);
                const std::vector<int> indices = spec.array ? std::vector<int>{0, 2} : std::vector<int>{-1};
                for (int index : indices) {
                    CAPTURE(index);
                    const rig::Plug plug{node, attr, index, -1};
                    if (spec.type == rig::ValueType::Enum) {
                        // Every value, then on to a different last value each pass.
                        const int n = static_cast<int>(spec.enumNames.size());
                        const int start = std::get<int>(spec.defaultValue);
                        for (int i = 1; i <= n + 1 + pass; ++i) {
                            const int value = (start + i) % n;
                            CAPTURE(value);
                            setAndCheck(plug, value);
                        }
                        continue;
                    }
                    rig::Value value;
                    std::optional<std::pair<rig::Plug, rig::Value>> first;
                    if (spec.type == rig::ValueType::String) {
                        // Strings name files (bvhClip.file): there is no valid value to invent here.
                        mattered[a] = 1;
                        continue;
                    }
                    if (spec.type == rig::ValueType::Bool) {
                        value = !std::get<bool>(graph.getValue(plug));
                    } else if (isAnimCurve(typeName) && attrName == "input") {
                        value = std::vector<double>{3.5, -4.25, 23.75}[static_cast<std::size_t>(pass)];
                    } else if (isAnimCurve(typeName) && attrName == "keyTime") {
                        // A consistent pair: keyValue first (not evaluated in between), then keyTime.
                        first.emplace(graph.plug("n.keyValue"), std::vector<double>{0.0, 1.5 + pass, -0.5});
                        value = std::vector<double>{0.0, 4.0 + pass, 10.0 + 2 * pass};
                    } else if (isAnimCurve(typeName) && attrName == "keyValue") {
                        value = std::vector<double>{0.25, 2.0 + pass, -1.0};
                    } else if (isAnimCurve(typeName) && attrName == "keyInTangent") {
                        // Tangent type indices 0..7, -1 for the `tangents` fallback.
                        value = std::vector<double>{static_cast<double>((3 * pass + 1) % 8), -1.0,
                                                    static_cast<double>((5 * pass + 6) % 8)};
                    } else if (isAnimCurve(typeName) && attrName == "keyOutTangent") {
                        value = std::vector<double>{static_cast<double>((3 * pass + 4) % 8),
                                                    static_cast<double>((pass + 2) % 8), -1.0};
                    } else if (typeName == "lookAt" && spec.type == rig::ValueType::DoubleArray) {
                        // One share and one limit (degrees) per chain joint: inMatrix[0] and inMatrix[2].
                        value = attrName == "share" ? std::vector<double>{0.25 + 0.2 * pass, 1.0}
                                                    : std::vector<double>{20.0 + 10.0 * pass, 45.0};
                    } else if (typeName == "blendClips" && attrName == "inMatrixA") {
                        // A joint in one clip only is an error: its partner in the other clip comes first (with a
                        // value unlike the one inMatrixB gets when its own turn comes, so that it matters too).
                        first.emplace(rig::Plug{node, attr + 1, index, -1},
                                      testValue(specs[a + 1], pass, static_cast<int>(a) + 3));
                        value = testValue(spec, pass, static_cast<int>(a));
                    } else {
                        value = testValue(spec, pass, static_cast<int>(a));
                    }
                    setAndCheck(plug, value, first);
                }
            }
        }
        // Types added later (plugins' and new built-ins') may need more than one input set at a time
        // for some inputs to matter; this test knows its own values suit these.
        const bool known = std::find(knownTypes.begin(), knownTypes.end(), typeName) != knownTypes.end();
        for (std::size_t a = 0; known && a < specs.size(); ++a) {
            if (!specs[a].input) continue;
            const std::string attrName = specs[a].name;
            CAPTURE(attrName);
            CHECK_MESSAGE(mattered[a], "no value set on this input changed an output, so its checks prove nothing");
        }
        // Scene time reaches unconnected time inputs (time nodes, animCurveT* curves).
        graph.setTime(6.5);
        CHECK(check(graph) == "");
        graph.setTime(-2.0);
        CHECK(check(graph) == "");
    }
}

TEST_CASE("checked mode: a connected rig with driven keys and time")
{
    auto graph = rig::loadGraphText(R"(
nodes:
  - {name: time1, type: time}
  - {name: ctrl, type: transform, addAttr: [{name: bend, min: 0, max: 10}], rotatePivot: [1, 0, 0]}
  - {name: sdk, type: animCurveUA, keys: [[0, 0], [10, 90, flat]], tangents: spline, postInfinity: oscillate}
  - {name: anim, type: animCurveTL, keys: [[0, 0], [12, 5], [24, 0]], preInfinity: cycle, postInfinity: cycle}
  - {name: hips, type: joint, translate: [0, 100, 0], rotateOrder: zxy}
  - {name: knee, type: joint, parent: hips, translate: [0, -40, 0], jointOrient: [0, 0, 10]}
  - {name: ankle, type: joint, parent: knee, translate: [0, -40, 0]}
  - {name: md, type: multiplyDivide, input2X: 0.5}
  - {name: cm, type: composeMatrix}
  - {name: mm, type: multMatrix}
connections:
  - time1.outTime -> anim.input
  - anim.output -> hips.translateX
  - ctrl.bend -> sdk.input
  - sdk.output -> knee.rotateZ
  - ctrl.rotateY -> md.input1X
  - md.outputX -> cm.inputRotateY
  - cm.outputMatrix -> mm.matrixIn[0]
  - ankle.worldMatrix -> mm.matrixIn[1]
  - ctrl.scale -> hips.scale
)",
                                    "t.yaml", rig::makeBuiltinRegistry());
    CHECK(check(*graph) == "");
    for (double frame : {0.0, 5.0, 13.25, 30.0, -7.5}) {
        CAPTURE(frame);
        graph->setTime(frame);
        CHECK(check(*graph) == "");
    }
    graph->setValue(graph->plug("ctrl.bend"), 7.5);
    CHECK(check(*graph) == "");
    graph->setValue(graph->plug("ctrl.rotate"), Eigen::Vector3d(0.1, -0.4, pi / 3));
    CHECK(check(*graph) == "");
    graph->setValue(graph->plug("ctrl.scale"), Eigen::Vector3d(1.5, 1.0, 0.5));
    CHECK(check(*graph) == "");
    graph->setValue(graph->plug("hips.rotateOrder"), 4);
    CHECK(check(*graph) == "");
    graph->setValue(graph->plug("knee.segmentScaleCompensate"), false);
    CHECK(check(*graph) == "");
    graph->setValue(graph->plug("sdk.postInfinity"), 1);
    graph->setValue(graph->plug("ctrl.bend"), 10.0);
    CHECK(check(*graph) == "");
}
