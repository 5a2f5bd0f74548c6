// A node plugin built against the installed package: `installScale`, output = input * factor.
#include <rig/graph/node.h>
#include <rig/graph/node_registry.h>
#include <rig/graph/node_type.h>

namespace {

enum Attr : rig::AttrId { input, factor, output };

class Scale : public rig::Node {
public:
    void compute(rig::ComputeContext& c) override { c.setOutput(output, c.getDouble(input) * c.getDouble(factor)); }
};

}  // namespace

extern "C" void initializePlugin(rig::NodeRegistry& registry)
{
    rig::NodeTypeBuilder b("installScale");
    b.description("Install test plugin node: output = input * factor.");
    b.input(input, "input", rig::ValueType::Double).keyable();
    b.input(factor, "factor", rig::ValueType::Double).defaultValue(1.0);
    b.output(output, "output", rig::ValueType::Double);
    b.affects(input, {output});
    b.affects(factor, {output});
    registry.add(b.factory<Scale>().build());
}
