#include "graph/node.h"

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

int childIndex(const AttributeSpec& spec, std::string_view name)
{
    if (spec.type != ValueType::Vector3) return -1;
    for (int i = 0; i < 3; ++i)
        if (spec.childNames[static_cast<std::size_t>(i)] == name) return i;
    return -1;
}

int mayaChildIndex(const AttributeSpec& spec, std::string_view name)
{
    if (spec.type != ValueType::Vector3) return -1;
    for (std::size_t i = 0; i < 3; ++i)
        if (spec.childNames[i] == name || (!spec.childShortNames[i].empty() && spec.childShortNames[i] == name))
            return static_cast<int>(i);
    return -1;
}

ValueStore::Slot ComputeContext::inputSlot(AttrId a, bool array) const
{
    // Maya's rule: compute reads only its own node's inputs.
    const auto i = static_cast<std::size_t>(a);
    if (a < 0 || i >= specs_.size() || !specs_[i].input || specs_[i].array != array)
        throw internalError(fmt::format("node '{}': compute read attribute {} which is not one of its {}inputs",
                                        *nodeName_, a, array ? "array " : ""));
    return slots_[i];
}

void ComputeContext::wrongType(AttrId a) const
{
    throw internalError(fmt::format("node '{}': compute read attribute {} as another type than its {}", *nodeName_, a,
                                    valueTypeName(specs_[static_cast<std::size_t>(a)].type)));
}

void ComputeContext::setOutput(AttrId a, Value value)
{
    const auto i = static_cast<std::size_t>(a);
    if (a < 0 || i >= specs_.size() || specs_[i].input || specs_[i].array ||
        !store_.assign(specs_[i].type, slots_[i], std::move(value)))
        throw internalError(fmt::format(
            "node '{}': compute wrote attribute {} which is not a plain output of that type", *nodeName_, a));
}

void ComputeContext::setOutputElements(AttrId a, std::vector<Value> elements)
{
    const auto i = static_cast<std::size_t>(a);
    if (a < 0 || i >= specs_.size() || specs_[i].input || !specs_[i].array)
        throw internalError(
            fmt::format("node '{}': compute wrote attribute {} which is not an array output", *nodeName_, a));
    visitValueType(specs_[i].type, [&]<class T>(std::type_identity<T>) {
        for (const Value& v : elements)
            if (!std::holds_alternative<T>(v))
                throw internalError(
                    fmt::format("node '{}': compute wrote an element of attribute {} as another type "
                                "than its {}",
                                *nodeName_, a, valueTypeName(specs_[i].type)));
        store_.elements(slots_[i], specs_[i].type).assign<T>(elements.size(), [&](Cell<T>& cell, std::size_t k) {
            if constexpr (std::is_same_v<T, bool>) cell.value = std::get<bool>(elements[k]);
            else cell = std::move(std::get<T>(elements[k]));
        });
    });
}

template <class T>
void ComputeContext::assignElements(AttrId a, std::span<const T> elements)
{
    const auto i = static_cast<std::size_t>(a);
    if (a < 0 || i >= specs_.size() || specs_[i].input || !specs_[i].array || !holds<T>(specs_[i].type))
        throw internalError(fmt::format(
            "node '{}': compute wrote attribute {} which is not an array output of that type", *nodeName_, a));
    store_.elements(slots_[i], specs_[i].type).assign<T>(elements.size(), [&](T& cell, std::size_t k) {
        cell = elements[k];
    });
}

void ComputeContext::assignOutputElements(AttrId a, std::span<const double> elements) { assignElements(a, elements); }

void ComputeContext::assignOutputElements(AttrId a, std::span<const Eigen::Matrix4d> elements)
{
    assignElements(a, elements);
}

}  // namespace rig
