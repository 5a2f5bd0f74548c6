#include "graph/maya/ma_parser.h"

#include <fmt/format.h>

#include "core/error.h"

namespace rig::maya {
namespace {

// A statement's words, at most (a mesh's vertex list is one statement: millions of numbers are fine, a file that
// never ends its statement is not).
constexpr std::size_t maxWordsPerStatement = std::size_t{1} << 26;

class Lexer {
public:
    Lexer(std::string_view text, const std::string& fileName) : text_(text), file_(fileName) {}

    std::vector<Statement> run()
    {
        std::vector<Statement> statements;
        Statement current;
        while (skipBlanksAndComments()) {
            const char ch = text_[pos_];
            if (ch == ';') {
                advance();
                if (!current.words.empty()) statements.push_back(std::move(current));
                current = Statement{};
                continue;
            }
            Word word = ch == '"' ? quoted() : bare();
            if (word.quoted && !current.words.empty() && current.words.back().quoted && joinPending_) {
                current.words.back().text += word.text;  // "a" + "b": Maya's long strings, split over lines
                joinPending_ = false;
                continue;
            }
            if (!word.quoted && word.text == "+" && !current.words.empty() && current.words.back().quoted) {
                joinPending_ = true;
                continue;
            }
            joinPending_ = false;
            if (current.words.size() >= maxWordsPerStatement)
                fail(current.words.front(), fmt::format("statement '{}' has more than {} words; the file is damaged",
                                                        current.command(), maxWordsPerStatement));
            current.words.push_back(std::move(word));
        }
        if (!current.words.empty())
            fail(current.words.front(),
                 fmt::format("the file ends inside the statement '{}' begun here (no ';'): the scene is truncated; "
                             "save it again from Maya",
                             messageExcerpt(current.command())));
        return statements;
    }

private:
    [[noreturn]] void fail(int line, int column, const std::string& what) const
    {
        throw Error(fmt::format("{}: {}", formatMark({file_, line, column}), what));
    }
    [[noreturn]] void fail(const Word& at, const std::string& what) const { fail(at.line, at.column, what); }

    void advance()
    {
        if (text_[pos_] == '\n') {
            ++line_;
            lineStart_ = pos_ + 1;
        }
        ++pos_;
    }
    int column() const { return static_cast<int>(pos_ - lineStart_) + 1; }

    // False at the end of the text.
    bool skipBlanksAndComments()
    {
        while (pos_ < text_.size()) {
            const char ch = text_[pos_];
            if (ch == '\0') fail(line_, column(), "a NUL byte: this is not a Maya ASCII file (a Maya binary .mb?)");
            if (ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n') {
                advance();
            } else if (ch == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '/') {
                while (pos_ < text_.size() && text_[pos_] != '\n') advance();
            } else if (ch == '/' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '*') {
                const int line = line_, col = column();
                const auto end = text_.find("*/", pos_ + 2);
                if (end == std::string_view::npos) fail(line, col, "a comment begun here is never closed ('*/')");
                while (pos_ < end + 2) advance();
            } else {
                return true;
            }
        }
        return false;
    }

    Word quoted()
    {
        Word word{{}, true, line_, column()};
        advance();  // the opening quote
        while (true) {
            if (pos_ >= text_.size())
                fail(word, "a string begun here is never closed (no closing '\"'): the scene is truncated");
            const char ch = text_[pos_];
            if (ch == '"') break;
            if (ch == '\0') fail(line_, column(), "a NUL byte inside a string: the file is damaged");
            if (ch == '\\' && pos_ + 1 < text_.size()) {
                advance();
                const char e = text_[pos_];
                word.text += e == 'n' ? '\n' : e == 't' ? '\t' : e == 'r' ? '\r' : e;
                advance();
                continue;
            }
            word.text += ch;
            advance();
        }
        advance();  // the closing quote
        return word;
    }

    Word bare()
    {
        Word word{{}, false, line_, column()};
        const std::size_t start = pos_;
        while (pos_ < text_.size()) {
            const char ch = text_[pos_];
            if (ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n' || ch == ';' || ch == '"' || ch == '\0') break;
            ++pos_;  // no newline inside a bare word
        }
        word.text.assign(text_.substr(start, pos_ - start));
        return word;
    }

    std::string_view text_;
    const std::string& file_;
    std::size_t pos_ = 0;
    std::size_t lineStart_ = 0;
    int line_ = 1;
    bool joinPending_ = false;
};

}  // namespace

std::vector<Statement> parseStatements(std::string_view text, const std::string& fileName)
{
    return Lexer(text, fileName).run();
}

}  // namespace rig::maya
