#pragma once
// A Maya scene as a target clip (docs/clips.md): the scene's graph (graph/rig_file.h, references and their edits
// included) evaluated at each frame of its playback range, its joints' world matrices as the targets, in cm as every
// graph here is (the scene's own units are converted where it is read). What else the scene says is kept with the
// clip (TargetClip::scene): its units, frame rate and references (for writing curves back into a scene of the same
// rig, app/invert/maya_scene_output.h) and what its own time curves give the plugs they drive at each frame (for
// comparing an inversion's controls with the animator's).

#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "graph/graph.h"
#include "nodes/clips/target_clip.h"

namespace rig {

// Reads a Maya ASCII scene as a clip, the map applied as to any clip's joints. The frames are the whole frames of
// its playback range (playbackOptions -min -max); of the span of its time curves' keys where it has none; else its
// saved time; joints are named as the graph
// names them (a referenced rig's under its namespace: "hero:hips"). A scene without joints, or one the reader refuses
// (docs/maya.md), is a rig::Error in one line.
// `frames`, when given (first and last: rig-invert's --frames), extend the frames to reach them.
TargetClip readMayaClip(const std::filesystem::path& file, const TargetMap& map,
                        std::optional<std::pair<double, double>> frames = std::nullopt);

// The frames a clip of the scene plays (as readMayaClip reads it): the whole frames of its playback range, of its time
// curves' keys' span where it has none, else its saved time.
std::vector<double> sceneClipFrames(Graph& graph, const MayaSceneInfo& info, const std::string& file);

// `name` without the namespaces of its DAG components: "hero:grp|hero:hips" -> "grp|hips"; a plug's attribute
// ("hero:ctrl.rotateX" -> "ctrl.rotateX") has none.
std::string withoutNamespaces(std::string_view name);

// Renames each clip joint that is not one of `rigJoints` to the rig joint of the same name without namespaces, where
// exactly one rig joint has it: a scene that references the rig names its joints under the reference's namespace
// ("hero:hips" is the rig's "hips"), and a rig read from such a scene the other way round. Returns the number
// renamed.
int matchNamespaces(TargetClip& clip, std::span<const std::string> rigJoints);

}  // namespace rig
