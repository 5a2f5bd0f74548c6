#include "nodes/curves/anim_file.h"

#include <array>
#include <cmath>
#include <numbers>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

#include "core/error.h"
#include "core/input_file.h"
#include "core/parse_number.h"

namespace rig {
namespace {

constexpr std::array<std::pair<AnimQuantity, std::string_view>, 4> quantityNames{{
    {AnimQuantity::time, "time"},
    {AnimQuantity::linear, "linear"},
    {AnimQuantity::angular, "angular"},
    {AnimQuantity::unitless, "unitless"},
}};

// Lengths in cm, angles in degrees: what each of Maya's unit names is worth.
constexpr std::array<std::pair<std::string_view, double>, 8> linearUnits{{
    {"mm", 0.1},
    {"cm", 1.0},
    {"m", 100.0},
    {"km", 1e5},
    {"in", 2.54},
    {"ft", 30.48},
    {"yd", 91.44},
    {"mi", 160934.4},
}};
constexpr std::array<std::pair<std::string_view, double>, 4> angularUnits{{
    {"rad", 180.0 / std::numbers::pi},
    {"deg", 1.0},
    {"min", 1.0 / 60.0},
    {"sec", 1.0 / 3600.0},
}};
constexpr std::array<std::pair<std::string_view, double>, 7> namedFrameRates{{
    {"game", 15.0},
    {"film", 24.0},
    {"pal", 25.0},
    {"ntsc", 30.0},
    {"show", 48.0},
    {"palf", 50.0},
    {"ntscf", 60.0},
}};
// The other rates Maya names "Nfps".
constexpr std::array<double, 31> fpsRates{2,   3,   4,   5,   6,    8,    10,   12,   16,  20,  40,
                                          75,  80,  100, 120, 125,  150,  200,  240,  250, 300, 375,
                                          400, 500, 600, 750, 1200, 1500, 2000, 3000, 6000};
constexpr std::array<std::string_view, 4> clockUnits{"hour", "min", "sec", "millisec"};

template <typename Table>
std::optional<double> factorOf(const Table& table, std::string_view name)
{
    for (const auto& [entry, factor] : table)
        if (entry == name) return factor;
    return std::nullopt;
}

template <typename Table>
std::string namesOf(const Table& table)
{
    std::string out;
    for (const auto& entry : table) out += fmt::format("{}{}", out.empty() ? "" : ", ", entry.first);
    return out;
}

std::string tangentNames()
{
    std::string out;
    for (const TangentType t : {TangentType::spline, TangentType::linear, TangentType::flat, TangentType::step,
                                TangentType::stepNext, TangentType::clamped, TangentType::plateau, TangentType::auto_})
        out += fmt::format("{}{}", out.empty() ? "" : ", ", tangentTypeName(t));
    return out;
}

// A frame-rate time unit ("film", "120fps"): key times count its frames.
bool isFrameRate(std::string_view name)
{
    if (factorOf(namedFrameRates, name)) return true;
    if (!name.ends_with("fps")) return false;
    const auto rate = parseFiniteNumber(name.substr(0, name.size() - 3));
    return rate && *rate > 0.0;
}

struct Token {
    std::string_view text;
    int line = 0;
    int column = 0;
};

// Words, and ';', '{' and '}' on their own; "//" and "#" start a comment to the end of the line.
class Lexer {
public:
    explicit Lexer(std::string_view text) : text_(text) {}

    std::optional<Token> next()
    {
        skipBlanks();
        if (at_ >= text_.size()) return std::nullopt;
        Token token{{}, line_, column_};
        const std::size_t start = at_;
        if (isSeparator(text_[at_])) advance();
        else
            while (at_ < text_.size() && !isSpace(text_[at_]) && !isSeparator(text_[at_])) advance();
        token.text = text_.substr(start, at_ - start);
        return token;
    }

    // Where the text ends, for a file cut short.
    Token end() const { return {{}, line_, column_}; }

private:
    static bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
    static bool isSeparator(char c) { return c == ';' || c == '{' || c == '}'; }

    void advance()
    {
        if (text_[at_] == '\n') {
            ++line_;
            column_ = 1;
        } else ++column_;
        ++at_;
    }

    void skipBlanks()
    {
        while (at_ < text_.size()) {
            if (isSpace(text_[at_])) advance();
            else if (text_[at_] == '#' || text_.substr(at_).starts_with("//"))
                while (at_ < text_.size() && text_[at_] != '\n') advance();
            else break;
        }
    }

