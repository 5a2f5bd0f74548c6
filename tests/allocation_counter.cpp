// Replaces the global operator new and delete of the test binary (allocation_counter.h). The heap held is
// followed always, allocations counted only while asked: the sizes are malloc's own (malloc_usable_size), so a
// block freed is subtracted as it was added, whenever it was allocated.
#include "allocation_counter.h"

#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>

namespace {

std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
std::atomic<long long> held{0};
std::atomic<long long> base{0};
std::atomic<long long> peak{0};

void added(void* p)
{
    const auto size = static_cast<long long>(malloc_usable_size(p));
    const long long now = held.fetch_add(size, std::memory_order_relaxed) + size;
    long long highest = peak.load(std::memory_order_relaxed);
    while (now > highest && !peak.compare_exchange_weak(highest, now, std::memory_order_relaxed)) {
    }
    if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1, std::memory_order_relaxed);
}

void* allocate(std::size_t size)
{
    void* p = std::malloc(size == 0 ? 1 : size);
    if (!p) throw std::bad_alloc();
    added(p);
    return p;
}

void* allocateAligned(std::size_t size, std::align_val_t alignment)
{
    const std::size_t a = static_cast<std::size_t>(alignment);
    void* p = std::aligned_alloc(a, (size + a - 1) / a * a);
    if (!p) throw std::bad_alloc();
    added(p);
    return p;
}

void release(void* p) noexcept
{
    if (!p) return;
    held.fetch_sub(static_cast<long long>(malloc_usable_size(p)), std::memory_order_relaxed);
    std::free(p);
}

}  // namespace

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void* operator new(std::size_t size, std::align_val_t alignment) { return allocateAligned(size, alignment); }
void* operator new[](std::size_t size, std::align_val_t alignment) { return allocateAligned(size, alignment); }
void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { release(p); }

namespace rig::test {

void startCountingAllocations()
{
    allocations = 0;
    base = held.load();
    peak = held.load();
    counting = true;
}

long stopCountingAllocations()
{
    counting = false;
    return allocations.load();
}

std::size_t peakHeapBytes() { return static_cast<std::size_t>(std::max(0LL, peak.load() - base.load())); }

}  // namespace rig::test
