#pragma once
// A large graph's memory moved into 2 MB pages once it is built. A crowd of 512 bipeds spreads its frame over about
// 300 MB in 4 KB pages, far past what the processor's translation cache maps (1536 pages, 6 MB, on the 2-core
// Xeon here): nearly every read of another node's records or values also waits for a page-table walk. In 2 MB pages
// the same frame took 6 to 7% less time there (docs/crowds.md).

#include <cstddef>

namespace rig {

// Collapses this process's private anonymous writable memory (the heap, large allocations) into transparent huge
// pages where 2 MB-aligned ranges of it lie (Linux 6.1's MADV_COLLAPSE, synchronous: about 3 ms per MB). Returns
// the bytes collapsed: 0 where the system does not have it (an older kernel, transparent huge pages 'never').
// What it cannot collapse (memory short, a thread's stack) stays as it was; the contents never change. The pages
// of a range only partly in use are filled: call it once a large structure is built, not for a small one.
std::size_t collapseIntoHugePages();

}  // namespace rig
