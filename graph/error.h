#pragma once
// User-facing errors: one line that says what, where and what to do. Tools print it after "error: "
// and exit with code 2; anything else escaping a tool is an internal failure (exit code 1).

#include <stdexcept>
#include <string>
#include <string_view>

namespace rig {

class Error : public std::runtime_error {
public:
    // A NUL byte in the message (from a name in a binary file) is stored as the text \x00, since
    // what() is read up to the first NUL.
    explicit Error(const std::string& message);
    explicit Error(const char* message) : Error(std::string(message)) {}
};

// A place in a text file, 1-based, as editors count.
struct SourceMark {
    std::string file;
    int line = 0;
    int column = 0;
};

// "file:line:col" (or just "file" when the line is unknown).
std::string formatMark(const SourceMark& mark);

// A message made safe to print as one line: control characters (a newline inside a quoted YAML
// name, a NUL from binary garbage) and bytes that are not UTF-8 are written as escapes (\n, \x00,
// \xff), and a message longer than
// `maxLength` keeps its start (where) and end (what to do) around a note of what was cut.
std::string oneLine(std::string_view message, std::size_t maxLength = 2000);

// User text quoted in a message, cut to `maxLength` characters ("abc..." plus the full length).
std::string messageExcerpt(std::string_view text, std::size_t maxLength = 80);

}  // namespace rig
