#pragma once
/// @file Internal to csg/: values of the scene language, scopes, and expression evaluation.

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "csg/syntax.h"

namespace isoforge::csg {

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

/// The value of an expression in a scope. @throw EvalError at the expression.
Value evaluate(const Expr& e, const Scope& scope);

}  // namespace isoforge::csg
