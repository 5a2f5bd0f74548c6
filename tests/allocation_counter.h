#pragma once
// The test binary's global operator new and delete (allocation_counter.cpp): every library of the process
// allocates through them, so a test can count the allocations a piece of work makes and the heap it holds at most.

#include <cstddef>

namespace rig::test {

// Counts from now on: allocations made, and the highest heap held above what is held now.
void startCountingAllocations();
// Stops counting and returns the allocations made since startCountingAllocations.
long stopCountingAllocations();
// The most bytes held at once above the heap held at startCountingAllocations (as malloc sizes its blocks),
// whether or not counting has stopped since.
std::size_t peakHeapBytes();

}  // namespace rig::test
