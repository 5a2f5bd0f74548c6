#include "app/report/html_report.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "app/invert/contacts_run.h"
#include "inversion/clip/rig_binding.h"

namespace rig::app {
namespace {

// The page's own style: the curve panel and the timeline.
constexpr std::string_view pageStyle = R"page(#curve { flex: 1; width: 100%; }
#timeline { width: 100%; height: 110px; display: block; }
)page";

// The page's elements, above the controls every page has (app/report/report_page.h).
constexpr std::string_view pageElements = R"page(<header id="summary"></header>
<div id="main">
  <div id="view"><div id="legend"></div></div>
  <div id="side"><select id="control"></select><canvas id="curve"></canvas></div>
</div>
<canvas id="timeline"></canvas>
)page";

// The page's script (drawing with ReportKit).
constexpr std::string_view pageScript = R"page(<script>
(function () {
  'use strict';
  var kit = window.ReportKit, $ = kit.$, fmt = kit.fmt, esc = kit.esc;
  var data = kit.data();
  var n = data.frames.length;
  var status = kit.status({frames: n, contacts: data.contacts ? data.contacts.count : null});

  var scale = Math.max(1e-6, Math.max.apply(null, data.worst.map(function (x) { return x || 0; })));
  var summary = '<b>' + esc(data.clip_name) + '</b> on <b>' + esc(data.rig_name) + '</b> with ' +
      esc(data.approximation_name) + ': ' + n + ' frames (' +
      data.frames[0] +
      ' to ' + data.frames[n - 1] + '); real rig against the targets: worst ' + fmt(scale, 3) + ' cm';
  if (data.keyed) {
    summary += '; keys: ' + data.keyed.keys + ' against ' + data.keyed.dense_keys + ' dense (' +
        fmt(100 * data.keyed.reduction, 1) + '% fewer), within ' + data.keyed.tolerance_cm + ' cm and ' +
        data.keyed.tolerance_deg + ' deg of the dense curves';
  }
  if (data.contacts) {
    summary += '; contacts: ' + data.contacts.count + ', foot slide on the real rig worst ' +
        fmt(data.contacts.max_slide_cm, 4) + ' cm, mean ' + fmt(data.contacts.mean_slide_cm, 4) + ' cm';
  }
  $('summary').innerHTML = summary;
  $('legend').innerHTML = 'joint error 0<span></span>' + fmt(scale, 2) + ' cm';

  // The 3D view: the targets' skeleton (grey) and the rig's joints (coloured by error) and bones (white).
  var view = kit.view($('view'), kit.box(data.target.positions), function () { show(current); });
  var size = view.size;
  var targetJoints = kit.joints(view.scene, data.target.joints.length, size * 0.006, 0x8a96aa);
  var targetBones = kit.bones(view.scene, data.target.parents, 0x5f6b80);
  var rigJoints = kit.joints(view.scene, data.rig.joints.length, size * 0.009, 0xffffff);
  var rigBones = kit.bones(view.scene, data.rig.parents, 0xf0f0f0);

  // Plots on 2D canvases sized to their box.
  function canvas2d(id) {
    var c = $(id);
    c.width = Math.max(50, c.clientWidth);
    c.height = Math.max(50, c.clientHeight);
    var g = c.getContext('2d');
    g.clearRect(0, 0, c.width, c.height);
    return g;
  }
  function plotLine(g, values, lo, hi, color, box) {
    g.strokeStyle = color;
    g.beginPath();
    var started = false;
    values.forEach(function (v, f) {
      if (v === null) { started = false; return; }
      var x = box.x + box.w * (n > 1 ? f / (n - 1) : 0.5);
      var y = box.y + box.h * (1 - (v - lo) / (hi - lo || 1));
      if (started) g.lineTo(x, y); else g.moveTo(x, y);
      started = true;
    });
    g.stroke();
  }
  function cursor(g, f, box) {
    var x = box.x + box.w * (n > 1 ? f / (n - 1) : 0.5);
    g.strokeStyle = '#ffffff';
    g.beginPath(); g.moveTo(x, box.y); g.lineTo(x, box.y + box.h); g.stroke();
  }
  function plotBox(g) { return {x: 48, y: 16, w: g.canvas.width - 58, h: g.canvas.height - 30}; }
  function axis(g, lo, hi, unit, box) {
    g.fillStyle = '#9aa0ac';
    g.fillText(fmt(hi, 3), 2, box.y + 8);
    g.fillText(fmt(lo, 3), 2, box.y + box.h);
    g.fillText(unit, 2, box.y + box.h / 2);
  }

  function drawTimeline(f) {
    var g = canvas2d('timeline');
    var box = plotBox(g);
    axis(g, 0, scale, 'cm', box);
    plotLine(g, data.worst, 0, scale, '#ff851b', box);
    g.fillStyle = '#ff851b';
    g.fillText('worst joint error against the targets, per frame (left scale)', box.x + 4, 11);
    if (data.keyed) {
      // On its own scale (right), up to the tolerance, drawn dashed.
      var tolerance = data.keyed.tolerance_cm;
      var hi = Math.max(tolerance, Math.max.apply(null, data.keyed.error_cm)) * 1.1;
      g.setLineDash([4, 4]);
      plotLine(g, data.frames.map(function () { return tolerance; }), 0, hi, '#39cccc', box);
      g.setLineDash([]);
      plotLine(g, data.keyed.error_cm, 0, hi, '#39cccc', box);
      g.fillStyle = '#39cccc';
      g.fillText('keyed against dense, tolerance ' + tolerance + ' cm dashed (right scale)', box.x + 380, 11);
      g.fillText(fmt(hi, 3), box.x + box.w + 2 - 40, box.y + 8);
    }
    cursor(g, f, box);
  }

  var select = $('control');
  data.controls.forEach(function (c, i) {
    var option = document.createElement('option');
    option.value = i;
    option.textContent = c.name + (c.keys ? ' (' + c.keys.length + ' keys)' : '');
    select.appendChild(option);
  });
  var busiest = 0;
  data.controls.forEach(function (c, i) {
    var spread = Math.max.apply(null, c.dense) - Math.min.apply(null, c.dense);
    var best = data.controls[busiest];
    if (spread > Math.max.apply(null, best.dense) - Math.min.apply(null, best.dense)) busiest = i;
  });
  select.value = busiest;
  select.addEventListener('change', function () { show(current); });

  function drawCurve(f) {
    var c = data.controls[Number(select.value)];
    var g = canvas2d('curve');
    var box = plotBox(g);
    var all = c.dense.concat(c.keyed || []);
    var lo = Math.min.apply(null, all), hi = Math.max.apply(null, all);
    if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
    axis(g, lo, hi, c.unit, box);
    plotLine(g, c.dense, lo, hi, '#8a96aa', box);
    g.fillStyle = '#8a96aa';
    g.fillText('dense', box.x + 4, 11);
    if (c.keyed) {
      plotLine(g, c.keyed, lo, hi, '#39cccc', box);
      g.fillStyle = '#39cccc';
      g.fillText('keyed', box.x + 50, 11);
      c.keys.forEach(function (k) {
        var x = box.x + box.w * (n > 1 ? (k[0] - data.frames[0]) / (data.frames[n - 1] - data.frames[0]) : 0.5);
        var y = box.y + box.h * (1 - (k[1] - lo) / (hi - lo));
        g.fillRect(x - 2, y - 2, 4, 4);
      });
    }
    cursor(g, f, box);
  }

  var current = 0;
  var color = new THREE.Color();
  var scrubTo = kit.playback(n, data.fps, show, function () { return current; });
  function show(f) {
    current = f;
    kit.place(targetJoints, targetBones, data.target.positions[f]);
    kit.place(rigJoints, rigBones, data.rig.positions[f]);
    rigJoints.forEach(function (m, j) { kit.errorColor(data.rig.errors[f][j], scale, m.material.color); });
    view.render();
    scrubTo(f);
    var text = 'frame ' + data.frames[f] + ': worst ' + fmt(data.worst[f], 3) + ' cm';
    if (data.keyed) text += ', keyed ' + fmt(data.keyed.error_cm[f], 3) + ' cm';
    $('frame').textContent = text;
    drawTimeline(f);
    drawCurve(f);
  }
  $('timeline').addEventListener('click', function (e) {
    var box = plotBox($('timeline').getContext('2d'));
    var t = (e.offsetX - box.x) / box.w;
    show(Math.max(0, Math.min(n - 1, Math.round(t * (n - 1)))));
  });

  show(0);
  kit.drawn(status, view);
})();
</script>
)page";

