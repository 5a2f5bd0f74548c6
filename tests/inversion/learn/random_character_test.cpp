// Random production-style characters (the developers' guide: "test on rigs you did not tune for"): a whole rig
// combining every constraint family of issue #32 as rigs/creature.yaml does (IK arms with and without poles behind
// held ikFk switches, aimed eyes, forearm twist shares, a spine bend shared by fractions, finger curls), each part at
// random, written as a rig file and a spec, learned as rig-learn learns it (helper frames found) and solved on the
// real rig.
#include <doctest/doctest.h>

#include <unistd.h>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "core/rotation_math.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/hybrid_solve.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/constraint.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
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
struct CharacterParts {
    int spineJoints = 0, ikArms = 0, fkArms = 0, eyes = 0;
    std::vector<std::string> rigidIkSides;  // the IK arms without stretch ("L_", "R_")
    std::string summary;
};

// The rig file and the spec (rig-learn --spec) of one random character, written part by part.
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
    std::string specYaml(int switches = -1) const
    {
        std::string spec = std::string("helpers: auto\n") + (set_.empty() && held_.empty() ? "" : "set:\n");
        for (const auto& [plug, value] : set_) spec += fmt::format("  {}: {}\n", plug, switches < 0 ? value : switches);
        for (const auto& [plug, value] : held_) spec += fmt::format("  {}: {:.9g}\n", plug, value);
        spec += "params:\n" + params_ + "outputs:\n";
        for (const std::string& j : outputs_) spec += "  - " + j + "\n";
        return spec;
    }
    CharacterParts parts;
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
    void param(const std::string& glob) { params_ += "  - '" + glob + "'\n"; }
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
    if (atIk) {
        param(side + "arm_ik_ctrl.translate?");
        if (pole) param(side + "arm_pole_ctrl.translate?");
        param(side + (handOrient_ ? "arm_ik_ctrl.rotate?" : "wrist_ctrl.rotate?"));
    } else {
        param(side + "arm_fk_ctrl.rotate?");
        param(side + "elbow_fk_ctrl.rotate?");
        param(side + "wrist_ctrl.rotate?");
    }
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
                        "{}jointTranslate: [{}], jointOrient: [{}], jointRotateOrder: [{}], effectorTranslate: {}}}",
                        ik, goalParent, v3(goalFromParent), choice.scLeg ? "ikSCsolver" : "ikRPsolver",
                        choice.pole || choice.scLeg ? "" : "poleVector: " + v3(across) + ", ", translates, orients,
                        orders, v3(chain.back().translate)));
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
                    "jointTranslate: [{}], jointOrient: [{}], jointRotateOrder: [{}], effectorTranslate: {}}}",
                    ik, goal, v3(worldAt(end) - worldAt(goal)), v3(j.translate), v3(j.orient), j.order,
                    v3(world_.at(name).inverse().block<3, 3>(0, 0) * (worldAt(end) - worldAt(name)))));
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

// One leg on the side `sign`, IK: the chain (a copy of it under an IK chain and an FK chain when blended), a ball and
// a toe, the foot control at the ankle (in spaces or not) over its reverse foot, the IK, the ankle and the ball turned
// by their own controls or orient-constrained to the foot.
void CharacterBuilder::leg(const std::string& side, double sign, const LegChoice& c)
{
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
    joint(ball, ankle, Eigen::Vector3d(0, -ballDown, ballForward), Eigen::Vector3d::Zero(), ballOrder);
    joint(side + "toe_end", ball, Eigen::Vector3d(0, 0, between(5.0, 8.0)), Eigen::Vector3d::Zero(), "xyz");
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
        singleBoneIk(side, ankle,
                     {"ball", Eigen::Vector3d(0, -ballDown, ballForward), Eigen::Vector3d::Zero(), ballOrder},
                     side + "toe_end", scParent, c.scControls & 2);
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

struct Character {
    std::string rig, spec;
    std::array<std::string, 2> specAt;  // every switch held at FK, at IK
    CharacterParts parts;
    std::vector<Eigen::Matrix4d> rest;  // the outputs' rest worlds as the builder placed them
};

// The constructions of production Maya rigs the legged characters add (issue #46), one forced per character.
enum class Construction { reverseFoot, orientEnd, threeBones, constraintBlend, spaceSwitch, singleChain };

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
    return {b.rigYaml(), b.specYaml(), {b.specYaml(0), b.specYaml(1)}, b.parts, b.restWorlds()};
}

