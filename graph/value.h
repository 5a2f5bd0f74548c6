#pragma once
// Plug values. A Value holds one of the engine's data types; which ValueType it stands for comes
// from the attribute (Int and Enum share the int alternative).

#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <Eigen/Core>

namespace rig {

enum class ValueType { Double, Int, Bool, Enum, String, Vector3, Matrix4, DoubleArray, Matrix4Array };

// Units matter only at the surface (files, command lines) and across connections: angles are degrees
// outside and radians inside; a connection between an angle plug and a unitless plug converts, as
// Maya's automatic unitConversion nodes do. Distances are centimetres and times are frames everywhere.
enum class Unit { None, Angle, Distance, Time };

using Matrix4Array = std::vector<Eigen::Matrix4d>;
using Value =
    std::variant<double, int, bool, std::string, Eigen::Vector3d, Eigen::Matrix4d, std::vector<double>, Matrix4Array>;

std::string_view valueTypeName(ValueType type);
std::string_view unitName(Unit unit);

// The zero of a type: 0, false, "", (0,0,0), identity, empty arrays.
Value zeroValue(ValueType type);

// Double, Int, Bool and Enum convert into each other (as Maya connects them).
bool isNumeric(ValueType type);

// Whether a value of type `from` may be connected into a plug of type `to`.
bool canConvert(ValueType from, ValueType to);

// Scale factor applied across a connection from a `from` unit plug to a `to` unit plug.
double unitFactor(Unit from, Unit to);

// The value's numeric scalar (for Double/Int/Bool/Enum values).
double toDouble(const Value& value);

// Converts a value stored for type `from` into the representation of type `to`, scaling numbers
// by `factor` (a unit conversion). Requires canConvert(from, to).
Value convertValue(const Value& value, ValueType from, ValueType to, double factor);

// True when every number in the value is finite.
bool isFinite(const Value& value);

// Bitwise equality (checked mode and determinism tests compare exact bits, NaN included).
bool bitEqual(const Value& a, const Value& b);

}  // namespace rig
