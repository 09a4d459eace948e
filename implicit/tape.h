#pragma once
/// @file Tapes: straight-line programs (single static assignment) of arithmetic on x, y, z.
/// Algebraic expressions and implicit models in the SSA text format of the Prospero challenge,
/// fidget and MPR compile to tapes. A tape evaluates in batches (one loop per instruction over a
/// block of points), bounds itself over boxes by interval arithmetic, and simplifies itself over
/// a box: min/max nodes whose argument intervals do not overlap keep only the side that wins, and
/// what no longer reaches the output is dropped (what libfive and fidget call tape pruning).

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "implicit/field.h"

namespace isoforge::implicit {

enum class Op : std::uint8_t {
    Const,
    VarX,
    VarY,
    VarZ,
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    Neg,
    Square,
    Sqrt,
    Abs,
    Exp,
    Log,
    Sin,
    Cos,
};

struct Instruction {
    Op op = Op::Const;
    std::uint32_t a = 0, b = 0;  ///< argument instructions (earlier in the tape)
    float imm = 0.f;             ///< the constant of Const
};

class Tape {
public:
    /// Takes instructions in SSA order; the last one is the output.
    /// @throw std::invalid_argument if an argument refers forward or the tape is empty.
    explicit Tape(std::vector<Instruction> code);

    std::size_t size() const { return code_.size(); }
    const std::vector<Instruction>& code() const { return code_; }
    std::size_t registers() const { return slots_; }

    float eval(const glm::vec3& p) const;
    /// Values at points, in chunks of up to 256 with per-thread scratch.
    void eval(std::span<const glm::vec3> p, std::span<float> out) const;
    Interval eval(const Box3& box) const;
    /// The tape restricted to `box`, or nullptr when nothing can be dropped there; `bound`, when
    /// given, receives eval(box), which the same pass computes.
    std::shared_ptr<const Tape> simplify(const Box3& box, Interval* bound = nullptr) const;
    /// A bound on the length of the tape's gradient everywhere (its Lipschitz constant) from its
    /// structure alone (lipschitzBound); infinity when none is known. Computed on first use.
    float lipschitz() const;

private:
    void evalChunk(const glm::vec3* p, float* out, std::size_t n, float* regs) const;
    std::vector<Instruction> code_;
    std::vector<std::uint32_t> slot_;  ///< register of each instruction's result
    std::size_t slots_ = 0;
    mutable std::atomic<float> lipschitz_{-1.f};  ///< negative until computed
};

/// A bound on the gradient's length of the function `code` computes, over all of space: exact for
/// affine values, norms of affine vectors (sqrt(dx^2 + dy^2 + dz^2): 1) and their min, max, sums and
/// scalings; infinity where a node has none (squares, products, exp, log). implicit/lipschitz.cpp.
float lipschitzBound(const std::vector<Instruction>& code);

/// A Field evaluated by a tape, bounded by a box (unbounded unless given).
FieldPtr makeTapeField(std::shared_ptr<const Tape> tape, const Box3& bounds, std::string description);

/// Compiles "x^4 - 5*x^2 + ..." : + - * / ^ (integer powers), unary minus, parentheses, numbers,
/// x y z, pi, and sqrt abs exp log sin cos (one argument), min max (two).
/// @throw ParseError with the column and what was expected.
std::shared_ptr<const Tape> parseExpression(std::string_view text);

/// Reads the SSA text format: one `_id op args` statement a line, `#` comments; ops const var-x
/// var-y var-z add sub mul div min max neg square sqrt abs exp ln sin cos. The last statement is
/// the output. @throw ParseError naming file:line:column and what was expected.
std::shared_ptr<const Tape> parseVm(std::string_view text, const std::string& fileName);
std::shared_ptr<const Tape> readVmFile(const std::string& path);

}  // namespace isoforge::implicit
