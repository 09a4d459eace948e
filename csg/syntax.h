#pragma once
/// @file Internal to csg/: the syntax tree of the scene language (expressions and statements).

#include <memory>
#include <string>
#include <vector>

namespace isoforge::csg {

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

}  // namespace isoforge::csg
