#pragma once
/// @file Internal to csg/: the arguments of one module call, evaluated, with typed accessors.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "csg/value.h"

namespace isoforge::csg {

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

/// Rows of numbers of a matrix value ([[..], [..], ..]); empty if it is not one.
inline std::vector<std::vector<double>> matrixOf(const Value& v) {
    std::vector<std::vector<double>> m;
    if (v.kind != Value::Vector) return m;
    for (const auto& row : v.v) {
        if (row.kind != Value::Vector) return {};
        m.emplace_back();
        for (const auto& x : row.v) m.back().push_back(x.n);
    }
    return m;
}

}  // namespace isoforge::csg