Character randomCharacter(std::mt19937& rng)
{
    CharacterBuilder b(rng);
    b.body();
    const bool twoArms = std::bernoulli_distribution(0.7)(rng);
    b.arm("L_", 1.0);
    if (twoArms) b.arm("R_", -1.0);
    b.eyes(std::bernoulli_distribution(0.7)(rng) ? 2 : 1);
    return {b.rigYaml(), b.specYaml(), {b.specYaml(0), b.specYaml(1)}, b.parts, b.restWorlds()};
}

struct FamilyCounts {
    int chains = 0, aims = 0, shares = 0, oriented = 0, orientedChains = 0;
};

// Planar chains read an IK goal (those turning as another output counted apart too), aims are planar chains whose
// goal is the eye target, twist shares, oriented bases.
FamilyCounts familyCounts(const Approximation& a)
{
    FamilyCounts counts;
    for (const ConstraintBase& c : a.constraints) {
        if (c.kind == ConstraintKind::twistShare) ++counts.shares;
        else if (c.kind == ConstraintKind::oriented) ++counts.oriented;
        else if (c.kind == ConstraintKind::blend) continue;
        else if (a.outputs[static_cast<std::size_t>(c.goal)].name == "eye_target_ctrl") ++counts.aims;
        else {
            ++counts.chains;
            counts.orientedChains += c.orient >= 0 ? 1 : 0;
        }
    }
    return counts;
}

// The most an IK arm without stretch is straight in these worlds: 0 where one is (its goal at or past its reach, where
// moving the goal along the arm changes nothing), else the least of |shoulder-elbow| + |elbow-wrist| -
// |shoulder-wrist|.
double rigidArmSlack(const Approximation& a, const CharacterParts& parts, const std::vector<Eigen::Matrix4d>& worlds)
{
    double least = std::numeric_limits<double>::infinity();
    for (const std::string& side : parts.rigidIkSides) {
        const auto at = [&](const std::string& joint) -> Eigen::Vector3d {
            return worlds[static_cast<std::size_t>(test::outputIndex(a, side + joint))].block<3, 1>(0, 3);
        };
        const Eigen::Vector3d s = at("upperArm"), e = at("forearm"), h = at("hand");
        least = std::min(least, std::max(0.0, (e - s).norm() + (h - e).norm() - (h - s).norm()));
    }
    return least;
}

// A missed pose: whether the solve from rest left a rigid arm straight where the truth bends it.
bool straightenedRigidArm(const Approximation& a, const Solver& solver, RigBinding& binding,
                          const CharacterParts& parts, const std::vector<JointTarget>& targets)
{
    std::vector<Eigen::Matrix4d> truth, solved;
    for (const JointTarget& t : targets) truth.push_back(t.world);
    std::vector<double> values = a.defaults();
    solver.initialGuess(targets, values);
    solver.solve(targets, values);
    binding.evaluate(values, solved);
    return rigidArmSlack(a, parts, truth) > 1e-3 && rigidArmSlack(a, parts, solved) < 1e-6;
}

// The character's rig and spec written to `dir`, loaded as rig-learn loads them (helper frames found).
GraphRigFunction loadCharacter(const Character& character, const std::filesystem::path& dir, int index,
                               std::filesystem::path& rigFile)
{
    rigFile = test::writeFile(dir / fmt::format("character{}.yaml", index), character.rig);
    const InversionSpec spec =
        readInversionSpec(test::writeFile(dir / fmt::format("character{}.spec.yaml", index), character.spec));
    GraphRigOptions options{spec.params, spec.outputs, {}, spec.set, spec.ranges};
    options.autoHelpers = spec.autoHelpers;
    return GraphRigFunction(rigFile, options);
}

}  // namespace

