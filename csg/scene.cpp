#include "csg/scene.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "core/error.h"
#include "csg/nodes.h"
#include "csg/shapes.h"
#include "implicit/blobby.h"
#include "implicit/primitives.h"
#include "implicit/quadric.h"
#include "implicit/tape.h"
#include "mesh/io.h"
#include "mesh/parametric.h"
#include "mesh/subdivide.h"
#include "volume/grid_field.h"

namespace isoforge::csg {

using implicit::Box3;

namespace {

// ---------------------------------------------------------------------------------------------
// Lexer
enum class Tok { Ident, Number, String, Punct, End };
struct Token {
    Tok kind = Tok::End;
    std::string text;
    double number = 0;
    int line = 0, col = 0;
};

/// Collected errors; thrown together at the end.
struct Diagnostics {
    std::string file;
    std::vector<std::string_view> lines;
    std::vector<std::string> errors;
    std::vector<Warning> warnings;

    void warn(int line, int col, const std::string& what) {
        Warning w;
        w.loc.file = file;
        w.loc.line = line;
        w.loc.column = col;
        w.message = what;
        warnings.push_back(std::move(w));
    }
    void error(int line, int col, const std::string& what) {
        if (errors.size() >= 20) return;
        std::string msg = file + ":" + std::to_string(line) + ":" + std::to_string(col) + ": " + what;
        if (line >= 1 && static_cast<std::size_t>(line) <= lines.size()) {
            // The line with a caret under the column; a long line is cut to 100 characters around it.
            std::string_view text = lines[static_cast<std::size_t>(line) - 1];
            std::size_t at = static_cast<std::size_t>(std::max(col - 1, 0));
            std::string head, tail;
            constexpr std::size_t kWindow = 100;
            if (text.size() > kWindow) {
                const std::size_t from = at > kWindow / 2 ? std::min(at - kWindow / 2, text.size() - kWindow) : 0;
                if (from > 0) head = "...";
                if (from + kWindow < text.size()) tail = "...";
                text = text.substr(from, kWindow);
                at = at - from + head.size();
            }
            std::string shown = head + std::string(text) + tail;
            for (char& c : shown)
                if (static_cast<unsigned char>(c) < 32 && c != '\t') c = '?';  // no control bytes on the terminal
            msg += "\n  " + shown + "\n  " + std::string(at, ' ') + "^";
        }
        errors.push_back(msg);
    }
};

class Lexer {
public:
    Lexer(std::string_view text, Diagnostics& d) : t_(text), d_(d) {}
    std::vector<Token> run() {
        std::vector<Token> out;
        for (;;) {
            skip();
            Token tok;
            tok.line = line_;
            tok.col = static_cast<int>(pos_ - lineStart_) + 1;
            if (pos_ >= t_.size()) {
                out.push_back(tok);
                return out;
            }
            const char c = t_[pos_];
            if (std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == '$') {
                const std::size_t b = pos_++;
                while (pos_ < t_.size() && (std::isalnum(static_cast<unsigned char>(t_[pos_])) || t_[pos_] == '_'))
                    ++pos_;
                tok.kind = Tok::Ident;
                tok.text = std::string(t_.substr(b, pos_ - b));
            } else if (std::isdigit(static_cast<unsigned char>(c)) ||
                       (c == '.' && pos_ + 1 < t_.size() && std::isdigit(static_cast<unsigned char>(t_[pos_ + 1])))) {
                auto [p, ec] = std::from_chars(t_.data() + pos_, t_.data() + t_.size(), tok.number);
                if (ec != std::errc()) {
                    d_.error(tok.line, tok.col, "malformed number");
                    ++pos_;
                    continue;
                }
                tok.kind = Tok::Number;
                tok.text = std::string(t_.substr(pos_, static_cast<std::size_t>(p - (t_.data() + pos_))));
                pos_ = static_cast<std::size_t>(p - t_.data());
            } else if (c == '"') {
                ++pos_;
                std::string s;
                while (pos_ < t_.size() && t_[pos_] != '"' && t_[pos_] != '\n') {
                    if (t_[pos_] == '\\' && pos_ + 1 < t_.size()) ++pos_;
                    s += t_[pos_++];
                }
                if (pos_ >= t_.size() || t_[pos_] != '"')
                    d_.error(tok.line, tok.col, "string not closed: expected '\"' before the end of the line");
                else
                    ++pos_;
                tok.kind = Tok::String;
                tok.text = s;
            } else {
                static const char* two[] = {"<=", ">=", "==", "!=", "&&", "||"};
                tok.kind = Tok::Punct;
                tok.text = std::string(1, c);
                for (const char* op : two)
                    if (t_.substr(pos_, 2) == op) tok.text = op;
                pos_ += tok.text.size();
                if (std::string_view("(){}[],;=+-*/%<>!?:#.&|^").find(c) == std::string_view::npos) {
                    d_.error(tok.line, tok.col, std::string("unexpected character '") + c + "'");
                    continue;
                }
            }
            out.push_back(tok);
        }
    }

private:
    void skip() {
        for (;;) {
            while (pos_ < t_.size() && std::isspace(static_cast<unsigned char>(t_[pos_]))) {
                if (t_[pos_] == '\n') {
                    ++line_;
                    lineStart_ = pos_ + 1;
                }
                ++pos_;
            }
            if (t_.substr(pos_, 2) == "//") {
                while (pos_ < t_.size() && t_[pos_] != '\n') ++pos_;
            } else if (t_.substr(pos_, 2) == "/*") {
                const int l = line_, c = static_cast<int>(pos_ - lineStart_) + 1;
                pos_ += 2;
                while (pos_ < t_.size() && t_.substr(pos_, 2) != "*/") {
                    if (t_[pos_] == '\n') {
                        ++line_;
                        lineStart_ = pos_ + 1;
                    }
                    ++pos_;
                }
                if (pos_ >= t_.size())
                    d_.error(l, c, "comment not closed: expected '*/'");
                else
                    pos_ += 2;
            } else {
                return;
            }
        }
    }
    std::string_view t_;
    Diagnostics& d_;
    std::size_t pos_ = 0, lineStart_ = 0;
    int line_ = 1;
};

// ---------------------------------------------------------------------------------------------
// Syntax tree
struct Expr;
using ExprPtr = std::shared_ptr<const Expr>;
struct Expr {
    enum Kind { Number, String, Bool, Undef, Var, Vector, Unary, Binary, Call, Ternary, Range } kind;
    double number = 0;
    std::string text;  // string value, variable, operator or function name
    std::vector<ExprPtr> args;
    int line = 0, col = 0;
    int depth = 1;  ///< height of the expression tree (bounded: evaluation recurses over it)
};
struct Arg {
    std::string name;  // empty: positional
    ExprPtr value;
    int line = 0, col = 0;
};
struct Statement {
    bool assignment = false;
    std::string name;
    ExprPtr value;  // assignment
    std::vector<Arg> args;
    std::vector<Statement> children;
    char modifier = 0;  // '#', '!', '%', '*'
    int line = 0, col = 0;
};

class Parser {
public:
    Parser(std::vector<Token> toks, Diagnostics& d) : t_(std::move(toks)), d_(d) {}
    std::vector<Statement> program() {
        std::vector<Statement> out;
        while (peek().kind != Tok::End) {
            if (auto s = statement()) out.push_back(std::move(*s));
        }
        return out;
    }

private:
    struct Failure {};
    static constexpr int kMaxNesting = 256;
    /// Bounds the parser's recursion (and so the evaluator's): hostile inputs such as 100,000
    /// opening brackets get an error, not a stack overflow.
    class Nest {
    public:
        Nest(Parser& p) : p_(p) {
            if (++p_.nest_ > kMaxNesting) {
                --p_.nest_;
                p_.d_.error(p_.peek().line, p_.peek().col, "nesting deeper than 256 levels");
                throw Failure{};
            }
        }
        ~Nest() { --p_.nest_; }
        Nest(const Nest&) = delete;
        Nest& operator=(const Nest&) = delete;

    private:
        Parser& p_;
    };
    const Token& peek(int k = 0) const { return t_[std::min(i_ + static_cast<std::size_t>(k), t_.size() - 1)]; }
    bool is(const char* p, int k = 0) const { return peek(k).kind == Tok::Punct && peek(k).text == p; }
    Token next() { return t_[std::min(i_++, t_.size() - 1)]; }
    [[noreturn]] void fail(const Token& at, const std::string& expected) {
        std::string found = at.kind == Tok::End ? "the end of the file" : "'" + at.text + "'";
        d_.error(at.line, at.col, "expected " + expected + ", found " + found);
        throw Failure{};
    }
    void expect(const char* p, const std::string& what) {
        if (!is(p)) fail(peek(), what);
        next();
    }
    void recover() {
        // Skip to the end of the statement: past the next ';' or balanced '}' at this level.
        int depth = 0;
        while (peek().kind != Tok::End) {
            const Token t = next();
            if (t.kind != Tok::Punct) continue;
            if (t.text == "{")
                ++depth;
            else if (t.text == "}") {
                if (--depth <= 0) return;
            } else if (t.text == ";" && depth == 0) {
                return;
            }
        }
    }

