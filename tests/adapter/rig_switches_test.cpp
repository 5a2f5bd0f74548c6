// findSwitches (adapter/rig_switches.h): which parameters are animated switches (a blendColors blender driven through
// plain connections) and which outputs each one blends, from the rig's graph; one line for an output two switches
// blend.
#include <doctest/doctest.h>

#include <map>
#include <string>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "adapter/rig_switches.h"
#include "core/error.h"
#include "test_support.h"

using namespace rig;

namespace {

// Per switch's parameter name, the outputs it blends, in rig order.
std::map<std::string, std::vector<std::string>> blendedBy(GraphRigFunction& rig)
{
    const RigSwitches s = findSwitches(rig, "rig.yaml");
    std::map<std::string, std::vector<std::string>> out;
    for (const int p : s.switches) out[rig.parameters()[static_cast<std::size_t>(p)].name];
    for (std::size_t k = 0; k < rig.outputs().size(); ++k)
        if (const int p = s.switchOfOutput[k]; p >= 0)
            out[rig.parameters()[static_cast<std::size_t>(p)].name].push_back(rig.outputs()[k]);
    return out;
}

// A knee blended by `ikFk` through a relay's input (a plain connection), a foot by `space` through a reverse node.
const char* const relayedRig = R"(nodes:
  - {name: settings, type: transform, addAttr: [{name: ikFk, min: 0, max: 1, keyable: true},
                                                {name: space, min: 0, max: 1, keyable: true},
                                                {name: free, keyable: true}]}
  - {name: relay, type: transform, addAttr: [{name: w, min: 0, max: 1, keyable: true}]}
  - {name: a_ctrl, type: transform}
  - {name: b_ctrl, type: transform}
  - {name: flip, type: reverse}
  - {name: knee_switch, type: blendColors}
  - {name: foot_switch, type: blendColors, color1: [0, -40, 0], color2: [0, -50, 0]}
  - {name: hip, type: joint}
  - {name: knee, type: joint, parent: hip, translate: [0, -40, 0]}
  - {name: foot, type: joint, parent: knee}
connections:
  - settings.ikFk -> relay.w
  - relay.w -> knee_switch.blender
  - a_ctrl.rotate -> knee_switch.color1
  - b_ctrl.rotate -> knee_switch.color2
  - knee_switch.output -> knee.rotate
  - settings.space -> flip.inputX
  - flip.outputX -> foot_switch.blender
  - foot_switch.output -> foot.translate
)";

}  // namespace

TEST_CASE("switches: the biped's ikFk parameters blend their own leg's thigh, knee and foot, and no other control")
{
    const InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs/biped_inversion_ikfk.yaml");
    GraphRigFunction rig(test::sourceDir() / "rigs/biped.yaml", {spec.params, spec.outputs, {}, spec.set});
    // The FK controls feed the same blendColors nodes (their colors), the hips and feet controls feed the legs too:
    // only what drives a blender is a switch.
    CHECK(blendedBy(rig) == std::map<std::string, std::vector<std::string>>{
                                {"L_leg_settings.ikFk", {"LeftUpLeg", "LeftLeg", "LeftFoot"}},
                                {"R_leg_settings.ikFk", {"RightUpLeg", "RightLeg", "RightFoot"}}});

    // The IK spec holds the switches: no parameter is one.
    const InversionSpec ik = readInversionSpec(test::sourceDir() / "rigs/biped_inversion_ik.yaml");
    GraphRigFunction held(test::sourceDir() / "rigs/biped.yaml", {ik.params, ik.outputs, {}, ik.set});
    CHECK(blendedBy(held).empty());
}

TEST_CASE("switches: a blender driven through a plain connection is a switch's, through a node's output it is not")
{
    const auto file = test::writeFile(test::scratchDir("rig-switches") / "relayed.yaml", relayedRig);
    GraphRigFunction rig(file, {{"a_ctrl.rotate?", "b_ctrl.rotate?", "settings.ikFk", "settings.space"}, {}, {}, {}});
    CHECK(blendedBy(rig) == std::map<std::string, std::vector<std::string>>{{"settings.ikFk", {"knee"}}});
}

TEST_CASE("switches: an output two switches blend is one line naming both")
{
    const auto file = test::sourceDir() / "tests/corpus/rigs/learn_two_switches.yaml";
    GraphRigFunction rig(file, {{"a_ctrl.rotate?", "b_ctrl.rotate?", "settings.ikFk", "settings.space"}, {}, {}, {}});
    std::string message;
    try {
        findSwitches(rig, "two.yaml");
    }
    catch (const Error& e) {
        message = e.what();
        CHECK(e.kind() == ErrorKind::userInput);
    }
    CHECK(message ==
          "two.yaml: output 'knee' is blended by two switches, settings.ikFk and settings.space; rig-learn blends an "
          "output by one switch: hold the other with the spec's `set:` (or --set)");
    // One of them held: the other blends the knee.
    GraphRigFunction one(file,
                         {{"a_ctrl.rotate?", "b_ctrl.rotate?", "settings.ikFk"}, {}, {}, {{"settings.space", 1}}});
    CHECK(blendedBy(one) == std::map<std::string, std::vector<std::string>>{{"settings.ikFk", {"knee"}}});
}

TEST_CASE("switches: a switch not limited to [0, 1] is one line saying how to limit or hold it")
{
    // settings.free drives the knee's blender in place of settings.ikFk: a parameter without limits.
    std::string text = relayedRig;
    const std::string from = "  - settings.ikFk -> relay.w\n";
    text.replace(text.find(from), from.size(), "  - settings.free -> relay.w\n");
    const auto file = test::writeFile(test::scratchDir("rig-switches") / "free.yaml", text);
    GraphRigFunction rig(file, {{"a_ctrl.rotate?", "b_ctrl.rotate?", "settings.free"}, {}, {}, {}});
    std::string message;
    try {
        findSwitches(rig, "free.yaml");
    }
    catch (const Error& e) {
        message = e.what();
        CHECK(e.kind() == ErrorKind::userInput);
    }
    CHECK(message ==
          "free.yaml: switch 'settings.free' (it drives a blendColors blender) is not limited to [0, 1]; give its "
          "attribute min 0 and max 1, or hold it with the spec's `set:` (or --set)");
}
