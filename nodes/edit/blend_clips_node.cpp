// blendClips: per joint blend of two poses' world matrices (two clips, a clip and its edit), rotations by
// quaternion slerp, the rest linearly (docs/nodes.md, "Editing a clip's skeleton").
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/error.h"
#include "nodes/builtin_nodes.h"
#include "nodes/edit/skeleton_edit_math.h"

namespace rig {
namespace {

enum Attr : AttrId { InMatrixA, InMatrixB, Weight, OutMatrix };

// The logical indices of an array input, and its elements by index (gaps as identity).
std::vector<int> presentIndices(const ComputeContext& c, AttrId a, std::vector<Eigen::Matrix4d>& matrices)
{
    std::vector<int> indices;
    c.forEachElement<Eigen::Matrix4d>(a, [&](int i, const Eigen::Matrix4d& m) {
        indices.push_back(i);
        matrices.resize(static_cast<std::size_t>(i) + 1, Eigen::Matrix4d::Identity());
        matrices[static_cast<std::size_t>(i)] = m;
    });
    return indices;
}

class BlendClipsNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        std::vector<Eigen::Matrix4d> a, b;
        const std::vector<int> inA = presentIndices(c, InMatrixA, a);
        const std::vector<int> inB = presentIndices(c, InMatrixB, b);
        if (inA != inB) {
            // The first index given on one side only.
            std::size_t k = 0;
            while (k < inA.size() && k < inB.size() && inA[k] == inB[k]) ++k;
            const bool aHasIt = k < inA.size() && (k >= inB.size() || inA[k] < inB[k]);
            throw Error(
                fmt::format("{0}.inMatrix{1}[{2}] has no inMatrix{3}[{2}]; connect the same joints of both "
                            "clips, at the same indices",
                            c.nodeName(), aHasIt ? 'A' : 'B', aHasIt ? inA[k] : inB[k], aHasIt ? 'B' : 'A'));
        }
        const double weight = c.getDouble(Weight);
        std::vector<Value> out(a.size(), Value(Eigen::Matrix4d::Identity().eval()));
        for (int i : inA) {
            const auto j = static_cast<std::size_t>(i);
            out[j] = blendMatrix(a[j], b[j], weight);
        }
        c.setOutputElements(OutMatrix, std::move(out));
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeBlendClipsType()
{
    NodeTypeBuilder b("blendClips");
    b.description(
        "Blends two poses joint by joint: outMatrix[j] from inMatrixA[j] and inMatrixB[j] with weight w. Each "
        "3x3 part is split by the polar decomposition M3 = Q S (Q a rotation, S the symmetric stretch; S = I "
        "for a pure rotation); then Q = slerp(Q_A, Q_B, w) on unit quaternions the shorter way round (a "
        "constant angular speed about one axis), S = (1 - w) S_A + w S_B and the translation (1 - w) t_A + w "
        "t_B. w 0 gives inMatrixA, w 1 inMatrixB, exactly. Both inputs must give the same joints (indices).");
    b.input(InMatrixA, "inMatrixA", ValueType::Matrix4)
        .array()
        .doc("The first pose's world matrices (connect a clip's worldMatrix[j] to inMatrixA[j]).");
    b.input(InMatrixB, "inMatrixB", ValueType::Matrix4)
        .array()
        .doc("The second pose's world matrices, at the same indices as inMatrixA.");
    b.input(Weight, "weight", ValueType::Double)
        .range(0.0, 1.0)
        .keyable()
        .doc("0: inMatrixA; 1: inMatrixB. A connected value is clamped to 0..1.");
    b.output(OutMatrix, "outMatrix", ValueType::Matrix4)
        .array()
        .doc("The blended world matrix of each joint, at the inputs' indices (a gap stays identity).");
    b.affects(InMatrixA, {OutMatrix}).affects(InMatrixB, {OutMatrix}).affects(Weight, {OutMatrix});
    return b.factory<BlendClipsNode>().build();
}

}  // namespace rig
