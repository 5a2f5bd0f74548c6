#pragma once
// Curves as a Maya ASCII scene that references the rig's scene (docs/rig-invert.md): what rig-invert -o OUT.ma
// writes, so that an animator opens it in Maya and keeps working. The file holds
//
//   file -rdi 1 -ns "hero" -rfn "heroRN" "rigs/hero.ma";       the rig, referenced under a namespace
//   file -r -ns "hero" -rfn "heroRN" "rigs/hero.ma";
//   requires maya "2018";
//   currentUnit -l centimeter -a degree -t film;                the rig scene's units, the clip's frame rate
//   createNode reference -n "heroRN";                           its edits, as Maya writes them:
//       4 "hero:L_arm_ctrl_rotateX.o" "|hero:grp|hero:L_arm_ctrl.rx" ""     the rig's own curve disconnected
//       2 "hero:settings" "ikFk" " 1"                                       a plug the curves need held
//       5 4 "heroRN" "hero:L_arm_ctrl.rotateX" "heroRN.placeHolderList[1]" ""
//   createNode animCurveTA -n "L_arm_ctrl_rotateX";             a curve per control, keys in the file's units
//   createNode script -n "sceneConfigurationScriptNode";        the playback range: the keys' frames
//   connectAttr "L_arm_ctrl_rotateX.o" "heroRN.phl[1]";         the curve into the control, through the placeholder
//
// and graph-eval reads it back as any scene (graph/maya/).

#include <string>
#include <vector>

#include "graph/maya/maya_loader.h"
#include "nodes/curves/anim_file.h"

namespace rig {

// A plug set as a reference edit: one the curves need held (a mode switch the approximation was learned in).
struct MayaHeldPlug {
    std::string node;       // as the rig's graph names it
    std::string attribute;  // "ikFk", "rotateX"
    AnimQuantity quantity = AnimQuantity::unitless;
    double value = 0.0;  // cm, degrees or unitless
};

struct MayaAnimScene {
    std::string fileName;       // the scene's own name, for its header
    std::string rigPath;        // the rig scene, as the reference writes it
    std::string nameSpace;      // the rig's namespace
    std::string referenceNode;  // the reference node ("heroRN")
    // The rig scene's units and time curves (MayaSceneInfo of the rig): the values are written in its units, and its
    // own time curves on the curves' plugs are disconnected.
    MayaSceneInfo rig;
    std::string timeUnit;  // the frame rate the key times count (Maya's name: film, ntsc, ...)
    // One curve per control: `node` as the rig's graph names it ("grp|ctrl"), keys in frames and cm or degrees.
    std::vector<AnimFileCurve> curves;
    std::vector<MayaHeldPlug> held;
};

// The scene's text. The playback range is the first curve's keys'.
std::string formatMayaAnimScene(const MayaAnimScene& scene);

// A Maya name made of any text (a file's name): letters, digits and '_', not starting with a digit.
std::string mayaName(const std::string& text);

}  // namespace rig