    std::optional<Statement> statement() {
        const std::size_t start = i_;
        try {
            Nest nest(*this);
            if (is(";")) {
                next();
                return std::nullopt;
            }
            Statement s;
            s.line = peek().line;
            s.col = peek().col;
            while (is("#") || is("!") || is("%") || is("*")) s.modifier = next().text[0];
            if (is("{")) {  // a bare block: a group
                s.name = "group";
                s.children = block();
                return s;
            }
            if (peek().kind != Tok::Ident) fail(peek(), "a statement (a name such as cube, union or a variable)");
            const Token name = next();
            s.name = name.text;
            s.line = name.line;
            s.col = name.col;
            if (is("=") && !s.modifier) {
                next();
                s.assignment = true;
                s.value = expression();
                expect(";", "';' after the assignment");
                return s;
            }
            if (name.text == "module" || name.text == "function" || name.text == "include" || name.text == "use") {
                d_.error(name.line, name.col,
                         "'" + name.text +
                             "' is not supported: isoforge reads OpenSCAD's CSG exports (openscad -o model.csg "
                             "model.scad), where modules are already expanded");
                throw Failure{};
            }
            expect("(", "'(' after '" + name.text + "'");
            s.args = arguments();
            if (is(";")) {
                next();
            } else if (is("{")) {
                s.children = block();
            } else {
                if (auto child = statement()) s.children.push_back(std::move(*child));
            }
            return s;
        } catch (const Failure&) {
            if (i_ == start) next();
            recover();
            return std::nullopt;
        }
    }
    std::vector<Statement> block() {
        expect("{", "'{'");
        std::vector<Statement> out;
        while (!is("}")) {
            if (peek().kind == Tok::End) fail(peek(), "'}' to close the block");
            if (auto s = statement()) out.push_back(std::move(*s));
        }
        next();
        return out;
    }
    std::vector<Arg> arguments() {
        std::vector<Arg> out;
        if (is(")")) {
            next();
            return out;
        }
        for (;;) {
            Arg a;
            a.line = peek().line;
            a.col = peek().col;
            if (peek().kind == Tok::Ident && is("=", 1) && !is("==", 1)) {
                a.name = next().text;
                next();
            }
            a.value = expression();
            out.push_back(std::move(a));
            if (is(",")) {
                next();
                if (is(")")) {  // trailing comma
                    next();
                    return out;
                }
                continue;
            }
            expect(")", "',' or ')' in the argument list");
            return out;
        }
    }

    ExprPtr make(Expr::Kind k, const Token& at) {
        auto e = std::make_shared<Expr>();
        e->kind = k;
        e->line = at.line;
        e->col = at.col;
        return e;
    }
    ExprPtr expression() {
        Nest nest(*this);
        ExprPtr c = binary(0);
        if (is("?")) {
            const Token q = next();
            auto e = std::const_pointer_cast<Expr>(make(Expr::Ternary, q));
            ExprPtr a = expression();
            expect(":", "':' in the conditional expression");
            ExprPtr b = expression();
            e->args = {c, a, b};
            return e;
        }
        return c;
    }
    static int precedence(const std::string& op) {
        if (op == "||") return 1;
        if (op == "&&") return 2;
        if (op == "==" || op == "!=") return 3;
        if (op == "<" || op == ">" || op == "<=" || op == ">=") return 4;
        if (op == "+" || op == "-") return 5;
        if (op == "*" || op == "/" || op == "%") return 6;
        if (op == "^") return 7;
        return 0;
    }
    ExprPtr binary(int minPrec) {
        ExprPtr lhs = unary();
        for (;;) {
            const Token& op = peek();
            const int p = op.kind == Tok::Punct ? precedence(op.text) : 0;
            if (p == 0 || p <= minPrec) return lhs;
            const Token t = next();
            ExprPtr rhs = binary(t.text == "^" ? p - 1 : p);
            auto e = std::const_pointer_cast<Expr>(make(Expr::Binary, t));
            e->text = t.text;
            e->depth = std::max(lhs->depth, rhs->depth) + 1;
            if (e->depth > kMaxNesting) {
                d_.error(t.line, t.col, "expression deeper than 256 levels");
                throw Failure{};
            }
            e->args = {lhs, rhs};
            lhs = e;
        }
    }
    ExprPtr unary() {
        Nest nest(*this);
        if (is("-") || is("!") || is("+")) {
            const Token t = next();
            auto e = std::const_pointer_cast<Expr>(make(Expr::Unary, t));
            e->text = t.text;
            e->args = {unary()};
            return e;
        }
        return primary();
    }
    ExprPtr primary() {
        const Token t = peek();
        if (t.kind == Tok::Number) {
            next();
            auto e = std::const_pointer_cast<Expr>(make(Expr::Number, t));
            e->number = t.number;
            return e;
        }
        if (t.kind == Tok::String) {
            next();
            auto e = std::const_pointer_cast<Expr>(make(Expr::String, t));
            e->text = t.text;
            return e;
        }
        if (t.kind == Tok::Ident) {
            next();
            if (t.text == "true" || t.text == "false") {
                auto e = std::const_pointer_cast<Expr>(make(Expr::Bool, t));
                e->number = t.text == "true";
                return e;
            }
            if (t.text == "undef") return make(Expr::Undef, t);
            if (is("(")) {
                next();
                auto e = std::const_pointer_cast<Expr>(make(Expr::Call, t));
                e->text = t.text;
                for (const Arg& a : arguments()) e->args.push_back(a.value);
                return e;
            }
            auto e = std::const_pointer_cast<Expr>(make(Expr::Var, t));
            e->text = t.text;
            return e;
        }
        if (is("(")) {
            next();
            ExprPtr e = expression();
            expect(")", "')'");
            return e;
        }
        if (is("[")) {
            next();
            auto e = std::const_pointer_cast<Expr>(make(Expr::Vector, t));
            if (is("]")) {
                next();
                return e;
            }
            ExprPtr first = expression();
            if (is(":")) {  // a range [a : b] or [a : s : b]
                e->kind = Expr::Range;
                e->args.push_back(first);
                while (is(":")) {
                    next();
                    e->args.push_back(expression());
                }
                expect("]", "']' to close the range");
                return e;
            }
            e->args.push_back(first);
            while (is(",")) {
                next();
                if (is("]")) break;
                e->args.push_back(expression());
            }
            expect("]", "',' or ']' in the vector");
            return e;
        }
        fail(t, "a value (a number, a string, a vector [..], a variable or '(')");
    }

