// Maya's expression node as rigs use it: the parser's precedence, variables, functions, time and frame, the
// node through a Graph (inputs, outputs, reparsing), and refusals that name the construct.

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "graph/graph.h"
#include "nodes/builtin_nodes.h"
#include "nodes/math/expression.h"
#include "test_support.h"

namespace {

constexpr double pi = std::numbers::pi;

// .O[0] of `statement` with the inputs given, at frame 0.
double value(const std::string& expression, const std::vector<double>& inputs = {})
{
    return rig::ExpressionProgram::parse(".O[0] = " + expression + ";").evaluate(inputs, 0.0, 0.0).at(0);
}

// The error parse throws for `text`.
std::string refusal(const std::string& text)
{
    return rig::test::errorOf([&] { rig::ExpressionProgram::parse(text); });
}

}  // namespace

TEST_CASE("expression: precedence, associativity, unary minus and parentheses")
{
    CHECK(value("1 + 2 * 3 - 4 / 2") == 5.0);
    CHECK(value("(1 + 2) * 3") == 9.0);
    CHECK(value("2 - 3 - 4") == -5.0);
    CHECK(value("8 / 4 / 2") == 1.0);
    CHECK(value("-2 * -3") == 6.0);
    CHECK(value("-(-2) + +3") == 5.0);
    CHECK(value("-(1 + 2) * 2") == -6.0);
    CHECK(value("1.5e1 + .5") == 15.5);
    CHECK(value(".I[0] * 0.25 + .I[2]", {8, 100, 1}) == 3.0);
    // An input nothing set reads 0.
    CHECK(value(".I[5] + 1", {8}) == 1.0);
}

TEST_CASE("expression: float variables and several outputs")
{
    const auto program = rig::ExpressionProgram::parse(R"(
        // the bend, halved
        float $a = .I[0] * 2;
        float $b;            /* starts at 0 */
        $b = $a + 1;
        $c = $b * $b;        // assigned before use: declared by the assignment
        .O[2] = $c;
        .O[1] = .O[2] - $a;  // an output reads what was assigned to it above
    )");
    CHECK(program.outputCount() == 3);
    CHECK(program.evaluate({3}, 0, 0) == std::vector<double>{0, 43, 49});
    CHECK(program.evaluate({0}, 0, 0) == std::vector<double>{0, 1, 1});
}

TEST_CASE("expression: functions")
{
    CHECK(value("clamp(-1, 1, 5)") == 1.0);
    CHECK(value("clamp(-1, 1, -5)") == -1.0);
    CHECK(value("clamp(-1, 1, 0.5)") == 0.5);
    CHECK(value("min(2, -3) + max(2, -3)") == -1.0);
    CHECK(value("abs(-2.5)") == 2.5);
    CHECK(value("sqrt(16) + pow(2, 10)") == 1028.0);
    CHECK(value("floor(-1.5) + ceil(1.2)") == 0.0);
    CHECK(value("exp(0) + log(1)") == 1.0);
    CHECK(value("sin(.I[0])", {pi / 6}) == doctest::Approx(0.5).epsilon(1e-15));
    CHECK(value("cos(0) + tan(0)") == 1.0);
    CHECK(value("atan2(1, 1)") == doctest::Approx(pi / 4).epsilon(1e-15));
    CHECK(value("asin(1) + acos(1) + atan(0)") == doctest::Approx(pi / 2).epsilon(1e-15));
    CHECK(value("deg_to_rad(180)") == doctest::Approx(pi).epsilon(1e-15));
    CHECK(value("rad_to_deg(.I[0])", {pi / 2}) == doctest::Approx(90).epsilon(1e-15));
    CHECK(value("sign(-3) + sign(0) + 2 * sign(7)") == 1.0);
    CHECK(value("max(min(.I[0], 10), 0) * 9", {20}) == 90.0);
}

