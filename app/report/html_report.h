#pragma once
// rig-invert --html: one self-contained page (docs/keys-anim-report.md) that plays the clip with the target
// skeleton and the rig's joints overlaid, each rig joint coloured by its error, the worst error per frame on
// a timeline and each control's curve (dense against keys), all under one scrubber. The page's frame, three.js
// and the status it writes for tests (#status: ok, errors, frames, drawn, pixels, view) are app/report/report_page.h's.

#include <string>

#include "app/invert/invert_run.h"
#include "app/invert/keys_run.h"
#include "app/report/report_page.h"

namespace rig::app {

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
