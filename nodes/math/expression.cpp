#include "nodes/math/expression.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "core/error.h"
#include "core/parse_number.h"

namespace rig {

namespace {

struct Function {
    std::string_view name;
    int arguments;
};

// The functions read, by index (Instruction::index of a call).
constexpr std::array<Function, 19> functions{{
    {"abs", 1}, {"ceil", 1}, {"floor", 1}, {"sqrt", 1},       {"exp", 1},        {"log", 1},  {"pow", 2},
    {"sin", 1}, {"cos", 1},  {"tan", 1},   {"asin", 1},       {"acos", 1},       {"atan", 1}, {"atan2", 2},
    {"min", 2}, {"max", 2},  {"clamp", 3}, {"deg_to_rad", 1}, {"rad_to_deg", 1},
}};
// Not in the table: sign, read as its own function below to keep the table's indices contiguous.
constexpr int signFunction = static_cast<int>(functions.size());

double callFunction(int index, const double* a)
{
    constexpr double degreesPerRadian = 180.0 / std::numbers::pi;
    switch (index) {
        case 0:
            return std::abs(a[0]);
        case 1:
            return std::ceil(a[0]);
        case 2:
            return std::floor(a[0]);
        case 3:
            return std::sqrt(a[0]);
        case 4:
            return std::exp(a[0]);
        case 5:
            return std::log(a[0]);
        case 6:
            return std::pow(a[0], a[1]);
        case 7:
            return std::sin(a[0]);
        case 8:
            return std::cos(a[0]);
        case 9:
            return std::tan(a[0]);
        case 10:
            return std::asin(a[0]);
        case 11:
            return std::acos(a[0]);
        case 12:
            return std::atan(a[0]);
        case 13:
            return std::atan2(a[0], a[1]);
        case 14:
            return std::min(a[0], a[1]);
        case 15:
            return std::max(a[0], a[1]);
        case 16:
            return std::min(std::max(a[2], a[0]), a[1]);  // Maya's clamp(low, high, value)
        case 17:
            return a[0] / degreesPerRadian;
        case 18:
            return a[0] * degreesPerRadian;
        case signFunction:
            return a[0] > 0.0 ? 1.0 : a[0] < 0.0 ? -1.0 : 0.0;
        default:
            return 0.0;  // unreachable: the parser emits known indices only
    }
}

enum class TokenKind { number, name, variable, element, symbol, end };

struct Token {
    TokenKind kind = TokenKind::end;
    std::string text;  // as written; for an element ".I" or ".O"
    int index = 0;     // an element's index
    double value = 0.0;
    int line = 1;
};

// MEL words Maya's expressions use that are refused; named in the message as what they are.
std::string describeName(const std::string& name)
{
    static const std::map<std::string, std::string, std::less<>> known{
        {"if", "a conditional ('if')"},
        {"else", "a conditional ('else')"},
        {"for", "a loop ('for')"},
        {"while", "a loop ('while')"},
        {"do", "a loop ('do')"},
        {"switch", "a conditional ('switch')"},
        {"int", "an int variable"},
        {"string", "a string variable"},
        {"vector", "a vector variable"},
        {"matrix", "a matrix variable"},
        {"getAttr", "the MEL command getAttr"},
        {"setAttr", "the MEL command setAttr"},
        {"return", "'return'"},
        {"global", "a global variable"},
        {"proc", "a MEL procedure ('proc')"},
    };
    if (const auto it = known.find(name); it != known.end()) return it->second;
    return fmt::format("'{}' (a MEL command, function or name this reader does not evaluate)", name);
}

class Lexer {
public:
    explicit Lexer(std::string_view text) : text_(text) {}

    Token next()
    {
        skipBlanks();
        Token token;
        token.line = line_;
        if (at_ >= text_.size()) return token;
        const char c = text_[at_];
        if (std::isdigit(static_cast<unsigned char>(c)) ||
            (c == '.' && at_ + 1 < text_.size() && std::isdigit(static_cast<unsigned char>(text_[at_ + 1]))))
            return number(token);
        if (std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == '$') return name(token);
        if (c == '.') return element(token);
        // Two-character operators are read whole so that the message names them (==, +=, &&, ...).
        static constexpr std::string_view pairs[] = {
            "==", "!=", "<=", ">=", "&&", "||", "+=", "-=", "*=", "/=", "++", "--", "<<", ">>"};
        std::size_t length = 1;
        for (std::string_view pair : pairs)
            if (text_.substr(at_, 2) == pair) length = 2;
        return symbol(length);
    }