    std::vector<Token> t_;
    std::size_t i_ = 0;
    int nest_ = 0;
    Diagnostics& d_;
};

// ---------------------------------------------------------------------------------------------
// Values and evaluation
struct Value {
    enum Kind { Undef, Number, Bool, String, Vector } kind = Undef;
    double n = 0;
    std::string s;
    std::vector<Value> v;
    static Value num(double x) { return {Number, x, {}, {}}; }
    static Value boolean(bool b) { return {Bool, b ? 1.0 : 0.0, {}, {}}; }
    bool truthy() const {
        switch (kind) {
            case Undef:
                return false;
            case Number:
            case Bool:
                return n != 0;
            case String:
                return !s.empty();
            case Vector:
                return !v.empty();
        }
        return false;
    }
};

struct EvalError {
    int line, col;
    std::string message;
};

struct Scope {
    std::map<std::string, Value> vars;
    const Scope* parent = nullptr;
    const Value* find(const std::string& k) const {
        for (const Scope* s = this; s; s = s->parent) {
            auto it = s->vars.find(k);
            if (it != s->vars.end()) return &it->second;
        }
        return nullptr;
    }
};

constexpr double kDeg = M_PI / 180.0;

Value evaluate(const Expr& e, const Scope& scope) {
    auto err = [&](const std::string& m) -> EvalError { return {e.line, e.col, m}; };
    switch (e.kind) {
        case Expr::Number:
            return Value::num(e.number);
        case Expr::Bool:
            return Value::boolean(e.number != 0);
        case Expr::String:
            return {Value::String, 0, e.text, {}};
        case Expr::Undef:
            return {};
        case Expr::Var: {
            if (const Value* v = scope.find(e.text)) return *v;
            if (e.text == "PI") return Value::num(M_PI);
            if (e.text[0] == '$') return {};
            throw err("unknown variable '" + e.text + "'");
        }
        case Expr::Vector: {
            Value out{Value::Vector, 0, {}, {}};
            for (const auto& a : e.args) out.v.push_back(evaluate(*a, scope));
            return out;
        }
        case Expr::Range: {
            const double a = evaluate(*e.args[0], scope).n, last = evaluate(*e.args.back(), scope).n;
            const double step = e.args.size() == 3 ? evaluate(*e.args[1], scope).n : 1.0;
            Value out{Value::Vector, 0, {}, {}};
            if (step == 0 || (last - a) / step > 1e6) throw err("range too long or with a zero step");
            for (double x = a; step > 0 ? x <= last + 1e-9 : x >= last - 1e-9; x += step)
                out.v.push_back(Value::num(x));
            return out;
        }
        case Expr::Unary: {
            const Value a = evaluate(*e.args[0], scope);
            if (e.text == "!") return Value::boolean(!a.truthy());
            if (a.kind == Value::Number) return Value::num(e.text == "-" ? -a.n : a.n);
            if (a.kind == Value::Vector) {
                Value out = a;
                for (auto& x : out.v) x.n = e.text == "-" ? -x.n : x.n;
                return out;
            }
            throw err("'" + e.text + "' needs a number or a vector");
        }
        case Expr::Binary: {
            const Value a = evaluate(*e.args[0], scope);
            if (e.text == "&&") return Value::boolean(a.truthy() && evaluate(*e.args[1], scope).truthy());
            if (e.text == "||") return Value::boolean(a.truthy() || evaluate(*e.args[1], scope).truthy());
            const Value b = evaluate(*e.args[1], scope);
            const std::string& op = e.text;
            if (op == "==" || op == "!=") {
                const bool eq = a.kind == b.kind && a.n == b.n && a.s == b.s && a.v.size() == b.v.size();
                return Value::boolean((op == "==") == eq);
            }
            auto arith = [&](double x, double y) -> double {
                if (op == "+") return x + y;
                if (op == "-") return x - y;
                if (op == "*") return x * y;
                if (op == "/") return x / y;
                if (op == "%") return std::fmod(x, y);
                if (op == "^") return std::pow(x, y);
                if (op == "<") return x < y;
                if (op == ">") return x > y;
                if (op == "<=") return x <= y;
                return x >= y;
            };
            const bool cmp = op == "<" || op == ">" || op == "<=" || op == ">=";
            if (a.kind == Value::Number && b.kind == Value::Number)
                return cmp ? Value::boolean(arith(a.n, b.n) != 0) : Value::num(arith(a.n, b.n));
            if (!cmp && a.kind == Value::Vector && b.kind == Value::Number && (op == "*" || op == "/")) {
                Value out = a;
                for (auto& x : out.v) x.n = arith(x.n, b.n);
                return out;
            }
            if (!cmp && a.kind == Value::Number && b.kind == Value::Vector && op == "*") {
                Value out = b;
                for (auto& x : out.v) x.n = arith(a.n, x.n);
                return out;
            }
            if (!cmp && a.kind == Value::Vector && b.kind == Value::Vector && a.v.size() == b.v.size() &&
                (op == "+" || op == "-")) {
                Value out = a;
                for (std::size_t i = 0; i < a.v.size(); ++i) out.v[i].n = arith(a.v[i].n, b.v[i].n);
                return out;
            }
            throw err("'" + op + "' cannot combine these values");
        }
        case Expr::Ternary:
            return evaluate(*e.args[0], scope).truthy() ? evaluate(*e.args[1], scope) : evaluate(*e.args[2], scope);
        case Expr::Call: {
            std::vector<Value> a;
            for (const auto& x : e.args) a.push_back(evaluate(*x, scope));
            auto need = [&](std::size_t n) {
                if (a.size() != n)
                    throw err(e.text + "() takes " + std::to_string(n) + " argument" + (n == 1 ? "" : "s"));
                for (const auto& x : a)
                    if (x.kind != Value::Number) throw err(e.text + "() takes numbers");
            };
            static const std::map<std::string, double (*)(double)> one = {{"sqrt", [](double x) { return std::sqrt(x); }},
                                                                          {"abs", [](double x) { return std::abs(x); }},
                                                                          {"sin", [](double x) { return std::sin(x * kDeg); }},
                                                                          {"cos", [](double x) { return std::cos(x * kDeg); }},
                                                                          {"tan", [](double x) { return std::tan(x * kDeg); }},
                                                                          {"floor", [](double x) { return std::floor(x); }},
                                                                          {"ceil", [](double x) { return std::ceil(x); }},
                                                                          {"round", [](double x) { return std::round(x); }},
                                                                          {"exp", [](double x) { return std::exp(x); }},
                                                                          {"ln", [](double x) { return std::log(x); }},
                                                                          {"asin", [](double x) { return std::asin(x) / kDeg; }},
                                                                          {"acos", [](double x) { return std::acos(x) / kDeg; }},
                                                                          {"atan", [](double x) { return std::atan(x) / kDeg; }}};
            if (auto f = one.find(e.text); f != one.end()) {
                need(1);
                return Value::num(f->second(a[0].n));
            }
            if (e.text == "min" || e.text == "max") {
                if (a.empty()) throw err(e.text + "() needs arguments");
                double r = a[0].n;
                for (const auto& x : a) r = e.text == "min" ? std::min(r, x.n) : std::max(r, x.n);
                return Value::num(r);
            }
            if (e.text == "pow") {
                need(2);
                return Value::num(std::pow(a[0].n, a[1].n));
            }
            if (e.text == "atan2") {
                need(2);
                return Value::num(std::atan2(a[0].n, a[1].n) / kDeg);
            }
            if (e.text == "len") {
                if (a.size() != 1) throw err("len() takes 1 argument");
                return Value::num(a[0].kind == Value::Vector ? static_cast<double>(a[0].v.size())
                                                             : static_cast<double>(a[0].s.size()));
            }
            throw err("unknown function '" + e.text + "'");
        }
    }
    return {};
}

/// The arguments of one call, evaluated, with typed accessors that report errors at the argument.
class Args {
public:
    Args(const Statement& s, const Scope& scope, const std::vector<std::string>& order) : s_(s) {
        std::size_t pos = 0;
        for (const Arg& a : s.args) {
            std::string key = a.name;
            if (key.empty()) {
                if (pos >= order.size())
                    throw EvalError{
                        a.line, a.col,
                        s.name + "() takes at most " + std::to_string(order.size()) + " positional arguments"};
                key = order[pos++];
            }
            values_[key] = {evaluate(*a.value, scope), a.line, a.col};
        }
    }
    bool has(const std::string& k) const {
        auto it = values_.find(k);
        return it != values_.end() && it->second.v.kind != Value::Undef;
    }
    double number(const std::string& k, std::optional<double> def = std::nullopt) const {
        auto it = values_.find(k);
        if (it == values_.end() || it->second.v.kind == Value::Undef) {
            if (def) return *def;
            throw EvalError{s_.line, s_.col, s_.name + "() needs '" + k + "'"};
        }
        if (it->second.v.kind != Value::Number && it->second.v.kind != Value::Bool)
            throw EvalError{it->second.line, it->second.col, "'" + k + "' must be a number"};
        return it->second.v.n;
    }
    bool boolean(const std::string& k, bool def) const {
        auto it = values_.find(k);
        return it == values_.end() || it->second.v.kind == Value::Undef ? def : it->second.v.truthy();
    }
    std::string string(const std::string& k, std::optional<std::string> def = std::nullopt) const {
        auto it = values_.find(k);
        if (it == values_.end() || it->second.v.kind == Value::Undef) {
            if (def) return *def;
            throw EvalError{s_.line, s_.col, s_.name + "() needs '" + k + "' (a string)"};
        }
        if (it->second.v.kind != Value::String)
            throw EvalError{it->second.line, it->second.col, "'" + k + "' must be a string"};
        return it->second.v.s;
    }
    /// A number or a vector of 2/3 numbers (a number n gives [n, n, n]).
    glm::dvec3 vec3(const std::string& k, std::optional<glm::dvec3> def = std::nullopt, bool scalarOk = true) const {
        auto it = values_.find(k);
        if (it == values_.end() || it->second.v.kind == Value::Undef) {
            if (def) return *def;
            throw EvalError{s_.line, s_.col, s_.name + "() needs '" + k + "'"};
        }
        const Value& v = it->second.v;
        if (v.kind == Value::Number && scalarOk) return glm::dvec3(v.n);
        if (v.kind == Value::Vector && (v.v.size() == 2 || v.v.size() == 3)) {
            glm::dvec3 r(0.0);
            for (std::size_t i = 0; i < v.v.size(); ++i) {
                if (v.v[i].kind != Value::Number) break;
                r[static_cast<int>(i)] = v.v[i].n;
            }
            return r;
        }
        throw EvalError{it->second.line, it->second.col, "'" + k + "' must be a vector [x, y, z]"};
    }
    const Value* raw(const std::string& k, int* line = nullptr, int* col = nullptr) const {
        auto it = values_.find(k);
        if (it == values_.end()) return nullptr;
        if (line) *line = it->second.line;
        if (col) *col = it->second.col;
        return &it->second.v;
    }
    EvalError error(const std::string& k, const std::string& m) const {
        auto it = values_.find(k);
        return it == values_.end() ? EvalError{s_.line, s_.col, m} : EvalError{it->second.line, it->second.col, m};
    }

private:
    struct Located {
        Value v;
        int line = 0, col = 0;
    };
    const Statement& s_;
    std::map<std::string, Located> values_;
};

std::vector<std::vector<double>> matrixOf(const Value& v) {
    std::vector<std::vector<double>> m;
    if (v.kind != Value::Vector) return m;
    for (const auto& row : v.v) {
        if (row.kind != Value::Vector) return {};
        m.emplace_back();
        for (const auto& x : row.v) m.back().push_back(x.n);
    }
    return m;
}

}  // namespace

glm::vec4 parseColor(std::string name, bool& ok) {
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    // The SVG/CSS colour names OpenSCAD accepts (CSS Color Module Level 4).
    static const std::map<std::string, std::uint32_t> names = {{"aliceblue", 0xf0f8ff},
                                                               {"antiquewhite", 0xfaebd7},
                                                               {"aqua", 0x00ffff},
                                                               {"aquamarine", 0x7fffd4},
                                                               {"azure", 0xf0ffff},
                                                               {"beige", 0xf5f5dc},
                                                               {"bisque", 0xffe4c4},
                                                               {"black", 0x000000},
                                                               {"blanchedalmond", 0xffebcd},
                                                               {"blue", 0x0000ff},
                                                               {"blueviolet", 0x8a2be2},
                                                               {"brown", 0xa52a2a},
                                                               {"burlywood", 0xdeb887},
                                                               {"cadetblue", 0x5f9ea0},
                                                               {"chartreuse", 0x7fff00},
                                                               {"chocolate", 0xd2691e},
                                                               {"coral", 0xff7f50},
                                                               {"cornflowerblue", 0x6495ed},
                                                               {"cornsilk", 0xfff8dc},
                                                               {"crimson", 0xdc143c},
                                                               {"cyan", 0x00ffff},
                                                               {"darkblue", 0x00008b},
                                                               {"darkcyan", 0x008b8b},
                                                               {"darkgoldenrod", 0xb8860b},
                                                               {"darkgray", 0xa9a9a9},
                                                               {"darkgreen", 0x006400},
                                                               {"darkgrey", 0xa9a9a9},
                                                               {"darkkhaki", 0xbdb76b},
                                                               {"darkmagenta", 0x8b008b},
                                                               {"darkolivegreen", 0x556b2f},
                                                               {"darkorange", 0xff8c00},
                                                               {"darkorchid", 0x9932cc},
                                                               {"darkred", 0x8b0000},
                                                               {"darksalmon", 0xe9967a},
                                                               {"darkseagreen", 0x8fbc8f},
                                                               {"darkslateblue", 0x483d8b},
                                                               {"darkslategray", 0x2f4f4f},
                                                               {"darkslategrey", 0x2f4f4f},
                                                               {"darkturquoise", 0x00ced1},
                                                               {"darkviolet", 0x9400d3},
                                                               {"deeppink", 0xff1493},
                                                               {"deepskyblue", 0x00bfff},
                                                               {"dimgray", 0x696969},
                                                               {"dimgrey", 0x696969},
                                                               {"dodgerblue", 0x1e90ff},
                                                               {"firebrick", 0xb22222},
                                                               {"floralwhite", 0xfffaf0},
                                                               {"forestgreen", 0x228b22},
                                                               {"fuchsia", 0xff00ff},
                                                               {"gainsboro", 0xdcdcdc},
                                                               {"ghostwhite", 0xf8f8ff},
                                                               {"gold", 0xffd700},
                                                               {"goldenrod", 0xdaa520},
                                                               {"gray", 0x808080},
                                                               {"green", 0x008000},
                                                               {"greenyellow", 0xadff2f},
                                                               {"grey", 0x808080},
                                                               {"honeydew", 0xf0fff0},
                                                               {"hotpink", 0xff69b4},
                                                               {"indianred", 0xcd5c5c},
                                                               {"indigo", 0x4b0082},
                                                               {"ivory", 0xfffff0},
                                                               {"khaki", 0xf0e68c},
                                                               {"lavender", 0xe6e6fa},
                                                               {"lavenderblush", 0xfff0f5},
                                                               {"lawngreen", 0x7cfc00},
                                                               {"lemonchiffon", 0xfffacd},
                                                               {"lightblue", 0xadd8e6},
                                                               {"lightcoral", 0xf08080},
                                                               {"lightcyan", 0xe0ffff},
                                                               {"lightgoldenrodyellow", 0xfafad2},
                                                               {"lightgray", 0xd3d3d3},
                                                               {"lightgreen", 0x90ee90},
                                                               {"lightgrey", 0xd3d3d3},
                                                               {"lightpink", 0xffb6c1},
                                                               {"lightsalmon", 0xffa07a},
                                                               {"lightseagreen", 0x20b2aa},
                                                               {"lightskyblue", 0x87cefa},
                                                               {"lightslategray", 0x778899},
                                                               {"lightslategrey", 0x778899},
                                                               {"lightsteelblue", 0xb0c4de},
                                                               {"lightyellow", 0xffffe0},
                                                               {"lime", 0x00ff00},
                                                               {"limegreen", 0x32cd32},
                                                               {"linen", 0xfaf0e6},
                                                               {"magenta", 0xff00ff},
                                                               {"maroon", 0x800000},
                                                               {"mediumaquamarine", 0x66cdaa},
                                                               {"mediumblue", 0x0000cd},
                                                               {"mediumorchid", 0xba55d3},
                                                               {"mediumpurple", 0x9370db},
                                                               {"mediumseagreen", 0x3cb371},
                                                               {"mediumslateblue", 0x7b68ee},
                                                               {"mediumspringgreen", 0x00fa9a},
                                                               {"mediumturquoise", 0x48d1cc},
                                                               {"mediumvioletred", 0xc71585},
                                                               {"midnightblue", 0x191970},
                                                               {"mintcream", 0xf5fffa},
                                                               {"mistyrose", 0xffe4e1},
                                                               {"moccasin", 0xffe4b5},
                                                               {"navajowhite", 0xffdead},
                                                               {"navy", 0x000080},
                                                               {"oldlace", 0xfdf5e6},
                                                               {"olive", 0x808000},
                                                               {"olivedrab", 0x6b8e23},
                                                               {"orange", 0xffa500},
                                                               {"orangered", 0xff4500},
                                                               {"orchid", 0xda70d6},
                                                               {"palegoldenrod", 0xeee8aa},
                                                               {"palegreen", 0x98fb98},
                                                               {"paleturquoise", 0xafeeee},
                                                               {"palevioletred", 0xdb7093},
                                                               {"papayawhip", 0xffefd5},
                                                               {"peachpuff", 0xffdab9},
                                                               {"peru", 0xcd853f},
                                                               {"pink", 0xffc0cb},
                                                               {"plum", 0xdda0dd},
                                                               {"powderblue", 0xb0e0e6},
                                                               {"purple", 0x800080},
                                                               {"red", 0xff0000},
                                                               {"rosybrown", 0xbc8f8f},
                                                               {"royalblue", 0x4169e1},
                                                               {"saddlebrown", 0x8b4513},
                                                               {"salmon", 0xfa8072},
                                                               {"sandybrown", 0xf4a460},
                                                               {"seagreen", 0x2e8b57},
                                                               {"seashell", 0xfff5ee},
                                                               {"sienna", 0xa0522d},
                                                               {"silver", 0xc0c0c0},
                                                               {"skyblue", 0x87ceeb},
                                                               {"slateblue", 0x6a5acd},
                                                               {"slategray", 0x708090},
                                                               {"slategrey", 0x708090},
                                                               {"snow", 0xfffafa},
                                                               {"springgreen", 0x00ff7f},
                                                               {"steelblue", 0x4682b4},
                                                               {"tan", 0xd2b48c},
                                                               {"teal", 0x008080},
                                                               {"thistle", 0xd8bfd8},
                                                               {"tomato", 0xff6347},
                                                               {"turquoise", 0x40e0d0},
                                                               {"violet", 0xee82ee},
                                                               {"wheat", 0xf5deb3},
                                                               {"white", 0xffffff},
                                                               {"whitesmoke", 0xf5f5f5},
                                                               {"yellow", 0xffff00},
                                                               {"yellowgreen", 0x9acd32}};
    ok = true;
    if (name.size() == 7 && name[0] == '#') {
        unsigned v = 0;
        if (std::from_chars(name.data() + 1, name.data() + 7, v, 16).ec == std::errc())
            return {((v >> 16) & 255) / 255.f, ((v >> 8) & 255) / 255.f, (v & 255) / 255.f, 1.f};
    }
    auto it = names.find(name);
    if (it == names.end()) {
        ok = false;
        return glm::vec4(0.f);
    }
    const std::uint32_t v = it->second;
    return {((v >> 16) & 255) / 255.f, ((v >> 8) & 255) / 255.f, (v & 255) / 255.f, 1.f};
}

namespace {

class Evaluator {
public:
    Evaluator(Diagnostics& d, Scene& scene, std::filesystem::path dir) : d_(d), scene_(scene), dir_(std::move(dir)) {}

