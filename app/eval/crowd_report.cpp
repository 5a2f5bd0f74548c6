#include "app/eval/crowd_report.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "app/eval/eval_run.h"
#include "app/report/report_page.h"
#include "core/error.h"
#include "graph/suggest.h"
#include "nodes/clips/target_clip.h"

namespace rig::app {
namespace {

// The page's own style: the mode switch, the chosen character's figures and the crowd's table.
constexpr std::string_view pageStyle = R"page(#modes button.on { background: #3d6fd6; color: #fff; }
#figures { margin: 4px 0; line-height: 1.5; }
#table { flex: 1; overflow-y: auto; border-top: 1px solid #333; }
#table table { border-collapse: collapse; width: 100%; font-variant-numeric: tabular-nums; }
#table td, #table th { padding: 1px 6px; text-align: right; }
#table td:first-child, #table th:first-child { text-align: left; }
#table tr.chosen { background: #2b3346; }
#table tr { cursor: pointer; }
)page";

// The page's elements, above the controls every page has (app/report/report_page.h).
constexpr std::string_view pageElements = R"page(<header id="summary"></header>
<div id="main">
  <div id="view"><div id="legend"></div></div>
  <div id="side">
    <div id="modes"><button id="mode-character">One character</button>
      <button id="mode-crowd">The crowd from above</button></div>
    <select id="character"></select>
    <div id="figures"></div>
    <div id="table"></div>
  </div>
</div>
)page";

