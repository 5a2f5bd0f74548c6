#pragma once
// Runs a clip reader in a child process (nodes/clips/assimp_clip.cpp): libassimp, as Debian builds it, aborts on
// its own failed assertions on some damaged files (ai_assert in its Collada importer, found by the fuzzer) and
// may crash on others. The child makes the clip and sends it back through a pipe; a child that dies becomes one
// rig::Error line naming the file and what assimp printed (docs/robustness.md). The reader's own rig::Error comes
// back as it was thrown.

#include <functional>
#include <string>

#include "nodes/clips/assimp_clip.h"

namespace rig {

// `read` runs in a child process (fork); `file` names the input in the message for a child that dies. The
// child's standard output and error are captured, never shown.
SkeletalClip readClipIsolated(const std::function<SkeletalClip()>& read, const std::string& file);

}  // namespace rig
