#pragma once
// setAttr values and addAttr declarations of a Maya scene turned into this engine's values and attributes
// (docs/maya.md): numbers in the file's units (its currentUnit) become cm and radians, Maya's row-vector matrices
// become column-vector ones, yes/no/on/off become booleans.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "graph/attribute.h"
#include "graph/maya/ma_scene.h"
#include "graph/value.h"

namespace rig::maya {

// A Maya attribute path split: name[first:last].child (".tg[0].tt", ".ktv[0:5]"); not valid for a malformed one or
// an index past maxIndex (Maya's multi indices are dense here: a hostile index must not allocate).
struct AttrPath {
    std::string name;
    int first = -1, last = -1;
    std::string child;
    int childIndex = -1;
    bool valid = true;
    static constexpr int maxIndex = 1 << 16;
};
AttrPath splitAttr(std::string_view text);

// Reads values from a setAttr's words, from `pos` on, advancing it. Throws rig::Error with the message only.
class ValueReader {
public:
    ValueReader(const std::vector<Word>& words, const Units& units) : words_(words), units_(units) {}
    bool done() const { return pos_ >= words_.size(); }
    // One value of `type` for an attribute of `unit` (numbers scaled to cm and radians).
    Value read(ValueType type, Unit unit);

private:
    double number();
    const std::vector<Word>& words_;
    const Units& units_;
    std::size_t pos_ = 0;
};

// The factor from a number in the file to the stored value of an attribute of `unit`.
double fileFactor(Unit unit, const Units& units);

// The attribute an addAttr declares, or nothing for what this engine does not store (messages, generic compounds);
// `children` are the addAttr statements that follow it (a double3's three children, which name its components).
std::optional<AttributeSpec> dynamicAttribute(const AddAttr& add, const std::vector<AddAttr>& children,
                                              const Units& units);

}  // namespace rig::maya
