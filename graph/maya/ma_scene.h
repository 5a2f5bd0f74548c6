#pragma once
// A Maya ASCII scene as its statements describe it (docs/maya.md), before any evaluation: nodes with their type, DAG
// parent and attribute edits, connections, references, units and the playback range. createNode, setAttr, addAttr,
// connectAttr, disconnectAttr, parent, rename, select -ne, lockNode, file, requires, fileInfo and currentUnit are read;
// relationship, dataStructure and the other statements Maya writes that say nothing about evaluation are counted by
// name and skipped.

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "graph/maya/ma_parser.h"

namespace rig::maya {

// Where a statement is: a file of Scene::files and a line and column in it.
struct Where {
    int file = 0;
    int line = 0;
    int column = 0;
};

struct SetAttr {
    std::string plug;          // as written: ".t", ".tg[0].tot", ".ktv[0:5]" (relative to the node)
    std::vector<Word> values;  // the value words, flags removed
    std::string type;          // -type: double3, matrix, string, ...; empty for plain numbers
    int size = -1;             // -s
    std::optional<bool> keyable, locked, channelBox;
    Where where;
};

struct AddAttr {
    std::string longName, shortName, attributeType, dataType, parent, enumNames;
    std::optional<double> defaultValue, min, max, softMin, softMax;
    bool keyable = false;
    bool multi = false;
    bool hidden = false;
    Where where;
};

struct Node {
    std::string name;  // the leaf name with its namespace ("ns:L_arm_ctrl")
    std::string type;  // Maya's type
    int parent = -1;   // the DAG parent, an index into Scene::nodes
    bool shared = false;
    bool locked = false;
    std::vector<SetAttr> sets;
    std::vector<AddAttr> adds;
    Where where;
};

struct Connection {
    std::string source, destination;  // "node.attr" as written (node names resolved when the graph is built)
    bool nextAvailable = false;       // -na
    Where where;
};

struct Reference {
    std::string path;       // as written
    std::string nameSpace;  // -ns
    std::string node;       // -rfn: the reference node holding the edits
    Where where;
};

struct Units {
    double linearToCm = 1.0;        // currentUnit -l
    double angleToDegrees = 1.0;    // currentUnit -a
    double framesPerSecond = 24.0;  // currentUnit -t (film)
    std::string linear = "centimeter", angle = "degree", time = "film";
};

class Scene {
public:
    std::vector<std::string> files;  // files[0] is the scene; references are appended as they are read
    std::vector<Units> units;        // each file's currentUnit (its setAttr values are in them), as `files`
    std::vector<Node> nodes;
    std::vector<Connection> connections;
    std::vector<Connection> disconnections;  // from reference edits, applied after connections
    std::vector<Reference> references;
    std::optional<std::pair<double, double>> playbackRange;  // playbackOptions -min -max
    std::map<std::string, std::string> fileInfo;
    std::map<std::string, int> skipped;  // statements (and reference edits) skipped, by name

    // The node a name in the file refers to: a leaf name ("ctrl", "ns:ctrl"), a DAG path ("|grp|ctrl" or
    // "grp|ctrl") or a root-namespace name (":time1"). -1 when there is none; throws rig::Error when a leaf name
    // names several nodes (the message says to write the DAG path).
    int find(std::string_view name) const;
    // The node's DAG path from the world: "|grp|ctrl".
    std::string path(int node) const;
    // Adds a node (a createNode, a shared node first selected by `select -ne`). Throws for a name taken at the same
    // DAG level.
    int add(Node node);
    void rename(int node, std::string newName);
    void reparent(int node, int parent) { nodes[static_cast<std::size_t>(node)].parent = parent; }

private:
    std::unordered_multimap<std::string, int> byLeaf_;
};

// "file:line:col" of a statement.
std::string formatWhere(const Scene& scene, const Where& where);

// Reads the statements of file `fileIndex` (its name and default units already pushed by the caller) into `scene`.
// `nameSpace`, when not empty, prefixes every node name the statements create (a reference's namespace). Throws
// rig::Error "file:line:col: ..." for anything malformed.
void readStatements(Scene& scene, const std::vector<Statement>& statements, int fileIndex,
                    const std::string& nameSpace);

// Maya's plug text split: "node.attr[0].child" -> ("node", "attr[0].child"). The node part may hold '|' and ':'.
std::pair<std::string, std::string> splitPlug(std::string_view plug);

}  // namespace rig::maya
