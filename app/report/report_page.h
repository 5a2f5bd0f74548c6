#pragma once
// What the report pages share (docs/keys-anim-report.md): rig-invert --html (app/report/html_report.h) and graph-eval
// --html, a crowd (app/eval/crowd_report.h). One self-contained HTML file: its style, three.js (Debian's libjs-three,
// embedded: the page opens from a file, without a network), a script kit both pages draw with (window.ReportKit:
// a 3D view turning around its box or looking down from above, joints and bones, the scrubber and Play button,
// the status the tests read) and the page's data as JSON (script#report-data).
//
// Each page writes what it did into its element #status, as JSON, once it has drawn the first frame, and again
// on any script error: {"ok", "errors": [...], "frames", "drawn", "pixels" (lit pixels read back from the 3D
// view), "view": [x, y, width, height] (the 3D view's place on the page), ...the page's own fields}. Tests read
// it with a headless browser (tests/tools/html_report_test.cpp).

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "app/common/value_output.h"

namespace rig::app {

// Where Debian's libjs-three puts three.js.
inline const std::filesystem::path threeJsFile = "/usr/share/javascript/three/three.min.js";

// The text of three.js; rig::Error saying how to install it when it cannot be read.
std::string readThreeJs(const std::filesystem::path& file = threeJsFile);

// Rounded to 0.001 (cm, degrees): what a page can show, at a fraction of the size; null when not finite.
Json roundedJson(double x);

// The matrices' translations, x y z one after the other, rounded.
Json positionsJson(const std::vector<Eigen::Matrix4d>& worlds);

// The page: `title`, the shared style and `style`, three.js, the kit, `data`, then the page's own `elements`, the
// controls every page has (Play, the frame scrubber and #status), and its `script`, which reads the data with
// ReportKit.data().
std::string reportPage(std::string_view title, std::string_view style, const std::string& threeJs, const Json& data,
                       std::string_view elements, std::string_view script);

}  // namespace rig::app