// The page's script (drawing with ReportKit).
constexpr std::string_view pageScript = R"page(<script>
(function () {
  'use strict';
  var kit = window.ReportKit, $ = kit.$, fmt = kit.fmt, esc = kit.esc;
  var data = kit.data();
  var n = data.frames.length, chars = data.characters;
  var status = kit.status({frames: n, characters: chars.length, mode: '', character: ''});

  // The markers in cm (their characters' map scale), and each character's real-rig error per joint and frame.
  var markers = data.markers.map(function (m) {
    return m.positions.map(function (p) { return [p[0] * m.scale, p[1] * m.scale, p[2] * m.scale]; });
  });
  function errors(c, f) {
    var r = c.rig[f], t = c.target[f], out = [];
    for (var j = 0; j < c.joints.length; ++j) {
      var k = 3 * j;
      out.push(t[k] === null || r[k] === null ? null
               : Math.hypot(r[k] - t[k], r[k + 1] - t[k + 1], r[k + 2] - t[k + 2]));
    }
    return out;
  }
  chars.forEach(function (c) {
    c.rigWorst = 0;
    for (var f = 0; f < n; ++f)
      errors(c, f).forEach(function (e) { if (e !== null) c.rigWorst = Math.max(c.rigWorst, e); });
  });
  var scale = Math.max(1e-6, Math.max.apply(null, chars.map(function (c) { return c.rigWorst; })));
  $('summary').innerHTML = '<b>' + esc(data.title) + '</b>: ' + chars.length + ' characters, ' + n +
      ' frames (' + data.frames[0] + ' to ' + data.frames[n - 1] + '); real rigs against their edited targets: ' +
      'worst ' + fmt(scale, 3) + ' cm';
  $('legend').innerHTML = 'joint error 0<span></span>' + fmt(scale, 2) + ' cm';

  // From above, the characters fill the view: the look-at target may be far off (a camera), where framing it too left
  // them a few percent of the view; its gaze lines run out of the view towards it.
  var crowdBox = kit.box(chars.reduce(function (all, c) { return all.concat(c.rig); }, []));
  var view = kit.view($('view'), crowdBox, function () { show(current); });
  var boxes = chars.map(function (c) { return kit.box(c.rig.concat(c.target)); });
  var height = Math.max(1, kit.box(chars[0].rig).getSize(new THREE.Vector3()).y);
  chars.forEach(function (c) {
    c.rigJoints = kit.joints(view.scene, c.joints.length, height * 0.012, 0xffffff);
    c.rigBones = kit.bones(view.scene, c.parents, 0xf0f0f0);
    c.targetJoints = kit.joints(view.scene, c.joints.length, height * 0.008, 0x8a96aa);
    c.targetBones = kit.bones(view.scene, c.parents, 0x5f6b80);
  });
  var markerMeshes = markers.map(function () { return kit.joints(view.scene, 1, height * 0.03, 0xffdc00)[0]; });
  // One character's gaze: a line from its highest joint (a standing biped's head) to its marker, which may be
  // out of the view.
  var gaze = kit.bones(view.scene, [-1, 0], 0xffdc00);

  var mode = data.open >= 0 ? 'character' : 'crowd', chosen = Math.max(0, data.open);
  var select = $('character');
  chars.forEach(function (c, i) {
    var option = document.createElement('option');
    option.value = i;
    option.textContent = c.name;
    select.appendChild(option);
  });
  function counts(c) {
    return data.status_names.filter(function (s) { return c.status_counts[s]; }).map(function (s) {
      return s + ' ' + c.status_counts[s];
    }).join(', ');
  }
  var rows = chars.map(function (c, i) {
    return '<tr data-i="' + i + '"><td>' + esc(c.name) + '</td><td>' + esc(counts(c)) + '</td><td>' +
        fmt(c.worst_error_cm, 3) + '</td><td>' + fmt(c.rigWorst, 3) + '</td></tr>';
  });
  $('table').innerHTML = '<table><tr><th>character</th><th>frames by status</th><th>worst cm</th>' +
      '<th>real rig cm</th></tr>' + rows.join('') + '</table>';
  $('table').addEventListener('click', function (e) {
    var row = e.target.closest('tr[data-i]');
    if (row) choose(Number(row.getAttribute('data-i')), mode);
  });
  select.addEventListener('change', function () { choose(Number(select.value), mode); });
  $('mode-character').addEventListener('click', function () { choose(chosen, 'character'); });
  $('mode-crowd').addEventListener('click', function () { choose(chosen, 'crowd'); });

  function choose(i, m) {
    chosen = i;
    mode = m;
    select.value = i;
    var c = chars[i];
    $('mode-character').className = mode === 'character' ? 'on' : '';
    $('mode-crowd').className = mode === 'crowd' ? 'on' : '';
    $('figures').innerHTML = '<b>' + esc(c.name) + '</b> (' + esc(c.inverter) + '): ' + esc(counts(c)) +
        '; worst error ' + fmt(c.worst_error_cm, 3) + ' cm (the inverter\'s worstErrorCm), real rig ' +
        fmt(c.rigWorst, 3) + ' cm' + (c.marker >= 0 ? '; looks at ' + esc(data.markers[c.marker].name) : '');
    Array.prototype.forEach.call($('table').querySelectorAll('tr[data-i]'), function (row) {
      row.className = Number(row.getAttribute('data-i')) === i ? 'chosen' : '';
    });
    view.top = mode === 'crowd';
    view.fit(view.top ? crowdBox : boxes[i]);
    status.mode = mode;
    status.character = c.name;
    show(current);
  }

  var current = 0;
  var scrubTo = kit.playback(n, data.fps, show, function () { return current; });
  function show(f) {
    current = f;
    chars.forEach(function (c, i) {
      var shown = mode === 'crowd' || i === chosen;
      kit.place(c.rigJoints, c.rigBones, c.rig[f]);
      kit.place(c.targetJoints, c.targetBones, c.target[f]);
      var e = errors(c, f);
      c.rigJoints.forEach(function (m, j) {
        m.visible = m.visible && shown;
        kit.errorColor(e[j], scale, m.material.color);
      });
      c.rigBones.lines.visible = shown;
      c.rigBones.lines.material.color.setHex(mode === 'crowd' && i === chosen ? 0x39cccc : 0xf0f0f0);
      c.targetJoints.forEach(function (m) { m.visible = m.visible && mode === 'character' && i === chosen; });
      c.targetBones.lines.visible = mode === 'character' && i === chosen;
    });
    markerMeshes.forEach(function (m, k) {
      m.position.set(markers[k][f][0], markers[k][f][1], markers[k][f][2]);
      m.visible = mode === 'crowd' || chars[chosen].marker === k;
    });
    var c = chars[chosen], r = c.rig[f], top = 0;
    for (var j = 1; 3 * j < r.length; ++j)
      if (r[3 * j + 1] !== null && (r[3 * top + 1] === null || r[3 * j + 1] > r[3 * top + 1])) top = j;
    gaze.lines.visible = mode === 'character' && c.marker >= 0;
    if (gaze.lines.visible)
      kit.place([], gaze, [r[3 * top], r[3 * top + 1], r[3 * top + 2]].concat(markers[c.marker][f]));
    view.render();
    scrubTo(f);
    $('frame').textContent = 'frame ' + data.frames[f] + ': ' + c.name + ' ' + data.status_names[c.status[f]] +
        ', worst ' + fmt(c.worst_cm[f], 3) + ' cm';
  }

  choose(chosen, mode);
  kit.drawn(status, view);
})();
</script>
)page";