    [[noreturn]] void fail(int line, const std::string& what) const
    {
        throw Error(fmt::format("expression: line {}: {}", line, what));
    }

private:
    void skipBlanks()
    {
        while (at_ < text_.size()) {
            const char c = text_[at_];
            if (c == '\n') {
                ++line_;
                ++at_;
            } else if (std::isspace(static_cast<unsigned char>(c))) ++at_;
            else if (text_.substr(at_, 2) == "//")
                while (at_ < text_.size() && text_[at_] != '\n') ++at_;
            else if (text_.substr(at_, 2) == "/*") {
                const std::size_t close = text_.find("*/", at_ + 2);
                if (close == std::string_view::npos) fail(line_, "a comment '/*' is not closed with '*/'");
                line_ += static_cast<int>(std::count(text_.begin() + static_cast<std::ptrdiff_t>(at_),
                                                     text_.begin() + static_cast<std::ptrdiff_t>(close), '\n'));
                at_ = close + 2;
            } else break;
        }
    }

    Token symbol(std::size_t length)
    {
        Token token{TokenKind::symbol, std::string(text_.substr(at_, length)), 0, 0.0, line_};
        at_ += length;
        return token;
    }

    Token number(Token& token)
    {
        const std::size_t start = at_;
        while (at_ < text_.size() &&
               (std::isalnum(static_cast<unsigned char>(text_[at_])) || text_[at_] == '.' ||
                ((text_[at_] == '-' || text_[at_] == '+') && (text_[at_ - 1] == 'e' || text_[at_ - 1] == 'E'))))
            ++at_;
        token.text = std::string(text_.substr(start, at_ - start));
        const auto value = parseFiniteNumber(token.text);
        if (!value) fail(token.line, fmt::format("'{}' is not a number", messageExcerpt(token.text)));
        token.kind = TokenKind::number;
        token.value = *value;
        return token;
    }

    Token name(Token& token)
    {
        const std::size_t start = at_++;
        while (at_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[at_])) || text_[at_] == '_')) ++at_;
        token.text = std::string(text_.substr(start, at_ - start));
        token.kind = token.text[0] == '$' ? TokenKind::variable : TokenKind::name;
        if (token.text == "$") fail(token.line, "'$' without a variable name");
        return token;
    }

    // .I[n] or .O[n]; any other .name is an attribute of a node, which Maya's saved text does not hold.
    Token element(Token& token)
    {
        const std::size_t start = at_++;
        while (at_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[at_])) || text_[at_] == '_')) ++at_;
        token.text = std::string(text_.substr(start, at_ - start));
        if ((token.text != ".I" && token.text != ".O") || at_ >= text_.size() || text_[at_] != '[')
            fail(token.line, fmt::format("'{}' is not read: only .I[n] and .O[n] name the node's inputs and outputs",
                                         messageExcerpt(token.text)));
        const std::size_t close = text_.find(']', at_);
        const auto index =
            close == std::string_view::npos ? std::nullopt : parseFiniteNumber(text_.substr(at_ + 1, close - at_ - 1));
        if (!index || *index < 0 || *index != std::floor(*index) || *index > 1e6)
            fail(token.line, fmt::format("{}[...] needs a whole element index, as {}[0]", token.text, token.text));
        token.kind = TokenKind::element;
        token.index = static_cast<int>(*index);
        at_ = close + 1;
        return token;
    }

    std::string_view text_;
    std::size_t at_ = 0;
    int line_ = 1;
};

}  // namespace

// Recursive descent over statements and the usual precedence levels, emitting stack-machine code.
class ExpressionParser {
public:
    explicit ExpressionParser(std::string_view text) : lexer_(text) { advance(); }

    ExpressionProgram parse()
    {
        while (token_.kind != TokenKind::end) statement();
        program_.variableCount_ = static_cast<int>(variables_.size());
        return std::move(program_);
    }

private:
    using Code = ExpressionProgram::Code;