    /// Fields of the statements in order (assignments first update the scope, as OpenSCAD does).
    std::vector<FieldPtr> run(const std::vector<Statement>& list, Scope& scope, int depth) {
        for (const Statement& s : list)
            if (s.assignment) {
                try {
                    scope.vars[s.name] = evaluate(*s.value, scope);
                } catch (const EvalError& e) {
                    d_.error(e.line, e.col, e.message);
                }
            }
        std::vector<FieldPtr> out;
        for (const Statement& s : list) {
            if (s.assignment || s.modifier == '*' || s.modifier == '%') continue;
            try {
                FieldPtr f = call(s, scope, depth);
                if (!f) continue;
                if (s.modifier == '!' && !root_) root_ = f;
                out.push_back(f);
            } catch (const EvalError& e) {
                d_.error(e.line, e.col, e.message);
            } catch (const ParseError& e) {
                d_.error(s.line, s.col, e.what());
            } catch (const IoError& e) {
                d_.error(s.line, s.col, e.what());
            } catch (const std::invalid_argument& e) {
                d_.error(s.line, s.col, e.what());
            }
        }
        return out;
    }
    FieldPtr rootOverride() const { return root_; }
    std::string outline;

private:
    void note(int depth, const std::string& what, const Statement& s) {
        outline +=
            std::string(static_cast<std::size_t>(2 * depth), ' ') + what + "  (line " + std::to_string(s.line) + ")\n";
    }
    static int fragments(const Scope& scope, const Statement& s) {
        const Value* fn = scope.find("$fn");
        if (!fn || fn->kind != Value::Number || !(fn->n >= 3)) return 0;
        if (fn->n > 10000)
            throw EvalError{s.line, s.col, "$fn = " + std::to_string(fn->n) + " is more than 10,000 sides"};
        return static_cast<int>(fn->n);
    }
    std::vector<FieldPtr> children(const Statement& s, const Scope& scope, int depth) {
        Scope inner{{}, &scope};
        return run(s.children, inner, depth + 1);
    }
    FieldPtr group(const Statement& s, const Scope& scope, int depth) {
        auto kids = children(s, scope, depth);
        if (kids.empty()) return nullptr;
        return makeUnion(std::move(kids));
    }
    FieldPtr transformed(const Statement& s, const Scope& scope, int depth, const glm::dmat4& m) {
        FieldPtr g = group(s, scope, depth);
        return g ? implicit::makeTransformed(g, glm::mat4(m)) : nullptr;
    }
    std::string path(const std::string& p) const {
        const std::filesystem::path q(p);
        const std::string full = q.is_absolute() ? p : (dir_ / q).string();
        std::error_code ec;
        if (std::filesystem::exists(full, ec) && !std::filesystem::is_regular_file(full, ec))
            throw IoError(full + ": not a regular file");  // a directory, /dev/zero, a FIFO
        return full;
    }
    void primitive() { ++scene_.primitives; }