    std::string_view text_;
    std::size_t at_ = 0;
    int line_ = 1;
    int column_ = 1;
};

// A key as read: numbers in the file's units, converted once the block's units are known, and where they are.
struct RawKey {
    double x = 0.0;
    double y = 0.0;
    TangentType in = TangentType::auto_;
    TangentType out = TangentType::auto_;
    Token time;
    Token value;
};

// A unit as a curve's block or the header gives it: what a number is multiplied by, and the name of what it
// is then in.
struct UnitScale {
    double factor = 1.0;
    std::string_view internal;  // "cm", "degrees", "frames" or "unitless numbers"
};

class Parser {
public:
    Parser(std::string_view text, const std::string& file, const AnimCurveCheck& check)
        : lexer_(text), file_(file), check_(check)
    {
        result_.file = file;
    }

    AnimFile parse()
    {
        bool first = true;
        bool inHeader = true;
        std::optional<AnimFileCurve> pending;  // an anim line waiting for its animData
        while (const auto token = lexer_.next()) {
            const std::string_view word = token->text;
            if (first && word != "animVersion")
                throw error(*token, fmt::format("'{}': a .anim file starts with its animVersion line; this is not a "
                                                "Maya .anim file (export one with the animImportExport plugin)",
                                                messageExcerpt(word)));
            first = false;
            if (word == "anim") {
                inHeader = false;
                pending = animLine(*token);
            } else if (word == "animData") {
                if (!pending)
                    throw error(*token,
                                "animData without an anim line naming its plug before it; write "
                                "'anim ATTRIBUTE LEAF NODE ...;' first");
                animData(*token, std::move(*pending));
                pending.reset();
            } else if (isHeaderKeyword(word)) {
                if (!inHeader)
                    throw error(*token, fmt::format("'{}' after the first anim line; header lines come before the "
                                                    "curves",
                                                    word));
                header(*token);
            } else
                throw error(*token, fmt::format("'{}' is not a .anim keyword; expected anim, animData or a header line "
                                                "(animVersion, mayaVersion, timeUnit, linearUnit, angularUnit, "
                                                "startTime, endTime)",
                                                messageExcerpt(word)));
        }
        if (first) throw error(lexer_.end(), "the file is empty; a .anim file starts with its animVersion line");
        return std::move(result_);
    }

private:
    Error error(const Token& at, const std::string& what) const
    {
        return Error(fmt::format("{}: {}", formatMark({file_, at.line, at.column}), what));
    }

    // The words up to the next ';'.
    std::vector<Token> statement(const Token& keyword)
    {
        std::vector<Token> words;
        while (true) {
            const auto token = lexer_.next();
            if (!token)
                throw error(lexer_.end(), fmt::format("the file ends inside the '{}' line (line {}); the file is "
                                                      "truncated: export it again",
                                                      keyword.text, keyword.line));
            if (token->text == ";") return words;
            if (token->text == "{" || token->text == "}")
                throw error(*token, fmt::format("'{}' inside the '{}' line; end the line with ';' first", token->text,
                                                keyword.text));
            words.push_back(*token);
        }
    }

    // One word, then ';'.
    Token single(const Token& keyword)
    {
        const auto words = statement(keyword);
        if (words.size() != 1)
            throw error(words.empty() ? keyword : words[1],
                        fmt::format("'{}' takes one value, got {}", keyword.text, words.size()));
        return words[0];
    }

    double number(const Token& token, std::string_view what) const
    {
        const auto x = parseFiniteNumber(token.text);
        if (!x) throw error(token, fmt::format("{} '{}' is not a finite number", what, messageExcerpt(token.text)));
        return *x;
    }

    static bool isHeaderKeyword(std::string_view word)
    {
        for (std::string_view k : {"animVersion", "mayaVersion", "timeUnit", "linearUnit", "angularUnit", "startTime",
                                   "endTime", "startUnitless", "endUnitless"})
            if (word == k) return true;
        return false;
    }

    void header(const Token& keyword)
    {
        const std::string_view word = keyword.text;
        if (word == "mayaVersion") {
            statement(keyword);  // a version string, possibly of several words ("2014 x64")
            return;
        }
        const Token value = single(keyword);
        if (word == "animVersion") {
            if (value.text != "1.0" && value.text != "1.1")
                throw error(value, fmt::format("animVersion {}: this reader knows versions 1.0 and 1.1 of the format",
                                               messageExcerpt(value.text)));
        } else if (word == "timeUnit") {
            timeUnit(value);
            result_.timeUnit = std::string(value.text);
        } else if (word == "linearUnit") linearFactor_ = unitFactor(value, linearUnits, "linearUnit");
        else if (word == "angularUnit") angularFactor_ = unitFactor(value, angularUnits, "angularUnit");
        else if (word == "startTime") result_.startTime = number(value, "startTime");
        else if (word == "endTime") result_.endTime = number(value, "endTime");
        else number(value, word);  // startUnitless, endUnitless: a clipboard range, unused here
    }

