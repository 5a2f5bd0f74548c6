// A plugin built for the tests: registers `testDoubler` (output = 2 * input) from initializePlugin.
#include "graph/node_registry.h"

namespace {

enum Attr : rig::AttrId { input, output };

class Doubler : public rig::Node {
public:
    void compute(rig::ComputeContext& c) override { c.setOutput(output, 2.0 * c.getDouble(input)); }
};

}  // namespace

extern "C" void initializePlugin(rig::NodeRegistry& registry)
{
    rig::NodeTypeBuilder b("testDoubler");
    b.description("Test plugin node: output = 2 * input.");
    b.input(input, "input", rig::ValueType::Double).keyable();
    b.output(output, "output", rig::ValueType::Double);
    b.affects(input, {output});
    registry.add(b.factory<Doubler>().build());
}
