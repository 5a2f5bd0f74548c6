#pragma once
// Contacts files (docs/retargeting.md, Contacts): joints mapped to lists of frame ranges [first, last], inclusive, in
// a clip's numbering, as rig-invert --contacts FILE (app/invert/contacts_run.h) and the rigInversion node's `contacts`
// read them. The file's shape is checked here; its joints and frames against an approximation and a clip by the reader.

#include <string>
#include <vector>

#include "core/error.h"

namespace rig {

struct ContactRange {
    std::string joint;
    double first = 0.0;
    double last = 0.0;
    SourceMark jointMark, rangeMark, firstMark, lastMark;  // where each is in the file, for messages
};

// The ranges in file order. Throws rig::Error with file:line:col: not a file (readInputFile), a YAML syntax error,
// not a map, a joint without a list of ranges, a range that is not two frames, a frame that is not a number.
std::vector<ContactRange> readContactRanges(const std::string& file);

}  // namespace rig
