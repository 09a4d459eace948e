#pragma once
/// @file Internal to csg/: the recursive-descent parser of the scene language.

#include <vector>

#include "csg/diagnostics.h"
#include "csg/lexer.h"
#include "csg/syntax.h"

namespace isoforge::csg {

/// The statements of a program; syntax errors go to `d` (the parser recovers at the next statement).
std::vector<Statement> parseProgram(std::vector<Token> tokens, Diagnostics& d);

}  // namespace isoforge::csg
