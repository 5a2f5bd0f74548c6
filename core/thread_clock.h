#pragma once
// This thread's CPU time: what a single-threaded figure is measured in, steadier than the wall clock on
// a busy machine (other processes do not count).

namespace rig {

// Seconds of CPU time this thread has used (CLOCK_THREAD_CPUTIME_ID); differences only.
double threadCpuSeconds();

}  // namespace rig