    static int resolutionArg(const Args& a, int def) {
        const double r = a.number("resolution", def);
        if (!(r >= 1 && r <= 1024)) throw a.error("resolution", "resolution must be from 1 to 1024");
        return static_cast<int>(r);
    }

    /// nurbs(points = [[p, ...], ...] rows along v of points along u, each [x, y, z] or [x, y, z, w],
    /// knots_u, knots_v (default: clamped uniform), degree = p or [pu, pv] (default 3, at most the
    /// count - 1), weights = [[w, ...], ...]).
    static mesh::NurbsSurface nurbsSurface(const Args& a) {
        int line = 0, col = 0;
        const Value* pts = a.raw("points", &line, &col);
        if (!pts || pts->kind != Value::Vector || pts->v.empty())
            throw a.error("points", "nurbs() needs points: rows of [x, y, z] or [x, y, z, w]");
        mesh::NurbsSurface ns;
        ns.countV = static_cast<int>(pts->v.size());
        ns.countU = static_cast<int>(pts->v[0].v.size());
        if (ns.countV > 4096 || ns.countU > 4096) throw a.error("points", "nurbs() takes at most 4096 x 4096 points");
        bool rational = false;
        std::vector<double> w;
        for (const Value& row : pts->v) {
            if (row.kind != Value::Vector || static_cast<int>(row.v.size()) != ns.countU)
                throw a.error("points", "nurbs() points must be rows of the same length (" + std::to_string(ns.countU) +
                                            " points each)");
            for (const Value& p : row.v) {
                if (p.kind != Value::Vector || p.v.size() < 3 || p.v.size() > 4)
                    throw a.error("points", "each nurbs() point must be [x, y, z] or [x, y, z, w]");
                for (const Value& c : p.v)
                    if (c.kind != Value::Number) throw a.error("points", "nurbs() point coordinates must be numbers");
                ns.points.emplace_back(p.v[0].n, p.v[1].n, p.v[2].n);
                w.push_back(p.v.size() == 4 ? p.v[3].n : 1.0);
                rational = rational || p.v.size() == 4;
            }
        }
        if (const Value* wv = a.raw("weights"); wv && wv->kind != Value::Undef) {
            std::vector<double> given;
            if (wv->kind == Value::Vector)
                for (const Value& row : wv->v) {
                    if (row.kind == Value::Number) given.push_back(row.n);
                    for (const Value& x : row.v)
                        if (x.kind == Value::Number) given.push_back(x.n);
                }
            if (given.size() != w.size())
                throw a.error("weights", "nurbs() needs one weight per point (" + std::to_string(w.size()) + ")");
            w = std::move(given);
            rational = true;
        }
        if (rational) ns.weights = std::move(w);
        ns.degreeU = ns.degreeV = 3;
        if (a.has("degree")) {
            const glm::dvec3 d = a.vec3("degree");
            ns.degreeU = static_cast<int>(d.x);
            ns.degreeV = static_cast<int>(d.y);
        } else {
            ns.degreeU = std::min(3, ns.countU - 1);
            ns.degreeV = std::min(3, ns.countV - 1);
        }
        auto knots = [&](const char* k, int count, int degree) {
            const Value* kv = a.raw(k);
            if (!kv || kv->kind == Value::Undef) return mesh::clampedUniformKnots(count, degree);
            std::vector<double> out;
            if (kv->kind == Value::Vector)
                for (const Value& x : kv->v) {
                    if (x.kind != Value::Number) throw a.error(k, std::string(k) + " must be a list of numbers");
                    out.push_back(x.n);
                }
            else
                throw a.error(k, std::string(k) + " must be a list of numbers");
            return out;
        };
        if (ns.degreeU < 1 || ns.degreeV < 1) throw a.error("degree", "nurbs() degrees must be at least 1");
        ns.knotsU = knots("knots_u", ns.countU, ns.degreeU);
        ns.knotsV = knots("knots_v", ns.countV, ns.degreeV);
        try {
            ns.validate();
        } catch (const std::invalid_argument& e) {
            throw EvalError{line, col, std::string("nurbs(): ") + e.what()};
        }
        return ns;
    }

