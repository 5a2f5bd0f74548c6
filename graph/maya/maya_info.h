#pragma once
// What a Maya scene holds beside its graph (docs/maya.md): its skin bindings, its controls, and the --stats lines.

#include <functional>
#include <string>

#include "graph/maya/ma_scene.h"
#include "graph/maya/maya_loader.h"

namespace rig::maya {

// Each skinCluster's influences (`graphName` of the joint connected into its `.matrix[i]`, "" where none is evaluated)
// and its bind-pre matrices (`.pm[i]`), into info.skins.
void readSkins(const Scene& scene, const std::function<std::string(int)>& graphName, MayaSceneInfo& info);

// The graph nodes an animator picks in the viewport: each transform or joint with a nurbsCurve shape (not an
// intermediate object) under it, by `graphName`, in scene order, into info.controls.
void readControls(const Scene& scene, const std::function<std::string(int)>& graphName, MayaSceneInfo& info);

}  // namespace rig::maya
