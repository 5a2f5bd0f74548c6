#pragma once
// Runs a clip reader in a child process (nodes/clips/assimp_clip.cpp): libassimp, as Debian builds it, aborts on
// its own failed assertions on some damaged files (ai_assert in its Collada importer, found by the fuzzer) and
// may crash on others. The child makes the clip and sends it back through a pipe; a child that dies becomes one
// rig::Error line naming the file and what assimp printed (docs/robustness.md). The reader's own rig::Error comes
// back as it was thrown. The child's memory and CPU time are bounded: a file may declare counts it does not hold.

#include <cstddef>
#include <functional>
#include <string>

#include "nodes/clips/assimp_clip.h"

namespace rig {

// What the child may spend: address space beyond what it inherits from this process, and CPU time. The fuzzer
// found a 14 KB Collada file on which assimp allocated for 40 s before giving up; these stop such files early.
struct ChildLimits {
    std::size_t memoryBytes = 0;
    int cpuSeconds = 0;
};

// The limits for a file of `bytes` bytes: 2 GiB plus 32 times the file, 60 s plus 1 s per MB (docs/clips.md).
ChildLimits childLimitsFor(std::size_t bytes);

// `read` runs in a child process (fork) within `limits`; `file` names the input in the message for a child that
// dies or runs past a limit. The child's standard output and error are captured, never shown.
SkeletalClip readClipIsolated(const std::function<SkeletalClip()>& read, const std::string& file,
                              const ChildLimits& limits);

}  // namespace rig
