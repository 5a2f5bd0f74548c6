#pragma once
// The one error type of every layer: one line that says what, where and what to do, and its kind. Tools
// print a user-input error after "error: " with exit code 2, a numerical one (a result measured wrong, a
// real rig that evaluates to NaN) with exit code 3, and an internal one (a broken invariant, a bug: its
// message is for us) after "internal error: " with exit code 1 (tools/cli_common.h).

#include <stdexcept>
#include <string>
#include <string_view>

namespace rig {

enum class ErrorKind {
    userInput,  // a file, flag or value the user gave: the message says what to change
    numerical,  // a result the program measured as wrong
    internal,   // a broken invariant: a bug, whatever the input
};

class Error : public std::runtime_error {
public:
    // A NUL byte in the message (from a name in a binary file) is stored as the text \x00, since
    // what() is read up to the first NUL.
    explicit Error(const std::string& message, ErrorKind kind = ErrorKind::userInput);
    explicit Error(const char* message, ErrorKind kind = ErrorKind::userInput) : Error(std::string(message), kind) {}

    ErrorKind kind() const { return kind_; }
    // The same error with `where` in front ("where: message"): a caller naming the file or node it was
    // working on.
    Error in(std::string_view where) const;

private:
    ErrorKind kind_;
};

// An internal error: a caller broke a function's contract (sizes that do not match, an index out of range).
inline Error internalError(const std::string& message) { return Error(message, ErrorKind::internal); }

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
