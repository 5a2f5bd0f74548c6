// lookAt: turns a chain of joints (spine, neck, head; an eye) toward a target point, each joint taking a
// share of the remaining turn within its limit. World matrices in, world matrices out: it sits between a
// clip and a rigInversion node (docs/nodes.md, "Editing a clip's skeleton").
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/error.h"
#include "nodes/builtin_nodes.h"
#include "nodes/edit/skeleton_edit_math.h"

namespace rig {
namespace {

enum Attr : AttrId {
    InMatrix,
    Target,
    Share,
    Limit,
    Weight,
    AimAxis,
    UpAxis,
    UpMode,
    WorldUp,
    OutMatrix,
    DeltaMatrix,
    Turn
};
enum Up { None = 0, World = 1 };

constexpr double degrees = std::numbers::pi / 180.0;

// Checks that a per-joint list gives one number per chain joint, or none.
void checkPerJoint(const ComputeContext& c, const char* attr, const std::vector<double>& values, std::size_t joints)
{
    if (!values.empty() && values.size() != joints)
        throw Error(
            fmt::format("{}.{} has {} numbers but the chain has {} joints (inMatrix elements); give one "
                        "number per joint, root first, or none",
                        c.nodeName(), attr, values.size(), joints));
}

class LookAtNode final : public Node {
public:
    void compute(ComputeContext& c) override
    {
        // The settings and the result on the computing thread's buffers: the result is copied into the outputs at
        // once, so a crowd's members reuse one set, warm in the cache, and a frame allocates nothing.
        thread_local LookAtSettings s;
        thread_local LookAtResult result;
        s.chain.clear();
        c.forEachElement<Eigen::Matrix4d>(InMatrix, [&](int, const Eigen::Matrix4d& m) { s.chain.push_back(m); });
        const std::vector<double>& share = c.getDoubleArray(Share);
        s.share.assign(share.begin(), share.end());
        checkPerJoint(c, "share", s.share, s.chain.size());
        for (std::size_t k = 0; k < s.share.size(); ++k)
            if (!(s.share[k] >= 0.0 && s.share[k] <= 1.0))
                throw Error(
                    fmt::format("{}.share[{}] is {}; a share is the fraction of the remaining turn the "
                                "joint takes, from 0 to 1",
                                c.nodeName(), k, s.share[k]));
        const std::vector<double>& limit = c.getDoubleArray(Limit);
        s.limit.assign(limit.begin(), limit.end());
        checkPerJoint(c, "limit", s.limit, s.chain.size());
        for (std::size_t k = 0; k < s.limit.size(); ++k) {
            if (!(s.limit[k] >= 0.0))
                throw Error(
                    fmt::format("{}.limit[{}] is {} degrees; a limit is the largest angle the joint may "
                                "turn, 0 or more",
                                c.nodeName(), k, s.limit[k]));
            s.limit[k] *= degrees;
        }
        s.target = c.getVector3(Target);
        s.weight = c.getDouble(Weight);
        s.aimAxis = c.getVector3(AimAxis);
        s.upAxis = c.getVector3(UpAxis);
        s.worldUp.reset();
        if (c.getEnum(UpMode) == World) s.worldUp = c.getVector3(WorldUp);
        lookAtChain(s, result);
        // Output k is the chain's joint k: outputs as many as the joints given, however sparse their indices.
        c.assignOutputElements(OutMatrix, result.world);
        c.assignOutputElements(DeltaMatrix, result.delta);
        c.assignOutputElements(Turn, result.turn);
    }
};

void declareInputs(NodeTypeBuilder& b)
{
    b.input(InMatrix, "inMatrix", ValueType::Matrix4)
        .array()
        .doc(
            "World matrix of each joint of the chain, root first (connect a clip's worldMatrix[j]: spine, "
            "neck, head). The chain is the elements given, in index order (a gap is no joint).");
    b.input(Target, "target", ValueType::Vector3).unit(Unit::Distance).keyable().doc("The world point to look at, cm.");
    b.input(Share, "share", ValueType::DoubleArray)
        .doc(
            "Per joint, root first: the fraction (0..1) of the remaining turn the joint takes. None given: "
            "1 / (joints from this one to the end of the chain), equal parts when the joints share a pivot; "
            "give the last joint 1 for its aim to reach the target.");
    b.input(Limit, "limit", ValueType::DoubleArray)
        .doc(
            "Per joint, root first: the largest angle the joint's swing toward the target may reach, degrees "
            "(0 or more; the up roll of the last joint is not limited). None given: no limits.");
    b.input(Weight, "weight", ValueType::Double)
        .defaultValue(1.0)
        .range(0.0, 1.0)
        .keyable()
        .doc(
            "0: the chain unchanged, exactly; 1: the full edit; between: every joint turns by weight times its "
            "full angle about the same axis. A connected value is clamped to 0..1.");
    b.input(AimAxis, "aimAxis", ValueType::Vector3)
        .defaultValue(Eigen::Vector3d(0, 0, 1))
        .doc("The last joint's local axis that looks at the target (any length; +Z: a BVH clip's forward).");
    b.input(UpAxis, "upAxis", ValueType::Vector3)
        .defaultValue(Eigen::Vector3d(0, 1, 0))
        .doc("The last joint's local axis kept nearest worldUp (upMode world), any length.");
    b.input(UpMode, "upMode", ValueType::Enum)
        .enumNames({"none", "world"})
        .defaultValue(static_cast<int>(World))
        .doc(
            "world: after its swing the last joint rolls about its aim so that its upAxis leans toward worldUp "
            "as far as the aim allows (no roll when either lies along the aim); none: swings only, the "
            "smallest turns, the clip's roll kept.");
    b.input(WorldUp, "worldUp", ValueType::Vector3)
        .defaultValue(Eigen::Vector3d(0, 1, 0))
        .doc("The world up direction for upMode world (any length).");
}

}  // namespace

std::shared_ptr<const NodeType> makeLookAtType()
{
    NodeTypeBuilder b("lookAt");
    b.notMaya();  // Maya's lookAt is a camera's aim constraint
    b.description(
        "Turns a chain of joints toward a target point (docs/nodes.md, \"Editing a clip's skeleton\"). Root "
        "first, joint k at its current pivot p_k (moved by the turns before it) measures theta_k, the angle "
        "between the last joint's current aim (its aimAxis in world) and the direction from p_k to the target, "
        "and swings by phi_k = min(share_k * theta_k, limit_k) about aim x direction (about the up when the "
        "target is straight behind), carrying the joints after it rigidly; with upMode world the last joint "
        "then rolls about its aim toward worldUp. The result is weighted per joint: outMatrix[k] = H_0(w) * "
        "... * H_k(w) * inMatrix[k], H_j(w) the turn of joint j about its input pivot by w times its angle. "
        "A joint whose pivot is on the target (within 1e-9 relative) does not turn; nothing gives NaN that "
        "was not NaN. A target or worldUp that is not finite (NaN, infinite) gives NaN outputs, never the "
        "unedited chain.");
    declareInputs(b);
    b.output(OutMatrix, "outMatrix", ValueType::Matrix4)
        .array()
        .doc(
            "The edited world matrix of the chain's joint k (inMatrix[k] when its indices have no gap); connect "
            "to rigInversion.target[j].");
    b.output(DeltaMatrix, "deltaMatrix", ValueType::Matrix4)
        .array()
        .doc(
            "The rigid motion of each joint's frame: outMatrix[k] = deltaMatrix[k] * inMatrix[k]. A joint "
            "parented under chain joint k (an arm under the spine, an eye under the head) follows as "
            "deltaMatrix[k] * its world matrix (multMatrix: matrixIn[0] = the joint, matrixIn[1] = deltaMatrix).");
    b.output(Turn, "turn", ValueType::Double)
        .array()
        .unit(Unit::Angle)
        .doc("The angle each joint turned, degrees (its swing and, for the last joint, its roll; weight included).");
    for (AttrId in = InMatrix; in <= WorldUp; ++in) b.affects(in, {OutMatrix, DeltaMatrix, Turn});
    return b.factory<LookAtNode>().build();
}

}  // namespace rig
