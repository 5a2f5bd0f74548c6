#include "graph/value_store.h"

namespace rig {

ValueStore::ValueStore(const ValueStore& other) : pools_(other.pools_)
{
    arrays_.reserve(other.arrays_.size());
    for (const auto& a : other.arrays_) arrays_.push_back(a ? std::make_unique<ArrayData>(*a) : nullptr);
}

ValueStore& ValueStore::operator=(const ValueStore& other)
{
    if (this != &other) *this = ValueStore(other);
    return *this;
}

ValueStore::Slot ValueStore::add(ValueType type, const Value& value)
{
    return visitValueType(type, [&]<class T>(std::type_identity<T>) {
        if constexpr (std::is_same_v<T, bool>) {
            auto& pool = std::get<std::vector<BoolCell>>(pools_);
            pool.push_back({std::get<bool>(value)});
            return static_cast<Slot>(pool.size() - 1);
        } else {
            auto& pool = std::get<std::vector<T>>(pools_);
            pool.push_back(std::get<T>(value));
            return static_cast<Slot>(pool.size() - 1);
        }
    });
}

void ValueStore::shrink()
{
    std::apply([](auto&... pool) { (pool.shrink_to_fit(), ...); }, pools_);
    arrays_.shrink_to_fit();
}

ValueStore::Slot ValueStore::addArray()
{
    arrays_.emplace_back();
    return static_cast<Slot>(arrays_.size() - 1);
}

Value ValueStore::value(ValueType type, Slot slot) const
{
    return visitValueType(type, [&]<class T>(std::type_identity<T>) { return Value(get<T>(slot)); });
}

bool ValueStore::assign(ValueType type, Slot slot, Value value)
{
    return visitValueType(type, [&]<class T>(std::type_identity<T>) {
        T* v = std::get_if<T>(&value);
        if (!v) return false;
        get<T>(slot) = std::move(*v);
        return true;
    });
}

ArrayData& ValueStore::elements(Slot slot, ValueType type)
{
    std::unique_ptr<ArrayData>& a = arrays_[slot];
    if (!a) a = std::make_unique<ArrayData>(type);
    return *a;
}

ArrayData::ArrayData(ValueType type)
{
    visitValueType(type, [&]<class T>(std::type_identity<T>) { column_.emplace<std::vector<Cell<T>>>(); });
}

Value ArrayData::value(std::size_t i) const
{
    return std::visit(
        [&](const auto& c) -> Value {
            const auto& x = c[i];
            if constexpr (std::is_same_v<std::decay_t<decltype(x)>, BoolCell>) return x.value;
            else return x;
        },
        column_);
}

void ArrayData::make(std::size_t i, const Value& fallback)
{
    std::visit(
        [&](auto& c) {
            using C = typename std::decay_t<decltype(c)>::value_type;
            if (i >= c.size()) {
                if constexpr (std::is_same_v<C, BoolCell>) c.resize(i + 1, BoolCell{std::get<bool>(fallback)});
                else c.resize(i + 1, std::get<C>(fallback));
            }
        },
        column_);
    if (i >= present_.size()) present_.resize(i + 1, false);
    // Read before written: a pull makes its element every frame, and a line only read is not written back.
    if (!present_[i]) present_[i] = true;
}

bool ArrayData::sameAs(const ArrayData& other) const
{
    if (present_ != other.present_) return false;
    for (std::size_t i = 0; i < present_.size(); ++i)
        if (present_[i] && !bitEqual(value(i), other.value(i))) return false;
    return true;
}

}  // namespace rig
