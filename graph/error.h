#pragma once
// User-facing errors: one line that says what, where and what to do. Tools print it after "error: "
// and exit with code 2; anything else escaping a tool is an internal failure (exit code 1).

#include <stdexcept>
#include <string>

namespace rig {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// A place in a text file, 1-based, as editors count.
struct SourceMark {
    std::string file;
    int line = 0;
    int column = 0;
};

// "file:line:col" (or just "file" when the line is unknown).
std::string formatMark(const SourceMark& mark);

}  // namespace rig