TEST_CASE("random character: the generator's IK arms rest where their FK arms do")
{
    std::mt19937 rng(2028);
    const auto dir = test::scratchDir(fmt::format("random-character-rest.{}", ::getpid()));
    for (int c = 0; c < 8; ++c) {
        Character character = randomCharacter(rng);
        CAPTURE(character.parts.summary);
        std::array<std::vector<Eigen::Matrix4d>, 2> worlds;
        for (const int ikFk : {0, 1}) {
            character.spec = character.specAt[static_cast<std::size_t>(ikFk)];
            std::filesystem::path rigFile;
            GraphRigFunction rig = loadCharacter(character, dir, c * 2 + ikFk, rigFile);
            std::vector<double> rest;
            for (const RigParameter& p : rig.parameters()) rest.push_back(p.defaultValue);
            rig.evaluate(rest, worlds[static_cast<std::size_t>(ikFk)]);
        }
        REQUIRE(worlds[0].size() == worlds[1].size());
        double worst = 0.0;
        for (std::size_t k = 0; k < worlds[0].size(); ++k)
            worst = std::max(worst, (worlds[0][k] - worlds[1][k]).cwiseAbs().maxCoeff());
        // Equal up to the rounding of the file's nine digits through the IK (1e-6 measured).
        CHECK(worst < 1e-5);
    }
}

TEST_CASE(
    "random character: random production-style characters (IK and FK arms, poles, stretch, IK hands turned by their "
    "controls, aimed eyes, twist shares, shared spines, curled fingers) are learned within epsilon and their poses "
    "reached on the real rig")
{
    std::mt19937 rng(2028);
    const auto dir = test::scratchDir(fmt::format("random-character.{}", ::getpid()));
    const int characters = 10;
    // Poses on characters whose IK arms all stretch (or that have none), and on those with a rigid IK arm.
    int modelled = 0, withinEpsilon = 0, reached = 0, poses = 0, rigidReached = 0, rigidPoses = 0, straightened = 0;
    for (int c = 0; c < characters; ++c) {
        const Character character = randomCharacter(rng);
        CAPTURE(c);
        CAPTURE(character.parts.summary);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        std::vector<UnmodelledOutput> unmodelled;
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string(), &unmodelled);
        const FamilyCounts counts = familyCounts(a);
        MESSAGE("character " << c << ": " << character.parts.summary << "planar chains " << counts.chains << ", aims "
                             << counts.aims << ", twist shares " << counts.shares << "; unmodelled "
                             << unmodelled.size() << "; worst " << a.validation.maxRelativeError << " cm per unit ("
                             << a.validation.worstRelativeOutput << ")");
        for (const UnmodelledOutput& u : unmodelled) MESSAGE("  " << u.name << ": " << u.reason);
        withinEpsilon += a.validation.withinEpsilon ? 1 : 0;
        if (a.hasUnmodelledOutputs()) continue;
        ++modelled;
        // Every family as built: the IK arms' upper arm and forearm (and their hand, as a chain or relative to the
        // forearm), each eye, every forearm's roll joint (under an IK forearm, a share of the chain hand's twist).
        CHECK(counts.chains >= 2 * character.parts.ikArms);
        CHECK(counts.chains <= 3 * character.parts.ikArms);
        CHECK(counts.aims == character.parts.eyes);
        CHECK(counts.shares == character.parts.fkArms + character.parts.ikArms);
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        for (int pose = 0; pose < 6; ++pose) {
            const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.4));
            const double worst = test::solvedFromRest(a, solver, binding, targets);
            const bool rigid = !character.parts.rigidIkSides.empty(), hit = worst < 1e-3;
            if (!hit) {
                const bool straight = straightenedRigidArm(a, solver, binding, character.parts, targets);
                MESSAGE(
                    "  pose " << pose << " missed by " << worst << " cm"
                              << std::string(straight ? ", a rigid arm left straight where the truth bends it" : ""));
                straightened += straight ? 1 : 0;
            }
            (rigid ? rigidReached : reached) += hit ? 1 : 0;
            ++(rigid ? rigidPoses : poses);
        }
    }
    MESSAGE("random characters: " << withinEpsilon << " of " << characters << " within epsilon, " << modelled
                                  << " fully modelled; poses reached from rest on the real rig: " << reached << " of "
                                  << poses << " where every IK arm stretches, " << rigidReached << " of " << rigidPoses
                                  << " with a rigid IK arm (" << straightened
                                  << " of the misses a rigid arm left straight where the truth bends it)");
    // Measured (seed 2028, 10 characters, in 8 of them a hand orient-constrained to its IK control): 10 of 10
    // within epsilon, 10 of 10 fully modelled, every such hand a planar chain turning as its control, every forearm's
    // roll joint a twist share (under an IK forearm, of the hand's twist relative to the forearm, both planar chain
    // outputs); 30 of 30 poses reached where every IK arm stretches, 29 of 30 with a rigid one (the miss 0.0011 cm).
    // Before the orient input, those hands and their roll joints were left unmodelled (7 of 10 characters).
    // (Earlier, with hands turned by FK controls alone: character 1's
    // R_forearm was 0.00114 cm per unit off while the planar chain's shape stopped at a fifth of the rest reach,
    // docs/rig-learn.md.)
    // - With a rigid (no stretch) IK arm, before goal holds (GoalHold, docs/solver.md) 4 poses (3.4 to 15.5 cm) ended
    //   with the arm straight where the truth bends it: the solve took the goal past the chain's reach, where the shape
    //   is flat and no step brings it back. One more (0.029 cm, that arm straight in the truth too) was missed
    //   while the roll joints under IK forearms were left out of the outputs, and is reached with them.
    // - The roll joints under IK forearms were first learned as planar chains on the arm's goal and pole, 0.03 to 0.06
    //   cm per unit over epsilon: tried before the hand that drives them had its own chain, and checked only on what
    //   moves the chain's inputs. The learner now tries a chain over epsilon as a twist share again, its inputs
    //   constraint outputs too.
    CHECK(withinEpsilon == characters);
    CHECK(modelled == characters);
    CHECK(reached >= poses * 95 / 100);
    CHECK(rigidReached >= rigidPoses * 95 / 100);
    CHECK(straightened == 0);
}