std::vector<std::string> lines(const std::string& text)
{
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
}

std::string stringOf(Graph& graph, const std::string& plug)
{
    return std::get<std::string>(graph.getValue(graph.plug(plug)));
}

// The prefix (a namespace and its ':', or nothing) of the rig the inverter's parameters drive: what the plug
// value[i] connects to has before parameter i's name.
std::string rigPrefix(const Graph& graph, NodeId inverter, const std::vector<std::string>& parameters,
                      const std::string& where)
{
    for (const Connection& c : graph.connections()) {
        if (c.source.node != inverter || graph.spec(c.source).name != "value" || c.source.index < 0 ||
            c.source.index >= static_cast<int>(parameters.size()))
            continue;
        const std::string driven = graph.plugName(c.destination);
        const std::string& parameter = parameters[static_cast<std::size_t>(c.source.index)];
        if (driven.size() >= parameter.size() && driven.ends_with(parameter))
            return driven.substr(0, driven.size() - parameter.size());
    }
    throw Error(
        fmt::format("{}: --html: {}.value drives none of its parameters' plugs; connect the inverter to its rig "
                    "(connect: {{parameters: true}}, docs/crowds.md)",
                    where, graph.nodeName(inverter)));
}

}  // namespace

CrowdReport::CrowdReport(Graph& graph, std::string rigName) : rigName_(std::move(rigName))
{
    for (NodeId node = 0; node < graph.nodeCount(); ++node)
        if (graph.nodeType(node).name() == "rigInversion") characters_.push_back(character(graph, node));
    if (characters_.empty())
        throw Error(
            fmt::format("{}: --html: the graph has no rigInversion node; the crowd page shows the characters "
                        "rigInversion nodes drive (docs/crowds.md)",
                        rigName_));
}

CrowdReport::Character CrowdReport::character(Graph& graph, NodeId inverter)
{
    Character c;
    c.inverter = graph.nodeName(inverter);
    const auto parameters = lines(stringOf(graph, c.inverter + ".parameterNames"));
    const std::string prefix = rigPrefix(graph, inverter, parameters, rigName_);
    c.name = prefix.empty() ? c.inverter : prefix.substr(0, prefix.size() - 1);
    c.joints = lines(stringOf(graph, c.inverter + ".outputNames"));
    const std::string map = stringOf(graph, c.inverter + ".map");
    c.scale = map.empty() ? 1.0 : readTargetMap(map).scale;

    std::map<NodeId, int> outputOfNode;
    std::vector<NodeId> nodes;
    for (std::size_t k = 0; k < c.joints.size(); ++k) {
        const NodeId node = graph.findNode(prefix + c.joints[k]);
        if (node < 0)
            throw Error(
                fmt::format("{}: --html: {} drives no node '{}' (its output {} under {}'s namespace); the page "
                            "draws the rig the inverter's parameters drive",
                            rigName_, c.inverter, prefix + c.joints[k], c.joints[k], c.name));
        nodes.push_back(node);
        outputOfNode[node] = static_cast<int>(k);
    }
    c.firstJointPlug = plugs_.size();
    for (const NodeId node : nodes) {
        c.parents.push_back(parentOutput(graph, node, outputOfNode));
        plugs_.push_back(graph.plug(graph.nodeName(node) + ".worldMatrix"));
    }
    // The targets it was asked for: its connected target[k] (the node solves for those only).
    for (std::size_t k = 0; k < c.joints.size(); ++k) {
        const Plug target = graph.plug(fmt::format("{}.target[{}]", c.inverter, k));
        c.targetPlug.push_back(graph.incomingConnection(target) ? static_cast<int>(plugs_.size()) : -1);
        if (graph.incomingConnection(target)) plugs_.push_back(target);
    }
    c.statusPlug = plugs_.size();
    plugs_.push_back(graph.plug(c.inverter + ".status"));
    c.worstPlug = plugs_.size();
    plugs_.push_back(graph.plug(c.inverter + ".worstErrorCm"));
    if (statusNames_.empty()) statusNames_ = graph.spec(plugs_[c.statusPlug]).enumNames;
    c.marker = marker(graph, c, inverter);
    return c;
}

