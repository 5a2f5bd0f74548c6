#pragma once
// Approximation files (docs/approximation-format.md): a learned approximation as human-readable YAML,
// read back bit for bit. Numbers are written in the shortest form that reads back to the same double
// (fmt "{}"), and in internal units (radians for angles, cm), which a comment at the top of the file
// says. Reading checks everything an evaluation relies on (types, indices, knots) and reports the
// first problem as "file:line:col: where: what".

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/error.h"
#include "inversion/model/approximation.h"

namespace rig {

inline constexpr std::string_view approximationFormatName = "rigInversionApproximation";
// Version 3 added constraint operators (the top-level `constraints:`, an output's `constraint:`) and helper
// outputs (`helper: true`); version 2 parent-relative outputs (`parent:`), the relative validation figures and
// `noEffect` ranges. Versions 1 and 2 still read (version 1: every output in world space).
inline constexpr int approximationFormatVersion = 3;
// Largest file readApproximationFile reads (a biped's approximation is under 1 MB).
inline constexpr std::uintmax_t approximationMaxFileBytes = std::uintmax_t{256} << 20;

// The file's text. Throws an internal rig::Error naming the field when a number is not finite or the
// structure is inconsistent (indices out of range): an approximation like that is a bug, not a file.
std::string approximationToYaml(const Approximation& approximation);

// Parses a file's text; `fileName` is used in messages. Throws rig::Error (user input): one line, "file:line:col:
// field: problem".
Approximation approximationFromYaml(std::string_view text, const std::string& fileName);

// Reads and parses a file. Throws rig::Error (also when the file cannot be read).
Approximation readApproximationFile(const std::filesystem::path& file);

// Compares the fingerprint recorded in the approximation with a rig's current one. Returns "" when they
// match; otherwise a one-line warning saying the rig changed since learning (re-run rig-learn), or,
// when `strict`, throws rig::Error with that line.
std::string checkFingerprint(const Approximation& approximation, const std::string& fingerprint, bool strict);

}  // namespace rig