TEST_CASE(
    "random character: with a restart every frame, each frame of a clip of random poses is the clip of that pose "
    "alone, "
    "bit for bit, with and without the hybrid solve")
{
    // A restart makes a frame independent of the frames before it: a chunk solves as the whole clip does, a cold frame
    // as it would alone. Before continuity shifts met only warm frames, each restart frame was shifted to meet the one
    // before: over 25 random poses of a creature, 24 frames were up to 720 degrees off their own clip's values and
    // rotation controls wound past 360 degrees (issue #45).
    std::mt19937 rng(45);
    const auto dir = test::scratchDir(fmt::format("random-character-restarts.{}", ::getpid()));
    const int characters = 3, poses = 10;
    int frames = 0, differing = 0;
    double furthest = 0.0;  // the largest rotation control, degrees from its rest value
    for (int c = 0; c < characters; ++c) {
        const Character character = randomCharacter(rng);
        CAPTURE(c);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string());
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        ClipTargets targets;
        for (int pose = 0; pose < poses; ++pose)
            targets.frames.push_back(test::realTargetsAt(a, binding, test::randomValues(a, rng, 1.0)));
        for (const bool hybridSolve : {false, true}) {
            CAPTURE(hybridSolve);
            HybridSolver hybrid(solver, binding, 1);
            ChainScratch scratch;
            ClipInversionOptions options;
            options.restartInterval = 1;
            if (hybridSolve)
                options.frameSolve = [&](std::span<const JointTarget> t, std::vector<double>& values,
                                         double previousCost, ChainFrame& frame) {
                    hybrid.solveFrame(t, values, previousCost, scratch, frame);
                };
            std::vector<std::vector<double>> whole, alone;
            invertClip(solver, binding, targets, 0, poses - 1, options, whole);
            for (int f = 0; f < poses; ++f) {
                CAPTURE(f);
                invertClip(solver, binding, targets, f, f, options, alone);
                REQUIRE(alone.size() == 1);
                const bool same = alone[0] == whole[static_cast<std::size_t>(f)];
                CHECK(same);
                differing += same ? 0 : 1;
                ++frames;
                for (std::size_t p = 0; p < a.parameters.size(); ++p)
                    if (rotationPeriod(a.parameters[p]) > 0.0)
                        furthest = std::max(furthest, std::abs(whole[static_cast<std::size_t>(f)][p] -
                                                               a.parameters[p].parameter.defaultValue) *
                                                          180.0 / std::numbers::pi);
            }
        }
    }
    MESSAGE("restart every frame: " << frames - differing << " of " << frames
                                    << " frames equal their own clip's, bit for bit; the furthest rotation control "
                                    << furthest << " degrees from rest");
    CHECK(furthest <= 360.0);
}

