#include "bench/random_character.h"

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <utility>

#include "adapter/inversion_spec.h"
#include "core/rotation_math.h"

namespace rig::bench {
namespace {

constexpr std::array rotateOrders{"xyz", "yzx", "zxy", "xzy", "yxz", "zyx"};

std::string v3(const Eigen::Vector3d& v) { return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", v.x(), v.y(), v.z()); }

// A matrix as rig files write it: 16 numbers row by row (at 17 digits: a rest matrix the rig compares with its own).
std::string m4(const Eigen::Matrix4d& m)
{
    std::string out;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out += fmt::format("{}{:.17g}", r + c ? ", " : "[", m(r, c));
    return out + "]";
}

// A joint's local matrix at rest (rotate zero): T * JO, the joint orient in xyz order, degrees.
Eigen::Matrix4d restLocal(const Eigen::Vector3d& translate, const Eigen::Vector3d& jointOrientDeg)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 3>(0, 0) = eulerToMatrix(jointOrientDeg * std::numbers::pi / 180.0, RotateOrder::xyz);
    m.block<3, 1>(0, 3) = translate;
    return m;
}

// What the generator chose, for messages and for the family counts it expects.

class CharacterBuilder {
public:
    explicit CharacterBuilder(std::mt19937& rng) : rng_(rng) {}

    void body();
    void arm(const std::string& side, double sign);
    void eyes(int count);
    // The production constructions of legs (issue #46): what one leg draws.
    struct LegChoice {
        int bones = 2;                 // 2, or 3 (a hind leg: thigh, knee, hock under one mayaIkHandle)
        bool mayaHandle = false;       // mayaIkHandle (ikRPsolver) instead of the two-bone ikHandle
        int pivots = 0;                // reverse foot: 0 to 3 of heel, toe and ball pivots above the IK goal
        bool sdkPivots = false;        // the pivots turned by one `roll` through set-driven keys, not a channel each
        bool pole = false;             // a pole control (else the rotate plane's default)
        int orient = 0;                // 1: the ankle orient-constrained to the foot, 2: the ball, 3: both
        bool constraintBlend = false;  // FK and IK chains blended onto the leg by constraints weighted by a switch
        int spaces = 0;                // 0, or the foot control's parent parent-constrained to 2 or 3 weighted spaces
        bool oneHotSpace = false;  // the space weights from a `space` enum through condition nodes, else held fractions
        bool scLeg = false;        // the mayaIkHandle's solver the ikSCsolver: no pole, the rest plane turned minimally
        int scBones = 0;  // one-bone ikSCsolver handles: 1 the ankle aimed at the ball, 2 the ball at the toe, 3 both
        int scControls =
            0;  // per one-bone handle (bits as scBones): its goal a control of its own under the foot control
    };
    void leg(const std::string& side, double sign, const LegChoice& choice);

