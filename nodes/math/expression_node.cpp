// expression: Maya's expression node for the arithmetic rigs write in it (nodes/math/expression.h gives what
// is read). The text is parsed once and again only when it changes.
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/math/expression.h"

namespace rig {
namespace {

enum Attr : AttrId { Expression, Input, Time, FramesPerSecond, Output };

class ExpressionNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const std::string& text = c.getString(Expression);
        if (!parsed_ || text != text_) {
            try {
                program_ = ExpressionProgram::parse(text);
            }
            catch (const Error& e) {
                parsed_ = false;
                throw e.in(fmt::format("node '{}'", c.nodeName()));
            }
            text_ = text;
            parsed_ = true;
        }
        inputs_.clear();
        c.forEachElement<double>(Input, [&](int i, double v) {
            if (static_cast<std::size_t>(i) >= inputs_.size()) inputs_.resize(static_cast<std::size_t>(i) + 1, 0.0);
            inputs_[static_cast<std::size_t>(i)] = v;
        });
        const double frame = c.getDouble(Time);
        // Maya's `time` is in seconds, `frame` in frames.
        const std::vector<double> outputs = program_.evaluate(inputs_, frame, frame / c.getDouble(FramesPerSecond));
        std::vector<Value> elements(outputs.begin(), outputs.end());
        c.setOutputElements(Output, std::move(elements));
    }

private:
    ExpressionProgram program_;
    std::string text_;
    bool parsed_ = false;
    std::vector<double> inputs_;
};

}  // namespace

std::shared_ptr<const NodeType> makeExpressionType()
{
    NodeTypeBuilder b("expression");
    b.description(
        "Maya's expression node for rig arithmetic: the text assigns outputs .O[n] from inputs .I[n], float "
        "variables, + - * /, functions (abs, min, max, clamp, sin, cos, sqrt, pow, ...), `time` (seconds) and "
        "`frame`; anything else (MEL commands, getAttr, conditionals) is refused naming it (docs/maya.md).");
    b.input(Expression, "expression", ValueType::String)
        .shortName("ixp")
        .doc("The expression text as Maya saves it (its internal expression, inputs as .I[n], outputs as .O[n]).");
    b.input(Input, "input", ValueType::Double).array().shortName("in").doc("The values .I[n] reads.");
    b.input(Time, "time", ValueType::Double)
        .unit(Unit::Time)
        .sceneTime()
        .shortName("tim")
        .doc("The time in frames (`frame`; `time` is it in seconds). Follows the scene time when unconnected.");
    b.input(FramesPerSecond, "framesPerSecond", ValueType::Double)
        .defaultValue(24.0)
        .min(1e-6)
        .doc("The scene's frame rate, which turns frames into the seconds `time` reads.");
    b.output(Output, "output", ValueType::Double).array().shortName("out").doc("The values .O[n] are assigned.");
    b.affectsAll();
    b.mayaCheck([](const std::function<Value(AttrId)>& value) {
        return expressionUnsupported(std::get<std::string>(value(Expression)));
    });
    return b.factory<ExpressionNode>().build();
}

}  // namespace rig
