// spring: a damped spring that follows its input, one integration step per evaluation. History
// dependent (stateful): its output depends on the evaluations before, not only on its inputs.

#include <algorithm>
#include <cmath>

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Input, Stiffness, Damping, Time, StartTime, Output };

class SpringNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double input = context.getDouble(Input);
        if (!started_ || context.getDouble(Time) <= context.getDouble(StartTime)) {
            started_ = true;
            position_ = input;
            velocity_ = 0.0;
        } else {
            // Semi-implicit Euler with a unit step; stable for stiffness and damping in [0, 1].
            const double k = std::clamp(context.getDouble(Stiffness), 0.0, 1.0);
            const double c = std::clamp(context.getDouble(Damping), 0.0, 1.0);
            velocity_ = (1.0 - c) * velocity_ + k * (input - position_);
            position_ += velocity_;
            if (!std::isfinite(position_) || !std::isfinite(velocity_)) {
                position_ = input;
                velocity_ = 0.0;
            }
        }
        context.setOutput(Output, position_);
    }

private:
    bool started_ = false;
    double position_ = 0.0;
    double velocity_ = 0.0;
};

}  // namespace

std::shared_ptr<const NodeType> makeSpringType()
{
    NodeTypeBuilder b("spring");
    b.notMaya();  // Maya's spring is a particle dynamics node
    b.description(
        "A damped spring following input, HISTORY-DEPENDENT (stateful): each computation is one step, "
        "velocity = (1 - damping) * velocity + stiffness * (input - output); output += velocity. The node "
        "computes whenever an input changed (the scene time included) and the output depends on every "
        "earlier computation, so the same inputs give different outputs (checked mode skips it). The first "
        "computation, and any with time <= startTime, resets: output = input, velocity = 0. Like Maya's "
        "jiggle deformer or a spring/dynamics setup, not a function of the current parameters.");
    b.input(Input, "input", ValueType::Double).keyable().doc("The value followed (the rest target).");
    b.input(Stiffness, "stiffness", ValueType::Double)
        .defaultValue(0.2)
        .range(0.0, 1.0)
        .keyable()
        .doc("Pull towards input per step (0 = frozen, 1 = stiff).");
    b.input(Damping, "damping", ValueType::Double)
        .defaultValue(0.1)
        .range(0.0, 1.0)
        .keyable()
        .doc("Fraction of the velocity lost per step (0 = oscillates forever, 1 = no momentum).");
    b.input(Time, "time", ValueType::Double)
        .unit(Unit::Time)
        .sceneTime()
        .doc("Current frame (the scene time unless connected); a new frame makes the node compute a step.");
    b.input(StartTime, "startTime", ValueType::Double)
        .unit(Unit::Time)
        .defaultValue(1.0)
        .doc("At or before this frame the spring rests at the input (resets).");
    b.output(Output, "output", ValueType::Double).doc("The spring's position after this step.");
    b.affectsAll();
    b.stateful();
    b.factory<SpringNode>();
    return b.build();
}

}  // namespace rig
