#pragma once
// Hints that memory is about to be read or written: the next of many independent problems solved one after
// another (a crowd's trees) is fetched into the cache while the current one is solved.

#include <cstddef>
#include <iterator>

namespace rig {

// Every cache line of [data, data + bytes).
inline void prefetchBytes(const void* data, std::size_t bytes)
{
    const char* p = static_cast<const char*>(data);
    for (std::size_t i = 0; i < bytes; i += 64) __builtin_prefetch(p + i, 1, 3);
}

// Every cache line of a contiguous container's elements (a std::vector, whatever its allocator).
template <class Container>
void prefetch(const Container& v)
{
    prefetchBytes(std::data(v), std::size(v) * sizeof(*std::data(v)));
}

}  // namespace rig
