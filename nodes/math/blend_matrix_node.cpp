// blendMatrix: Maya's blendMatrix (Maya 2020+), a matrix blended toward each target in turn.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"
#include "nodes/math/rotation_blend.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    InputMatrix,
    Envelope,
    TargetMatrix,
    TargetWeight,
    TranslateWeight,
    RotateWeight,
    ScaleWeight,
    ShearWeight,
    OutputMatrix
};

struct Weights {
    double translate = 1.0, rotate = 1.0, scale = 1.0, shear = 1.0;
};

// `from` moved toward `to` component by component: translation, scale and shear linearly, the rotation along
// the shorter arc.
Eigen::Matrix4d blendTRS(const Eigen::Matrix4d& from, const Eigen::Matrix4d& to, const Weights& w)
{
    const DecomposedMatrix a = decomposeMatrix(from, RotateOrder::xyz);
    const DecomposedMatrix b = decomposeMatrix(to, RotateOrder::xyz);
    const Eigen::Vector3d t = a.translate + w.translate * (b.translate - a.translate);
    const Eigen::Vector3d s = a.scale + w.scale * (b.scale - a.scale);
    const Eigen::Vector3d sh = a.shear + w.shear * (b.shear - a.shear);
    Eigen::Matrix4d m = composeTRS(t, Eigen::Vector3d::Zero(), RotateOrder::xyz, s, sh);
    const Eigen::Matrix3d r = slerpShortest(a.quat, b.quat, w.rotate).toRotationMatrix();
    m.topLeftCorner<3, 3>() = (r * m.topLeftCorner<3, 3>()).eval();
    return m;
}

// Elements 0..count-1 of an array input, 1 where one is absent.
std::vector<double> elements(const ComputeContext& context, AttrId attr, std::size_t count)
{
    std::vector<double> values(count, 1.0);
    context.forEachElement<double>(attr, [&](int i, double v) {
        if (static_cast<std::size_t>(i) < count) values[static_cast<std::size_t>(i)] = v;
    });
    return values;
}

class BlendMatrixNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        std::vector<std::pair<int, Eigen::Matrix4d>> targets;
        context.forEachElement<Eigen::Matrix4d>(TargetMatrix,
                                                [&](int i, const Eigen::Matrix4d& m) { targets.emplace_back(i, m); });
        const std::size_t count = targets.empty() ? 0 : static_cast<std::size_t>(targets.back().first) + 1;
        const auto weight = elements(context, TargetWeight, count);
        const auto tw = elements(context, TranslateWeight, count);
        const auto rw = elements(context, RotateWeight, count);
        const auto sw = elements(context, ScaleWeight, count);
        const auto shw = elements(context, ShearWeight, count);
        const double envelope = context.getDouble(Envelope);
        Eigen::Matrix4d m = context.getMatrix(InputMatrix);
        for (const auto& [i, target] : targets) {
            const auto k = static_cast<std::size_t>(i);
            const double w = weight[k] * envelope;
            m = blendTRS(m, target, {tw[k] * w, rw[k] * w, sw[k] * w, shw[k] * w});
        }
        context.setOutput(OutputMatrix, m);
    }
};

AttributeBuilder targetInput(NodeTypeBuilder& b, AttrId id, const char* name, const char* shortName)
{
    return b.input(id, name, ValueType::Double)
        .array()
        .defaultValue(1.0)
        .keyable()
        .shortName(shortName)
        .mayaCompound("target", "tgt");
}

}  // namespace

std::shared_ptr<const NodeType> makeBlendMatrixType()
{
    NodeTypeBuilder b("blendMatrix");
    b.description(
        "Blends inputMatrix toward each target in index order, each blend starting from the last one's result "
        "(Maya's blendMatrix node, Maya 2020+): translation, scale and shear move linearly and the rotation along "
        "the shorter arc, each by its weight times the target's weight times envelope. Maya's compound multi "
        "target[i] is flattened into targetMatrix[i], weight[i], translateWeight[i], rotateWeight[i], "
        "scaleWeight[i], shearWeight[i]. Maya's pre/post space matrices are not modelled.");
    b.input(InputMatrix, "inputMatrix", ValueType::Matrix4).shortName("imat").doc("The matrix blended from.");
    b.input(Envelope, "envelope", ValueType::Double)
        .shortName("env")
        .defaultValue(1.0)
        .keyable()
        .doc("Scales every target's weight: 0 outputs inputMatrix.");
    b.input(TargetMatrix, "targetMatrix", ValueType::Matrix4)
        .array()
        .shortName("tmat")
        .mayaCompound("target", "tgt")
        .doc("Target i's matrix (target[i].targetMatrix); a target exists where this element does.");
    targetInput(b, TargetWeight, "weight", "wgt").doc("Target i's weight (target[i].weight), 1 when absent.");
    targetInput(b, TranslateWeight, "translateWeight", "tw").doc("How much of target i's translation, 1 when absent.");
    targetInput(b, RotateWeight, "rotateWeight", "rw").doc("How much of target i's rotation, 1 when absent.");
    targetInput(b, ScaleWeight, "scaleWeight", "sw").doc("How much of target i's scale, 1 when absent.");
    targetInput(b, ShearWeight, "shearWeight", "shw").doc("How much of target i's shear, 1 when absent.");
    b.output(OutputMatrix, "outputMatrix", ValueType::Matrix4).shortName("omat").doc("The blended matrix.");
    for (AttrId in :
         {InputMatrix, Envelope, TargetMatrix, TargetWeight, TranslateWeight, RotateWeight, ScaleWeight, ShearWeight})
        b.affects(in, {OutputMatrix});
    b.factory<BlendMatrixNode>();
    return b.build();
}

}  // namespace rig
