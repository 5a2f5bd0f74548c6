#pragma once
// What a Maya scene holds beside its graph (docs/maya.md): its skin bindings, and the --stats lines.

#include <functional>
#include <string>

#include "graph/maya/ma_scene.h"
#include "graph/maya/maya_loader.h"

namespace rig::maya {

// Each skinCluster's influences (`graphName` of the joint connected into its `.matrix[i]`, "" where none is evaluated)
// and its bind-pre matrices (`.pm[i]`), into info.skins.
void readSkins(const Scene& scene, const std::function<std::string(int)>& graphName, MayaSceneInfo& info);

}  // namespace rig::maya