    void timeUnit(const Token& value) const
    {
        for (std::string_view clock : clockUnits)
            if (value.text == clock)
                throw error(value, fmt::format("timeUnit {}: key times in clock units are not read; export with a "
                                               "frame rate (film, ntsc, 120fps, ...)",
                                               value.text));
        if (!isFrameRate(value.text))
            throw error(value, fmt::format("unknown timeUnit '{}'; use one of {} or a rate such as 120fps",
                                           messageExcerpt(value.text), namesOf(namedFrameRates)));
    }

    template <typename Table>
    double unitFactor(const Token& value, const Table& table, std::string_view keyword) const
    {
        const auto factor = factorOf(table, value.text);
        if (!factor)
            throw error(value, fmt::format("unknown {} '{}'; use one of {}", keyword, messageExcerpt(value.text),
                                           namesOf(table)));
        return *factor;
    }

    // anim ATTRIBUTE LEAF NODE [ROW CHILD INDEX]; (an animated attribute) or anim NODE [ROW CHILD INDEX]; (a
    // node kept for the hierarchy, with no curve).
    std::optional<AnimFileCurve> animLine(const Token& keyword)
    {
        const auto words = statement(keyword);
        if (words.size() == 1 || words.size() == 4) return std::nullopt;
        if (words.size() != 3 && words.size() != 6)
            throw error(keyword, fmt::format("an anim line is 'anim ATTRIBUTE LEAF NODE ROW CHILD INDEX;' or 'anim "
                                             "NODE ROW CHILD INDEX;', got {} words",
                                             words.size()));
        AnimFileCurve curve;
        curve.attribute = std::string(words[0].text);
        curve.leaf = std::string(words[1].text);
        curve.node = std::string(words[2].text);
        curve.mark = {file_, keyword.line, keyword.column};
        // A hash, not a search of the curves read: files of many thousand curves are read in linear time.
        const auto [first, added] = curveLines_.try_emplace(curve.plugName(), keyword.line);
        if (!added)
            throw error(keyword, fmt::format("a second curve for {} (the first is at line {}); keep one",
                                             curve.plugName(), first->second));
        return curve;
    }

    void animData(const Token& keyword, AnimFileCurve curve)
    {
        const auto truncated = [&] {
            return error(lexer_.end(), fmt::format("the file ends inside the animData block of {} (line {}); the file "
                                                   "is truncated: export it again",
                                                   curve.plugName(), keyword.line));
        };
        auto open = lexer_.next();
        if (!open) throw truncated();
        if (open->text != "{") throw error(*open, "animData is followed by '{'");
        std::optional<AnimQuantity> output;
        std::optional<Token> inputUnit, outputUnit;
        std::vector<RawKey> keys;
        bool keysSeen = false;
        while (true) {
            const auto token = lexer_.next();
            if (!token) throw truncated();
            const std::string_view word = token->text;
            if (word == "}") break;
            if (word == "keys") {
                if (keysSeen) throw error(*token, "a second keys block in one animData; keep one");
                keysSeen = true;
                keys = keyBlock(*token, curve);
            } else if (word == "input") curve.input = quantity(single(*token), "input");
            else if (word == "output") output = quantity(single(*token), "output");
            else if (word == "weighted") {
                const Token value = single(*token);
                if (value.text == "1")
                    throw error(value,
                                "weighted tangents are not read; make the curve's tangents non-weighted in "
                                "Maya and export again");
                if (value.text != "0") throw error(value, "weighted is 0 or 1");
            } else if (word == "inputUnit") inputUnit = single(*token);
            else if (word == "outputUnit") outputUnit = single(*token);
            else if (word == "tangentAngleUnit") unitFactor(single(*token), angularUnits, "tangentAngleUnit");
            else if (word == "preInfinity") curve.pre = infinity(single(*token));
            else if (word == "postInfinity") curve.post = infinity(single(*token));
            else
                throw error(*token, fmt::format("'{}' is not an animData keyword; expected input, output, weighted, "
                                                "preInfinity, postInfinity, keys or a unit",
                                                messageExcerpt(word)));
        }
        if (!output) throw error(keyword, fmt::format("the animData of {} has no output line", curve.plugName()));
        curve.output = *output;
        if (curve.output == AnimQuantity::time)
            throw error(keyword, fmt::format("{} has time values (output time); no animCurve node plays those",
                                             curve.plugName()));
        if (!keysSeen || keys.empty())
            throw error(keyword, fmt::format("the animData of {} has no key", curve.plugName()));
        convertKeys(curve, keys, quantityScale(curve.input, inputUnit), quantityScale(curve.output, outputUnit));
        if (check_) check_(curve);
        result_.curves.push_back(std::move(curve));
    }