    void advance() { token_ = lexer_.next(); }
    bool isSymbol(std::string_view s) const { return token_.kind == TokenKind::symbol && token_.text == s; }
    void emit(Code code, int index = 0, double value = 0.0, int arguments = 0)
    {
        program_.code_.push_back({code, value, index, arguments});
    }
    [[noreturn]] void refuse(const std::string& what) const { lexer_.fail(token_.line, what); }

    std::string shown() const
    {
        if (token_.kind == TokenKind::end) return "the end of the text";
        if (token_.kind == TokenKind::element) return fmt::format("'{}[{}]'", token_.text, token_.index);
        return fmt::format("'{}'", messageExcerpt(token_.text));
    }

    void expect(std::string_view symbol, std::string_view where)
    {
        if (!isSymbol(symbol)) {
            if (token_.kind == TokenKind::symbol && token_.text != ";" && token_.text != ")" && token_.text != ",")
                refuse(fmt::format("the operator {} is not read (only + - * / and parentheses)", shown()));
            refuse(fmt::format("expected '{}' {}, found {}", symbol, where, shown()));
        }
        advance();
    }

    void statement()
    {
        if (isSymbol(";")) return advance();
        if (token_.kind == TokenKind::name && token_.text == "float") {
            advance();
            if (token_.kind != TokenKind::variable)
                refuse(fmt::format("expected a $variable after 'float', found {}", shown()));
            const int slot = declare(token_.text);
            advance();
            if (isSymbol("[")) refuse("an array variable is not read");
            // Without an initial value MEL's float is 0, which the evaluation's fresh variables already hold.
            if (isSymbol("=")) {
                advance();
                expression();  // before the variable counts as assigned: `float $x = $x;` reads nothing
                emit(Code::storeVariable, slot);
            }
            assigned_[static_cast<std::size_t>(slot)] = true;
            return expect(";", "after the declaration");
        }
        if (token_.kind == TokenKind::variable) {
            const int slot = declare(token_.text);
            advance();
            expect("=", "in the assignment");
            expression();
            emit(Code::storeVariable, slot);
            assigned_[static_cast<std::size_t>(slot)] = true;
            return expect(";", "after the assignment");
        }
        if (token_.kind == TokenKind::element && token_.text == ".O") {
            const int index = token_.index;
            advance();
            expect("=", "in the assignment");
            expression();
            emit(Code::storeOutput, index);
            program_.outputCount_ = std::max(program_.outputCount_, index + 1);
            return expect(";", "after the assignment");
        }
        if (token_.kind == TokenKind::name) refuse(fmt::format("{} is not read", describeName(token_.text)));
        if (token_.kind == TokenKind::element) refuse(fmt::format("{} cannot be assigned (an input)", shown()));
        refuse(fmt::format("a statement cannot start with {}", shown()));
    }

    int declare(const std::string& name)
    {
        const auto [it, added] = variables_.try_emplace(name, static_cast<int>(variables_.size()));
        if (added) assigned_.push_back(false);
        return it->second;
    }

    void expression()
    {
        term();
        while (isSymbol("+") || isSymbol("-")) {
            const Code code = token_.text == "+" ? Code::add : Code::subtract;
            advance();
            term();
            emit(code);
        }
    }

    void term()
    {
        unary();
        while (isSymbol("*") || isSymbol("/")) {
            const Code code = token_.text == "*" ? Code::multiply : Code::divide;
            advance();
            unary();
            emit(code);
        }
        if (isSymbol("%")) refuse("the operator '%' is not read (only + - * / and parentheses)");
    }

    void unary()
    {
        if (isSymbol("-")) {
            advance();
            unary();
            return emit(Code::negate);
        }
        if (isSymbol("+")) {
            advance();
            return unary();
        }
        primary();
    }

