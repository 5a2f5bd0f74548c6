#pragma once
// The arithmetic of Maya's expression node as rigs write it (docs/maya.md): the text Maya saves in a scene
// (the node's internal expression), whose statements read the node's inputs as .I[n] and write its outputs as
// .O[n]:
//
//   float $bend = .I[0] * 0.5;       // float variables (declared, or assigned before use)
//   .O[0] = clamp(-45, 45, $bend);   // assignments to outputs
//   .O[1] = sin(time * 6.2832) + frame / 100;
//
// Read: numbers, + - * / with C precedence, unary minus and plus, parentheses, .I[n] and .O[n] (an output reads
// what this evaluation assigned to it so far, 0 before), `time` (seconds) and `frame`, float variables, and the
// functions abs, ceil, floor, sqrt, exp, log, pow(x, y), sin, cos, tan, asin, acos, atan, atan2(y, x) (radians,
// as Maya's), min(a, b), max(a, b), clamp(low, high, x) (Maya's argument order), deg_to_rad, rad_to_deg, sign.
// Comments // and /* */. Anything else (MEL commands, getAttr/setAttr, if/else and loops, comparisons, strings,
// vectors, int variables, object.attribute names) is refused with an error naming the construct: a reader
// that met it would otherwise have to guess. The program is parsed once into a small stack machine.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rig {

class ExpressionProgram {
public:
    // Throws rig::Error "expression: line L: what" naming the construct it cannot read.
    static ExpressionProgram parse(std::string_view text);

    // The outputs .O[0 .. outputCount()-1] at these inputs (inputs[n] is .I[n]; a missing one reads 0), frame
    // and time in seconds. Outputs the text never assigns are 0.
    std::vector<double> evaluate(const std::vector<double>& inputs, double frame, double seconds) const;

    // One more than the highest .O[n] assigned (0 without assignments).
    int outputCount() const { return outputCount_; }

    enum class Code {
        constant,
        variable,
        inputElement,
        outputElement,
        time,
        frame,
        negate,
        add,
        subtract,
        multiply,
        divide,
        call,
        storeVariable,
        storeOutput
    };
    struct Instruction {
        Code code;
        double value = 0.0;  // constant
        int index = 0;       // variable slot, element index, function
        int arguments = 0;   // call
    };

private:
    friend class ExpressionParser;
    std::vector<Instruction> code_;
    int variableCount_ = 0;
    int outputCount_ = 0;
};

// Why `text` is not an expression this library evaluates (the error ExpressionProgram::parse would throw),
// or nullopt when it is one. A loader asks before wiring an expression node toward a joint.
std::optional<std::string> expressionUnsupported(const std::string& text);

}  // namespace rig
