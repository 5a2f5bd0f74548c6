#pragma once
// graph-eval --html: the report page of a crowd played by graph-eval (docs/keys-anim-report.md, "The crowd
// page"; docs/crowds.md). Each rigInversion node of the graph is a character: the real rig it drives (the
// approximation's outputs, as joints of the graph named with the namespace its parameters' plugs have, driven
// by the solved controls), the edited targets it was asked for (its connected target[k], scaled to cm by its map
// file), its status and worst error per frame, and the point its lookAt nodes aim at (a marker). The page shows
// one character beside its targets, or the whole crowd from above, with a switch and a character chooser; its
// frame, three.js and status are app/report/report_page.h's (#status adds "characters", "mode" and "character").

#include <string>
#include <vector>

#include "app/common/value_output.h"
#include "graph/graph.h"

namespace rig::app {

class CrowdReport {
public:
    // The characters of `graph` (evaluated at least once, so that each inverter knows its approximation);
    // `rigName` names the rig file in errors. rig::Error when the graph has no rigInversion node, or one whose
    // parameters drive no rig of this graph.
    CrowdReport(Graph& graph, std::string rigName);

    // graph-eval --character: the page opens on this character (its name, e.g. c0001, or its inverter's node
    // name) instead of the crowd; rig::Error naming the characters when there is none of that name.
    void open(const std::string& character);

    // Reads the frame's values; the graph's scene time is already `frame` (graph-eval's loop has evaluated it).
    void record(Graph& graph, double frame);

    // The page, with the frames recorded.
    std::string page(const std::string& title, const std::string& threeJs) const;

private:
    struct Character {
        std::string name;      // the namespace of its rig (c0001), or its inverter's name without one
        std::string inverter;  // the rigInversion node
        std::vector<std::string> joints;
        std::vector<int> parents;
        std::vector<int> targetPlug;  // per joint: its target's index in plugs_, or -1 without one
        std::size_t firstJointPlug = 0, statusPlug = 0, worstPlug = 0;
        double scale = 1.0;  // the map file's: targets to cm
        int marker = -1;
        Json rig = Json::array(), target = Json::array(), status = Json::array(), worst = Json::array();
    };
    struct Marker {
        std::string name;  // the plug the lookAt's target comes from
        std::size_t plug = 0;
        double scale = 1.0;  // its first character's
        Json positions = Json::array();
    };

    Character character(Graph& graph, NodeId inverter);
    int marker(const Graph& graph, const Character& c, NodeId inverter);
    Json characterJson(const Character& c) const;

    std::string rigName_;
    std::vector<Plug> plugs_;
    std::vector<Character> characters_;
    std::vector<Marker> markers_;
    std::vector<std::string> statusNames_;
    Json frames_ = Json::array();
    int opened_ = -1;  // the character the page opens on; -1: the crowd
};

}  // namespace rig::app
