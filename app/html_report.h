#pragma once
// rig-invert --html: one self-contained page (docs/keys-anim-report.md) that plays the clip with the target
// skeleton and the rig's joints overlaid, each rig joint coloured by its error, the worst error per frame on
// a timeline and each control's curve (dense against keys), all under one scrubber. three.js (Debian's
// libjs-three) is embedded in the page with the data: it opens from a file, without a network.
//
// The page writes what it did into its element #status, as JSON, once it has drawn the first frame, and
// again on any script error: {"ok", "errors": [...], "frames", "drawn", "pixels" (lit pixels read back
// from the 3D view), "view": [x, y, width, height] (the 3D view's place on the page)}. Tests read it with a
// headless browser (tests/tools/html_report_test.cpp).

#include <filesystem>
#include <string>

#include "app/invert_run.h"
#include "app/keys_run.h"

namespace rig::app {

// Where Debian's libjs-three puts three.js.
inline const std::filesystem::path threeJsFile = "/usr/share/javascript/three/three.min.js";

// The text of three.js; rig::Error saying how to install it when it cannot be read.
std::string readThreeJs(const std::filesystem::path& file = threeJsFile);

// What the page's title line names.
struct HtmlReportNames {
    std::string clip;
    std::string rig;
    std::string approximation;
};

// The page. With `keys`, the rig plays the keyed curves and the page shows them against the dense ones;
// without, the dense curves. Evaluates the outcome's real rig once per frame.
std::string htmlReport(const InvertOutcome& outcome, const KeysOutcome* keys, const HtmlReportNames& names,
                       const std::string& threeJs);

}  // namespace rig::app
