#pragma once
// Doubles compared to the bit: a signed zero is not the other zero, and a NaN equals the same NaN (a value read back,
// a call repeated, is the same value only so).

#include <cstring>
#include <span>

namespace rig {

inline bool sameBits(std::span<const double> a, std::span<const double> b)
{
    // An empty span's data() may be null, which memcmp must not be given even for zero bytes.
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

}  // namespace rig