namespace {

// One construction of issue #46 on random characters: learned, and random poses of the real rig solved from rest.
struct ConstructionResult {
    int characters = 0, modelled = 0, withinEpsilon = 0, poses = 0, reached = 0;
    int oriented = 0, orientedChains = 0;  // the bases of outputs turning as another output, over the characters
    std::uint64_t evaluations = 0;         // the rig evaluations learning took, over the characters
    double restError = 0.0;
    double jacobianGap = 0.0;  // the analytic Jacobian's largest difference from central differences, relative
    double fileGap = 0.0;      // the largest difference of the worlds after a round trip through a file
};

// What the approximation's analytic Jacobian and its file must keep: central differences (relative to the largest
// entry) and the worlds read back, at random poses.
void checkJacobianAndFile(const Approximation& a, RigBinding& binding, std::mt19937& rng, ConstructionResult& r)
{
    const Approximation read = approximationFromYaml(approximationToYaml(a), "round trip");
    for (int pose = 0; pose < 3; ++pose) {
        const std::vector<double> values = test::randomValues(a, rng, 0.4);
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.4));
        JacobianEvaluator evaluator(a, targets, 10.0);
        Eigen::MatrixXd analytic, numeric;
        Eigen::VectorXd r1, r2;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, analytic, r1);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-5, numeric, r2);
        r.jacobianGap = std::max(
            r.jacobianGap, (analytic - numeric).cwiseAbs().maxCoeff() / std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        std::vector<Eigen::Matrix4d> worlds, again;
        a.evaluate(values, worlds);
        read.evaluate(values, again);
        for (std::size_t k = 0; k < worlds.size(); ++k)
            r.fileGap = std::max(r.fileGap, (worlds[k] - again[k]).cwiseAbs().maxCoeff());
    }
}