    void primary()
    {
        const Token token = token_;
        if (token.kind == TokenKind::number) {
            advance();
            return emit(Code::constant, 0, token.value);
        }
        if (token.kind == TokenKind::element) {
            advance();
            return emit(token.text == ".I" ? Code::inputElement : Code::outputElement, token.index);
        }
        if (token.kind == TokenKind::variable) {
            const auto it = variables_.find(token.text);
            if (it == variables_.end() || !assigned_[static_cast<std::size_t>(it->second)])
                refuse(fmt::format("the variable {} is read before it is given a value", token.text));
            advance();
            return emit(Code::variable, it->second);
        }
        if (isSymbol("(")) {
            advance();
            expression();
            return expect(")", "to close '('");
        }
        if (token.kind == TokenKind::name) return name(token);
        if (token.kind == TokenKind::symbol && (token.text == "\"" || token.text == "`" || token.text == "<<"))
            refuse(
                fmt::format("{} is not read (strings, MEL commands in back quotes and vectors are not "
                            "expressions this reader evaluates)",
                            shown()));
        refuse(fmt::format("expected a number, .I[n], a $variable, time, frame or a function, found {}", shown()));
    }

    void name(const Token& token)
    {
        if (token.text == "time" || token.text == "frame") {
            advance();
            return emit(token.text == "time" ? Code::time : Code::frame);
        }
        int index = -1;
        int arity = 0;
        for (std::size_t i = 0; i < functions.size(); ++i)
            if (functions[i].name == token.text) {
                index = static_cast<int>(i);
                arity = functions[i].arguments;
            }
        if (token.text == "sign") {
            index = signFunction;
            arity = 1;
        }
        // Refused before reading on: what follows an unknown name (pCube1.tx) is not the construct to name.
        if (index < 0) lexer_.fail(token.line, fmt::format("{} is not read", describeName(token.text)));
        advance();
        expect("(", fmt::format("after {}", token.text));
        int count = 0;
        if (!isSymbol(")")) {
            expression();
            ++count;
            while (isSymbol(",")) {
                advance();
                expression();
                ++count;
            }
        }
        expect(")", fmt::format("to close {}(", token.text));
        if (count != arity)
            lexer_.fail(token.line, fmt::format("{} takes {} argument{}, given {}", token.text, arity,
                                                arity == 1 ? "" : "s", count));
        emit(Code::call, index, 0.0, arity);
    }

    Lexer lexer_;
    Token token_;
    ExpressionProgram program_;
    std::map<std::string, int, std::less<>> variables_;
    std::vector<bool> assigned_;
};

ExpressionProgram ExpressionProgram::parse(std::string_view text) { return ExpressionParser(text).parse(); }

std::vector<double> ExpressionProgram::evaluate(const std::vector<double>& inputs, double frame, double seconds) const
{
    std::vector<double> outputs(static_cast<std::size_t>(outputCount_), 0.0);
    std::vector<double> variables(static_cast<std::size_t>(variableCount_), 0.0);
    std::vector<double> stack;
    stack.reserve(16);
    const auto pop = [&] {
        const double v = stack.back();
        stack.pop_back();
        return v;
    };
    for (const Instruction& in : code_) {
        const auto i = static_cast<std::size_t>(in.index);
        switch (in.code) {
            case Code::constant:
                stack.push_back(in.value);
                break;
            case Code::variable:
                stack.push_back(variables[i]);
                break;
            case Code::inputElement:
                stack.push_back(i < inputs.size() ? inputs[i] : 0.0);
                break;
            case Code::outputElement:
                stack.push_back(i < outputs.size() ? outputs[i] : 0.0);
                break;
            case Code::time:
                stack.push_back(seconds);
                break;
            case Code::frame:
                stack.push_back(frame);
                break;
            case Code::negate:
                stack.back() = -stack.back();
                break;
            case Code::storeVariable:
                variables[i] = pop();
                break;
            case Code::storeOutput:
                outputs[i] = pop();
                break;
            case Code::call: {
                const std::size_t first = stack.size() - static_cast<std::size_t>(in.arguments);
                const double result = callFunction(in.index, stack.data() + first);
                stack.resize(first);
                stack.push_back(result);
                break;
            }
            default: {
                const double b = pop();
                double& a = stack.back();
                a = in.code == Code::add        ? a + b
                    : in.code == Code::subtract ? a - b
                    : in.code == Code::multiply ? a * b
                                                : a / b;
            }
        }
    }
    return outputs;
}

std::optional<std::string> expressionUnsupported(const std::string& text)
{
    try {
        ExpressionProgram::parse(text);
    }
    catch (const Error& e) {
        return std::string(e.what());
    }
    return std::nullopt;
}

}  // namespace rig