    // The keys in cm and degrees, refused where a unit's factor overflows a number or where the curve through
    // them would (keys at +-1.7e308 have infinite slopes and play NaN).
    void convertKeys(AnimFileCurve& curve, const std::vector<RawKey>& keys, UnitScale input, UnitScale output) const
    {
        const auto converted = [&](const Token& at, double raw, UnitScale unit, const char* what) {
            const double x = raw * unit.factor;
            if (!std::isfinite(x))
                throw error(at, fmt::format("key {} '{}' overflows in {} (the file's unit makes it more than a "
                                            "double holds, about 1.8e308); check the value and the unit",
                                            what, messageExcerpt(at.text), unit.internal));
            return x;
        };
        for (const RawKey& k : keys)
            curve.keys.push_back(
                {converted(k.time, k.x, input, "time"), converted(k.value, k.y, output, "value"), k.in, k.out});
        const auto built = AnimCurve::tryBuild(curve.keys, curve.pre, curve.post);
        if (const auto* problem = std::get_if<AnimKeyProblem>(&built))
            throw error(keys[problem->key].time, fmt::format("{}: {}", curve.plugName(), problem->what));
    }

    // What a number of `quantity` is multiplied by to be in cm or degrees: the block's unit, else the header's.
    UnitScale quantityScale(AnimQuantity quantity, const std::optional<Token>& unit) const
    {
        if (quantity == AnimQuantity::linear)
            return {unit ? unitFactor(*unit, linearUnits, "linear unit") : linearFactor_, "cm"};
        if (quantity == AnimQuantity::angular)
            return {unit ? unitFactor(*unit, angularUnits, "angular unit") : angularFactor_, "degrees"};
        if (quantity == AnimQuantity::time && unit) timeUnit(*unit);
        return {1.0, quantity == AnimQuantity::time ? "frames" : "unitless numbers"};
    }

    AnimQuantity quantity(const Token& value, std::string_view keyword) const
    {
        for (const auto& [q, name] : quantityNames)
            if (value.text == name) return q;
        throw error(value, fmt::format("{} '{}': expected time, linear, angular or unitless", keyword,
                                       messageExcerpt(value.text)));
    }

    Infinity infinity(const Token& value) const
    {
        if (const auto mode = infinityFromName(value.text)) return *mode;
        throw error(value, fmt::format("unknown infinity '{}'; use one of constant, linear, cycle, cycleRelative, "
                                       "oscillate",
                                       messageExcerpt(value.text)));
    }

    TangentType tangent(const Token& value) const
    {
        if (value.text == "fixed")
            throw error(value,
                        "tangent type 'fixed' (explicit angles) is not read; give these keys another tangent "
                        "type in Maya (auto, spline, ...) and export again");
        if (const auto type = tangentTypeFromName(value.text)) return *type;
        throw error(
            value, fmt::format("unknown tangent type '{}'; use one of {}", messageExcerpt(value.text), tangentNames()));
    }

