#pragma once
// Maya ASCII scenes as graphs (docs/maya.md): the nodes this library evaluates become graph nodes under the names Maya
// shows (a unique leaf name, otherwise the shortest unique DAG path), with Maya's attribute names mapped to ours,
// DAG parenting wired as connections, IK handles wired to the joints their solver writes, references read with their
// namespaces and edits. Nodes that move no joint (shapes, shading, deformers, cameras) are kept out of the graph and
// counted; a node this library does not evaluate that drives a joint is refused in one line.

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "graph/graph.h"

namespace rig {

struct MayaLoadOptions {
    // Folders where references not found beside the scene are looked for (--search-path).
    std::vector<std::filesystem::path> searchPath;
};

// What a Maya scene holds beside its graph: its time, the values Maya saved (the test oracle), the skin bindings,
// and what was skipped.
struct MayaSceneInfo {
    double savedTime = 0.0;  // time1.outTime: the frame the scene was saved at
    std::optional<std::pair<double, double>> playbackRange;
    double framesPerSecond = 24.0;
    // The scene's own units (its currentUnit), as Maya names them: what its values are written in.
    std::string linearUnit = "centimeter", angularUnit = "degree", timeUnit = "film";
    double linearToCm = 1.0, angleToDegrees = 1.0;  // their factors
    // The references the scene itself makes (not those of the files it references).
    struct Reference {
        std::string path;            // as written
        std::filesystem::path file;  // the file read for it; empty where it was not found
        std::string nameSpace;       // -ns
        std::string node;            // -rfn: the reference node
    };
    std::vector<Reference> references;
    // Each connection out of a time curve (animCurveTA/TL/TU/TT): the curves an animator keyed.
    struct TimeCurve {
        std::string curve;  // the curve node's name with its namespace ("hero:L_arm_ctrl_rotateX")
        // The connection as a disconnectAttr names it: node paths from the world, attributes as the file spelled them.
        std::string source, destination;
        // The graph's plug the curve drives, directly or through a unitConversion ("L_arm_ctrl.rotateX"); "" where it
        // drives none (a character set, a node kept out of the graph).
        std::string plug;
    };
    std::vector<TimeCurve> timeCurves;
    // The rotate (degrees, in the joint's rotate order) Maya saved on each joint an IK solver writes: Maya's answer at
    // savedTime.
    std::map<std::string, Eigen::Vector3d> savedIkRotate;
    struct Skin {
        std::string name;
        std::vector<std::string> influences;         // graph node names, by influence index (empty: not evaluated)
        std::vector<Eigen::Matrix4d> bindPreMatrix;  // by influence index: the inverse of its world matrix at bind
    };
    std::vector<Skin> skins;
    // The channel-box state the scene gave plugs (setAttr -k, -l, -cb), by plug name as the graph names it: which
    // channels an animator keys (keyable, unlocked) and sees (in the channel box).
    struct PlugState {
        std::optional<bool> keyable, locked, channelBox;
    };
    std::map<std::string, PlugState> plugStates;
    // The graph nodes with a nurbsCurve shape (an animator's controls), in scene order (rig-learn --params auto).
    std::vector<std::string> controls;
    std::vector<std::string> warnings;                  // one line each (a missing reference)
    std::map<std::string, int> skippedStatements;       // by command
    std::map<std::string, int> notEvaluatedTypes;       // nodes kept out of the graph, by Maya type
    std::map<std::string, int> notEvaluatedAttributes;  // "type.attribute" set or connected but not evaluated
    int vectorConversions = 0;  // unitConversion nodes between vectors, made multiplyDivide nodes
    int nodes = 0;              // graph nodes made
    int connections = 0;        // graph connections made
};

// The --stats lines of a Maya scene: what was made, the nodes kept out of the graph by type, the statements skipped
// and the attributes not evaluated, most frequent first.
std::string mayaStatsText(const MayaSceneInfo& info);

// Whether `text` is the beginning of a Maya ASCII file ("//Maya ASCII").
bool isMayaAscii(std::string_view text);
// Whether it is a Maya binary file (an IFF "FOR4"/"FOR8" header).
bool isMayaBinary(std::string_view text);

// Loads a Maya ASCII scene. Throws rig::Error "file:line:col: ..." for anything malformed or not evaluated that drives
// a joint. `filesRead` receives the scene and every reference read.
std::unique_ptr<Graph> loadMayaFile(const std::filesystem::path& file, std::shared_ptr<NodeRegistry> registry,
                                    std::vector<std::filesystem::path>* filesRead = nullptr,
                                    MayaSceneInfo* info = nullptr, const MayaLoadOptions& options = {});
std::unique_ptr<Graph> loadMayaText(std::string_view text, const std::string& fileName,
                                    std::shared_ptr<NodeRegistry> registry, MayaSceneInfo* info = nullptr,
                                    const MayaLoadOptions& options = {});

}  // namespace rig
