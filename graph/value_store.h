#pragma once
// One graph instance's attribute values, each in a slot of its own type's size: a pool per type (numbers, vectors,
// matrices, strings, arrays of them), filled in the order the nodes are made. A Value is a variant as large as its
// largest alternative (a matrix: 136 bytes), and a crowd holds thousands of attributes per character, most of them
// numbers and vectors; in pools a frame also walks its characters' values in the order they were made, not through
// one heap block per node.

#include <cstdint>
#include <memory>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "graph/value.h"

namespace rig {

// Calls f(std::type_identity<T>{}) with T the Value alternative that holds a value of `type` (Int and Enum share int).
template <class F>
decltype(auto) visitValueType(ValueType type, F&& f)
{
    switch (type) {
        case ValueType::Double:
            return f(std::type_identity<double>{});
        case ValueType::Int:
        case ValueType::Enum:
            return f(std::type_identity<int>{});
        case ValueType::Bool:
            return f(std::type_identity<bool>{});
        case ValueType::String:
            return f(std::type_identity<std::string>{});
        case ValueType::Vector3:
            return f(std::type_identity<Eigen::Vector3d>{});
        case ValueType::Matrix4:
            return f(std::type_identity<Eigen::Matrix4d>{});
        case ValueType::DoubleArray:
            return f(std::type_identity<std::vector<double>>{});
        case ValueType::Matrix4Array:
            break;
    }
    return f(std::type_identity<Matrix4Array>{});
}

// How a value of type T is held in a pool: a bool in a struct of its own (std::vector<bool> packs bits, which have no
// address to return).
struct BoolCell {
    bool value;
};
template <class T>
using Cell = std::conditional_t<std::is_same_v<T, bool>, BoolCell, T>;
// A container of one vector per value type (a pool each, or one column of an array attribute): Of<...> is std::tuple
// or std::variant.
template <template <class...> class Of>
using PerValueType = Of<std::vector<double>, std::vector<int>, std::vector<BoolCell>, std::vector<std::string>,
                        std::vector<Eigen::Vector3d>, std::vector<Eigen::Matrix4d>, std::vector<std::vector<double>>,
                        std::vector<Matrix4Array>>;

// The elements of an array attribute, by logical index, held as the attribute's own type: a double array's elements
// take 8 bytes each, not a 136-byte Value each (a crowd member's inverter writes 79 of them every frame).
class ArrayData {
public:
    explicit ArrayData(ValueType type);

    // One past the highest index made; elements below it that were never made are absent.
    std::size_t size() const { return present_.size(); }
    bool has(std::size_t i) const { return i < present_.size() && present_[i]; }
    // Element i as T, the attribute's type: it must exist (has(i)).
    template <class T>
    const T& get(std::size_t i) const
    {
        return const_cast<ArrayData*>(this)->get<T>(i);
    }
    template <class T>
    T& get(std::size_t i)
    {
        if constexpr (std::is_same_v<T, bool>) return column<bool>()[i].value;
        else return column<T>()[i];
    }
    Value value(std::size_t i) const;
    // Makes elements up to index i (`fallback`, holding the attribute's type, where new) and marks i present.
    void make(std::size_t i, const Value& fallback);
    // Replaces every element: `count` present elements, each assigned by set(cell, k) (a BoolCell for bool).
    template <class T, class Set>
    void assign(std::size_t count, Set&& set)
    {
        auto& c = column<T>();
        c.resize(count);
        present_.assign(count, true);
        for (std::size_t k = 0; k < count; ++k) set(c[k], k);
    }
    // The same indices present, each element the same to the bit.
    bool sameAs(const ArrayData& other) const;

private:
    template <class T>
    std::vector<Cell<T>>& column()
    {
        return std::get<std::vector<Cell<T>>>(column_);
    }

    PerValueType<std::variant> column_;
    std::vector<bool> present_;  // which logical indices exist
};

class ValueStore {
public:
    using Slot = std::uint32_t;

    ValueStore() = default;
    ValueStore(const ValueStore& other);
    ValueStore& operator=(const ValueStore& other);
    ValueStore(ValueStore&&) noexcept = default;
    ValueStore& operator=(ValueStore&&) noexcept = default;
    ~ValueStore() = default;

    // A new slot of `type` holding `value` (which holds that type's alternative).
    Slot add(ValueType type, const Value& value);
    // A new array attribute, without elements.
    Slot addArray();

    template <class T>
    T& get(Slot slot)
    {
        if constexpr (std::is_same_v<T, bool>) return std::get<std::vector<BoolCell>>(pools_)[slot].value;
        else return std::get<std::vector<T>>(pools_)[slot];
    }
    template <class T>
    const T& get(Slot slot) const
    {
        return const_cast<ValueStore*>(this)->get<T>(slot);
    }
    // The slot's value as a Value (messages, getValue, checked mode).
    Value value(ValueType type, Slot slot) const;
    // Assigns a Value holding the slot type's alternative; false when it holds another.
    bool assign(ValueType type, Slot slot, Value value);

    // Gives back what the pools hold past their size (they grow by doubling while a graph is built).
    void shrink();

    // An array attribute's elements: null until it has one; elements() makes them, of the attribute's type.
    const ArrayData* array(Slot slot) const { return arrays_[slot].get(); }
    ArrayData& elements(Slot slot, ValueType type);

private:
    PerValueType<std::tuple> pools_;
    std::vector<std::unique_ptr<ArrayData>> arrays_;
};

}  // namespace rig
