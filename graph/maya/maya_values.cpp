#include "graph/maya/maya_values.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <numbers>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::maya {

AttrPath splitAttr(std::string_view text)
{
    AttrPath p;
    auto segment = [&](std::string_view s, std::string& name, int& first, int* last) {
        const auto open = s.find('[');
        name = std::string(s.substr(0, open));
        if (open == std::string_view::npos) return;
        const auto close = s.find(']', open);
        if (close == std::string_view::npos || close + 1 != s.size()) {
            p.valid = false;
            return;
        }
        const std::string inside(s.substr(open + 1, close - open - 1));
        const auto colon = inside.find(':');
        first = static_cast<int>(std::strtol(inside.c_str(), nullptr, 10));
        if (last)
            *last = colon == std::string::npos ? first
                                               : static_cast<int>(std::strtol(inside.c_str() + colon + 1, nullptr, 10));
        if (inside.empty() || first < 0 || first > AttrPath::maxIndex ||
            (last && (*last < first || *last > AttrPath::maxIndex)))
            p.valid = false;
    };
    const auto dot = text.find('.');
    segment(text.substr(0, dot), p.name, p.first, &p.last);
    if (dot != std::string_view::npos) {
        const std::string_view rest = text.substr(dot + 1);
        if (rest.find('.') != std::string_view::npos) p.valid = false;
        segment(rest, p.child, p.childIndex, nullptr);
    }
    return p;
}

double fileFactor(Unit unit, const Units& units)
{
    if (unit == Unit::Angle) return units.angleToDegrees * std::numbers::pi / 180.0;
    if (unit == Unit::Distance) return units.linearToCm;
    return 1.0;
}

double ValueReader::number()
{
    if (done()) throw Error("too few values");
    const std::string& t = words_[pos_++].text;
    if (t == "yes" || t == "on" || t == "true") return 1.0;
    if (t == "no" || t == "off" || t == "false") return 0.0;
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(t.c_str(), &end);
    if (t.empty() || end != t.c_str() + t.size()) throw Error(fmt::format("'{}' is not a number", messageExcerpt(t)));
    if (!std::isfinite(x) || errno == ERANGE)
        throw Error(fmt::format("{} is not a finite number a double holds", messageExcerpt(t)));
    return x;
}

Value ValueReader::read(ValueType type, Unit unit)
{
    const double k = fileFactor(unit, units_);
    switch (type) {
        case ValueType::Double:
            return number() * k;
        case ValueType::Int:
        case ValueType::Enum: {
            const double x = number();
            if (x != std::floor(x) || std::abs(x) > 2e9) throw Error(fmt::format("{} is not a whole number", x));
            return static_cast<int>(x);
        }
        case ValueType::Bool:
            return number() != 0.0;
        case ValueType::String:
            if (done()) throw Error("no string");
            return words_[pos_++].text;
        case ValueType::Vector3: {
            const double x = number(), y = number(), z = number();
            return Eigen::Vector3d(x * k, y * k, z * k);
        }
        case ValueType::Matrix4: {
            if (!done() && words_[pos_].text == "xform")
                throw Error("a matrix written as an xform (its components) is not read; save it as 16 numbers");
            // Maya's matrices act on row vectors (p * M, translation in the last row): ours is the transpose.
            Eigen::Matrix4d m;
            for (int i = 0; i < 16; ++i) m(i % 4, i / 4) = number();
            return m;
        }
        case ValueType::DoubleArray: {
            const double count = number();
            if (count < 0 || count != std::floor(count) || count > static_cast<double>(words_.size()))
                throw Error(fmt::format("an array of {} values, but the statement holds fewer", count));
            std::vector<double> xs(static_cast<std::size_t>(count));
            for (double& x : xs) x = number() * k;
            return xs;
        }
        case ValueType::Matrix4Array:
            throw Error("matrix arrays are not read from Maya scenes");
    }
    return zeroValue(type);
}