// The rig's joints are the approximation's outputs; their bones, the rig's parent outputs.
Json rigSkeleton(const InvertOutcome& outcome)
{
    const Approximation& a = *outcome.approximation;
    Json joints = Json::array(), parents = Json::array();
    const auto& rigOutputs = outcome.rig->outputs();
    const auto rigParentOf = outcome.rig->outputParents();
    const auto outputIndex = [&](const std::string& name) {
        for (std::size_t o = 0; o < a.outputs.size(); ++o)
            if (a.outputs[o].name == name) return static_cast<int>(o);
        return -1;
    };
    for (const auto& o : a.outputs) {
        joints.push_back(o.name);
        const auto at = std::find(rigOutputs.begin(), rigOutputs.end(), o.name) - rigOutputs.begin();
        const int parent = rigParentOf[static_cast<std::size_t>(at)];
        parents.push_back(parent >= 0 ? outputIndex(rigOutputs[static_cast<std::size_t>(parent)]) : -1);
    }
    return Json{{"joints", std::move(joints)}, {"parents", std::move(parents)}};
}

// Per frame: the targets' and the rig's joint positions, each rig joint's distance from its target (null
// without one) and the frame's worst.
struct FramePositions {
    Json target = Json::array(), rig = Json::array(), errors = Json::array(), worst = Json::array();
};

