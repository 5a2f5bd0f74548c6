#pragma once
// A Maya scene read with its references (docs/maya.md): `file -r` resolved as written, then by each suffix of the
// written path under the scene's folder and its parents, then under the search path; each referenced file read under
// its namespace, nested references too; the reference nodes' edits (dataReferenceEdits: setAttr, connectAttr,
// disconnectAttr, parent, and the placeholder list through which an animation scene drives the rig's controls)
// applied; the playback range read from the scene's configuration script.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "graph/maya/ma_scene.h"

namespace rig::maya {

struct ReadResult {
    std::vector<std::filesystem::path> files;    // the scene, then each reference read
    std::vector<std::string> missingNamespaces;  // references not found: connections into them are dropped
    // Per entry of Scene::references, the file read for it ("" where it was not found).
    std::vector<std::filesystem::path> referenceFiles;
};

// Throws rig::Error for a file that is not Maya ASCII (a binary .mb says so), a malformed statement or a reference
// that loops back to itself. A reference not found is one line in `warnings`.
ReadResult readSceneFile(Scene& scene, const std::filesystem::path& file,
                         const std::vector<std::filesystem::path>& searchPath, std::vector<std::string>& warnings);
ReadResult readSceneText(Scene& scene, std::string_view text, const std::string& fileName,
                         const std::vector<std::filesystem::path>& searchPath, std::vector<std::string>& warnings);

}  // namespace rig::maya
