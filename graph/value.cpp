#include "graph/value.h"

#include "core/same_bits.h"

#include <cmath>
#include <numbers>

namespace rig {

std::string_view valueTypeName(ValueType type)
{
    switch (type) {
        case ValueType::Double:
            return "double";
        case ValueType::Int:
            return "int";
        case ValueType::Bool:
            return "bool";
        case ValueType::Enum:
            return "enum";
        case ValueType::String:
            return "string";
        case ValueType::Vector3:
            return "vector3";
        case ValueType::Matrix4:
            return "matrix4";
        case ValueType::DoubleArray:
            return "doubleArray";
        case ValueType::Matrix4Array:
            return "matrix4Array";
    }
    return "?";
}

std::string_view unitName(Unit unit)
{
    switch (unit) {
        case Unit::None:
            return "none";
        case Unit::Angle:
            return "angle";
        case Unit::Distance:
            return "distance";
        case Unit::Time:
            return "time";
    }
    return "?";
}

Value zeroValue(ValueType type)
{
    switch (type) {
        case ValueType::Double:
            return 0.0;
        case ValueType::Int:
        case ValueType::Enum:
            return 0;
        case ValueType::Bool:
            return false;
        case ValueType::String:
            return std::string();
        case ValueType::Vector3:
            return Eigen::Vector3d::Zero().eval();
        case ValueType::Matrix4:
            return Eigen::Matrix4d::Identity().eval();
        case ValueType::DoubleArray:
            return std::vector<double>();
        case ValueType::Matrix4Array:
            return Matrix4Array();
    }
    return 0.0;
}

bool isNumeric(ValueType type)
{
    return type == ValueType::Double || type == ValueType::Int || type == ValueType::Bool || type == ValueType::Enum;
}

bool canConvert(ValueType from, ValueType to) { return from == to || (isNumeric(from) && isNumeric(to)); }

double unitFactor(Unit from, Unit to)
{
    constexpr double degreesPerRadian = 180.0 / std::numbers::pi;
    if (from == Unit::Angle && to != Unit::Angle) return degreesPerRadian;
    if (from != Unit::Angle && to == Unit::Angle) return 1.0 / degreesPerRadian;
    return 1.0;
}

double toDouble(const Value& value)
{
    if (const auto* d = std::get_if<double>(&value)) return *d;
    if (const auto* i = std::get_if<int>(&value)) return *i;
    if (const auto* b = std::get_if<bool>(&value)) return *b ? 1.0 : 0.0;
    return 0.0;
}

Value convertValue(const Value& value, ValueType from, ValueType to, double factor)
{
    if (isNumeric(from) && isNumeric(to)) {
        const double x = toDouble(value) * factor;
        switch (to) {
            case ValueType::Double:
                return x;
            case ValueType::Bool:
                return x != 0.0;
            default:
                return static_cast<int>(std::lround(x));
        }
    }
    if (factor == 1.0) return value;
    if (const auto* v = std::get_if<Eigen::Vector3d>(&value)) return Eigen::Vector3d(*v * factor);
    if (const auto* a = std::get_if<std::vector<double>>(&value)) {
        std::vector<double> scaled(*a);
        for (double& x : scaled) x *= factor;
        return scaled;
    }
    return value;
}

bool isFinite(const Value& value)
{
    return std::visit(
        [](const auto& v) -> bool {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, double>) return std::isfinite(v);
            else if constexpr (std::is_same_v<T, Eigen::Vector3d> || std::is_same_v<T, Eigen::Matrix4d>)
                return v.allFinite();
            else if constexpr (std::is_same_v<T, std::vector<double>>) {
                for (double x : v)
                    if (!std::isfinite(x)) return false;
                return true;
            } else if constexpr (std::is_same_v<T, Matrix4Array>) {
                for (const auto& m : v)
                    if (!m.allFinite()) return false;
                return true;
            } else return true;
        },
        value);
}

bool bitEqual(const Value& a, const Value& b)
{
    if (a.index() != b.index()) return false;
    return std::visit(
        [&](const auto& x) -> bool {
            using T = std::decay_t<decltype(x)>;
            const T& y = std::get<T>(b);
            if constexpr (std::is_same_v<T, double>) return sameBits({&x, 1}, {&y, 1});
            else if constexpr (std::is_same_v<T, Eigen::Vector3d> || std::is_same_v<T, Eigen::Matrix4d>)
                return sameBits({x.data(), static_cast<std::size_t>(x.size())},
                                {y.data(), static_cast<std::size_t>(y.size())});
            else if constexpr (std::is_same_v<T, std::vector<double>>) return sameBits(x, y);
            else if constexpr (std::is_same_v<T, Matrix4Array>) {
                if (x.size() != y.size()) return false;
                for (std::size_t i = 0; i < x.size(); ++i)
                    if (!sameBits({x[i].data(), 16}, {y[i].data(), 16})) return false;
                return true;
            } else return x == y;
        },
        a);
}

}  // namespace rig
