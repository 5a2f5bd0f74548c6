#pragma once
// rig-bench's contacts row (docs/performance.md, docs/retargeting.md): the CMU clip onto the biped with other
// proportions (rigs/biped_long_legs.yaml: thighs, shins and feet 15% longer), its feet's contacts detected from the
// clip, inverted without holding them and with: the foot slide per contact and the other joints' errors on the real
// rig, and the time per frame of both.

#include "bench/bench_suite.h"

namespace rig::bench {

// JSON: rig, clip, frames, contacts (how many cover the frames), before and after ({max_slide_cm, mean_slide_cm,
// other_mean_position_error_cm, other_max_position_error_cm, other_mean_rotation_error_deg, ms_per_frame}),
// time_ratio (after / before), multiplier_updates, learn_seconds.
Json contactsBenchJson(const BenchOptions& options);

}  // namespace rig::bench
