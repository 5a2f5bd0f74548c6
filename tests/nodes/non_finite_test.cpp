// NaN and infinities reaching nodes at evaluation. Values set from files and command lines are refused
// when not finite, but a node can compute them (the inverse of a zero-scaled joint, products that
// overflow) and pass them downstream. Every input of every built-in type is fed NaN, +inf and huge
// numbers through connections: nothing may crash or hit undefined behaviour (scripts/sanitize.sh runs
// this under AddressSanitizer and UBSan), numbers into int and enum inputs are refused with a rig::Error,
// and graph-eval prints what is not finite as null (tests/tools/robustness_test.cpp).
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

using namespace rig;

namespace {

// Sources of bad numbers, each a double, a vector3 and a matrix4 plug:
//   nan:  the inverse of a zero-scaled joint (NaN everywhere), decomposed;
//   inf:  a product of two matrices with 1e300 entries (infinities and NaN), decomposed;
//   huge: 1e300 itself (finite, but far beyond what rigs hold: 1e300 degrees, 1e300 cm).
const char* sources = R"(
  - {name: zero, type: joint, scale: [0, 0, 0]}
  - {name: nanD, type: decomposeMatrix}
  - {name: big, type: transform, translate: [1e300, -1e300, 1e300], scale: [1e300, 1e300, 1e300]}
  - {name: bigSquared, type: multMatrix}
  - {name: infD, type: decomposeMatrix}
  - {name: hugeD, type: decomposeMatrix}
)";
const char* sourceConnections = R"(
  - zero.worldInverseMatrix -> nanD.inputMatrix
  - big.worldMatrix -> bigSquared.matrixIn[0]
  - big.worldMatrix -> bigSquared.matrixIn[1]
  - bigSquared.matrixSum -> infD.inputMatrix
  - big.worldMatrix -> hugeD.inputMatrix
)";

struct Source {
    std::string name;
    std::string number;  // a double plug
    std::string vector;  // a vector3 plug
    std::string matrix;  // a matrix4 plug
};

const std::vector<Source> badSources{
    {"nan", "nanD.outputTranslateX", "nanD.outputTranslate", "zero.worldInverseMatrix"},
    {"inf", "infD.outputTranslateX", "infD.outputTranslate", "bigSquared.matrixSum"},
    {"huge", "hugeD.outputTranslateX", "hugeD.outputScale", "big.worldMatrix"},
};

}  // namespace

TEST_CASE("non-finite numbers: the sources really are NaN, infinite and huge")
{
    auto g = loadGraphText(fmt::format("nodes:{}connections:{}", sources, sourceConnections), "sources.yaml",
                           makeBuiltinRegistry());
    CHECK(std::isnan(std::get<double>(g->getValue(g->plug("nanD.outputTranslateX")))));
    CHECK(!std::get<Eigen::Matrix4d>(g->getValue(g->plug("bigSquared.matrixSum"))).allFinite());
    CHECK(std::isinf(std::get<double>(g->getValue(g->plug("infD.outputTranslateX")))));
    CHECK(std::get<double>(g->getValue(g->plug("hugeD.outputTranslateX"))) == 1e300);
}

TEST_CASE("non-finite numbers into every input of every built-in node type: no crash, errors only for ints and enums")
{
    const auto registry = makeBuiltinRegistry();
    const std::string clip = (test::sourceDir() / "tests/corpus/bvh/good.bvh").string();
    int fed = 0;
    for (const auto& typeName : registry->typeNames()) {
        const auto type = registry->get(typeName);
        for (const AttributeSpec& spec : type->attributes()) {
            if (!spec.input) continue;
            for (const Source& source : badSources) {
                const std::string plug = fmt::format("n.{}{}", spec.name, spec.array ? "[1]" : "");
                std::string from;
                switch (spec.type) {
                    case ValueType::Double:
                    case ValueType::Int:
                    case ValueType::Bool:
                    case ValueType::Enum:
                        from = source.number;
                        break;
                    case ValueType::Vector3:
                        from = source.vector;
                        break;
                    case ValueType::Matrix4:
                        from = source.matrix;
                        break;
                    default:
                        continue;  // strings and arrays of numbers: no computed source to connect
                }
                CAPTURE(typeName);
                CAPTURE(plug);
                CAPTURE(source.name);
                // A bvhClip needs a clip to play; everything else starts from its defaults.
                const std::string extra = typeName == "bvhClip" ? fmt::format(", file: '{}'", clip) : "";
                // blendClips pairs its two clips joint by joint (a joint in one only is an error): the
                // same source feeds both.
                const std::string partner =
                    typeName == "blendClips" && spec.array
                        ? fmt::format("  - {} -> n.{}[1]\n", from, spec.name == "inMatrixA" ? "inMatrixB" : "inMatrixA")
                        : "";
                const std::string text =
                    fmt::format("nodes:{}  - {{name: n, type: {}{}}}\nconnections:{}  - {} -> {}\n{}", sources,
                                typeName, extra, sourceConnections, from, plug, partner);
                std::unique_ptr<Graph> g;
                try {
                    g = loadGraphText(text, "feed.yaml", registry);
                }
                catch (const Error& e) {
                    // The only refusals at load time: connections the types do not allow.
                    CHECK(std::string(e.what()).find("the types do not match") != std::string::npos);
                    continue;
                }
                bool refused = false;
                for (double time : {1.0, 1e300, -1e300}) {
                    try {
                        g->setTime(time);
                        g->evaluateAll();
                        for (const AttributeSpec& out : g->attributes(g->node("n")))
                            if (!out.input && !out.array) (void)g->getValue(g->plug("n." + out.name));
                    }
                    catch (const Error& e) {
                        // Numbers that are not a valid int or enum value are refused, naming the plug.
                        const bool integral =
                            spec.type == ValueType::Int || spec.type == ValueType::Enum || spec.type == ValueType::Bool;
                        CHECK(integral);
                        CHECK(std::string(e.what()).find(plug) == 0);
                        refused = true;
                        break;
                    }
                }
                // NaN, infinity and 1e300 never fit an int or enum input; a bool takes any number (x != 0).
                if (spec.type == ValueType::Int || spec.type == ValueType::Enum) CHECK(refused);
                ++fed;
            }
        }
    }
    MESSAGE(fed << " inputs fed NaN, infinity and 1e300");
    CHECK(fed > 300);
}
