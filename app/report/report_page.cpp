#include "app/report/report_page.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::app {
namespace {

// The page's head up to its own style; then the style's end, the script that catches errors from the start,
// and three.js.
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
#controls { display: flex; align-items: center; padding: 4px 10px; gap: 10px; }
#scrub { flex: 1; }
#frame { min-width: 190px; font-variant-numeric: tabular-nums; }
#status { display: none; }
)page";

constexpr std::string_view pageScripts = R"page(</style>
<script>
window.reportErrors = [];
window.addEventListener('error', function (e) {
  window.reportErrors.push(String(e.message || e));
  if (window.reportStatus) window.reportStatus();
});
</script>
<script>
)page";

// What both pages draw with. A view's camera turns around the box (drag; the wheel comes closer) or, with
// `top`, looks down the Y axis from above (X to the right; the wheel zooms).
constexpr std::string_view kit = R"page(
</script>
<script>
window.ReportKit = (function () {
  'use strict';
  var kit = {};
  kit.$ = function (id) { return document.getElementById(id); };
  kit.fmt = function (x, d) { return x === null || x === undefined ? '-' : Number(x).toFixed(d); };
  kit.esc = function (text) {
    return String(text).replace(/[&<>"]/g, function (c) {
      return {'&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;'}[c];
    });
  };
  kit.data = function () { return JSON.parse(kit.$('report-data').textContent); };

  // The page's #status: `fields` and ok (no error and drawn), written again on every error.
  kit.status = function (fields) {
    var status = {ok: false, errors: window.reportErrors, drawn: false, pixels: 0, view: null};
    Object.keys(fields).forEach(function (k) { status[k] = fields[k]; });
    window.reportStatus = function () {
      status.ok = status.errors.length === 0 && status.drawn;
      kit.$('status').textContent = JSON.stringify(status);
    };
    return status;
  };

  // Colour of an error: green at 0, yellow at half the scale, red at the scale and beyond.
  kit.errorColor = function (e, scale, color) {
    var t = Math.min(1, Math.max(0, (e || 0) / scale));
    return t < 0.5 ? color.setRGB(0.18 + 1.64 * t, 0.8 + 0.12 * t, 0.25 - 0.5 * t)
                   : color.setRGB(1, 0.86 - 1.2 * (t - 0.5), 0.21 * (t - 0.5) * 2);
  };

  // A box around flat x y z lists (nulls skipped).
  kit.box = function (lists) {
    var box = new THREE.Box3();
    lists.forEach(function (p) {
      for (var j = 0; j + 2 < p.length; j += 3)
        if (p[j] !== null) box.expandByPoint(new THREE.Vector3(p[j], p[j + 1], p[j + 2]));
    });
    if (box.isEmpty()) box.expandByPoint(new THREE.Vector3(0, 0, 0));
    return box;
  };

  // A 3D view in `element` around `box`; `changed` redraws the page when the user moves the camera.
  kit.view = function (element, box, changed) {
    var renderer = new THREE.WebGLRenderer({antialias: true});
    renderer.setPixelRatio(1);
    renderer.setSize(element.clientWidth, element.clientHeight);
    element.insertBefore(renderer.domElement, element.firstChild);
    var scene = new THREE.Scene();
    scene.background = new THREE.Color(0x20232a);
    var center = box.getCenter(new THREE.Vector3());
    var size = Math.max(1, box.getSize(new THREE.Vector3()).length());
    var grid = new THREE.GridHelper(size * 1.5, 20, 0x555a66, 0x33363f);
    grid.position.set(center.x, box.min.y, center.z);
    scene.add(grid);
    var perspective = new THREE.PerspectiveCamera(40, 1, 0.1, 1e6);
    var above = new THREE.OrthographicCamera(-1, 1, 1, -1, -1e6, 1e6);
    // Far enough for the whole box to fit the field of view.
    var v = {renderer: renderer, scene: scene, center: center, size: size, top: false, zoom: 1,
             azimuth: 0.7, elevation: 0.25, distance: 0, box: box};
    // Looks at another box: around it, or from above its whole ground extent.
    v.fit = function (b) {
      v.box = b;
      b.getCenter(v.center);
      var s = Math.max(1, b.getSize(new THREE.Vector3()).length());
      v.distance = 0.6 * s / Math.tan(perspective.fov * Math.PI / 360);
    };
    v.fit(box);
    v.render = function () {
      var w = element.clientWidth, h = element.clientHeight;
      if (renderer.domElement.width !== w || renderer.domElement.height !== h) renderer.setSize(w, h);
      var camera = perspective;
      if (v.top) {
        var aspect = w / Math.max(1, h), extent = v.box.getSize(new THREE.Vector3());
        var half = 0.62 * Math.max(1, extent.z, extent.x / aspect) / v.zoom;  // a margin for the legend
        above.left = -half * aspect; above.right = half * aspect; above.top = half; above.bottom = -half;
        above.position.set(v.center.x, v.center.y + size, v.center.z);
        above.up.set(0, 0, -1);
        above.lookAt(v.center);
        above.updateProjectionMatrix();
        camera = above;
      } else {
        perspective.aspect = w / Math.max(1, h);
        perspective.updateProjectionMatrix();
        perspective.position.set(v.center.x + v.distance * Math.cos(v.elevation) * Math.sin(v.azimuth),
                                 v.center.y + v.distance * Math.sin(v.elevation),
                                 v.center.z + v.distance * Math.cos(v.elevation) * Math.cos(v.azimuth));
        perspective.lookAt(v.center);
      }
      renderer.render(scene, camera);
    };
    var drag = null;
    renderer.domElement.addEventListener('mousedown', function (e) { drag = [e.clientX, e.clientY]; });
    window.addEventListener('mouseup', function () { drag = null; });
    window.addEventListener('mousemove', function (e) {
      if (!drag || v.top) return;
      v.azimuth -= 0.01 * (e.clientX - drag[0]);
      v.elevation = Math.max(-1.4, Math.min(1.4, v.elevation + 0.01 * (e.clientY - drag[1])));
      drag = [e.clientX, e.clientY];
      changed();
    });
    renderer.domElement.addEventListener('wheel', function (e) {
      e.preventDefault();
      if (v.top) v.zoom *= Math.exp(-0.001 * e.deltaY);
      else v.distance *= Math.exp(0.001 * e.deltaY);
      changed();
    });
    window.addEventListener('resize', changed);
    return v;
  };

  var sphere = null;
  kit.joints = function (scene, count, radius, color) {
    sphere = sphere || new THREE.SphereBufferGeometry(1, 12, 8);
    var out = [];
    for (var j = 0; j < count; ++j) {
      var mesh = new THREE.Mesh(sphere, new THREE.MeshBasicMaterial({color: color}));
      mesh.scale.setScalar(radius);
      scene.add(mesh);
      out.push(mesh);
    }
    return out;
  };
  kit.bones = function (scene, parents, color) {
    var pairs = [];
    parents.forEach(function (p, j) { if (p >= 0) pairs.push([p, j]); });
    var geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(pairs.length * 6), 3));
    var lines = new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({color: color}));
    scene.add(lines);
    return {pairs: pairs, lines: lines};
  };
  // Joints at the flat x y z list `p`; a joint without a position (null) is hidden, and so are its bones.
  kit.place = function (meshes, skeleton, p) {
    meshes.forEach(function (m, j) {
      m.visible = p[3 * j] !== null;
      if (m.visible) m.position.set(p[3 * j], p[3 * j + 1], p[3 * j + 2]);
    });
    var a = skeleton.lines.geometry.attributes.position;
    skeleton.pairs.forEach(function (pair, k) {
      var ends = p[3 * pair[0]] === null || p[3 * pair[1]] === null ? [pair[1], pair[1]] : pair;
      for (var e = 0; e < 2; ++e)
        for (var c = 0; c < 3; ++c) a.array[6 * k + 3 * e + c] = p[3 * ends[e] + c] || 0;
    });
    a.needsUpdate = true;
  };

  // The scrubber (#scrub) and the Play button (#play) over n frames at fps; show(f) draws frame f and
  // current() is the frame shown.
  kit.playback = function (n, fps, show, current) {
    var scrub = kit.$('scrub');
    scrub.max = n - 1;
    scrub.addEventListener('input', function () { show(Number(scrub.value)); });
    var playing = false, start = 0, startFrame = 0;
    function tick(time) {
      if (!playing) return;
      show((startFrame + Math.floor((time - start) / 1000 * fps)) % n);
      requestAnimationFrame(tick);
    }
    kit.$('play').addEventListener('click', function () {
      playing = !playing;
      kit.$('play').textContent = playing ? 'Pause' : 'Play';
      if (playing) {
        startFrame = current();
        requestAnimationFrame(function (t) { start = t; tick(t); });
      }
    });
    return function (f) { scrub.value = f; };
  };

  // Once the first frame is drawn: what the 3D view shows, read back, pixels unlike the background.
  kit.drawn = function (status, view) {
    var gl = view.renderer.getContext();
    var w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    var pixels = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    var lit = 0;
    for (var i = 0; i < pixels.length; i += 4)
      if (Math.abs(pixels[i] - 0x20) + Math.abs(pixels[i + 1] - 0x23) + Math.abs(pixels[i + 2] - 0x2a) > 24) ++lit;
    var rect = view.renderer.domElement.getBoundingClientRect();
    status.pixels = lit;
    status.view = [Math.round(rect.left), Math.round(rect.top), Math.round(rect.width), Math.round(rect.height)];
    status.drawn = true;
    window.reportStatus();
  };
  return kit;
})();
</script>
<script id="report-data" type="application/json">
)page";

