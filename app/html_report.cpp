#include "app/html_report.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "app/contacts_run.h"
#include "core/error.h"
#include "inversion/rig_binding.h"

namespace rig::app {
namespace {

// The page around its three parts: the title, three.js and the data.
constexpr std::string_view pageHead = R"page(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>@TITLE@</title>
<style>
body { margin: 0; background: #16181d; color: #d8dce4; font: 13px sans-serif; }
header { padding: 6px 10px; }
header b { color: #fff; }
#main { display: flex; height: 58vh; }
#view { flex: 2; position: relative; min-width: 200px; overflow: hidden; }
#view canvas { display: block; }
#legend { position: absolute; left: 8px; bottom: 6px; font-size: 12px; }
#legend span { display: inline-block; width: 120px; height: 8px; margin: 0 6px;
  background: linear-gradient(to right, #2ecc40, #ffdc00, #ff4136); }
#side { flex: 1; display: flex; flex-direction: column; min-width: 200px; padding: 0 6px; }
#side select { margin: 4px 0; background: #23262e; color: #d8dce4; border: 1px solid #444; }
#curve { flex: 1; width: 100%; }
#timeline { width: 100%; height: 110px; display: block; }
#controls { display: flex; align-items: center; padding: 4px 10px; gap: 10px; }
#scrub { flex: 1; }
#frame { min-width: 190px; font-variant-numeric: tabular-nums; }
#status { display: none; }
</style>
<script>
window.reportErrors = [];
window.addEventListener('error', function (e) {
  window.reportErrors.push(String(e.message || e));
  if (window.reportStatus) window.reportStatus();
});
</script>
<script>
)page";

constexpr std::string_view pageMiddle = R"page(
</script>
<script id="report-data" type="application/json">
)page";

constexpr std::string_view pageTail = R"page(
</script>
</head>
<body>
<header id="summary"></header>
<div id="main">
  <div id="view"><div id="legend"></div></div>
  <div id="side"><select id="control"></select><canvas id="curve"></canvas></div>
</div>
<canvas id="timeline"></canvas>
<div id="controls">
  <button id="play">Play</button><input id="scrub" type="range" min="0" value="0"><span id="frame"></span>
</div>
<pre id="status">{"ok": false, "errors": ["the page's script did not run"]}</pre>
<script>
(function () {
  'use strict';
  var data = JSON.parse(document.getElementById('report-data').textContent);
  var n = data.frames.length;
  var status = {ok: false, errors: window.reportErrors, frames: n, drawn: false, pixels: 0, view: null,
                contacts: data.contacts ? data.contacts.count : null};
  window.reportStatus = function () {
    status.ok = status.errors.length === 0 && status.drawn;
    document.getElementById('status').textContent = JSON.stringify(status);
  };
  var $ = function (id) { return document.getElementById(id); };
  var fmt = function (x, d) { return x === null ? '-' : Number(x).toFixed(d); };

  // Colour of an error: green at 0, yellow at half the scale, red at the scale and beyond.
  var scale = Math.max(1e-6, Math.max.apply(null, data.worst.map(function (x) { return x || 0; })));
  function errorColor(e, color) {
    var t = Math.min(1, Math.max(0, (e || 0) / scale));
    return t < 0.5 ? color.setRGB(0.18 + 1.64 * t, 0.8 + 0.12 * t, 0.25 - 0.5 * t)
                   : color.setRGB(1, 0.86 - 1.2 * (t - 0.5), 0.21 * (t - 0.5) * 2);
  }

  var esc = function (text) {
    return String(text).replace(/[&<>"]/g, function (c) {
      return {'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c];
    });
  };
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
  var view = $('view');
  var renderer = new THREE.WebGLRenderer({antialias: true});
  renderer.setPixelRatio(1);
  renderer.setSize(view.clientWidth, view.clientHeight);
  view.insertBefore(renderer.domElement, view.firstChild);
  var scene = new THREE.Scene();
  scene.background = new THREE.Color(0x20232a);
  var camera = new THREE.PerspectiveCamera(40, view.clientWidth / view.clientHeight, 0.1, 1e6);

  var box = new THREE.Box3();
  data.target.positions.forEach(function (p) {
    for (var j = 0; j + 2 < p.length; j += 3)
      if (p[j] !== null) box.expandByPoint(new THREE.Vector3(p[j], p[j + 1], p[j + 2]));
  });
  if (box.isEmpty()) box.expandByPoint(new THREE.Vector3(0, 0, 0));
  var center = box.getCenter(new THREE.Vector3());
  var size = Math.max(1, box.getSize(new THREE.Vector3()).length());
  var grid = new THREE.GridHelper(size * 1.5, 20, 0x555a66, 0x33363f);
  grid.position.set(center.x, box.min.y, center.z);
  scene.add(grid);

  var sphere = new THREE.SphereBufferGeometry(1, 12, 8);
  function joints(count, radius, color) {
    var out = [];
    for (var j = 0; j < count; ++j) {
      var mesh = new THREE.Mesh(sphere, new THREE.MeshBasicMaterial({color: color}));
      mesh.scale.setScalar(radius);
      scene.add(mesh);
      out.push(mesh);
    }
    return out;
  }
  function bones(parents, color) {
    var pairs = [];
    parents.forEach(function (p, j) { if (p >= 0) pairs.push([p, j]); });
    var geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(pairs.length * 6), 3));
    var lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({color: color}));
    scene.add(lines);
    return {pairs: pairs, lines: lines};
  }
  function place(meshes, skeleton, p) {
    meshes.forEach(function (m, j) {
      m.visible = p[3 * j] !== null;
      if (m.visible) m.position.set(p[3 * j], p[3 * j + 1], p[3 * j + 2]);
    });
    var a = skeleton.lines.geometry.attributes.position;
    skeleton.pairs.forEach(function (pair, k) {
      for (var e = 0; e < 2; ++e)
        for (var c = 0; c < 3; ++c) a.array[6 * k + 3 * e + c] = p[3 * pair[e] + c] || 0;
    });
    a.needsUpdate = true;
  }
  var targetJoints = joints(data.target.joints.length, size * 0.006, 0x8a96aa);
  var targetBones = bones(data.target.parents, 0x5f6b80);
  var rigJoints = joints(data.rig.joints.length, size * 0.009, 0xffffff);
  var rigBones = bones(data.rig.parents, 0xf0f0f0);

  // Far enough for the clip's whole box to fit the field of view.
  var azimuth = 0.7, elevation = 0.25, distance = 0.6 * size / Math.tan(camera.fov * Math.PI / 360);
  // The view follows its box (a window resized, the page laid out again).
  function fitView() {
    var w = view.clientWidth, h = view.clientHeight;
    if (renderer.domElement.width === w && renderer.domElement.height === h) return;
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
  window.addEventListener('resize', function () { show(current); });
  function placeCamera() {
    camera.position.set(center.x + distance * Math.cos(elevation) * Math.sin(azimuth),
                        center.y + distance * Math.sin(elevation),
                        center.z + distance * Math.cos(elevation) * Math.cos(azimuth));
    camera.lookAt(center);
  }
  var drag = null;
  renderer.domElement.addEventListener('mousedown', function (e) { drag = [e.clientX, e.clientY]; });
  window.addEventListener('mouseup', function () { drag = null; });
  window.addEventListener('mousemove', function (e) {
    if (!drag) return;
    azimuth -= 0.01 * (e.clientX - drag[0]);
    elevation = Math.max(-1.4, Math.min(1.4, elevation + 0.01 * (e.clientY - drag[1])));
    drag = [e.clientX, e.clientY];
    show(current);
  });
  renderer.domElement.addEventListener('wheel', function (e) {
    e.preventDefault();
    distance *= Math.exp(0.001 * e.deltaY);
    show(current);
  });

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

  var scrub = $('scrub');
  scrub.max = n - 1;
  var current = 0;
  var color = new THREE.Color();
  function show(f) {
    current = f;
    place(targetJoints, targetBones, data.target.positions[f]);
    place(rigJoints, rigBones, data.rig.positions[f]);
    rigJoints.forEach(function (m, j) { errorColor(data.rig.errors[f][j], m.material.color); });
    fitView();
    placeCamera();
    renderer.render(scene, camera);
    scrub.value = f;
    var text = 'frame ' + data.frames[f] + ': worst ' + fmt(data.worst[f], 3) + ' cm';
    if (data.keyed) text += ', keyed ' + fmt(data.keyed.error_cm[f], 3) + ' cm';
    $('frame').textContent = text;
    drawTimeline(f);
    drawCurve(f);
  }
  scrub.addEventListener('input', function () { show(Number(scrub.value)); });
  $('timeline').addEventListener('click', function (e) {
    var box = plotBox($('timeline').getContext('2d'));
    var t = (e.offsetX - box.x) / box.w;
    show(Math.max(0, Math.min(n - 1, Math.round(t * (n - 1)))));
  });

  var playing = false, start = 0, startFrame = 0;
  function tick(time) {
    if (!playing) return;
    var f = startFrame + Math.floor((time - start) / 1000 * data.fps);
    show(f % n);
    requestAnimationFrame(tick);
  }
  $('play').addEventListener('click', function () {
    playing = !playing;
    $('play').textContent = playing ? 'Pause' : 'Play';
    if (playing) {
      startFrame = current;
      requestAnimationFrame(function (t) { start = t; tick(t); });
    }
  });

  show(0);
  // What the 3D view shows, read back from the frame just drawn: pixels unlike the background.
  var gl = renderer.getContext();
  var w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  var pixels = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
  var lit = 0;
  for (var i = 0; i < pixels.length; i += 4)
    if (Math.abs(pixels[i] - 0x20) + Math.abs(pixels[i + 1] - 0x23) + Math.abs(pixels[i + 2] - 0x2a) > 24) ++lit;
  var rect = renderer.domElement.getBoundingClientRect();
  status.pixels = lit;
  status.view = [Math.round(rect.left), Math.round(rect.top), Math.round(rect.width), Math.round(rect.height)];
  status.drawn = true;
  window.reportStatus();
})();
</script>
</body>
</html>
)page";

std::string htmlEscape(std::string_view text)
{
    std::string out;
    for (const char c : text) {
        if (c == '&') out += "&amp;";
        else if (c == '<') out += "&lt;";
        else if (c == '>') out += "&gt;";
        else if (c == '"') out += "&quot;";
        else out += c;
    }
    return out;
}

// JavaScript that cannot end its <script> element early: "</script" (any case) becomes "<\/script", which
// means the same inside a string or a regular expression, the only places it can be.
std::string scriptSafe(std::string text)
{
    std::string lower = text;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
    for (std::size_t at = lower.find("</script"); at != std::string::npos; at = lower.find("</script", at + 1))
        text.replace(at + text.size() - lower.size(), 2, "<\\/");
    return text;
}

// JSON that cannot end its <script> element or open a comment in it: every '<' (only ever inside a string)
// written \u003c.
std::string jsonInScript(const std::string& json)
{
    std::string out;
    for (const char c : json) {
        if (c == '<') out += "\\u003c";
        else out += c;
    }
    return out;
}

// Rounded to 0.001 (cm, degrees): what the page can show, at a fraction of the size.
Json rounded(double x) { return std::isfinite(x) ? numberJson(std::round(x * 1000.0) / 1000.0) : Json(); }

Json positions(const std::vector<Eigen::Matrix4d>& worlds)
{
    Json out = Json::array();
    for (const auto& w : worlds)
        for (int c = 0; c < 3; ++c) out.push_back(rounded(w(c, 3)));
    return out;
}

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
        out.target.push_back(positions(targets));
        binding.evaluate(shown[f], worlds);
        out.rig.push_back(positions(worlds));
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
            frameErrors.push_back(rounded(e));
            if (std::isfinite(e)) frameWorst = std::max(frameWorst, e);
        }
        out.errors.push_back(std::move(frameErrors));
        out.worst.push_back(rounded(frameWorst));
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
            dense.push_back(rounded(parameterUserValue(parameter, outcome.values[f][p])));
            if (keys) keyed.push_back(rounded(parameterUserValue(parameter, keys->keyed.values[f][p])));
        }
        if (keys)
            for (const AnimKey& k : keys->keyed.keys[p])
                keyList.push_back({numberJson(k.x), rounded(parameterUserValue(parameter, k.y))});
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
    for (const double e : keys->keyed.error.positionCm) errorCm.push_back(rounded(e));
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

std::string readThreeJs(const std::filesystem::path& file)
{
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    if (in) text << in.rdbuf();
    if (!in || in.bad() || text.str().empty())
        throw Error(
            fmt::format("--html: cannot read three.js at {} ({}); install Debian's libjs-three "
                        "(scripts/setup.sh does)",
                        file.string(), in ? "empty" : std::strerror(errno)));
    return text.str();
}

std::string htmlReport(const InvertOutcome& outcome, const KeysOutcome* keys, const HtmlReportNames& names,
                       const std::string& threeJs)
{
    std::string head(pageHead);
    head.replace(head.find("@TITLE@"), 7, htmlEscape(fmt::format("rig-invert: {} on {}", names.clip, names.rig)));
    return head + scriptSafe(threeJs) + std::string(pageMiddle) +
           jsonInScript(jsonText(reportData(outcome, keys, names))) + std::string(pageTail);
}

}  // namespace rig::app
