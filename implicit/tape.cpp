#include "implicit/tape.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "core/error.h"

namespace isoforge::implicit {

namespace {

int arity(Op op) {
    switch (op) {
        case Op::Const:
        case Op::VarX:
        case Op::VarY:
        case Op::VarZ:
            return 0;
        case Op::Add:
        case Op::Sub:
        case Op::Mul:
        case Op::Div:
        case Op::Min:
        case Op::Max:
            return 2;
        default:
            return 1;
    }
}

constexpr std::size_t kChunk = 256;

}  // namespace

Tape::Tape(std::vector<Instruction> code) : code_(std::move(code)) {
    if (code_.empty()) throw std::invalid_argument("tape: no instructions");
    // Liveness: the last use of every value; the output lives to the end.
    std::vector<std::uint32_t> lastUse(code_.size(), 0);
    for (std::uint32_t i = 0; i < code_.size(); ++i) {
        const Instruction& in = code_[i];
        const int n = arity(in.op);
        if ((n >= 1 && in.a >= i) || (n >= 2 && in.b >= i))
            throw std::invalid_argument("tape: argument refers forward");
        if (n >= 1) lastUse[in.a] = i;
        if (n >= 2) lastUse[in.b] = i;
    }
    lastUse.back() = static_cast<std::uint32_t>(code_.size());
    // Linear-scan register allocation: a register is free once its value's last reader has read it
    // (elementwise evaluation lets a result overwrite an argument that dies in the same instruction).
    slot_.resize(code_.size());
    std::vector<std::uint32_t> free;
    for (std::uint32_t i = 0; i < code_.size(); ++i) {
        const Instruction& in = code_[i];
        const int n = arity(in.op);
        if (n >= 1 && lastUse[in.a] == i) free.push_back(slot_[in.a]);
        if (n >= 2 && lastUse[in.b] == i && in.b != in.a) free.push_back(slot_[in.b]);
        if (!free.empty()) {
            slot_[i] = free.back();
            free.pop_back();
        } else {
            slot_[i] = static_cast<std::uint32_t>(slots_++);
        }
        if (lastUse[i] == 0 && i + 1 != code_.size()) {  // never read: free at once
            free.push_back(slot_[i]);
        }
    }
}

float Tape::eval(const glm::vec3& p) const {
    // One point: scalar registers side by side (a chunk's registers are 256 floats apart), the same
    // operations as evalChunk's, so the same results bit for bit.
    thread_local std::vector<float> regs;
    if (regs.size() < slots_) regs.resize(slots_);
    float* r = regs.data();
    for (std::size_t i = 0; i < code_.size(); ++i) {
        const Instruction& in = code_[i];
        const float a = r[slot_[in.a]], b = r[slot_[in.b]];
        float v = 0.f;
        switch (in.op) {
            case Op::Const:
                v = in.imm;
                break;
            case Op::VarX:
                v = p.x;
                break;
            case Op::VarY:
                v = p.y;
                break;
            case Op::VarZ:
                v = p.z;
                break;
            case Op::Add:
                v = a + b;
                break;
            case Op::Sub:
                v = a - b;
                break;
            case Op::Mul:
                v = a * b;
                break;
            case Op::Div:
                v = a / b;
                break;
            case Op::Min:
                v = std::min(a, b);
                break;
            case Op::Max:
                v = std::max(a, b);
                break;
            case Op::Neg:
                v = -a;
                break;
            case Op::Square:
                v = a * a;
                break;
            case Op::Sqrt:
                v = std::sqrt(a);
                break;
            case Op::Abs:
                v = std::abs(a);
                break;
            case Op::Exp:
                v = std::exp(a);
                break;
            case Op::Log:
                v = std::log(a);
                break;
            case Op::Sin:
                v = std::sin(a);
                break;
            case Op::Cos:
                v = std::cos(a);
                break;
        }
        r[slot_[i]] = v;
    }
    return r[slot_.back()];
}

void Tape::eval(std::span<const glm::vec3> p, std::span<float> out) const {
    thread_local std::vector<float> regs;
    if (regs.size() < slots_ * kChunk) regs.resize(slots_ * kChunk);
    for (std::size_t i = 0; i < p.size(); i += kChunk)
        evalChunk(p.data() + i, out.data() + i, std::min(kChunk, p.size() - i), regs.data());
}

void Tape::evalChunk(const glm::vec3* p, float* out, std::size_t n, float* regs) const {
    for (std::size_t i = 0; i < code_.size(); ++i) {
        const Instruction& in = code_[i];
        float* r = regs + slot_[i] * kChunk;
        const float* a = regs + slot_[in.a] * kChunk;
        const float* b = regs + slot_[in.b] * kChunk;
        switch (in.op) {
            case Op::Const:
                std::fill(r, r + n, in.imm);
                break;
            case Op::VarX:
                for (std::size_t k = 0; k < n; ++k) r[k] = p[k].x;
                break;
            case Op::VarY:
                for (std::size_t k = 0; k < n; ++k) r[k] = p[k].y;
                break;
            case Op::VarZ:
                for (std::size_t k = 0; k < n; ++k) r[k] = p[k].z;
                break;
            case Op::Add:
                for (std::size_t k = 0; k < n; ++k) r[k] = a[k] + b[k];
                break;
            case Op::Sub:
                for (std::size_t k = 0; k < n; ++k) r[k] = a[k] - b[k];
                break;
            case Op::Mul:
                for (std::size_t k = 0; k < n; ++k) r[k] = a[k] * b[k];
                break;
            case Op::Div:
                for (std::size_t k = 0; k < n; ++k) r[k] = a[k] / b[k];
                break;
            case Op::Min:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::min(a[k], b[k]);
                break;
            case Op::Max:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::max(a[k], b[k]);
                break;
            case Op::Neg:
                for (std::size_t k = 0; k < n; ++k) r[k] = -a[k];
                break;
            case Op::Square:
                for (std::size_t k = 0; k < n; ++k) r[k] = a[k] * a[k];
                break;
            case Op::Sqrt:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::sqrt(a[k]);
                break;
            case Op::Abs:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::abs(a[k]);
                break;
            case Op::Exp:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::exp(a[k]);
                break;
            case Op::Log:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::log(a[k]);
                break;
            case Op::Sin:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::sin(a[k]);
                break;
            case Op::Cos:
                for (std::size_t k = 0; k < n; ++k) r[k] = std::cos(a[k]);
                break;
        }
    }
    const float* r = regs + slot_.back() * kChunk;
    std::copy(r, r + n, out);
}

float Tape::lipschitz() const {
    float L = lipschitz_.load(std::memory_order_relaxed);
    if (L < 0.f) {  // two threads may both compute it: the same number
        L = lipschitzBound(code_);
        lipschitz_.store(L, std::memory_order_relaxed);
    }
    return L;
}

namespace {
Interval evalOne(const Instruction& in, Interval a, Interval b, const Box3& box) {
    switch (in.op) {
        case Op::Const:
            return Interval(in.imm);
        case Op::VarX:
            return {box.min.x, box.max.x};
        case Op::VarY:
            return {box.min.y, box.max.y};
        case Op::VarZ:
            return {box.min.z, box.max.z};
        case Op::Add:
            return a + b;
        case Op::Sub:
            return a - b;
        case Op::Mul:
            return a * b;
        case Op::Div:
            return a / b;
        case Op::Min:
            return min(a, b);
        case Op::Max:
            return max(a, b);
        case Op::Neg:
            return -a;
        case Op::Square:
            return square(a);
        case Op::Sqrt:
            return sqrt(a);
        case Op::Abs:
            return abs(a);
        case Op::Exp:
            return exp(a);
        case Op::Log:
            return log(a);
        case Op::Sin:
            return sin(a);
        case Op::Cos:
            return cos(a);
    }
    return Interval::everything();
}
}  // namespace

Interval Tape::eval(const Box3& box) const {
    thread_local std::vector<Interval> regs;
    if (regs.size() < slots_) regs.resize(slots_);
    for (std::size_t i = 0; i < code_.size(); ++i) {
        const Instruction& in = code_[i];
        regs[slot_[i]] = evalOne(in, regs[slot_[in.a]], regs[slot_[in.b]], box);
    }
    const Interval r = regs[slot_.back()];
    if (std::isnan(r.lo) || std::isnan(r.hi)) return Interval::everything();
    return r;
}

namespace {
/// Nested mins (or maxes) whose inner nodes are used only by their parent are one n-ary min over
/// their leaves: a leaf whose lowest value exceeds the lowest highest value among all the leaves
/// never wins in the box. Pairwise choices miss that in a chain min(min(min(a, b), c), d) whose
/// first leaves are all far: each pair overlaps, though all lose to a near one further on (a union
/// of many spheres as a .vm model). Sets `choice` (1: keep a, 2: keep b) on the tree's nodes so that
/// only live leaves stay reachable; returns whether it set any.
bool pruneMinMaxTrees(const std::vector<Instruction>& code, const std::vector<Interval>& iv,
                      std::vector<std::uint8_t>& choice) {
    const std::size_t n = code.size();
    thread_local std::vector<std::uint32_t> uses, root;
    thread_local std::vector<float> best;
    thread_local std::vector<std::uint8_t> dead;
    uses.assign(n, 0);
    for (const Instruction& in : code) {
        const int ar = arity(in.op);
        if (ar >= 1) ++uses[in.a];
        if (ar >= 2) ++uses[in.b];
    }
    const auto isMinMax = [&](std::size_t i) { return code[i].op == Op::Min || code[i].op == Op::Max; };
    // An operand that belongs to its user's tree: the same operation, used only there.
    const auto inner = [&](std::size_t user, std::uint32_t x) { return code[x].op == code[user].op && uses[x] == 1; };
    constexpr std::uint32_t kNone = ~0u;
    root.assign(n, kNone);
    best.assign(n, 0.f);
    bool any = false;
    // Backwards: each tree's root first, then its inner nodes; the best bound over its leaves.
    for (std::size_t i = n; i-- > 0;) {
        if (!isMinMax(i)) continue;
        if (root[i] == kNone) {
            root[i] = static_cast<std::uint32_t>(i);
            best[i] = code[i].op == Op::Min ? std::numeric_limits<float>::infinity()
                                            : -std::numeric_limits<float>::infinity();
        }
        const std::uint32_t r = root[i];
        for (const std::uint32_t x : {code[i].a, code[i].b}) {
            if (inner(i, x))
                root[x] = r;
            else
                best[r] = code[i].op == Op::Min ? std::min(best[r], iv[x].hi) : std::max(best[r], iv[x].lo);
        }
    }
    // Forwards (operands before users): which subtrees hold only leaves that cannot win.
    dead.assign(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
        if (!isMinMax(i)) continue;
        const std::uint32_t r = root[i];
        const bool isMin = code[i].op == Op::Min;
        auto loses = [&](std::uint32_t x) {
            if (inner(i, x)) return dead[x] != 0;
            return isMin ? iv[x].lo > best[r] : iv[x].hi < best[r];
        };
        const bool a = loses(code[i].a), b = loses(code[i].b);
        dead[i] = a && b;
        if (choice[i] == 0 && a != b) {
            choice[i] = a ? 2 : 1;
            any = true;
        }
    }
    return any;
}
}  // namespace

std::shared_ptr<const Tape> Tape::simplify(const Box3& box, Interval* bound) const {
    const std::size_t n = code_.size();
    thread_local std::vector<Interval> iv;
    thread_local std::vector<std::uint8_t> choice;  // 0: both, 1: a only, 2: b only
    iv.resize(n);
    choice.assign(n, 0);
    bool anyChoice = false;
    for (std::size_t i = 0; i < n; ++i) {
        const Instruction& in = code_[i];
        const Interval a = iv[in.a], b = iv[in.b];
        iv[i] = evalOne(in, a, b, box);
        if (in.op == Op::Min || in.op == Op::Max) {
            const bool aBelow = a.hi < b.lo, bBelow = b.hi < a.lo;
            if (aBelow || bBelow) {
                choice[i] = (in.op == Op::Min) == aBelow ? 1 : 2;
                anyChoice = true;
            }
        }
    }
    if (bound) {
        *bound = iv[n - 1];
        if (std::isnan(bound->lo) || std::isnan(bound->hi)) *bound = Interval::everything();
    }
    anyChoice = pruneMinMaxTrees(code_, iv, choice) || anyChoice;
    if (!anyChoice) return nullptr;
    // Backwards: what the output still needs; decided min/max nodes pass through one argument.
    std::vector<std::uint8_t> alive(n, 0);
    alive[n - 1] = 1;
    for (std::size_t i = n; i-- > 0;) {
        if (!alive[i]) continue;
        const Instruction& in = code_[i];
        const int ar = arity(in.op);
        if (choice[i] == 1)
            alive[in.a] = 1;
        else if (choice[i] == 2)
            alive[in.b] = 1;
        else {
            if (ar >= 1) alive[in.a] = 1;
            if (ar >= 2) alive[in.b] = 1;
        }
    }
    std::vector<std::uint32_t> remap(n, 0);
    std::vector<Instruction> out;
    out.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        if (!alive[i]) continue;
        Instruction in = code_[i];
        if (choice[i]) {
            remap[i] = remap[choice[i] == 1 ? in.a : in.b];
            continue;
        }
        const int ar = arity(in.op);
        if (ar >= 1) in.a = remap[in.a];
        if (ar >= 2) in.b = remap[in.b];
        if (ar == 0) in.a = in.b = 0;
        remap[i] = static_cast<std::uint32_t>(out.size());
        out.push_back(in);
    }
    // The output must be the last instruction: if it became an alias, copy it through an identity.
    if (remap[n - 1] + 1 != out.size()) {
        const std::uint32_t src = remap[n - 1];
        out.push_back({Op::Min, src, src, 0.f});
    }
    if (out.size() >= n) return nullptr;
    return std::make_shared<const Tape>(std::move(out));
}