    FieldPtr call(const Statement& s, const Scope& outer, int depth) {
        // Special variables given as arguments ($fn = 0, ...) apply to this call.
        Scope scope{{}, &outer};
        for (const Arg& a : s.args)
            if (!a.name.empty() && a.name[0] == '$') scope.vars[a.name] = evaluate(*a.value, outer);
        const std::string& n = s.name;
        auto args = [&](std::vector<std::string> order) { return Args(s, scope, order); };
        auto leaf = [&](FieldPtr f, const std::string& what) {
            if (!s.children.empty()) d_.warn(s.line, s.col, n + "() takes no children; they are ignored");
            primitive();
            note(depth, what, s);
            return f;
        };
        // A triangle mesh as a solid: a file (any mesh, inside from the winding number) or one we
        // tessellated (closed ones are trusted to be oriented, so the sign comes from pseudonormals).
        auto meshLeaf = [&](mesh::TriMesh m, const std::string& what, bool generated) {
            bool closed = false;
            std::vector<glm::uvec3> tris(m.triangles.begin(), m.triangles.end());
            FieldPtr f = makeTriangleMeshField(std::move(m.positions), std::move(tris), n, &closed, generated);
            if (!closed)
                d_.warn(s.line, s.col,
                        what +
                            " is not closed: inside and outside come from the generalized winding number, "
                            "which bridges small holes");
            return leaf(f, n);
        };

        // --- OpenSCAD 3D primitives
        if (n == "cube") {
            Args a = args({"size", "center"});
            const glm::dvec3 size = a.vec3("size", glm::dvec3(1.0));
            if (size.x <= 0 || size.y <= 0 || size.z <= 0) throw a.error("size", "cube sizes must be positive");
            FieldPtr f = implicit::makeBox(glm::vec3(size));
            if (!a.boolean("center", false)) f = implicit::makeTranslated(f, glm::vec3(0.5 * size));
            return leaf(f, "cube");
        }
        if (n == "sphere") {
            Args a = args({"r"});
            const double r = a.has("d") ? 0.5 * a.number("d") : a.number("r", 1.0);
            if (!(r > 0)) throw a.error(a.has("d") ? "d" : "r", "sphere radius must be positive");
            const int fn = fragments(scope, s);
            return leaf(fn ? makeFacetedSphere(static_cast<float>(r), fn) : implicit::makeSphere(static_cast<float>(r)),
                        fn ? "sphere ($fn=" + std::to_string(fn) + ")" : "sphere");
        }
        if (n == "cylinder") {
            Args a = args({"h", "r1", "r2", "center"});
            const double h = a.number("h", 1.0);
            double r1 = a.has("r") ? a.number("r") : (a.has("d") ? 0.5 * a.number("d") : 1.0);
            double r2 = r1;
            if (a.has("r1")) r1 = a.number("r1");
            if (a.has("r2")) r2 = a.number("r2");
            if (a.has("d1")) r1 = 0.5 * a.number("d1");
            if (a.has("d2")) r2 = 0.5 * a.number("d2");
            const bool center = a.boolean("center", false);
            if (!(h > 0)) throw a.error("h", "cylinder height must be positive");
            if (r1 < 0 || r2 < 0 || r1 + r2 <= 0)
                throw a.error("r", "cylinder radii must be non-negative and not both zero");
            const int fn = fragments(scope, s);
            if (fn)
                return leaf(makeFacetedCylinder(float(r1), float(r2), float(h), center, fn),
                            "cylinder ($fn=" + std::to_string(fn) + ")");
            FieldPtr f = r1 == r2 ? implicit::makeCylinder(float(r1), float(h))
                                  : implicit::makeCone(float(r1), float(r2), float(h));
            if (!center) f = implicit::makeTranslated(f, glm::vec3(0, 0, 0.5f * float(h)));
            return leaf(f, "cylinder");
        }
        if (n == "polyhedron") {
            Args a = args({"points", "faces", "convexity"});
            int pl = s.line, pc = s.col;
            const Value* pts = a.raw("points", &pl, &pc);
            const Value* faces = a.has("faces") ? a.raw("faces") : a.raw("triangles");
            if (!pts || !faces) throw EvalError{s.line, s.col, "polyhedron() needs points and faces"};
            std::vector<glm::vec3> p;
            for (const auto& q : pts->v) {
                if (q.kind != Value::Vector || q.v.size() != 3)
                    throw EvalError{pl, pc, "polyhedron points must be [x, y, z]"};
                p.emplace_back(q.v[0].n, q.v[1].n, q.v[2].n);
            }
            std::vector<std::vector<int>> f;
            for (const auto& q : faces->v) {
                f.emplace_back();
                for (const auto& i : q.v) f.back().push_back(static_cast<int>(i.n));
            }
            return leaf(makePolyhedron(std::move(p), f), "polyhedron");
        }
        // --- 2D primitives and extrusions
        if (n == "circle") {
            Args a = args({"r"});
            const double r = a.has("d") ? 0.5 * a.number("d") : a.number("r", 1.0);
            const int fn = fragments(scope, s);
            return leaf(fn ? makePolygon2D(regularPolygon(float(r), fn)) : makeCircle2D(float(r)), "circle");
        }
        if (n == "square") {
            Args a = args({"size", "center"});
            const glm::dvec3 size = a.vec3("size", glm::dvec3(1.0));
            const glm::vec2 sz(static_cast<float>(size.x), static_cast<float>(size.y));
            const glm::vec2 lo = a.boolean("center", false) ? -0.5f * sz : glm::vec2(0.f);
            return leaf(makeRectangle2D(lo, lo + sz), "square");
        }
        if (n == "polygon") {
            Args a = args({"points", "paths", "convexity", "subdivide", "levels"});
            const Value* pts = a.raw("points");
            if (!pts) throw EvalError{s.line, s.col, "polygon() needs points"};
            std::vector<glm::vec2> p;
            for (const auto& q : pts->v) p.emplace_back(q.v.size() > 0 ? q.v[0].n : 0, q.v.size() > 1 ? q.v[1].n : 0);
            std::vector<std::vector<int>> paths;
            if (const Value* pv = a.raw("paths"); pv && pv->kind == Value::Vector)
                for (const auto& q : pv->v) {
                    paths.emplace_back();
                    for (const auto& i : q.v) paths.back().push_back(static_cast<int>(i.n));
                }
            // isoforge's extension: smooth the outline(s) by curve subdivision before use.
            if (a.has("subdivide")) {
                const std::string scheme = a.string("subdivide");
                if (scheme != "chaikin" && scheme != "4point")
                    throw a.error("subdivide", "subdivide must be \"chaikin\" or \"4point\"");
                const double levels = a.number("levels", 3.0);
                if (!(levels >= 0 && levels <= 10)) throw a.error("levels", "levels must be from 0 to 10");
                if (p.size() * (std::size_t(1) << static_cast<int>(levels)) > 10000000)
                    throw a.error("levels", "subdividing " + std::to_string(p.size()) + " points " +
                                                std::to_string(static_cast<int>(levels)) + " times is too many");
                auto smooth = [&](std::vector<glm::vec2> ring) {
                    return scheme == "chaikin" ? mesh::chaikin(std::move(ring), static_cast<int>(levels))
                                               : mesh::fourPoint(std::move(ring), static_cast<int>(levels));
                };
                if (paths.empty()) {
                    p = smooth(std::move(p));
                } else {
                    std::vector<glm::vec2> all;
                    std::vector<std::vector<int>> newPaths;
                    for (const auto& path : paths) {
                        std::vector<glm::vec2> ring;
                        for (int i : path) {
                            if (i < 0 || std::size_t(i) >= p.size())
                                throw a.error("paths", "path index " + std::to_string(i) + " is out of range");
                            ring.push_back(p[std::size_t(i)]);
                        }
                        newPaths.emplace_back();
                        for (const glm::vec2& q : smooth(std::move(ring))) {
                            newPaths.back().push_back(static_cast<int>(all.size()));
                            all.push_back(q);
                        }
                    }
                    p = std::move(all);
                    paths = std::move(newPaths);
                }
            }
            return leaf(makePolygon2D(std::move(p), std::move(paths)), "polygon");
        }
        if (n == "linear_extrude") {
            Args a = args({"height", "center", "convexity", "twist", "slices", "scale"});
            const double twist = a.number("twist", 0.0);
            const glm::dvec3 sc = a.vec3("scale", glm::dvec3(1.0));
            if (sc.x < 0 || sc.y < 0) throw a.error("scale", "linear_extrude scale must not be negative");
            note(depth, "linear_extrude", s);
            FieldPtr g = group(s, scope, depth);
            return g ? makeLinearExtrude(g, float(a.number("height", 100.0)), a.boolean("center", false), float(twist),
                                         glm::vec2(float(sc.x), float(sc.y)))
                     : nullptr;
        }
        if (n == "rotate_extrude") {
            Args a = args({"angle", "convexity"});
            const double angle = a.number("angle", 360.0);
            if (angle == 0 || !std::isfinite(angle)) throw a.error("angle", "rotate_extrude angle must be non-zero");
            note(depth, "rotate_extrude", s);
            FieldPtr g = group(s, scope, depth);
            return g ? makeRotateExtrude(g, float(angle)) : nullptr;
        }
        // --- transforms
        if (n == "translate") {
            Args a = args({"v"});
            note(depth, "translate", s);
            return transformed(s, scope, depth, glm::translate(glm::dmat4(1.0), a.vec3("v", glm::dvec3(0.0), false)));
        }
        if (n == "scale") {
            Args a = args({"v"});
            const glm::dvec3 v = a.vec3("v", glm::dvec3(1.0));
            if (v.x == 0 || v.y == 0 || v.z == 0) throw a.error("v", "scale factors must not be zero");
            note(depth, "scale", s);
            return transformed(s, scope, depth, glm::scale(glm::dmat4(1.0), v));
        }
        if (n == "rotate") {
            Args a = args({"a", "v"});
            glm::dmat4 m(1.0);
            const Value* av = a.raw("a");
            if (av && av->kind == Value::Vector) {
                const glm::dvec3 r = a.vec3("a");
                m = glm::rotate(glm::dmat4(1.0), r.z * kDeg, glm::dvec3(0, 0, 1)) *
                    glm::rotate(glm::dmat4(1.0), r.y * kDeg, glm::dvec3(0, 1, 0)) *
                    glm::rotate(glm::dmat4(1.0), r.x * kDeg, glm::dvec3(1, 0, 0));
            } else {
                const glm::dvec3 axis = a.vec3("v", glm::dvec3(0, 0, 1), false);
                if (glm::length(axis) == 0) throw a.error("v", "the rotation axis must not be zero");
                m = glm::rotate(glm::dmat4(1.0), a.number("a", 0.0) * kDeg, glm::normalize(axis));
            }
            note(depth, "rotate", s);
            return transformed(s, scope, depth, m);
        }
        if (n == "mirror") {
            Args a = args({"v"});
            const glm::dvec3 v = a.vec3("v", glm::dvec3(1, 0, 0), false);
            if (glm::length(v) == 0) throw a.error("v", "the mirror normal must not be zero");
            const glm::dvec3 u = glm::normalize(v);
            glm::dmat4 m(1.0);
            for (int c = 0; c < 3; ++c)
                for (int r = 0; r < 3; ++r) m[c][r] -= 2.0 * u[r] * u[c];
            note(depth, "mirror", s);
            return transformed(s, scope, depth, m);
        }
        if (n == "multmatrix") {
            Args a = args({"m"});
            int ml = s.line, mc = s.col;
            const Value* mv = a.raw("m", &ml, &mc);
            const auto rows = mv ? matrixOf(*mv) : std::vector<std::vector<double>>{};
            if (rows.size() < 3 || rows.size() > 4) throw EvalError{ml, mc, "multmatrix needs a 3x4 or 4x4 matrix"};
            glm::dmat4 m(1.0);
            for (std::size_t r = 0; r < 3; ++r) {
                if (rows[r].size() < 3) throw EvalError{ml, mc, "multmatrix rows need 4 numbers"};
                for (std::size_t c = 0; c < std::min<std::size_t>(4, rows[r].size()); ++c)
                    m[static_cast<int>(c)][static_cast<int>(r)] = rows[r][c];
            }
            note(depth, "multmatrix", s);
            return transformed(s, scope, depth, m);
        }
        if (n == "resize") {
            Args a = args({"newsize", "auto"});
            const glm::dvec3 ns = a.vec3("newsize", std::nullopt, false);
            note(depth, "resize", s);
            FieldPtr g = group(s, scope, depth);
            if (!g) return nullptr;
            const Box3 b = g->bounds();
            if (!b.isBounded()) throw a.error("newsize", "resize() needs a bounded child");
            const glm::dvec3 size(b.size());
            glm::dvec3 f(1.0);
            for (int k = 0; k < 3; ++k)
                if (ns[k] > 0) f[k] = ns[k] / size[k];
            return implicit::makeTransformed(g, glm::mat4(glm::scale(glm::dmat4(1.0), f)));
        }
        // --- booleans and groups
        if (n == "union" || n == "group" || n == "render" || n == "intersection" || n == "difference" ||
            n == "smooth_union" || n == "smooth_intersection" || n == "smooth_difference") {
            const bool smooth = n.rfind("smooth_", 0) == 0;
            Args a = args(smooth ? std::vector<std::string>{"k"} : std::vector<std::string>{"convexity"});
            const float k = smooth ? float(a.number("k", 0.1)) : 0.f;
            if (smooth && !(k > 0)) throw a.error("k", "the blend radius k must be positive");
            note(depth, n, s);
            auto kids = children(s, scope, depth);
            if (kids.empty()) return nullptr;
            const std::string base = smooth ? n.substr(7) : n;
            if (base == "intersection") {
                // A child whose bounds miss the others' (a shape outside its clipping box): nothing is left.
                Box3 common = Box3::everything();
                for (const auto& c : kids) common = common.intersect(c->bounds());
                if (kids.size() > 1 && common.isEmpty())
                    d_.warn(s.line, s.col,
                            "this intersection is empty: a child lies outside the others (outside its clipping box?)");
                return makeIntersection(std::move(kids), k);
            }
            if (base == "difference") {
                if (kids.size() > 1) {
                    const Box3 first = kids[0]->bounds();
                    bool removes = false;
                    for (std::size_t i = 1; i < kids.size(); ++i)
                        removes = removes || !first.intersect(kids[i]->bounds()).isEmpty();
                    if (!removes)
                        d_.warn(s.line, s.col,
                                "this difference removes nothing: the subtracted children lie outside the first");
                }
                return makeDifference(std::move(kids), k);
            }
            return makeUnion(std::move(kids), k);
        }
        if (n == "color" || n == "material") {
            const bool mat = n == "material";
            Args a = mat ? args({"color", "diffuse", "specular", "shininess", "opacity"}) : args({"c", "alpha"});
            const std::string key = mat ? "color" : "c";
            glm::vec4 rgba(1.f);
            if (mat) rgba = glm::vec4(0.8f, 0.8f, 0.8f, 1.f);
            int cl = s.line, cc = s.col;
            const Value* c = a.raw(key, &cl, &cc);
            if (c && c->kind == Value::String) {
                bool ok = false;
                rgba = parseColor(c->s, ok);
                if (!ok)
                    throw EvalError{cl, cc,
                                    "unknown colour '" + c->s + "' (use a name such as red, \"#ff8000\" or [r, g, b])"};
            } else if (c && c->kind == Value::Vector && c->v.size() >= 3) {
                rgba = glm::vec4(c->v[0].n, c->v[1].n, c->v[2].n, c->v.size() > 3 ? c->v[3].n : 1.0);
            } else if (c && c->kind != Value::Undef) {
                throw EvalError{cl, cc, n + " needs a colour name or [r, g, b(, a)]"};
            }
            if (a.has("alpha")) rgba.a = static_cast<float>(a.number("alpha"));
            if (a.has("opacity")) rgba.a = static_cast<float>(a.number("opacity"));
            if (!(rgba.a >= 0.f && rgba.a <= 1.f))
                throw a.error(mat ? "opacity" : "alpha", "opacity must be in [0, 1]");
            implicit::Material m;
            m.color = glm::vec4(glm::vec3(rgba), std::max(rgba.a, 1e-3f));
            if (mat) {
                m.diffuse = float(a.number("diffuse", m.diffuse));
                m.specular = float(a.number("specular", m.specular));
                m.shininess = float(a.number("shininess", m.shininess));
                if (m.diffuse < 0 || m.specular < 0 || m.shininess < 1)
                    throw a.error("shininess", "diffuse and specular must be >= 0 and shininess >= 1");
            }
            note(depth, n, s);
            FieldPtr g = group(s, scope, depth);
            return g ? makeMaterial(g, m) : nullptr;
        }
        // --- our extensions
        if (n == "torus") {
            Args a = args({"R", "r"});
            return leaf(implicit::makeTorus(float(a.number("R", 1.0)), float(a.number("r", 0.25))), "torus");
        }
        if (n == "cone") {
            Args a = args({"r1", "r2", "h", "center"});
            FieldPtr f =
                implicit::makeCone(float(a.number("r1", 1.0)), float(a.number("r2", 0.0)), float(a.number("h", 1.0)));
            if (!a.boolean("center", true))
                f = implicit::makeTranslated(f, glm::vec3(0, 0, 0.5f * float(a.number("h", 1.0))));
            return leaf(f, "cone");
        }
        if (n == "box") {
            Args a = args({"size", "r", "center"});
            const glm::dvec3 size = a.vec3("size", glm::dvec3(1.0));
            FieldPtr f = implicit::makeBox(glm::vec3(size), float(a.number("r", 0.0)));
            if (!a.boolean("center", true)) f = implicit::makeTranslated(f, glm::vec3(0.5 * size));
            return leaf(f, "box");
        }
        if (n == "plane") {
            Args a = args({"n", "d"});
            return leaf(
                implicit::makePlane(glm::vec3(a.vec3("n", glm::dvec3(0, 0, 1), false)), float(a.number("d", 0.0))),
                "plane");
        }
        if (n == "ellipsoid") {
            Args a = args({"r"});
            return leaf(implicit::makeEllipsoid(glm::vec3(a.vec3("r", glm::dvec3(1.0, 0.6, 0.4)))), "ellipsoid");
        }
        if (n == "capsule") {
            Args a = args({"r", "h"});
            return leaf(implicit::makeCapsule(float(a.number("r", 0.25)), float(a.number("h", 1.0))), "capsule");
        }
        if (n == "tetrahedron") {
            Args a = args({"size"});
            return leaf(implicit::makeTetrahedron(float(a.number("size", 1.0))), "tetrahedron");
        }
        if (n == "quadric") {
            Args a = args({"type", "a", "b", "c"});
            if (a.has("coefficients")) {
                const Value* c = a.raw("coefficients");
                if (c->kind != Value::Vector || c->v.size() != 10)
                    throw a.error("coefficients", "quadric coefficients must be 10 numbers A..J");
                std::array<float, 10> k{};
                for (std::size_t i = 0; i < 10; ++i) k[i] = static_cast<float>(c->v[i].n);
                return leaf(implicit::makeQuadric(k), "quadric");
            }
            return leaf(implicit::makeNamedQuadric(a.string("type"), float(a.number("a", 1.0)),
                                                   float(a.number("b", 1.0)), float(a.number("c", 1.0))),
                        "quadric " + a.string("type"));
        }
        if (n == "implicit") {
            Args a = args({"expr"});
            const std::string e = a.string("expr");
            return leaf(implicit::makeTapeField(implicit::parseExpression(e), Box3::everything(), e), "implicit");
        }
        if (n == "vm") {
            Args a = args({"file"});
            const std::string file = path(a.string("file"));
            return leaf(implicit::makeTapeField(implicit::readVmFile(file), Box3::everything(), a.string("file")),
                        "vm");
        }
        if (n == "volume") {
            Args a = args({"file", "iso", "grid"});
            const std::string file = path(a.string("file"));
            std::optional<std::string> grid;
            if (a.has("grid")) grid = a.string("grid");
            return leaf(volume::makeGridField(file, float(a.number("iso", 0.0)), grid), "volume");
        }
        if (n == "mesh") {
            Args a = args({"file"});
            const std::string file = path(a.string("file"));
            return meshLeaf(mesh::readMesh(file), "mesh(\"" + a.string("file") + "\")", false);
        }
        if (n == "bezier_patches") {
            Args a = args({"file", "resolution"});
            const std::string file = path(a.string("file"));
            const int res = resolutionArg(a, 16);
            const auto patches = mesh::readBezierPatches(file);
            return meshLeaf(mesh::tessellate(patches, res), "bezier_patches(\"" + a.string("file") + "\")", true);
        }
        if (n == "nurbs") {
            Args a = args({"points", "knots_u", "knots_v", "degree", "weights", "resolution"});
            return meshLeaf(mesh::tessellate(nurbsSurface(a), resolutionArg(a, 32)), "nurbs()", true);
        }
        if (n == "blobby") {
            Args a = args({"threshold", "kernel"});
            const std::string k = a.string("kernel", std::string("metaball"));
            implicit::BlobKernel kernel = implicit::BlobKernel::Metaball;
            if (k == "blinn")
                kernel = implicit::BlobKernel::Blinn;
            else if (k == "wyvill")
                kernel = implicit::BlobKernel::Wyvill;
            else if (k != "metaball")
                throw a.error("kernel", "kernel must be blinn, wyvill or metaball");
            std::vector<implicit::Ball> balls;
            for (const Statement& c : s.children) {
                if (c.assignment) continue;
                if (c.name != "ball")
                    throw EvalError{c.line, c.col, "blobby() holds ball(center, r, strength) children only"};
                Args b(c, scope, {"center", "r", "strength"});
                balls.push_back({glm::vec3(b.vec3("center", glm::dvec3(0.0), false)), float(b.number("r", 1.0)),
                                 float(b.number("strength", 1.0))});
            }
            if (balls.empty()) throw EvalError{s.line, s.col, "blobby() needs at least one ball"};
            primitive();
            note(depth, "blobby (" + std::to_string(balls.size()) + " balls)", s);
            return implicit::makeBlobby(std::move(balls), float(a.number("threshold", 0.5)), kernel);
        }
        if (n == "offset") {
            Args a = args({"r", "delta", "chamfer"});
            note(depth, "offset", s);
            FieldPtr g = group(s, scope, depth);
            return g ? implicit::makeOffset(g, float(a.has("delta") ? a.number("delta") : a.number("r", 0.0)))
                     : nullptr;
        }
        if (n == "shell") {
            Args a = args({"t"});
            note(depth, "shell", s);
            FieldPtr g = group(s, scope, depth);
            return g ? implicit::makeShell(g, float(a.number("t", 0.1))) : nullptr;
        }
        // --- scene statements
        if (n == "camera") {
            Args a = args({"eye", "target", "up", "fov", "orthographic"});
            scene_.camera.given = true;
            scene_.camera.eye = glm::vec3(a.vec3("eye", glm::dvec3(scene_.camera.eye), false));
            scene_.camera.target = glm::vec3(a.vec3("target", glm::dvec3(scene_.camera.target), false));
            scene_.camera.up = glm::vec3(a.vec3("up", glm::dvec3(scene_.camera.up), false));
            scene_.camera.fov = float(a.number("fov", scene_.camera.fov));
            scene_.camera.orthographic = a.boolean("orthographic", false);
            if (scene_.camera.fov <= 0 || scene_.camera.fov >= 180)
                throw a.error("fov", "fov must be between 0 and 180 degrees");
            return nullptr;
        }
        if (n == "light") {
            Args a = args({"direction", "color", "intensity"});
            Light l;
            if (a.has("position")) {
                l.point = true;
                l.vector = glm::vec3(a.vec3("position", std::nullopt, false));
            } else {
                l.vector = glm::vec3(a.vec3("direction", glm::dvec3(l.vector), false));
            }
            l.color = glm::vec3(a.vec3("color", glm::dvec3(1.0)));
            l.intensity = float(a.number("intensity", 1.0));
            scene_.lights.push_back(l);
            return nullptr;
        }
        if (n == "background") {
            Args a = args({"color"});
            if (a.has("color")) scene_.backgroundTop = scene_.backgroundBottom = glm::vec3(a.vec3("color"));
            if (a.has("top")) scene_.backgroundTop = glm::vec3(a.vec3("top"));
            if (a.has("bottom")) scene_.backgroundBottom = glm::vec3(a.vec3("bottom"));
            return nullptr;
        }
        if (n == "echo" || n == "assert") return nullptr;
        static const char* unsupported[] = {"minkowski", "hull", "import", "surface",          "text", "projection",
                                            "children",  "let",  "for",    "intersection_for", "if"};
        for (const char* u : unsupported)
            if (n == u)
                throw EvalError{
                    s.line, s.col,
                    "'" + n +
                        "' is not supported (isoforge reads the CSG subset of OpenSCAD; see docs/scene-language.md)"};
        throw EvalError{s.line, s.col, "unknown module '" + n + "'"};
    }