ConstructionResult learnAndSolve(Construction construction, unsigned seed, int characters, int posesEach)
{
    std::mt19937 rng(seed);
    const auto dir = test::scratchDir(fmt::format("random-character-legs.{}.{}", seed, ::getpid()));
    ConstructionResult r;
    for (int c = 0; c < characters; ++c) {
        const Character character = leggedCharacter(rng, construction);
        CAPTURE(c);
        CAPTURE(character.parts.summary);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        std::vector<double> defaults;
        for (const RigParameter& p : rig.parameters()) defaults.push_back(p.defaultValue);
        std::vector<Eigen::Matrix4d> rest;
        rig.evaluate(defaults, rest);
        for (std::size_t k = 0; k < character.rest.size(); ++k) {
            const double e = (rest[k] - character.rest[k]).cwiseAbs().maxCoeff();
            if (e > 1e-5) MESSAGE("  " << rig.outputs()[k] << " rests " << e << " from where the builder put it");
            r.restError = std::max(r.restError, e);
        }
        std::vector<UnmodelledOutput> unmodelled;
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string(), &unmodelled);
        const FamilyCounts counts = familyCounts(a);
        MESSAGE("character " << c << ": " << character.parts.summary << "planar chains " << counts.chains << " ("
                             << counts.orientedChains << " turning as another output), oriented bases "
                             << counts.oriented << ", twist shares " << counts.shares << "; unmodelled "
                             << unmodelled.size() << "; worst " << a.validation.maxRelativeError << " cm per unit ("
                             << a.validation.worstRelativeOutput << ")");
        for (const UnmodelledOutput& u : unmodelled) MESSAGE("  " << u.name << ": " << u.reason);
        ++r.characters;
        r.evaluations += a.training.evaluations;
        r.withinEpsilon += a.validation.withinEpsilon ? 1 : 0;
        if (a.hasUnmodelledOutputs()) continue;
        ++r.modelled;
        r.oriented += counts.oriented;
        r.orientedChains += counts.orientedChains;
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        // Poses from their own stream: a character's draws do not depend on whether the one before was modelled.
        std::mt19937 poseRng(seed * 31u + static_cast<unsigned>(c));
        checkJacobianAndFile(a, binding, poseRng, r);
        for (int pose = 0; pose < posesEach; ++pose) {
            const std::vector<JointTarget> targets =
                test::realTargetsAt(a, binding, test::randomValues(a, poseRng, 0.4));
            const double worst = test::solvedFromRest(a, solver, binding, targets);
            if (worst >= 1e-3) MESSAGE("  pose " << pose << " missed by " << worst << " cm");
            r.reached += worst < 1e-3 ? 1 : 0;
            ++r.poses;
        }
    }
    MESSAGE(r.withinEpsilon << " of " << r.characters << " within epsilon, " << r.modelled
                            << " fully modelled; poses reached from rest on the real rig: " << r.reached << " of "
                            << r.poses << "; " << r.evaluations << " training evaluations; rest " << r.restError
                            << " from the builder's; analytic Jacobian " << r.jacobianGap
                            << " from central differences, worlds " << r.fileGap << " off after a file");
    return r;
}

// Each construction on three random characters (or `characters`), 8 random poses each solved from rest on the real
// rig: every output modelled within epsilon, 95% of the poses reached within 1e-3 cm (issue #46's goal).
ConstructionResult expectAll(Construction construction, unsigned seed, int characters = 3)
{
    const ConstructionResult r = learnAndSolve(construction, seed, characters, 8);
    CHECK(r.restError < 1e-5);
    CHECK(r.withinEpsilon == r.characters);
    CHECK(r.modelled == r.characters);
    CHECK(r.reached * 100 >= r.poses * 95);
    CHECK(r.jacobianGap < 1e-5);
    CHECK(r.fileGap < 1e-9);
    return r;
}

}  // namespace

