#include "csg/value.h"

namespace isoforge::csg {

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
            // OpenSCAD's exports write infinite and undefined numbers as inf and nan.
            if (e.text == "inf") return Value::num(HUGE_VAL);
            if (e.text == "nan") return Value::num(std::nan(""));
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

}  // namespace isoforge::csg