    Diagnostics& d_;
    Scene& scene_;
    std::filesystem::path dir_;
    FieldPtr root_;
};

std::vector<std::string_view> splitLines(std::string_view t) {
    std::vector<std::string_view> out;
    std::size_t b = 0;
    for (std::size_t i = 0; i <= t.size(); ++i)
        if (i == t.size() || t[i] == '\n') {
            std::string_view l = t.substr(b, i - b);
            if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
            out.push_back(l);
            b = i + 1;
        }
    return out;
}

Scene parse(std::string_view text, const std::string& file, const std::filesystem::path& dir) {
    Diagnostics d;
    d.file = file;
    d.lines = splitLines(text);
    std::vector<Token> toks = Lexer(text, d).run();
    std::vector<Statement> program = Parser(std::move(toks), d).program();
    Scene scene;
    Evaluator ev(d, scene, dir);
    Scope global;
    global.vars["$fn"] = Value::num(0);
    std::vector<FieldPtr> top;
    if (d.errors.empty()) top = ev.run(program, global, 0);
    if (!d.errors.empty()) {
        std::string all;
        for (const auto& e : d.errors) all += (all.empty() ? "" : "\n") + e;
        if (d.errors.size() > 1) all += "\n" + std::to_string(d.errors.size()) + " errors";
        throw ParseError(all);
    }
    FieldPtr root = ev.rootOverride();
    if (!root) root = top.empty() ? makeEmpty() : makeUnion(std::move(top));
    if (!root->bounds().isBounded() && !top.empty())
        d.warn(1, 1,
               "the scene is unbounded (a plane, a quadric, an expression or a 2D shape not extruded): give a box to "
               "sample it");
    scene.root = root;
    scene.warnings = std::move(d.warnings);
    scene.tree = ev.outline;
    return scene;
}

}  // namespace

Scene parseScene(std::string_view text, const std::string& fileName) {
    return parse(text, fileName, ".");
}

Scene readScene(const std::string& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw IoError(path + ": is a directory, expected a scene file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path + ": cannot open");
    std::stringstream s;
    s << in.rdbuf();
    const std::string text = s.str();
    if (text.find('\0') != std::string::npos) throw IoError(path + ": not a text file (it contains NUL bytes)");
    return parse(text, path, std::filesystem::path(path).parent_path());
}

}  // namespace isoforge::csg
