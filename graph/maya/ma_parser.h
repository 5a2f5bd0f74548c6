#pragma once
// The MEL that Maya writes into a Maya ASCII file, split into statements (docs/maya.md): words separated by blanks,
// double-quoted strings (with C escapes, and "a" + "b" joined as Maya splits long strings), `//` and `/* */`
// comments, and `;` ending each statement. Nothing is interpreted here: ma_scene.h gives the statements a meaning.

#include <string>
#include <string_view>
#include <vector>

namespace rig::maya {

struct Word {
    std::string text;
    bool quoted = false;  // written as a string: never a flag, even when it starts with '-'
    int line = 0;         // 1-based, where the word begins
    int column = 0;
};

struct Statement {
    std::vector<Word> words;  // words[0] is the command (createNode, setAttr, ...)
    const std::string& command() const { return words.front().text; }
    int line() const { return words.front().line; }
    int column() const { return words.front().column; }
};

// Splits `text` into statements. Throws rig::Error "file:line:col: ..." for an unterminated string or comment, a
// file that ends inside a statement (a truncated scene), a NUL byte (a binary file) or a statement longer than the
// limits of docs/robustness.md.
std::vector<Statement> parseStatements(std::string_view text, const std::string& fileName);

}  // namespace rig::maya
