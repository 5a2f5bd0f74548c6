#pragma once
// The one entry point for rig files (docs/maya.md): a Maya ASCII scene or a YAML rig, told apart by content (a Maya
// scene begins "//Maya ASCII"; a Maya binary one is refused in one line), not by suffix. The same kind of graph comes
// out of both: nothing downstream knows which file it was.

#include <filesystem>
#include <memory>
#include <vector>

#include "graph/graph.h"
#include "graph/maya/maya_loader.h"

namespace rig {

// Loads `file` as a Maya scene or a YAML rig; `filesRead` as loadGraphFile's (the scene and its references, or the
// rig and its includes). A Maya scene is evaluated at its saved time; `mayaInfo`, when given, receives what the scene
// holds beside its graph (cleared for a YAML rig).
std::unique_ptr<Graph> loadRigFile(const std::filesystem::path& file, std::shared_ptr<NodeRegistry> registry,
                                   std::vector<std::filesystem::path>* filesRead = nullptr,
                                   MayaSceneInfo* mayaInfo = nullptr, const MayaLoadOptions& mayaOptions = {});

// Whether `file` holds a Maya scene (ASCII or binary), from its first bytes; false when it cannot be read.
bool isMayaFile(const std::filesystem::path& file);

}  // namespace rig
