#pragma once
// rig-learn's work for a rig whose parameters include animated switches (adapter/rig_switches.h; docs/rig-learn.md,
// Blends): the rig learned with every switch held at 1 and again at 0, as the spec's `set:` would hold them, each
// switched output's blend fitted from samples of the rig, the two branches merged (inversion/learn/blend_merge.h) and
// the merge validated against the rig with the switches' weights random in [0, 1].

#include <vector>

#include "adapter/rig_switches.h"
#include "app/learn/learn_run.h"

namespace rig::app {

// Learns `job` on `rig` (loaded with the job's options), whose switches are `switches` (not empty). The outputs the
// branches leave unmodelled go to `unmodelled` (an FK copy's as NAME@fk).
Approximation learnSwitched(const LearnJob& job, GraphRigFunction& rig, const RigSwitches& switches,
                            std::vector<UnmodelledOutput>& unmodelled);

}  // namespace rig::app