    // keys { TIME VALUE IN OUT [TANGENT_LOCKED WEIGHT_LOCKED [BREAKDOWN]]; ... }
    std::vector<RawKey> keyBlock(const Token& keyword, const AnimFileCurve& curve)
    {
        const auto open = lexer_.next();
        if (!open || open->text != "{") throw error(open ? *open : lexer_.end(), "keys is followed by '{'");
        std::vector<RawKey> keys;
        while (true) {
            const auto first = lexer_.next();
            if (!first)
                throw error(lexer_.end(), fmt::format("the file ends inside the keys of {} (line {}); the file is "
                                                      "truncated: export it again",
                                                      curve.plugName(), keyword.line));
            if (first->text == "}") return keys;
            if (first->text == ";" || first->text == "{")
                throw error(*first,
                            fmt::format("'{}' where a key starts; a key is 'TIME VALUE IN OUT 1 1 0;'", first->text));
            std::vector<Token> words{*first};
            for (const Token& w : statement(*first)) words.push_back(w);
            const auto count = [&] {
                return error(*first, fmt::format("a key is 'TIME VALUE IN_TANGENT OUT_TANGENT TANGENT_LOCKED "
                                                 "WEIGHT_LOCKED BREAKDOWN;', got {} words",
                                                 words.size()));
            };
            if (words.size() < 4) throw count();
            // The tangents first: a fixed one has more words, and that is what to say.
            RawKey key{number(words[0], "key time"),
                       number(words[1], "key value"),
                       tangent(words[2]),
                       tangent(words[3]),
                       words[0],
                       words[1]};
            if (words.size() > 7) throw count();
            for (std::size_t i = 4; i < words.size(); ++i)
                if (words[i].text != "0" && words[i].text != "1")
                    throw error(words[i], fmt::format("'{}': the locks and the breakdown flag are 0 or 1",
                                                      messageExcerpt(words[i].text)));
            if (!keys.empty() && !(key.x > keys.back().x))
                throw error(words[0], fmt::format("key time {} is not after the previous key's {}; keys are in "
                                                  "increasing time",
                                                  key.x, keys.back().x));
            keys.push_back(key);
        }
    }

    Lexer lexer_;
    std::string file_;
    const AnimCurveCheck& check_;
    AnimFile result_;
    std::unordered_map<std::string, int> curveLines_;  // plug name to the line of its anim line
    double linearFactor_ = 1.0;                        // the header's units (Maya's defaults: cm and degrees)
    double angularFactor_ = 1.0;
};

std::string quantityWord(AnimQuantity quantity) { return std::string(animQuantityName(quantity)); }

}  // namespace

std::string_view animQuantityName(AnimQuantity quantity)
{
    for (const auto& [q, name] : quantityNames)
        if (q == quantity) return name;
    return {};
}

std::string AnimFileCurve::nodeTypeName() const
{
    const char out = output == AnimQuantity::angular ? 'A' : output == AnimQuantity::linear ? 'L' : 'U';
    return fmt::format("animCurve{}{}", input == AnimQuantity::time ? 'T' : 'U', out);
}

const AnimFileCurve* AnimFile::find(std::string_view plug) const
{
    for (const auto& c : curves)
        if (c.plugName() == plug) return &c;
    return nullptr;
}

AnimFile parseAnimFile(std::string_view text, const std::string& fileName, const AnimCurveCheck& check)
{
    return Parser(text, fileName, check).parse();
}

AnimFile readAnimFile(const std::filesystem::path& file, const AnimCurveCheck& check)
{
    return parseAnimFile(
        readInputFile(file, {"a .anim file", "a .anim file", animMaxFileBytes, "export fewer curves or frames"}),
        file.string(), check);
}

std::string formatAnimFile(const AnimFile& file)
{
    // The animImportExport plugin does not check mayaVersion; the version of the format is animVersion's.
    std::string out = fmt::format(
        "animVersion 1.1;\nmayaVersion 2024;\ntimeUnit {};\nlinearUnit cm;\nangularUnit "
        "deg;\n",
        file.timeUnit);
    if (file.startTime) out += fmt::format("startTime {};\n", *file.startTime);
    if (file.endTime) out += fmt::format("endTime {};\n", *file.endTime);
    std::string node;
    int index = 0;
    for (const auto& c : file.curves) {
        index = c.node == node ? index + 1 : 0;
        node = c.node;
        out += fmt::format(
            "anim {} {} {} 0 0 {};\nanimData {{\n  input {};\n  output {};\n  weighted 0;\n"
            "  preInfinity {};\n  postInfinity {};\n  keys {{\n",
            c.attribute, c.leaf, c.node, index, quantityWord(c.input), quantityWord(c.output), infinityName(c.pre),
            infinityName(c.post));
        for (const auto& k : c.keys)
            out += fmt::format("    {} {} {} {} 1 1 0;\n", k.x, k.y, tangentTypeName(k.inTangent),
                               tangentTypeName(k.outTangent));
        out += "  }\n}\n";
    }
    return out;
}

std::optional<std::string> mayaTimeUnit(double framesPerSecond)
{
    for (const auto& [name, rate] : namedFrameRates)
        if (std::abs(framesPerSecond - rate) < 1e-3 * rate) return std::string(name);
    for (const double rate : fpsRates)
        if (std::abs(framesPerSecond - rate) < 1e-3 * rate) return fmt::format("{}fps", rate);
    return std::nullopt;
}

}  // namespace rig