// -------------------------------------------------------------------------------------------------
namespace {

class TapeField final : public Field {
public:
    TapeField(std::shared_ptr<const Tape> t, const Box3& b, std::string d)
        : tape_(std::move(t)), bounds_(b), description_(std::move(d)) {}
    float value(const glm::vec3& p) const override { return tape_->eval(p); }
    void values(std::span<const glm::vec3> p, std::span<float> out) const override { tape_->eval(p, out); }
    Interval bound(const Box3& box) const override { return tape_->eval(box); }
    Box3 bounds() const override { return bounds_; }
    bool isDistance() const override { return false; }
    float gradientBound() const override { return tape_->lipschitz(); }
    FieldPtr simplify(const Box3& box) const override {
        auto t = tape_->simplify(box);
        return t ? std::make_shared<TapeField>(std::move(t), bounds_, description_) : nullptr;
    }
    /// One pass gives both: simplify's forward pass is the interval evaluation.
    Pruned prune(const Box3& box) const override {
        Interval b;
        auto t = tape_->simplify(box, &b);
        return {t ? std::make_shared<TapeField>(std::move(t), bounds_, description_) : nullptr, b};
    }
    std::string describe() const override {
        return description_ + " (" + std::to_string(tape_->size()) + " instructions)";
    }

private:
    std::shared_ptr<const Tape> tape_;
    Box3 bounds_;
    std::string description_;
};

/// Builds tapes with common constants and variables shared.
class TapeBuilder {
public:
    std::uint32_t push(Instruction in) {
        code.push_back(in);
        return static_cast<std::uint32_t>(code.size() - 1);
    }
    std::uint32_t constant(float v) { return push({Op::Const, 0, 0, v}); }
    std::uint32_t unary(Op op, std::uint32_t a) { return push({op, a, 0, 0.f}); }
    std::uint32_t binary(Op op, std::uint32_t a, std::uint32_t b) { return push({op, a, b, 0.f}); }
    std::uint32_t power(std::uint32_t base, long n) {
        if (n == 0) return constant(1.f);
        if (n < 0) return binary(Op::Div, constant(1.f), power(base, -n));
        if (n == 1) return base;
        if (n == 2) return unary(Op::Square, base);
        const std::uint32_t half = unary(Op::Square, power(base, n / 2));
        return n % 2 ? binary(Op::Mul, half, base) : half;
    }
    std::vector<Instruction> code;
};

class ExpressionParser {
public:
    explicit ExpressionParser(std::string_view t) : text_(t) {}
    std::vector<Instruction> parse() {
        skip();
        if (pos_ >= text_.size()) fail("expected an expression, found nothing");
        expression();
        skip();
        if (pos_ < text_.size()) fail("expected an operator or the end, found '" + std::string(1, text_[pos_]) + "'");
        return std::move(b_.code);
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        throw ParseError("expression:1:" + std::to_string(pos_ + 1) + ": " + what + "\n  " + std::string(text_) +
                         "\n  " + std::string(pos_, ' ') + "^");
    }
    void skip() {
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    }
    bool accept(char c) {
        skip();
        if (pos_ < text_.size() && text_[pos_] == c) {
            ++pos_;
            return true;
        }
        return false;
    }
    std::uint32_t expression() {
        // Every nesting (parentheses, function arguments) passes here: bounded, so that no input can run the
        // recursion off the stack (fuzz_expression found a run of 4,000 signs, read recursively then).
        if (++depth_ > kMaxNesting) fail("expression nested more than " + std::to_string(kMaxNesting) + " deep");
        struct Leave {
            int& depth;
            ~Leave() { --depth; }
        } leave{depth_};
        std::uint32_t v = term();
        for (;;) {
            if (accept('+'))
                v = b_.binary(Op::Add, v, term());
            else if (accept('-'))
                v = b_.binary(Op::Sub, v, term());
            else
                return v;
        }
    }
    std::uint32_t term() {
        std::uint32_t v = unary();
        for (;;) {
            if (accept('*'))
                v = b_.binary(Op::Mul, v, unary());
            else if (accept('/'))
                v = b_.binary(Op::Div, v, unary());
            else
                return v;
        }
    }
    std::uint32_t unary() {
        // A run of signs in a loop: an odd number of '-' negates once.
        bool negate = false;
        for (;;) {
            if (accept('-'))
                negate = !negate;
            else if (!accept('+'))
                break;
        }
        const std::uint32_t v = power();
        return negate ? b_.unary(Op::Neg, v) : v;
    }
    std::uint32_t power() {
        const std::uint32_t base = primary();
        if (!accept('^')) return base;
        skip();
        const std::size_t at = pos_;
        bool negative = accept('-');
        skip();
        long n = 0;
        auto [p, ec] = std::from_chars(text_.data() + pos_, text_.data() + text_.size(), n);
        if (ec != std::errc() || (p < text_.data() + text_.size() && (*p == '.' || *p == 'e'))) {
            pos_ = at;
            fail("expected an integer exponent after '^' (only integer powers are supported)");
        }
        if (n > 64) {
            pos_ = at;
            fail("exponent too large (at most 64)");
        }
        pos_ = static_cast<std::size_t>(p - text_.data());
        return b_.power(base, negative ? -n : n);
    }
    std::uint32_t primary() {
        skip();
        if (pos_ >= text_.size()) fail("expected a number, x, y, z, a function or '(', found the end");
        const char c = text_[pos_];
        if (accept('(')) {
            const std::uint32_t v = expression();
            if (!accept(')')) fail("expected ')'");
            return v;
        }
        if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
            float v = 0;
            auto [p, ec] = std::from_chars(text_.data() + pos_, text_.data() + text_.size(), v);
            if (ec != std::errc()) fail("expected a number");
            pos_ = static_cast<std::size_t>(p - text_.data());
            return b_.constant(v);
        }
        if (std::isalpha(static_cast<unsigned char>(c))) {
            const std::size_t start = pos_;
            while (pos_ < text_.size() && std::isalnum(static_cast<unsigned char>(text_[pos_]))) ++pos_;
            const std::string name(text_.substr(start, pos_ - start));
            if (name == "x") return b_.push({Op::VarX});
            if (name == "y") return b_.push({Op::VarY});
            if (name == "z") return b_.push({Op::VarZ});
            if (name == "pi") return b_.constant(3.14159265358979f);
            static const std::unordered_map<std::string, Op> unaryOps = {{"sqrt", Op::Sqrt}, {"abs", Op::Abs},
                                                                         {"exp", Op::Exp},   {"log", Op::Log},
                                                                         {"sin", Op::Sin},   {"cos", Op::Cos}};
            auto u = unaryOps.find(name);
            const bool isBinary = name == "min" || name == "max";
            if (u == unaryOps.end() && !isBinary) {
                pos_ = start;
                fail("unknown name '" + name + "' (expected x, y, z, pi, sqrt, abs, exp, log, sin, cos, min, max)");
            }
            if (!accept('(')) fail("expected '(' after " + name);
            const std::uint32_t a = expression();
            if (isBinary) {
                if (!accept(',')) fail(name + " takes two arguments: expected ','");
                const std::uint32_t b = expression();
                if (!accept(')')) fail("expected ')'");
                return b_.binary(name == "min" ? Op::Min : Op::Max, a, b);
            }
            if (!accept(')')) fail("expected ')' (" + name + " takes one argument)");
            return b_.unary(u->second, a);
        }
        fail("expected a number, x, y, z, a function or '(', found '" + std::string(1, c) + "'");
    }
    std::string_view text_;
    static constexpr int kMaxNesting = 500;
    std::size_t pos_ = 0;
    int depth_ = 0;
    TapeBuilder b_;
};

}  // namespace