// The point the character's lookAt nodes (those feeding its inverter) aim at: a marker per plug their target
// comes from (camera.translate), shared by the characters that look at it.
int CrowdReport::marker(const Graph& graph, const Character& c, NodeId inverter)
{
    for (const Connection& link : graph.connections()) {
        if (link.destination.node != inverter || graph.nodeType(link.source.node).name() != "lookAt") continue;
        const Plug target = graph.plug(graph.nodeName(link.source.node) + ".target");
        const Connection* source = graph.incomingConnection(target);
        const std::string name = graph.plugName(source ? source->source : target);
        for (std::size_t m = 0; m < markers_.size(); ++m)
            if (markers_[m].name == name) return static_cast<int>(m);
        markers_.push_back({name, plugs_.size(), c.scale, Json::array()});
        plugs_.push_back(target);
        return static_cast<int>(markers_.size()) - 1;
    }
    return -1;
}

void CrowdReport::open(const std::string& character)
{
    std::vector<std::string> names;
    for (std::size_t i = 0; i < characters_.size(); ++i) {
        if (characters_[i].name == character || characters_[i].inverter == character) {
            opened_ = static_cast<int>(i);
            return;
        }
        names.push_back(characters_[i].name);
    }
    const std::string near = closestName(character, names);
    throw Error(
        fmt::format("--character '{}': the crowd has no such character{}; its characters are {}{}", character,
                    near.empty() ? "" : fmt::format(" (did you mean '{}'?)", near),
                    fmt::join(names.begin(), names.begin() + std::min<std::ptrdiff_t>(8, std::ssize(names)), ", "),
                    names.size() > 8 ? fmt::format(", ... ({} in all)", names.size()) : ""));
}

void CrowdReport::record(Graph& graph, double frame)
{
    const std::vector<Value> values = evaluateFrame(graph, rigName_, frame, false, plugs_);
    const auto world = [&](std::size_t i) { return std::get<Eigen::Matrix4d>(values[i]); };
    frames_.push_back(numberJson(frame));
    for (Character& c : characters_) {
        std::vector<Eigen::Matrix4d> rig, target;
        for (std::size_t k = 0; k < c.joints.size(); ++k) {
            rig.push_back(world(c.firstJointPlug + k));
            Eigen::Matrix4d t = Eigen::Matrix4d::Constant(std::nan(""));
            if (c.targetPlug[k] >= 0) {
                t = world(static_cast<std::size_t>(c.targetPlug[k]));
                t.block<3, 1>(0, 3) *= c.scale;
            }
            target.push_back(t);
        }
        c.rig.push_back(positionsJson(rig));
        c.target.push_back(positionsJson(target));
        c.status.push_back(std::get<int>(values[c.statusPlug]));
        c.worst.push_back(roundedJson(std::get<double>(values[c.worstPlug])));
    }
    for (Marker& m : markers_) m.positions.push_back(valueToJson(graph, plugs_[m.plug], values[m.plug]));
}

Json CrowdReport::characterJson(const Character& c) const
{
    std::vector<int> frames(statusNames_.size(), 0);
    for (const auto& s : c.status) ++frames.at(s.get<std::size_t>());
    Json counts = Json::object();
    for (std::size_t i = 0; i < statusNames_.size(); ++i) counts[statusNames_[i]] = frames[i];
    double worst = 0.0;
    for (const auto& w : c.worst)
        if (w.is_number()) worst = std::max(worst, w.get<double>());
    return Json{{"name", c.name},
                {"inverter", c.inverter},
                {"joints", c.joints},
                {"parents", c.parents},
                {"marker", c.marker},
                {"status_counts", std::move(counts)},
                {"worst_error_cm", roundedJson(worst)},
                {"status", c.status},
                {"worst_cm", c.worst},
                {"rig", c.rig},
                {"target", c.target}};
}

std::string CrowdReport::page(const std::string& title, const std::string& threeJs) const
{
    Json characters = Json::array();
    for (const Character& c : characters_) characters.push_back(characterJson(c));
    Json markers = Json::array();
    for (const Marker& m : markers_)
        markers.push_back({{"name", m.name}, {"scale", numberJson(m.scale)}, {"positions", m.positions}});
    // Scene frames have no rate of their own: the crowd's real-time budget, 30 a second (docs/crowds.md).
    const Json data{{"title", title},
                    {"fps", 30},
                    {"frames", frames_},
                    {"open", opened_},
                    {"status_names", statusNames_},
                    {"markers", std::move(markers)},
                    {"characters", std::move(characters)}};
    return reportPage(fmt::format("graph-eval: {}", title), pageStyle, threeJs, data, pageElements, pageScript);
}

}  // namespace rig::app