    std::string rigYaml() const { return "nodes:\n" + nodes_ + "connections:\n" + connections_; }
    double between(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
    bool coin(double p = 0.5) { return std::bernoulli_distribution(p)(rng_); }
    // `switches` 0 or 1 holds every ikFk switch there instead of at the mode chosen for it.
    std::string specYaml(int switches = -1) const { return specText(set_.size(), switches, true, params_); }
    // The whole character in FK (0) or IK (1) mode (Character::modeRig, modeSpec): in FK, the rig's parts before the
    // legs and the legs' FK twin, every arm's switch held at FK (the legs' blends and spaces are not in the twin).
    std::string modeRigYaml(int mode) const
    {
        if (mode == 1) return rigYaml();
        return "nodes:\n" + nodes_.substr(0, nodesBeforeLegs_) + fkLegNodes_ + "connections:\n" +
               connections_.substr(0, connectionsBeforeLegs_) + fkLegConnections_;
    }
    std::string modeSpecYaml(int mode) const
    {
        return mode == 1 ? specText(set_.size(), 1, true, ikParams_)
                         : specText(std::min(set_.size(), setBeforeLegs_), 0, false, fkParams_);
    }
    CharacterParts parts;
    // What was built: the rig, its specs and modes, and where the builder placed the outputs.
    Character character() const
    {
        return {rigYaml(),
                specYaml(),
                {specYaml(0), specYaml(1)},
                parts,
                restWorlds(),
                {modeRigYaml(0), modeRigYaml(1)},
                {modeSpecYaml(0), modeSpecYaml(1)}};
    }
    // The rest worlds the builder placed the outputs at, in output order.
    std::vector<Eigen::Matrix4d> restWorlds() const
    {
        std::vector<Eigen::Matrix4d> worlds;
        for (const std::string& j : outputs_) worlds.push_back(world_.at(j));
        return worlds;
    }

private:
    std::string order() { return rotateOrders[std::uniform_int_distribution<std::size_t>(0, 5)(rng_)]; }
    Eigen::Vector3d small(double deg) { return {between(-deg, deg), between(-deg, deg), between(-deg, deg)}; }
    void node(const std::string& text) { nodes_ += "  - " + text + "\n"; }
    void connect(const std::string& from, const std::string& to) { connections_ += "  - " + from + " -> " + to + "\n"; }
    // A parameter of the spec, and of both modes' (Character::modeSpec) until the legs start: the legs' parameters
    // are their IK mode's, their FK twin's are written apart (fkTwinLeg).
    void param(const std::string& glob)
    {
        const std::string line = "  - '" + glob + "'\n";
        params_ += line;
        ikParams_ += line;
        if (!legs_) fkParams_ += line;
    }
    // The spec: the first `setCount` switches, at `switches` (-1: at the mode chosen for each), the held plugs or
    // not, and `params`.
    std::string specText(std::size_t setCount, int switches, bool held, const std::string& params) const
    {
        std::string spec = std::string("helpers: auto\n") + (setCount == 0 && (!held || held_.empty()) ? "" : "set:\n");
        for (std::size_t i = 0; i < setCount; ++i)
            spec += fmt::format("  {}: {}\n", set_[i].first, switches < 0 ? set_[i].second : switches);
        for (const auto& [plug, value] : held_)
            if (held) spec += fmt::format("  {}: {:.9g}\n", plug, value);
        spec += "params:\n" + params + "outputs:\n";
        for (const std::string& j : outputs_) spec += "  - " + j + "\n";
        return spec;
    }
    // A joint with its rest world kept for the parts placed from it (IK goals, poles, eye targets).
    // `driven`: its translate comes from a switch, so the file does not set it.
    // `output` false: a copy chain's joint (an FK or IK chain under a blend), no output.
    void joint(const std::string& name, const std::string& parent, const Eigen::Vector3d& translate,
               const Eigen::Vector3d& jointOrient, const std::string& rotateOrder, bool driven = false,
               bool output = true);
    // The constants of one leg joint, for its chain and the copies a solver or a blend needs.
    struct LegJoint {
        std::string name;
        Eigen::Vector3d translate, orient;
        std::string order;
    };
    std::vector<LegJoint> legChain(double sign, int bones);
    void fkTwinLeg(const std::string& side, const std::vector<LegJoint>& joints, const Eigen::Vector3d& toe);
    std::string reverseFoot(const std::string& side, const LegChoice& choice, const std::string& ctrl);
    void legIk(const std::string& side, const LegChoice& choice, const std::vector<LegJoint>& chain,
               const std::string& suffix, const std::string& goalParent);
    void legBlend(const std::string& side, const std::vector<LegJoint>& chain, const std::vector<char>& parentKinds);
    void singleBoneIk(const std::string& side, const std::string& parent, const LegJoint& j, const std::string& end,
                      const std::string& goalParent, bool ownControl);
    std::string footSpace(const std::string& side, const LegChoice& choice);
    void orientTo(const std::string& jointName, const std::string& parent, const std::string& target,
                  const std::string& order);
    Eigen::Vector3d worldAt(const std::string& name) const { return world_.at(name).block<3, 1>(0, 3); }
    // The rotate Maya's handle tool gives a handle under `parent`: its effector's world orientation at rest (`joint`'s,
    // the chain's last), which an ikSCsolver's chain turns toward (docs/ik-and-deformers.md), so that the rest pose is
    // the solver's. As a rig file's field, degrees in xyz order.
    std::string handleRotate(const std::string& parent, const std::string& joint) const
    {
        const Eigen::Matrix3d r = world_.at(parent).block<3, 3>(0, 0).transpose() * world_.at(joint).block<3, 3>(0, 0);
        return "rotate: " + v3(matrixToEuler(polarRotation(r), RotateOrder::xyz) * (180.0 / std::numbers::pi)) + ", ";
    }
    // A control whose rotate drives `joint` (in the joint's rotate order).
    void fkControl(const std::string& control, const std::string& joint, const std::string& rotateOrder);
    void finger(const std::string& side, int index, double sign, const std::string& hand);
    // The constants of an arm's chain, which its ikHandle copies.
    struct ChainRest {
        Eigen::Vector3d upperAt, upperOrient;
        std::string upperOrder;
        double l1 = 0.0;
        Eigen::Vector3d foreOrient;
        std::string foreOrder;
        double l2 = 0.0;
    };
    void armSwitch(const std::string& side, double sign, const ChainRest& chain);

    std::mt19937& rng_;
    std::string nodes_, connections_, params_;
    std::string ikParams_, fkParams_;  // every arm's IK or FK controls (Character::modeSpec)
    // The legs come last: where they start in the rig's text and its switches, and their FK twin.
    bool legs_ = false;
    std::size_t nodesBeforeLegs_ = std::string::npos, connectionsBeforeLegs_ = std::string::npos,
                setBeforeLegs_ = std::string::npos;
    std::string fkLegNodes_, fkLegConnections_;
    std::vector<std::pair<std::string, int>> set_;
    std::vector<std::pair<std::string, double>> held_;  // held plugs that are no ikFk switch (space weights)
    std::vector<std::string> outputs_;                  // every joint
    std::map<std::string, Eigen::Matrix4d> world_;
    std::string chest_, head_;
    bool sdkCurl_ = false;
    bool handOrient_ = false;
    std::string handOrder_;
    std::string armMode_;
};

void CharacterBuilder::joint(const std::string& name, const std::string& parent, const Eigen::Vector3d& translate,
                             const Eigen::Vector3d& jointOrient, const std::string& rotateOrder, bool driven,
                             bool output)
{
    node(fmt::format("{{name: {}, type: joint{}{}, jointOrient: {}, rotateOrder: {}}}", name,
                     parent.empty() ? "" : ", parent: " + parent, driven ? "" : ", translate: " + v3(translate),
                     v3(jointOrient), rotateOrder));
    if (output) outputs_.push_back(name);
    world_[name] =
        (parent.empty() ? Eigen::Matrix4d::Identity() : world_.at(parent)) * restLocal(translate, jointOrient);
}

void CharacterBuilder::fkControl(const std::string& control, const std::string& joint, const std::string& rotateOrder)
{
    node(fmt::format("{{name: {}, type: transform, rotateOrder: {}}}", control, rotateOrder));
    connect(control + ".rotate", joint + ".rotate");
    param(control + ".rotate?");
}

// A root control on the pelvis, a spine of 2 to 4 joints sharing one bend control by random fractions with a chest
// FK control summed onto the last, a neck and a head.
void CharacterBuilder::body()
{
    const double height = between(85.0, 110.0);
    const std::string rootOrder = order();
    node(fmt::format("{{name: root_ctrl, type: transform, translate: [0, {:.9g}, 0], rotateOrder: {}}}", height,
                     rootOrder));
    joint("pelvis", "", Eigen::Vector3d(0, height, 0), Eigen::Vector3d::Zero(), rootOrder, true);
    connect("root_ctrl.translate", "pelvis.translate");
    connect("root_ctrl.rotate", "pelvis.rotate");
    param("root_ctrl.translate?");
    param("root_ctrl.rotate?");
    node(
        "{name: spine_ctrl, type: transform, addAttr: [{name: bendForward, unit: angle, min: -60, max: 60, keyable: "
        "true}, {name: bendSide, unit: angle, min: -60, max: 60, keyable: true}, {name: twist, unit: angle, min: -60, "
        "max: 60, keyable: true}]}");
    for (const char* attr : {"bendForward", "bendSide", "twist"}) param(fmt::format("spine_ctrl.{}", attr));
    parts.spineJoints = std::uniform_int_distribution<int>(2, 4)(rng_);
    // One rotate order along the spine, as riggers build it: the shared bend's channels then compose in the same
    // order on every joint (with an order per joint, bendForward and bendSide have no order in common and the learner
    // rightly discards one of them).
    std::string parent = "pelvis", fractions;
    const std::string jointOrder = order();
    for (int j = 1; j <= parts.spineJoints; ++j) {
        const std::string name = fmt::format("spine{}", j), share = name + "_share";
        const bool last = j == parts.spineJoints;
        joint(name, parent, Eigen::Vector3d(0, between(8.0, 12.0), between(-2.0, 2.0)), small(10.0), jointOrder);
        const double fraction = between(0.15, 0.4);
        fractions += fmt::format("{}{:.2f}", j > 1 ? "/" : "", fraction);
        node(fmt::format("{{name: {}, type: multiplyDivide, input2: [{:.9g}, {:.9g}, {:.9g}]}}", share, fraction,
                         fraction, fraction));
        connect("spine_ctrl.bendForward", share + ".input1X");
        connect("spine_ctrl.twist", share + ".input1Y");
        connect("spine_ctrl.bendSide", share + ".input1Z");
        if (last) {
            node(fmt::format("{{name: {}_rotate_sum, type: plusMinusAverage, operation: sum}}", name));
            connect(share + ".output", name + "_rotate_sum.input3D[0]");
            node(fmt::format("{{name: chest_ctrl, type: transform, rotateOrder: {}}}", jointOrder));
            connect("chest_ctrl.rotate", name + "_rotate_sum.input3D[1]");
            connect(name + "_rotate_sum.output3D", name + ".rotate");
            param("chest_ctrl.rotate?");
        } else {
            connect(share + ".output", name + ".rotate");
        }
        parent = name;
    }
    chest_ = parent;
    const double lean = between(10.0, 25.0);
    const std::string neckOrder = order(), headOrder = order();
    joint("neck", chest_, Eigen::Vector3d(0, between(10.0, 14.0), between(0.0, 3.0)), Eigen::Vector3d(lean, 0, 0),
          neckOrder);
    joint("head", "neck", Eigen::Vector3d(0, between(8.0, 11.0), 0), Eigen::Vector3d(-lean, between(-5.0, 5.0), 0),
          headOrder);
    joint("head_end", "head", Eigen::Vector3d(0, 12, 0), Eigen::Vector3d::Zero(), "xyz");
    fkControl("neck_ctrl", "neck", neckOrder);
    fkControl("head_ctrl", "head", headOrder);
    head_ = "head";
    parts.summary += fmt::format("spine of {} (shares {}); ", parts.spineJoints, fractions);
}

// A finger of two phalanges and an end, curled together by the wrist control's `curl`: through set-driven keys
// (animCurveUA, curl 0..10) or a multiplyDivide (curl an angle, 0..90 degrees), by random amounts.
void CharacterBuilder::finger(const std::string& side, int index, double sign, const std::string& hand)
{
    const std::string name = fmt::format("{}finger{}", side, index), mid = name + "_mid";
    const double z = index == 0 ? 0.0 : (index == 1 ? 1.0 : -1.0) * between(1.5, 2.5);
    joint(name, hand, Eigen::Vector3d(sign * between(6.0, 9.0), between(-1.0, 1.0), z), small(10.0), "xyz");
    joint(mid, name, Eigen::Vector3d(sign * between(3.0, 5.0), 0, 0), Eigen::Vector3d::Zero(), "xyz");
    joint(name + "_end", mid, Eigen::Vector3d(sign * between(2.0, 4.0), 0, 0), Eigen::Vector3d::Zero(), "xyz");
    if (sdkCurl_) {
        const double base = -sign * between(40.0, 80.0), tip = -sign * between(30.0, 70.0);
        node(fmt::format("{{name: {}_curl_sdk, type: animCurveUA, keys: [[0, 0], [10, {:.9g}]], tangents: spline}}",
                         name, base));
        node(
            fmt::format("{{name: {}_curl_sdk, type: animCurveUA, keys: [[0, 0], [5, {:.9g}], [10, {:.9g}]], "
                        "tangents: spline}}",
                        mid, tip / 3.0, tip));
        for (const std::string& j : {name, mid}) {
            connect(side + "wrist_ctrl.curl", j + "_curl_sdk.input");
            connect(j + "_curl_sdk.output", j + ".rotateZ");
        }
        return;
    }
    node(fmt::format("{{name: {}_curl_md, type: multiplyDivide, input2: [{:.9g}, {:.9g}, 0]}}", name,
                     -sign * between(0.5, 0.9), -sign * between(0.3, 0.8)));
    connect(side + "wrist_ctrl.curl", name + "_curl_md.input1X");
    connect(side + "wrist_ctrl.curl", name + "_curl_md.input1Y");
    connect(name + "_curl_md.outputX", name + ".rotateZ");
    connect(name + "_curl_md.outputY", mid + ".rotateZ");
}

// One arm on the side `sign` (+1 left, -1 right): an FK clavicle, a two-bone chain with a bent rest behind an ikFk
// switch held at IK (its goal and, or not, its pole the parameters) or at FK (the FK controls the parameters), a
// forearm twist joint sharing the wrist's twist, a hand with one or two curled fingers.
void CharacterBuilder::arm(const std::string& side, double sign)
{
    const std::string clavicle = side + "clavicle", upper = side + "upperArm", fore = side + "forearm",
                      hand = side + "hand";
    const std::string clavicleOrder = order(), upperOrder = order(), foreOrder = order(), handOrder = order();
    handOrder_ = handOrder;
    joint(clavicle, chest_, Eigen::Vector3d(sign * between(3.0, 5.0), between(6.0, 10.0), between(0.0, 2.0)),
          small(10.0), clavicleOrder);
    fkControl(side + "clavicle_ctrl", clavicle, clavicleOrder);
    const Eigen::Vector3d upperAt(sign * between(8.0, 12.0), 0, between(-1.0, 1.0));
    const Eigen::Vector3d upperOrient(between(-15.0, 15.0), 0, -sign * between(20.0, 60.0));
    const double l1 = between(20.0, 28.0), l2 = between(18.0, 25.0), bend = between(10.0, 40.0);
    const Eigen::Vector3d foreOrient(between(-20.0, 20.0), -sign * bend, 0);
    joint(upper, clavicle, upperAt, upperOrient, upperOrder);
    joint(fore, upper, Eigen::Vector3d(sign * l1, 0, 0), foreOrient, foreOrder, true);
    joint(side + "forearm_twist", fore, Eigen::Vector3d(sign * l2 * between(0.4, 0.6), 0, 0), Eigen::Vector3d::Zero(),
          "xyz");
    joint(hand, fore, Eigen::Vector3d(sign * l2, 0, 0), Eigen::Vector3d::Zero(), handOrder, true);
    sdkCurl_ = coin();
    node(
        fmt::format("{{name: {}wrist_ctrl, type: transform, rotateOrder: {}, addAttr: [{{name: curl, {}keyable: "
                    "true}}]}}",
                    side, handOrder, sdkCurl_ ? "min: 0, max: 10, " : "unit: angle, min: 0, max: 90, "));
    // The hand turns with its FK control, or (in IK) as its IK control, through an orient constraint and a switch.
    handOrient_ = coin();
    const std::string handRotation = side + (handOrient_ ? "hand_rotate_switch.output" : "wrist_ctrl.rotate");
    connect(handRotation, hand + ".rotate");
    param(side + "wrist_ctrl.curl");
    const double share = between(0.3, 0.7);
    node(
        fmt::format("{{name: {}forearm_twist_share, type: twistDistribute, rotateOrder: {}, twistAxis: x, weight: "
                    "[{:.9g}]}}",
                    side, handOrder, share));
    connect(handRotation, side + "forearm_twist_share.rotate");
    connect(side + "forearm_twist_share.outTwist[0]", side + "forearm_twist.rotateX");
    const int fingers = coin() ? 2 : 1;
    for (int f = 0; f < fingers; ++f) finger(side, fingers == 1 ? 0 : f + 1, sign, hand);
    armSwitch(side, sign, {upperAt, upperOrient, upperOrder, l1, foreOrient, foreOrder, l2});
    parts.summary += fmt::format("{}arm {} (share {:.2f}, {} finger(s) by {}{}); ", side, armMode_, share, fingers,
                                 sdkCurl_ ? "driven keys" : "multiplyDivide",
                                 handOrient_ ? ", the hand orient-constrained to its IK control" : "");
}

// The arm's ikHandle (stretch or not, a pole control or the rest plane) at the hand's rest, its FK controls, and a
// blendColors per driven plug, the switch held at IK or FK by the spec's `set:`.
void CharacterBuilder::armSwitch(const std::string& side, double sign, const ChainRest& chain)
{
    const std::string clavicle = side + "clavicle", ik = side + "arm_ik", settings = side + "arm_settings_ctrl";
    const Eigen::Vector3d shoulder = world_.at(side + "upperArm").block<3, 1>(0, 3),
                          elbow = world_.at(side + "forearm").block<3, 1>(0, 3),
                          wrist = world_.at(side + "hand").block<3, 1>(0, 3);
    const bool stretch = coin(), pole = coin(0.7), atIk = coin(0.75);
    // An IK control that turns the hand is aligned with the hand at rest, as riggers place it.
    const Eigen::Vector3d ikRotate = handOrient_
                                         ? Eigen::Vector3d(matrixToEuler(world_.at(side + "hand").block<3, 3>(0, 0),
                                                                         *rotateOrderFromName(handOrder_)) *
                                                           (180.0 / std::numbers::pi))
                                         : Eigen::Vector3d::Zero();
    node(fmt::format("{{name: {}arm_ik_ctrl, type: transform, translate: {}, rotate: {}, rotateOrder: {}}}", side,
                     v3(wrist), v3(ikRotate), handOrder_));
    if (handOrient_) {
        node(fmt::format("{{name: {}hand_orient, type: orientConstraint, constraintRotateOrder: {}}}", side,
                         handOrder_));
        connect(side + "arm_ik_ctrl.worldMatrix", side + "hand_orient.targetMatrix[0]");
        connect(side + "forearm.worldInverseMatrix", side + "hand_orient.constraintParentInverseMatrix");
        node(fmt::format("{{name: {}hand_rotate_switch, type: blendColors}}", side));
        connect(settings + ".ikFk", side + "hand_rotate_switch.blender");
        connect(side + "hand_orient.constraintRotate", side + "hand_rotate_switch.color1");
        connect(side + "wrist_ctrl.rotate", side + "hand_rotate_switch.color2");
    }
    node(
        fmt::format("{{name: {}, type: ikHandle, startTranslate: {}, startJointOrient: {}, startRotateOrder: {}, "
                    "midTranslate: [{:.9g}, 0, 0], midJointOrient: {}, midRotateOrder: {}, endTranslate: [{:.9g}, 0, "
                    "0], stretch: {}}}",
                    ik, v3(chain.upperAt), v3(chain.upperOrient), chain.upperOrder, sign * chain.l1,
                    v3(chain.foreOrient), chain.foreOrder, sign * chain.l2, stretch ? "true" : "false"));
    connect(clavicle + ".worldMatrix", ik + ".startParentMatrix");
    connect(clavicle + ".scale", ik + ".startInverseScale");
    connect(side + "arm_ik_ctrl.worldMatrix", ik + ".goalMatrix");
    if (pole) {
        // On the bend's side of the shoulder-wrist line, 30 cm out from the elbow: the rest pose is IK's at rest.
        const Eigen::Vector3d line = (wrist - shoulder).normalized(), out = elbow - shoulder;
        const Eigen::Vector3d at = elbow + 30.0 * (out - out.dot(line) * line).normalized();
        node(fmt::format("{{name: {}arm_pole_ctrl, type: transform, translate: {}}}", side, v3(at)));
        node(fmt::format("{{name: {}arm_pv, type: poleVectorConstraint, constraintRotatePivot: {}}}", side,
                         v3(chain.upperAt)));
        connect(side + "arm_pole_ctrl.worldMatrix", side + "arm_pv.targetMatrix[0]");
        connect(clavicle + ".worldMatrix", side + "arm_pv.pivotSpace");
        connect(side + "arm_pv.constraintTranslate", ik + ".poleVector");
    }
    node(fmt::format("{{name: {}arm_fk_ctrl, type: transform, rotateOrder: {}}}", side, chain.upperOrder));
    node(fmt::format("{{name: {}elbow_fk_ctrl, type: transform, rotateOrder: {}}}", side, chain.foreOrder));
    node(fmt::format("{{name: {}, type: transform, addAttr: [{{name: ikFk, min: 0, max: 1, keyable: true}}]}}",
                     settings));
    struct Driven {
        std::string joint, plug, ikOutput, fk;
    };
    const std::array<Driven, 4> driven{{{"upperArm", "rotate", "startRotate", side + "arm_fk_ctrl.rotate"},
                                        {"forearm", "rotate", "midRotate", side + "elbow_fk_ctrl.rotate"},
                                        {"forearm", "translate", "outMidTranslate", ""},
                                        {"hand", "translate", "outEndTranslate", ""}}};
    for (const Driven& d : driven) {
        const std::string blend = fmt::format("{}{}_{}_switch", side, d.joint, d.plug);
        const Eigen::Vector3d rest(sign * (d.joint == "forearm" ? chain.l1 : chain.l2), 0, 0);
        node(fmt::format("{{name: {}, type: blendColors{}}}", blend, d.fk.empty() ? ", color2: " + v3(rest) : ""));
        connect(settings + ".ikFk", blend + ".blender");
        connect(ik + "." + d.ikOutput, blend + ".color1");
        if (!d.fk.empty()) connect(d.fk, blend + ".color2");
        connect(blend + ".output", side + d.joint + "." + d.plug);
    }
    set_.emplace_back(settings + ".ikFk", atIk ? 1 : 0);
    // The spec's parameters are the drawn mode's controls, each mode's (Character::modeSpec) its own.
    std::vector<std::string> ikControls{side + "arm_ik_ctrl.translate?"}, fkControls;
    if (pole) ikControls.push_back(side + "arm_pole_ctrl.translate?");
    ikControls.push_back(side + (handOrient_ ? "arm_ik_ctrl.rotate?" : "wrist_ctrl.rotate?"));
    for (const char* control : {"arm_fk_ctrl.rotate?", "elbow_fk_ctrl.rotate?", "wrist_ctrl.rotate?"})
        fkControls.push_back(side + control);
    for (const std::string& glob : atIk ? ikControls : fkControls) params_ += "  - '" + glob + "'\n";
    for (const std::string& glob : ikControls) ikParams_ += "  - '" + glob + "'\n";
    for (const std::string& glob : fkControls) fkParams_ += "  - '" + glob + "'\n";
    ++(atIk ? parts.ikArms : parts.fkArms);
    if (atIk && !stretch) parts.rigidIkSides.push_back(side);
    armMode_ = atIk ? fmt::format("IK ({}, {})", pole ? "pole" : "no pole", stretch ? "stretch" : "no stretch") : "FK";
}

// One or two eyes aimed at one target control in front of the face: each a random aim axis (its end joint along
// it, so that its turn shows in positions), a random up axis and up mode, a random rotate order.
void CharacterBuilder::eyes(int count)
{
    const Eigen::Matrix3d headRotation = world_.at(head_).block<3, 3>(0, 0);
    const Eigen::Vector3d forward = headRotation * Eigen::Vector3d::UnitZ();
    std::vector<Eigen::Vector3d> at;
    for (int e = 0; e < count; ++e)
        at.emplace_back(count == 1 ? 0.0 : (e == 0 ? 1.0 : -1.0) * between(3.0, 4.0), between(3.0, 5.0),
                        between(7.0, 9.0));
    const Eigen::Vector3d middle = (world_.at(head_) * Eigen::Vector4d(0, 4, 8, 1)).head<3>();
    const Eigen::Vector3d target = middle + between(40.0, 80.0) * forward;
    node(fmt::format("{{name: eye_target_ctrl, type: transform, translate: {}}}", v3(target)));
    param("eye_target_ctrl.translate?");
    const auto unit = [&] { return Eigen::Vector3d(small(1.0).normalized()); };
    for (int e = 0; e < count; ++e) {
        const std::string eye = count == 1 ? "eye" : (e == 0 ? "L_eye" : "R_eye"), eyeOrder = order();
        joint(eye, head_, at[static_cast<std::size_t>(e)], Eigen::Vector3d::Zero(), eyeOrder);
        const Eigen::Vector3d aim = unit();
        Eigen::Vector3d up = unit();
        up = (up - up.dot(aim) * aim).normalized();
        joint(eye + "_end", eye, 2.0 * aim, Eigen::Vector3d::Zero(), "xyz");
        const std::array modes{"objectRotation", "scene", "vector"};
        const std::string mode = modes[std::uniform_int_distribution<std::size_t>(0, 2)(rng_)];
        // A world up well away from the line of sight: the aim is defined near every pose.
        Eigen::Vector3d worldUp = unit();
        while (std::abs((mode == "objectRotation" ? headRotation * worldUp : worldUp).dot(forward)) > 0.7)
            worldUp = unit();
        node(
            fmt::format("{{name: {}_aim, type: aimConstraint, aimVector: {}, upVector: {}, worldUpType: {}, "
                        "worldUpVector: {}, constraintTranslate: {}, constraintRotateOrder: {}}}",
                        eye, v3(aim), v3(up), mode, v3(worldUp), v3(at[static_cast<std::size_t>(e)]), eyeOrder));
        connect("eye_target_ctrl.worldMatrix", eye + "_aim.targetMatrix[0]");
        connect(head_ + ".worldInverseMatrix", eye + "_aim.constraintParentInverseMatrix");
        connect(head_ + ".worldMatrix", eye + "_aim.worldUpMatrix");
        connect(eye + "_aim.constraintRotate", eye + ".rotate");
        parts.summary += fmt::format("{} ({} up); ", eye, mode);
    }
    parts.eyes = count;
}

// A leg's thigh .. ankle at rest, bent forward at the knee (a hind leg: forward at the knee, back at the hock), each
// joint a random rotate order and a small random orient: the chain is not planar at rest.
std::vector<CharacterBuilder::LegJoint> CharacterBuilder::legChain(double sign, int bones)
{
    std::vector<LegJoint> chain{
        {"thigh", {sign * between(8.0, 11.0), between(-8.0, -5.0), between(-1.0, 1.0)}, small(8.0), order()}};
    if (bones == 2) {
        chain.push_back({"knee", {0, -between(35.0, 45.0), between(2.0, 5.0)}, small(5.0), order()});
        chain.push_back({"ankle", {0, -between(35.0, 45.0), -between(3.0, 6.0)}, Eigen::Vector3d::Zero(), order()});
        return chain;
    }
    chain.push_back({"knee", {0, -between(20.0, 28.0), between(6.0, 10.0)}, small(5.0), order()});
    chain.push_back({"hock", {0, -between(20.0, 28.0), -between(10.0, 15.0)}, small(5.0), order()});
    chain.push_back({"ankle", {0, -between(15.0, 22.0), between(3.0, 6.0)}, Eigen::Vector3d::Zero(), order()});
    return chain;
}

// `joint` turned by an orient constraint to `target` (whose rest orientation is the world's), keeping its rest
// orientation through the constraint's offset, as maintain offset sets it.
void CharacterBuilder::orientTo(const std::string& jointName, const std::string& parent, const std::string& target,
                                const std::string& jointOrder)
{
    const Eigen::Vector3d offset =
        matrixToEuler(world_.at(jointName).block<3, 3>(0, 0), RotateOrder::xyz) * (180.0 / std::numbers::pi);
    const std::string constraint = jointName + "_orient";
    node(fmt::format("{{name: {}, type: orientConstraint, constraintRotateOrder: {}, offset: {}}}", constraint,
                     jointOrder, v3(offset)));
    connect(target + ".worldMatrix", constraint + ".targetMatrix[0]");
    connect(parent + ".worldInverseMatrix", constraint + ".constraintParentInverseMatrix");
    connect(constraint + ".constraintRotate", jointName + ".rotate");
}

// The foot control's parent, parent-constrained (maintain offset) to 2 or 3 spaces among a fixed world space, the
// root control, the pelvis and the chest, weighted by a `space` enum through condition nodes or by held fractions.
std::string CharacterBuilder::footSpace(const std::string& side, const LegChoice& choice)
{
    const std::string space = side + "foot_space", pc = space + "_pc", settings = side + "foot_space_ctrl";
    node(fmt::format("{{name: {}, type: transform}}", space));
    if (!world_.contains("world_space")) {
        node("{name: world_space, type: transform}");
        world_["world_space"] = Eigen::Matrix4d::Identity();
        world_["root_ctrl"] = world_.at("pelvis");
    }
    std::vector<std::string> spaces{"world_space", "root_ctrl", "pelvis", chest_};
    std::shuffle(spaces.begin(), spaces.end(), rng_);
    spaces.resize(static_cast<std::size_t>(choice.spaces));
    node(
        fmt::format("{{name: {}, type: transform, addAttr: [{{name: space, min: 0, max: {}, keyable: true}}, "
                    "{{name: w0, min: 0, max: 1}}, {{name: w1, min: 0, max: 1}}, {{name: w2, min: 0, max: 1}}]}}",
                    settings, choice.spaces - 1));
    const int held = std::uniform_int_distribution<int>(0, choice.spaces - 1)(rng_);
    if (choice.oneHotSpace) held_.emplace_back(settings + ".space", held);
    std::string summary;
    std::string rests;
    for (const std::string& target : spaces) rests += (rests.empty() ? "" : ", ") + m4(world_.at(target));
    node(fmt::format("{{name: {}, type: parentConstraint, maintainOffset: true, targetRestMatrix: [{}]}}", pc, rests));
    for (std::size_t i = 0; i < spaces.size(); ++i) {
        const std::string weight = fmt::format("{}.targetWeight[{}]", pc, i);
        connect(spaces[i] + ".worldMatrix", fmt::format("{}.targetMatrix[{}]", pc, i));
        if (choice.oneHotSpace) {
            const std::string is = fmt::format("{}_is{}", space, i);
            node(
                fmt::format("{{name: {}, type: condition, secondTerm: {}, colorIfTrue: [1, 0, 0], colorIfFalse: [0, "
                            "0, 0]}}",
                            is, i));
            connect(settings + ".space", is + ".firstTerm");
            connect(is + ".outColorR", weight);
            summary += fmt::format("{}{}{}", i ? "/" : "", spaces[i], static_cast<int>(i) == held ? "*" : "");
        } else {
            const double w = between(0.2, 1.0);
            connect(fmt::format("{}.w{}", settings, i), weight);
            held_.emplace_back(fmt::format("{}.w{}", settings, i), w);
            summary += fmt::format("{}{} {:.2f}", i ? "/" : "", spaces[i], w);
        }
    }
    connect(pc + ".constraintTranslate", space + ".translate");
    connect(pc + ".constraintRotate", space + ".rotate");
    parts.summary += fmt::format("{}foot in spaces {}; ", side, summary);
    return space;
}

// The reverse foot under the foot control (at the ankle): heel, toe and ball pivots (the first `pivots` of them, in
// that order), each turned about its X by a channel of the control or by set-driven keys of one `roll`. Returns the
// transform the IK goal hangs under.
std::string CharacterBuilder::reverseFoot(const std::string& side, const LegChoice& choice, const std::string& ctrl)
{
    const Eigen::Vector3d ankle = worldAt(side + "ankle"), ball = worldAt(side + "ball"),
                          toe = worldAt(side + "toe_end");
    const std::array<std::pair<std::string, Eigen::Vector3d>, 3> pivots{
        {{"heel", Eigen::Vector3d(ankle.x(), toe.y(), ankle.z() - between(3.0, 6.0))}, {"toe", toe}, {"ball", ball}}};
    // A roll: the heel below 0, the ball from 0 to 5 (eased back by 10), the toe from 5 to 10.
    const std::array<std::string, 3> keys{
        fmt::format("[[-10, {:.9g}], [0, 0]], tangents: linear", -between(20.0, 40.0)),
        fmt::format("[[5, 0], [10, {:.9g}]], tangents: linear", between(30.0, 50.0)),
        fmt::format("[[0, 0], [5, {:.9g}], [10, {:.9g}]], tangents: spline", between(20.0, 35.0), between(5.0, 20.0))};
    std::string parent = ctrl;
    Eigen::Vector3d at = ankle;
    for (int p = 0; p < choice.pivots; ++p) {
        const auto& [name, where] = pivots[static_cast<std::size_t>(p)];
        const std::string pivot = side + name + "_pivot";
        node(fmt::format("{{name: {}, type: transform, parent: {}, translate: {}}}", pivot, parent, v3(where - at)));
        world_[pivot] = Eigen::Matrix4d::Identity();
        world_[pivot].block<3, 1>(0, 3) = where;
        if (choice.sdkPivots) {
            node(fmt::format("{{name: {}_roll_sdk, type: animCurveUA, keys: {}}}", pivot,
                             keys[static_cast<std::size_t>(p)]));
            connect(ctrl + ".roll", pivot + "_roll_sdk.input");
            connect(pivot + "_roll_sdk.output", pivot + ".rotateX");
        } else {
            connect(ctrl + "." + name + "Roll", pivot + ".rotateX");
            param(ctrl + "." + name + "Roll");
        }
        parent = pivot;
        at = where;
    }
    if (choice.sdkPivots && choice.pivots > 0) param(ctrl + ".roll");
    return parent;
}

// The leg's IK on the chain `suffix` names: a two-bone ikHandle whose goal is a transform at the ankle under
// `goalParent`, or a mayaIkHandle (ikRPsolver, 2 or 3 bones) parented there itself; a pole control or none.
void CharacterBuilder::legIk(const std::string& side, const LegChoice& choice, const std::vector<LegJoint>& chain,
                             const std::string& suffix, const std::string& goalParent)
{
    const std::string ik = side + "leg_ik";
    const Eigen::Vector3d hip = worldAt(side + "thigh"), ankle = worldAt(side + "ankle");
    const Eigen::Vector3d goalFromParent = ankle - worldAt(goalParent);
    // The chain's side: the sum of its inner joints' offsets from the hip, across the hip-ankle line.
    const Eigen::Vector3d line = (ankle - hip).normalized();
    Eigen::Vector3d out = Eigen::Vector3d::Zero();
    for (std::size_t j = 1; j + 1 < chain.size(); ++j) out += worldAt(side + chain[j].name) - hip;
    const Eigen::Vector3d across = (out - out.dot(line) * line).normalized();
    std::string goal = goalParent;
    if (choice.mayaHandle) {
        std::string translates, orients, orders;
        for (std::size_t j = 0; j + 1 < chain.size(); ++j) {
            translates += (j ? ", " : "") + v3(chain[j].translate);
            orients += (j ? ", " : "") + v3(chain[j].orient);
            orders += (j ? ", " : "") + chain[j].order;
        }
        // Without a pole control, the pole vector is the rest plane's side, in the handle's parent's space (which
        // is the world's at rest), and turns with the foot. The ikSCsolver reads no pole vector.
        node(
            fmt::format("{{name: {}, type: mayaIkHandle, parent: {}, translate: {}, solverType: {}, "
                        "{}{}jointTranslate: [{}], jointOrient: [{}], jointRotateOrder: [{}], effectorTranslate: {}}}",
                        ik, goalParent, v3(goalFromParent), choice.scLeg ? "ikSCsolver" : "ikRPsolver",
                        choice.pole || choice.scLeg ? "" : "poleVector: " + v3(across) + ", ",
                        choice.scLeg ? handleRotate(goalParent, side + chain[chain.size() - 2].name) : "", translates,
                        orients, orders, v3(chain.back().translate)));
        for (std::size_t j = 0; j + 1 < chain.size(); ++j)
            connect(fmt::format("{}.outRotate[{}]", ik, j), side + chain[j].name + suffix + ".rotate");
    } else {
        if (goalParent != side + "foot_ik_ctrl" || choice.pivots > 0) {
            goal = side + "ankle_goal";
            node(fmt::format("{{name: {}, type: transform, parent: {}, translate: {}}}", goal, goalParent,
                             v3(goalFromParent)));
        }
        node(
            fmt::format("{{name: {}, type: ikHandle, startTranslate: {}, startJointOrient: {}, startRotateOrder: {}, "
                        "midTranslate: {}, midJointOrient: {}, midRotateOrder: {}, endTranslate: {}}}",
                        ik, v3(chain[0].translate), v3(chain[0].orient), chain[0].order, v3(chain[1].translate),
                        v3(chain[1].orient), chain[1].order, v3(chain[2].translate)));
        connect(goal + ".worldMatrix", ik + ".goalMatrix");
        connect(ik + ".startRotate", side + "thigh" + suffix + ".rotate");
        connect(ik + ".midRotate", side + "knee" + suffix + ".rotate");
    }
    connect("pelvis.worldMatrix", ik + ".startParentMatrix");
    connect("pelvis.scale", ik + ".startInverseScale");
    if (!choice.pole) return;
    const std::string pole = side + "leg_pole_ctrl", pv = side + "leg_pv";
    // Straight out from the hip-ankle line along the chain's side: the rest pose is IK's at rest.
    node(fmt::format("{{name: {}, type: transform, translate: {}}}", pole,
                     v3(0.5 * (hip + ankle) + between(30.0, 50.0) * across)));
    node(
        fmt::format("{{name: {}, type: poleVectorConstraint, constraintRotatePivot: {}}}", pv, v3(chain[0].translate)));
    connect(pole + ".worldMatrix", pv + ".targetMatrix[0]");
    connect("pelvis.worldMatrix", pv + ".pivotSpace");
    // mayaIkHandle takes its pole vector in its parent's space, as Maya's constraint writes it.
    if (choice.mayaHandle) connect(goalParent + ".worldInverseMatrix", pv + ".constraintParentInverseMatrix");
    connect(pv + ".constraintTranslate", ik + ".poleVector");
    param(pole + ".translate?");
}

// A one-bone ikSCsolver handle turning joint `j` (under `parent`) so that its child `end` aims at the handle, which
// rests at `end` parented under `goalParent` or under a control of its own there (a child of `goalParent`, its
// translation the parameters): a ball or toe IK of a reverse foot.
void CharacterBuilder::singleBoneIk(const std::string& side, const std::string& parent, const LegJoint& j,
                                    const std::string& end, const std::string& goalParent, bool ownControl)
{
    const std::string name = side + j.name, ik = name + "_sc_ik";
    std::string goal = goalParent;
    if (ownControl) {
        goal = name + "_sc_ctrl";
        node(fmt::format("{{name: {}, type: transform, parent: {}, translate: {}}}", goal, goalParent,
                         v3(worldAt(end) - worldAt(goalParent))));
        world_[goal] = Eigen::Matrix4d::Identity();
        world_[goal].block<3, 1>(0, 3) = worldAt(end);
        param(goal + ".translate?");
    }
    node(
        fmt::format("{{name: {}, type: mayaIkHandle, parent: {}, translate: {}, solverType: ikSCsolver, "
                    "{}jointTranslate: [{}], jointOrient: [{}], jointRotateOrder: [{}], effectorTranslate: {}}}",
                    ik, goal, v3(worldAt(end) - worldAt(goal)), handleRotate(goal, name), v3(j.translate), v3(j.orient),
                    j.order, v3(world_.at(name).inverse().block<3, 3>(0, 0) * (worldAt(end) - worldAt(name)))));
    connect(parent + ".worldMatrix", ik + ".startParentMatrix");
    connect(parent + ".scale", ik + ".startInverseScale");
    connect(ik + ".outRotate[0]", name + ".rotate");
}

// The leg's joints blended from an FK chain and the IK chain by a constraint each (a parent or an orient constraint,
// at random) with two weighted targets: the switch's ikFk on the IK joint, its reverse on the FK joint. The switch is
// held at IK.
void CharacterBuilder::legBlend(const std::string& side, const std::vector<LegJoint>& chain,
                                const std::vector<char>& parentKinds)
{
    const std::string settings = side + "leg_settings_ctrl", reverse = side + "leg_ikFk_reverse";
    node(fmt::format("{{name: {}, type: transform, addAttr: [{{name: ikFk, min: 0, max: 1, keyable: true}}]}}",
                     settings));
    node(fmt::format("{{name: {}, type: reverse}}", reverse));
    connect(settings + ".ikFk", reverse + ".inputX");
    std::string parent = "pelvis", kinds;
    for (std::size_t k = 0; k < chain.size(); ++k) {
        const LegJoint& j = chain[k];
        const std::string name = side + j.name, blend = name + "_blend";
        const bool parentConstraint = parentKinds[k] != 0;
        kinds += parentConstraint ? "p" : "o";
        node(fmt::format("{{name: {}_fk_ctrl, type: transform, rotateOrder: {}}}", name, j.order));
        connect(name + "_fk_ctrl.rotate", name + "_fk.rotate");
        node(fmt::format("{{name: {}, type: {}, constraintRotateOrder: {}, constraintJointOrient: {}}}", blend,
                         parentConstraint ? "parentConstraint" : "orientConstraint", j.order, v3(j.orient)));
        connect(name + "_fk.worldMatrix", blend + ".targetMatrix[0]");
        connect(name + "_ik.worldMatrix", blend + ".targetMatrix[1]");
        connect(reverse + ".outputX", blend + ".targetWeight[0]");
        connect(settings + ".ikFk", blend + ".targetWeight[1]");
        connect(parent + ".worldInverseMatrix", blend + ".constraintParentInverseMatrix");
        connect(blend + ".constraintRotate", name + ".rotate");
        if (parentConstraint) connect(blend + ".constraintTranslate", name + ".translate");
        parent = name;
    }
    set_.emplace_back(settings + ".ikFk", 1);
    parts.summary += fmt::format("{}leg blended by constraints ({}); ", side, kinds);
}

// The leg's FK twin (Character::modeRig): its joints (thigh .. ball) as the rig places them, each turned by a control
// of its own, and the toe's end.
void CharacterBuilder::fkTwinLeg(const std::string& side, const std::vector<LegJoint>& joints,
                                 const Eigen::Vector3d& toe)
{
    std::string parent = "pelvis";
    const auto twinJoint = [&](const std::string& name, const Eigen::Vector3d& translate, const Eigen::Vector3d& orient,
                               const std::string& rotateOrder) {
        fkLegNodes_ += fmt::format(
            "  - {{name: {}, type: joint, parent: {}, translate: {}, jointOrient: {}, "
            "rotateOrder: {}}}\n",
            name, parent, v3(translate), v3(orient), rotateOrder);
        parent = name;
    };
    for (const LegJoint& j : joints) {
        const std::string name = side + j.name, control = name + "_ctrl";
        twinJoint(name, j.translate, j.orient, j.order);
        fkLegNodes_ += fmt::format("  - {{name: {}, type: transform, rotateOrder: {}}}\n", control, j.order);
        fkLegConnections_ += "  - " + control + ".rotate -> " + name + ".rotate\n";
        fkParams_ += "  - '" + control + ".rotate?'\n";
    }
    twinJoint(side + "toe_end", toe, Eigen::Vector3d::Zero(), "xyz");
}

// One leg on the side `sign`, IK: the chain (a copy of it under an IK chain and an FK chain when blended), a ball and
// a toe, the foot control at the ankle (in spaces or not) over its reverse foot, the IK, the ankle and the ball turned
// by their own controls or orient-constrained to the foot.
void CharacterBuilder::leg(const std::string& side, double sign, const LegChoice& c)
{
    if (!legs_) {
        legs_ = true;
        nodesBeforeLegs_ = nodes_.size();
        connectionsBeforeLegs_ = connections_.size();
        setBeforeLegs_ = set_.size();
    }
    const std::vector<LegJoint> chain = legChain(sign, c.bones);
    std::vector<char> parentKinds;  // per joint under a blend: a parent constraint (which drives its translate too)
    for (std::size_t k = 0; c.constraintBlend && k < chain.size(); ++k) parentKinds.push_back(coin() ? 1 : 0);
    const auto addChain = [&](const std::string& suffix, bool output) {
        std::string parent = "pelvis";
        for (std::size_t k = 0; k < chain.size(); ++k) {
            const LegJoint& j = chain[k];
            const bool driven = output && c.constraintBlend && parentKinds[k];
            joint(side + j.name + suffix, parent, j.translate, j.orient, j.order, driven, output);
            parent = side + j.name + suffix;
        }
    };
    addChain("", true);
    const std::string ikSuffix = c.constraintBlend ? "_ik" : "";
    if (c.constraintBlend) {
        addChain("_ik", false);
        addChain("_fk", false);
    }
    const std::string ankle = side + "ankle", ball = side + "ball";
    // The ball's rotate order is the one its control or its orient constraint writes its angles in.
    const double ballDown = between(5.0, 8.0), ballForward = between(10.0, 14.0);
    const std::string ballOrder = order();
    const LegJoint ballJoint{"ball", Eigen::Vector3d(0, -ballDown, ballForward), Eigen::Vector3d::Zero(), ballOrder};
    joint(ball, ankle, ballJoint.translate, ballJoint.orient, ballOrder);
    const Eigen::Vector3d toe(0, 0, between(5.0, 8.0));
    joint(side + "toe_end", ball, toe, Eigen::Vector3d::Zero(), "xyz");
    std::vector<LegJoint> twin = chain;
    twin.push_back(ballJoint);
    fkTwinLeg(side, twin, toe);
    const std::string ctrl = side + "foot_ik_ctrl";
    const std::string space = c.spaces > 0 ? footSpace(side, c) : "";
    std::string attrs;
    if (c.sdkPivots && c.pivots > 0) attrs = "{name: roll, min: -10, max: 10, keyable: true}";
    const std::array<const char*, 3> pivotNames{"heel", "toe", "ball"};
    for (int p = 0; !c.sdkPivots && p < c.pivots; ++p)
        attrs += fmt::format("{}{{name: {}Roll, unit: angle, min: -40, max: 40, keyable: true}}", p ? ", " : "",
                             pivotNames[static_cast<std::size_t>(p)]);
    node(fmt::format("{{name: {}, type: transform, translate: {}, rotateOrder: {}{}{}}}", ctrl, v3(worldAt(ankle)),
                     order(), space.empty() ? "" : ", parent: " + space,
                     attrs.empty() ? "" : ", addAttr: [" + attrs + "]"));
    world_[ctrl] = Eigen::Matrix4d::Identity();
    world_[ctrl].block<3, 1>(0, 3) = worldAt(ankle);
    param(ctrl + ".translate?");
    param(ctrl + ".rotate?");
    const std::string goalParent = reverseFoot(side, c, ctrl);
    legIk(side, c, chain, ikSuffix, goalParent);
    const LegJoint& ankleJoint = chain.back();
    const std::string shin = side + chain[chain.size() - 2].name;
    // A one-bone handle's goal hangs under the toe pivot where there is one, else under the foot control.
    const std::string scParent = c.pivots >= 2 ? side + "toe_pivot" : ctrl;
    if (c.scBones & 1) {
        singleBoneIk(side, shin, ankleJoint, ball, scParent, c.scControls & 1);
    } else if (c.orient & 1) {
        orientTo(ankle + ikSuffix, shin + ikSuffix, goalParent, ankleJoint.order);
    } else {
        fkControl(ankle + "_ctrl", ankle + ikSuffix, ankleJoint.order);
    }
    if (c.scBones & 2) {
        singleBoneIk(side, ankle, ballJoint, side + "toe_end", scParent, c.scControls & 2);
    } else if (c.orient & 2) {
        orientTo(ball, ankle, c.pivots >= 2 ? side + "toe_pivot" : ctrl, ballOrder);
    } else {
        fkControl(ball + "_ctrl", ball, ballOrder);
    }
    if (c.constraintBlend) legBlend(side, chain, parentKinds);
    parts.summary += fmt::format(
        "{}leg of {} bones by {} ({}), {} pivot(s){}, {}{}{}; ", side, c.bones,
        c.mayaHandle ? (c.scLeg ? "mayaIkHandle ikSCsolver" : "mayaIkHandle") : "ikHandle", c.pole ? "pole" : "no pole",
        c.pivots, c.sdkPivots ? " by driven keys" : "",
        std::array{"no orient constraint", "the ankle orient-constrained", "the ball orient-constrained",
                   "ankle and ball orient-constrained"}[static_cast<std::size_t>(c.orient)],
        c.constraintBlend ? ", blended by constraints" : "",
        c.scBones == 0
            ? ""
            : fmt::format(", one-bone ikSCsolver on the {} (goal {})",
                          std::array{"", "ankle", "ball", "ankle and ball"}[static_cast<std::size_t>(c.scBones)],
                          c.scControls ? "own control" : (c.pivots >= 2 ? "toe pivot" : "foot control")));
}

}  // namespace

// A body with one or two IK legs where `forced` is drawn at random and
// the rest of each leg is plain: two bones, an ikHandle or a mayaIkHandle, a pole or none.
Character leggedCharacter(std::mt19937& rng, Construction forced)
{
    CharacterBuilder b(rng);
    b.body();
    const int count = b.coin() ? 2 : 1;
    const auto draw = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    for (int l = 0; l < count; ++l) {
        CharacterBuilder::LegChoice c;
        c.mayaHandle = b.coin();
        c.pole = b.coin(0.6);
        if (forced == Construction::reverseFoot) {
            c.pivots = draw(1, 3);
            c.sdkPivots = b.coin();
        } else if (forced == Construction::orientEnd) {
            c.orient = draw(1, 3);
            c.pivots = draw(0, 3);
            c.sdkPivots = b.coin();
        } else if (forced == Construction::threeBones) {
            c.bones = 3;
            c.mayaHandle = true;
        } else if (forced == Construction::constraintBlend) {
            c.constraintBlend = true;
        } else if (forced == Construction::spaceSwitch) {
            c.spaces = draw(2, 3);
            c.oneHotSpace = b.coin();
        } else if (forced == Construction::singleChain) {
            // The leg's two bones under an ikSCsolver, or one-bone ikSCsolver handles on the ankle or the ball, or
            // both; their goals under pivots, the foot control, or controls of their own.
            c.scLeg = b.coin();
            if (c.scLeg) {
                c.mayaHandle = true;
                c.pole = false;
            }
            c.scBones = draw(c.scLeg ? 0 : 1, 3);
            c.scControls = draw(0, 3) & c.scBones;
            c.pivots = draw(0, 3);
        }
        b.leg(l == 0 ? "L_" : "R_", l == 0 ? 1.0 : -1.0, c);
    }
    return b.character();
}

Character randomCharacter(std::mt19937& rng)
{
    CharacterBuilder b(rng);
    b.body();
    const bool twoArms = std::bernoulli_distribution(0.7)(rng);
    b.arm("L_", 1.0);
    if (twoArms) b.arm("R_", -1.0);
    b.eyes(std::bernoulli_distribution(0.7)(rng) ? 2 : 1);
    return b.character();
}

GraphRigFunction loadCharacterRig(const std::string& rig, const std::string& spec, const std::filesystem::path& dir,
                                  const std::string& name, std::filesystem::path& rigFile)
{
    const auto write = [&](const std::string& file, const std::string& text) {
        const std::filesystem::path path = dir / file;
        std::ofstream(path, std::ios::binary) << text;
        return path;
    };
    rigFile = write(name + ".yaml", rig);
    const InversionSpec read = readInversionSpec(write(name + ".spec.yaml", spec));
    GraphRigOptions options{read.params, read.outputs, {}, read.set, read.ranges};
    options.autoHelpers = read.autoHelpers;
    return GraphRigFunction(rigFile, options);
}

GraphRigFunction loadCharacter(const Character& character, const std::filesystem::path& dir, int index,
                               std::filesystem::path& rigFile)
{
    return loadCharacterRig(character.rig, character.spec, dir, fmt::format("character{}", index), rigFile);
}

// The clip of random_character.h: two sines per parameter, the real rig's worlds as targets.
ClipTargets smoothClip(const Approximation& a, RigBinding& binding, int frames, std::mt19937& rng)
{
    struct Wave {
        double lo, hi, f1, f2, p1, p2;
    };
    std::vector<Wave> waves;
    const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
    for (const auto& m : a.parameters) {
        const RigParameter& p = m.parameter;
        const double lo = std::isfinite(p.min) ? p.defaultValue + 0.4 * (p.min - p.defaultValue) : p.defaultValue;
        const double hi = std::isfinite(p.max) ? p.defaultValue + 0.4 * (p.max - p.defaultValue) : p.defaultValue;
        waves.push_back({lo, hi, uniform(0.25, 0.75), uniform(0.5, 1.25), uniform(0.0, 2.0 * std::numbers::pi),
                         uniform(0.0, 2.0 * std::numbers::pi)});
    }
    ClipTargets targets;
    std::vector<double> values(waves.size());
    std::vector<Eigen::Matrix4d> worlds;
    for (int f = 0; f < frames; ++f) {
        const double t = 2.0 * std::numbers::pi * f / std::max(frames - 1, 1);
        for (std::size_t p = 0; p < waves.size(); ++p) {
            const Wave& w = waves[p];
            const double s = 0.5 * std::sin(w.f1 * t + w.p1) + 0.5 * std::sin(w.f2 * t + w.p2);  // in [-1, 1]
            values[p] = w.lo + (w.hi - w.lo) * 0.5 * (s + 1.0);
        }
        binding.evaluate(values, worlds);
        std::vector<JointTarget>& frame = targets.frames.emplace_back(a.outputs.size());
        for (std::size_t k = 0; k < a.outputs.size(); ++k) {
            frame[k].active = !a.outputs[k].helper;
            frame[k].world = worlds[k];
        }
    }
    return targets;
}

}  // namespace rig::bench