constexpr std::string_view pageBody = R"page(
</script>
</head>
<body>
)page";

// Under every page's own elements: the Play button, the frame scrubber and its label, and #status.
constexpr std::string_view playbackControls = R"page(<div id="controls">
  <button id="play">Play</button><input id="scrub" type="range" min="0" value="0"><span id="frame"></span>
</div>
<pre id="status">{"ok": false, "errors": ["the page's script did not run"]}</pre>
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

Json roundedJson(double x) { return std::isfinite(x) ? numberJson(std::round(x * 1000.0) / 1000.0) : Json(); }

Json positionsJson(const std::vector<Eigen::Matrix4d>& worlds)
{
    Json out = Json::array();
    for (const auto& w : worlds)
        for (int c = 0; c < 3; ++c) out.push_back(roundedJson(w(c, 3)));
    return out;
}

std::string reportPage(std::string_view title, std::string_view style, const std::string& threeJs, const Json& data,
                       std::string_view elements, std::string_view script)
{
    std::string head(pageHead);
    head.replace(head.find("@TITLE@"), 7, htmlEscape(title));
    return head + std::string(style) + std::string(pageScripts) + scriptSafe(threeJs) + std::string(kit) +
           jsonInScript(jsonText(data)) + std::string(pageBody) + std::string(elements) +
           std::string(playbackControls) + std::string(script) + "</body>\n</html>\n";
}

}  // namespace rig::app