namespace {

struct TypeOf {
    ValueType type;
    Unit unit;
};

std::optional<TypeOf> attributeType(const AddAttr& add)
{
    const std::string& t = add.attributeType.empty() ? add.dataType : add.attributeType;
    if (t == "double" || t == "float" || t == "doubleLinear" || t == "doubleAngle" || t == "time" ||
        t == "floatLinear" || t == "floatAngle")
        return TypeOf{ValueType::Double, t.ends_with("Linear")  ? Unit::Distance
                                         : t.ends_with("Angle") ? Unit::Angle
                                         : t == "time"          ? Unit::Time
                                                                : Unit::None};
    if (t == "long" || t == "short" || t == "byte" || t == "char" || t == "int")
        return TypeOf{ValueType::Int, Unit::None};
    if (t == "bool") return TypeOf{ValueType::Bool, Unit::None};
    if (t == "enum") return TypeOf{ValueType::Enum, Unit::None};
    if (t == "double3" || t == "float3") return TypeOf{ValueType::Vector3, Unit::None};
    if (t == "doubleLinear3" || t == "floatLinear3") return TypeOf{ValueType::Vector3, Unit::Distance};
    if (t == "doubleAngle3" || t == "floatAngle3") return TypeOf{ValueType::Vector3, Unit::Angle};
    if (t == "matrix" || t == "fltMatrix") return TypeOf{ValueType::Matrix4, Unit::None};
    if (t == "string") return TypeOf{ValueType::String, Unit::None};
    if (t == "doubleArray") return TypeOf{ValueType::DoubleArray, Unit::None};
    return std::nullopt;  // message, compound, typed, mesh, ...: nothing this engine evaluates
}

// "a:b=3:c" -> names by value (Maya's enum strings may give values; missing ones are named by their index).
std::vector<std::string> enumNames(const std::string& text)
{
    std::vector<std::pair<int, std::string>> entries;
    int next = 0;
    std::size_t start = 0;
    while (start <= text.size()) {
        const std::size_t colon = std::min(text.find(':', start), text.size());
        std::string entry = text.substr(start, colon - start);
        if (const auto eq = entry.find('='); eq != std::string::npos) {
            next = std::atoi(entry.c_str() + eq + 1);
            entry.resize(eq);
        }
        if (!entry.empty() && next >= 0 && next < 4096) entries.emplace_back(next, entry);
        ++next;
        start = colon + 1;
    }
    std::vector<std::string> names;
    for (const auto& [value, name] : entries) {
        if (static_cast<std::size_t>(value) >= names.size()) names.resize(static_cast<std::size_t>(value) + 1);
        names[static_cast<std::size_t>(value)] = name;
    }
    for (std::size_t i = 0; i < names.size(); ++i)
        if (names[i].empty()) names[i] = fmt::format("value{}", i);
    if (names.empty()) names.push_back("value0");
    return names;
}

bool validName(const std::string& name)
{
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
    for (char c : name)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
    return true;
}

}  // namespace

std::optional<AttributeSpec> dynamicAttribute(const AddAttr& add, const std::vector<AddAttr>& children,
                                              const Units& units)
{
    const auto type = attributeType(add);
    if (!type || !validName(add.longName)) return std::nullopt;
    AttributeSpec spec;
    spec.name = add.longName;
    spec.shortName = add.shortName == add.longName ? std::string() : add.shortName;
    spec.type = type->type;
    spec.unit = type->unit;
    spec.input = true;
    spec.dynamic = true;
    spec.keyable = add.keyable;
    spec.array = add.multi;
    const double k = fileFactor(spec.unit, units);
    spec.defaultValue = zeroValue(spec.type);
    if (spec.type == ValueType::Enum) spec.enumNames = enumNames(add.enumNames);
    if (add.defaultValue) {
        const double x = *add.defaultValue;
        if (spec.type == ValueType::Double) spec.defaultValue = x * k;
        else if (spec.type == ValueType::Bool) spec.defaultValue = x != 0.0;
        else if (spec.type == ValueType::Int) spec.defaultValue = static_cast<int>(x);
        else if (spec.type == ValueType::Enum && x >= 0 && x < static_cast<double>(spec.enumNames.size()))
            spec.defaultValue = static_cast<int>(x);
    }
    if (spec.type == ValueType::Double || spec.type == ValueType::Int) {
        if (add.min) spec.min = *add.min * k;
        if (add.max) spec.max = *add.max * k;
    }
    if (spec.type == ValueType::Vector3) {
        if (children.size() < 3) return std::nullopt;
        for (std::size_t i = 0; i < 3; ++i) {
            if (!validName(children[i].longName)) return std::nullopt;
            spec.childNames[i] = children[i].longName;
            spec.childShortNames[i] = children[i].shortName;
        }
        if (spec.unit == Unit::None) {
            const auto child = attributeType(children[0]);
            if (child) spec.unit = child->unit;
        }
    }
    return spec;
}

}  // namespace rig::maya