FieldPtr makeTapeField(std::shared_ptr<const Tape> tape, const Box3& bounds, std::string description) {
    return std::make_shared<TapeField>(std::move(tape), bounds, std::move(description));
}

std::shared_ptr<const Tape> parseExpression(std::string_view text) {
    return std::make_shared<const Tape>(ExpressionParser(text).parse());
}

std::shared_ptr<const Tape> parseVm(std::string_view text, const std::string& file) {
    static const std::unordered_map<std::string_view, Op> ops = {
        {"const", Op::Const}, {"var-x", Op::VarX},    {"var-y", Op::VarY}, {"var-z", Op::VarZ}, {"add", Op::Add},
        {"sub", Op::Sub},     {"mul", Op::Mul},       {"div", Op::Div},    {"min", Op::Min},    {"max", Op::Max},
        {"neg", Op::Neg},     {"square", Op::Square}, {"sqrt", Op::Sqrt},  {"abs", Op::Abs},    {"exp", Op::Exp},
        {"ln", Op::Log},      {"sin", Op::Sin},       {"cos", Op::Cos}};
    std::unordered_map<std::string, std::uint32_t> ids;
    std::vector<Instruction> code;
    std::size_t lineNo = 0, start = 0;
    while (start <= text.size()) {
        std::size_t end = text.find('\n', start);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(start, end - start);
        ++lineNo;
        const std::size_t lineStart = start;
        start = end + 1;
        if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
        // Tokens with their columns.
        std::vector<std::pair<std::string_view, std::size_t>> tok;
        for (std::size_t i = 0; i < line.size();) {
            while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
            const std::size_t b = i;
            while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
            if (i > b) tok.emplace_back(line.substr(b, i - b), b + 1);
        }
        (void)lineStart;
        if (tok.empty()) continue;
        auto fail = [&](std::size_t col, const std::string& what) -> void {
            throw ParseError(file + ":" + std::to_string(lineNo) + ":" + std::to_string(col) + ": " + what);
        };
        if (tok.size() < 2)
            fail(tok[0].second, "expected '<id> <op> <args>', found only '" + std::string(tok[0].first) + "'");
        const auto op = ops.find(tok[1].first);
        if (op == ops.end())
            fail(tok[1].second,
                 "unknown op '" + std::string(tok[1].first) +
                     "' (expected const var-x var-y var-z add sub mul div min max neg square sqrt abs exp ln sin cos)");
        Instruction in{op->second};
        const int n = op->second == Op::Const ? 1 : arity(op->second);
        if (static_cast<int>(tok.size()) - 2 != n)
            fail(tok[1].second, "'" + std::string(tok[1].first) + "' takes " + std::to_string(n) + " argument" +
                                    (n == 1 ? "" : "s") + ", found " + std::to_string(tok.size() - 2));
        if (op->second == Op::Const) {
            auto [p, ec] = std::from_chars(tok[2].first.data(), tok[2].first.data() + tok[2].first.size(), in.imm);
            if (ec != std::errc() || p != tok[2].first.data() + tok[2].first.size() || !std::isfinite(in.imm))
                fail(tok[2].second, "expected a number, found '" + std::string(tok[2].first) + "'");
        } else {
            for (int k = 0; k < n; ++k) {
                auto it = ids.find(std::string(tok[2 + k].first));
                if (it == ids.end())
                    fail(tok[2 + k].second, "unknown id '" + std::string(tok[2 + k].first) + "' (not defined above)");
                (k == 0 ? in.a : in.b) = it->second;
            }
        }
        if (!ids.emplace(std::string(tok[0].first), static_cast<std::uint32_t>(code.size())).second)
            fail(tok[0].second, "id '" + std::string(tok[0].first) + "' is defined twice");
        code.push_back(in);
    }
    if (code.empty()) throw ParseError(file + ":1:1: expected at least one statement");
    return std::make_shared<const Tape>(std::move(code));
}

std::shared_ptr<const Tape> readVmFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path + ": cannot open");
    std::stringstream s;
    s << in.rdbuf();
    return parseVm(s.str(), path);
}

}  // namespace isoforge::implicit