FramePositions framePositions(const InvertOutcome& outcome, const std::vector<std::vector<double>>& shown)
{
    const Approximation& a = *outcome.approximation;
    // Each output's clip joint, when it has a target.
    std::vector<int> jointOfOutput(a.outputs.size(), -1);
    for (std::size_t j = 0; j < outcome.targets.outputOfJoint.size(); ++j)
        if (const int o = outcome.targets.outputOfJoint[j]; o >= 0)
            jointOfOutput[static_cast<std::size_t>(o)] = static_cast<int>(j);

    RigBinding binding(a, *outcome.rig);
    std::vector<Eigen::Matrix4d> worlds;
    FramePositions out;
    for (std::size_t f = 0; f < outcome.values.size(); ++f) {
        const auto& targets = outcome.clip.worlds[static_cast<std::size_t>(outcome.first) + f];
        out.target.push_back(positionsJson(targets));
        binding.evaluate(shown[f], worlds);
        out.rig.push_back(positionsJson(worlds));
        Json frameErrors = Json::array();
        double frameWorst = 0.0;
        for (std::size_t o = 0; o < worlds.size(); ++o) {
            const int j = jointOfOutput[o];
            if (j < 0) {
                frameErrors.push_back(Json());
                continue;
            }
            const double e =
                (worlds[o].block<3, 1>(0, 3) - targets[static_cast<std::size_t>(j)].block<3, 1>(0, 3)).norm();
            frameErrors.push_back(roundedJson(e));
            if (std::isfinite(e)) frameWorst = std::max(frameWorst, e);
        }
        out.errors.push_back(std::move(frameErrors));
        out.worst.push_back(roundedJson(frameWorst));
    }
    return out;
}

// Each control's curve in the user's units: its value at every frame, and with keys the keyed curve's
// values and its keys.
Json controlCurves(const InvertOutcome& outcome, const KeysOutcome* keys)
{
    const Approximation& a = *outcome.approximation;
    Json controls = Json::array();
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        const RigParameter& parameter = a.parameters[p].parameter;
        Json dense = Json::array(), keyed = Json::array(), keyList = Json::array();
        for (std::size_t f = 0; f < outcome.values.size(); ++f) {
            dense.push_back(roundedJson(parameterUserValue(parameter, outcome.values[f][p])));
            if (keys) keyed.push_back(roundedJson(parameterUserValue(parameter, keys->keyed.values[f][p])));
        }
        if (keys)
            for (const AnimKey& k : keys->keyed.keys[p])
                keyList.push_back({numberJson(k.x), roundedJson(parameterUserValue(parameter, k.y))});
        controls.push_back({{"name", parameter.name},
                            {"unit", parameter.angular ? "deg" : ""},
                            {"dense", std::move(dense)},
                            {"keyed", keys ? std::move(keyed) : Json()},
                            {"keys", keys ? std::move(keyList) : Json()}});
    }
    return controls;
}

// The key reduction's figures (null without keys).
Json keyedSummary(const KeysOutcome* keys)
{
    if (!keys) return Json();
    Json errorCm = Json::array();
    for (const double e : keys->keyed.error.positionCm) errorCm.push_back(roundedJson(e));
    return {{"keys", keys->keyed.keyCount()},
            {"dense_keys", keys->denseKeys},
            {"reduction", numberJson(keys->reduction())},
            {"tolerance_cm", numberJson(keys->settings.toleranceCm)},
            {"tolerance_deg", numberJson(keys->settings.toleranceDeg)},
            {"error_cm", std::move(errorCm)}};
}

Json reportData(const InvertOutcome& outcome, const KeysOutcome* keys, const HtmlReportNames& names)
{
    const TargetClip& clip = outcome.clip;
    Json rig = rigSkeleton(outcome);
    FramePositions frames = framePositions(outcome, keys ? keys->keyed.values : outcome.values);
    rig["positions"] = std::move(frames.rig);
    rig["errors"] = std::move(frames.errors);
    Json frameNumbers = Json::array();
    for (std::size_t f = 0; f < outcome.values.size(); ++f)
        frameNumbers.push_back(numberJson(clip.frameNumbers[static_cast<std::size_t>(outcome.first) + f]));
    return Json{
        {"clip_name", names.clip},
        {"rig_name", names.rig},
        {"approximation_name", names.approximation},
        {"fps", numberJson(clip.frameTime > 0.0 ? 1.0 / clip.frameTime : 30.0)},
        {"frames", std::move(frameNumbers)},
        {"target", {{"joints", clip.joints}, {"parents", clip.parents}, {"positions", std::move(frames.target)}}},
        {"rig", std::move(rig)},
        {"worst", std::move(frames.worst)},
        {"keyed", keyedSummary(keys)},
        {"contacts", contactsJson(outcome.summary, *outcome.approximation, clip.frameNumbers, outcome.contactsAsked)},
        {"controls", controlCurves(outcome, keys)}};
}

}  // namespace

std::string htmlReport(const InvertOutcome& outcome, const KeysOutcome* keys, const HtmlReportNames& names,
                       const std::string& threeJs)
{
    return reportPage(fmt::format("rig-invert: {} on {}", names.clip, names.rig), pageStyle, threeJs,
                      reportData(outcome, keys, names), pageElements, pageScript);
}

}  // namespace rig::app