TEST_CASE("random character: production leg constructions of Maya rigs (issue #46) learned and solved on the real rig")
{
    // Measured: reverse feet 3 of 3 modelled, 24 of 24 poses; three bones 3 of 3, 24 of 24; spaces 3 of 3, 24 of 24;
    // FK/IK blends through parent and orient constraints (held at IK) 3 of 3, 24 of 24. Every analytic Jacobian within
    // 2e-9 of central differences, every file read back to the same worlds.
    // Before poles turned by a helper (poleTurns), every mayaIkHandle leg without a pole control was left unmodelled
    // (its pole vector turns with the foot), and a three-bone chain's side was no rest plane. While any moved helper
    // could carry a pole, the blended legs' thighs and knees were left unmodelled (36.8 and 10.6 cm per unit): a pole
    // turned by the IK control passed the fit's poses, which never turn it, and not the validation, which does.
    SUBCASE("reverse foot")
    {
        expectAll(Construction::reverseFoot, 4601);
        // On 8 more characters (seed 4701) 8 of 8 modelled and 64 of 64 poses reached (about 5 s), with 57634 training
        // evaluations. Before a roll's flat stretch inside its range (heel keyed below 0, toe above 5) broke the
        // curves at its ends (CubicSpline breaks), 60 of 64 (the misses 0.0014 to 0.215 cm, one character's
        // driven-key roll near the kinks its natural spline rounded) with 59950.
        expectAll(Construction::reverseFoot, 4701, 8);
    }
    SUBCASE("three bones under one IK") { expectAll(Construction::threeBones, 4603); }
    SUBCASE("space switch") { expectAll(Construction::spaceSwitch, 4606); }
    SUBCASE("FK/IK blend through constraints") { expectAll(Construction::constraintBlend, 4605); }
    SUBCASE("ikSCsolver chains: one-bone ankles and balls, two-bone legs")
    {
        // Measured: 3 of 3 modelled (the SC legs' thighs, knees and ankles planar chains on the rest plane turned
        // minimally, the one-bone SC ankles and balls carried by their parent and turned minimally onto their
        // handles), worst 3.7e-6 cm per unit; 24 of 24 poses reached; the analytic Jacobian within 4.3e-10 of central
        // differences. On 8 more characters (seed 4707, every goal kind drawn: own controls, the toe pivot, the foot
        // control) 8 of 8 modelled, worst 6.7e-6 cm per unit, and 62 of 64 poses reached (the run takes 12 s; 64 while
        // the guess solved a step again for any parameter of a free step that moves the constraint's inputs, not only
        // the free ones, which made the spider scene's guess solve its body's first step again with every leg).
        // Before the initial guess solved again the foot control's rotate and rolls with a ball or ankle aimed at a
        // goal under it (docs/solver.md, cold starts), 23 of 24 here (the miss 2.76 cm) and 57 of 64 on seed 4707
        // (57 of 64 on 8 characters of seed 4607): the 7 misses, 0.15 to 10.4 cm, were solves from rest stuck from
        // guesses 100 to 670 in cost, where the leg's step had left the foot turned at random (its rotate moves no
        // SC thigh) and the ball's chain placement had moved the foot control off the leg's targets (up to 19 cm at
        // the ankle).
        // Before the minimal turn, every SC leg's joints (and the foot below them) and every one-bone SC ankle or
        // ball were unmodelled, 0 of 3 characters: the closest constraints, planar chains on the rest plane or a
        // pole fixed to the pelvis, 0.13 to 0.42 cm per unit off on the legs, and planar chains on the handles 0.07
        // to 0.17 cm per unit off on the ankles and balls.
        const ConstructionResult r = expectAll(Construction::singleChain, 4607);
        CHECK(r.reached == r.poses);
        expectAll(Construction::singleChain, 4707, 8);
    }
    SUBCASE("ankles and balls orient-constrained to the foot or a pivot")
    {
        // Measured: 3 of 3 modelled, 4 ankles planar chains turning as their foot's goal; 24 of 24 poses reached. On 8
        // more characters (seed 4702) 8 of 8 modelled, 3 balls orient-constrained under an FK ankle oriented bases, and
        // 64 of 64 poses reached (about 5 s), with 53686 training evaluations. Before the curves broke at the ends of a
        // roll's flat stretch, 58 of 64 with 59118: the 6 misses, of 0.001 to 0.019 cm on one character, were where the
        // solve moved a driven-key roll near its keys' kink, which the sampled curve rounded; and here an FK ball (not
        // constrained) under an ankle turned by such a roll was an oriented base, where it is now relative to its
        // ankle (the simplest frame, validated; that character's learning 4341 evaluations instead of 5344). Before
        // the initial guess placed a goal whose control also moves the foot an orient constraint reads (pole_hold.h,
        // placeChain), it left the foot control where the thigh's target alone put it, up to 16 cm low, and the solves
        // from there stuck: 22 of 24 (19.0 and 12.0 cm), 54 of 64 on seed 4702 (4 of them 5 to 12 cm). Before the
        // oriented base, a ball orient-constrained under an FK ankle was left unmodelled (and, with the generator's
        // constraint writing angles in another rotate order than the ball's, it was no orient at all).
        const ConstructionResult r = expectAll(Construction::orientEnd, 4602);
        CHECK(r.orientedChains >= 3);
        const ConstructionResult more = expectAll(Construction::orientEnd, 4702, 8);
        CHECK(more.oriented >= 1);
    }
}

}  // namespace rig
