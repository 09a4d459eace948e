#include "csg/parser.h"

#include <optional>

namespace isoforge::csg {

namespace {

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
            // Several modifiers may stack ("%#"): disable (*) and background (%) win, as in OpenSCAD.
            auto rank = [](char m) { return m == '*' ? 4 : m == '%' ? 3 : m == '!' ? 2 : m == '#' ? 1 : 0; };
            while (is("#") || is("!") || is("%") || is("*")) {
                const char m = next().text[0];
                if (rank(m) > rank(s.modifier)) s.modifier = m;
            }
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

}  // namespace

std::vector<Statement> parseProgram(std::vector<Token> tokens, Diagnostics& d) {
    return Parser(std::move(tokens), d).program();
}

}  // namespace isoforge::csg