TEST_CASE("expression: time in seconds and frame, through a graph")
{
    rig::Graph g(rig::makeBuiltinRegistry());
    g.addNode("expression", "e");
    g.setValue(g.plug("e.expression"), std::string(".O[0] = time; .O[1] = frame; .O[2] = .I[1] * 2;"));
    g.setValue(g.plug("e.input[1]"), 4.0);
    g.setTime(48);
    const auto out = [&](int i) { return std::get<double>(g.getValue(g.plug("e.output[" + std::to_string(i) + "]"))); };
    CHECK(out(0) == 2.0);  // 48 frames at 24 fps
    CHECK(out(1) == 48.0);
    CHECK(out(2) == 8.0);
    g.setValue(g.plug("e.framesPerSecond"), 30.0);
    CHECK(out(0) == 1.6);

    // A new text is parsed again; a text it cannot read fails the evaluation, naming the node.
    g.setValue(g.plug("e.expression"), std::string(".O[0] = -frame;"));
    CHECK(out(0) == -48.0);
    g.setValue(g.plug("e.expression"), std::string(".O[0] = getAttr(\"x.ty\");"));
    CHECK(rig::test::errorOf([&] { out(0); }) == "node 'e': expression: line 1: the MEL command getAttr is not read");

    // Maya's short names.
    const rig::NodeType& type = g.nodeType(0);
    CHECK(type.findMayaAttribute("ixp") == type.findAttribute("expression"));
    CHECK(type.findMayaAttribute("in") == type.findAttribute("input"));
    CHECK(type.findMayaAttribute("out") == type.findAttribute("output"));
    CHECK(type.findMayaAttribute("tim") == type.findAttribute("time"));
}

TEST_CASE("expression: constructs it does not read are refused by name")
{
    CHECK(refusal("if (.I[0] > 1) .O[0] = 1;") == "expression: line 1: a conditional ('if') is not read");
    CHECK(refusal(".O[0] = 1;\n\nwhile (1) {}") == "expression: line 3: a loop ('while') is not read");
    CHECK(refusal("string $s = \"a\";") == "expression: line 1: a string variable is not read");
    CHECK(refusal("int $i = 2;") == "expression: line 1: an int variable is not read");
    CHECK(refusal(".O[0] = `getAttr x.ty`;").find("'`' is not read") != std::string::npos);
    CHECK(refusal(".O[0] = pCube1.tx;") ==
          "expression: line 1: 'pCube1' (a MEL command, function or name this reader does not evaluate) is not read");
    CHECK(refusal(".O[0] = noise(time);").find("'noise'") != std::string::npos);
    CHECK(refusal(".O[0] = .I[0] == 1;") ==
          "expression: line 1: the operator '==' is not read (only + - * / and parentheses)");
    CHECK(refusal(".O[0] = .I[0] % 2;") ==
          "expression: line 1: the operator '%' is not read (only + - * / and parentheses)");
    CHECK(refusal(".O[0] += 1;").find("'+='") != std::string::npos);
    CHECK(refusal("float $x = $y;") == "expression: line 1: the variable $y is read before it is given a value");
    CHECK(refusal(".O[0] = pow(2);") == "expression: line 1: pow takes 2 arguments, given 1");
    CHECK(refusal(".I[0] = 1;") == "expression: line 1: '.I[0]' cannot be assigned (an input)");
    CHECK(refusal(".O[0] = .tx;") ==
          "expression: line 1: '.tx' is not read: only .I[n] and .O[n] name the node's inputs and outputs");
    CHECK(refusal(".O[0] = (1 + 2;") == "expression: line 1: expected ')' to close '(', found ';'");
    CHECK(refusal("/* open").find("not closed") != std::string::npos);

    CHECK(rig::expressionUnsupported(".O[0] = .I[0] * 0.25;") == std::nullopt);
    CHECK(rig::expressionUnsupported("print(1);") ==
          std::optional<std::string>(
              "expression: line 1: 'print' (a MEL command, function or name this reader does not evaluate) is not "
              "read"));
}
