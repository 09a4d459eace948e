#pragma once
/// @file Internal to csg/: the scene language's tokens.

#include <string>
#include <string_view>
#include <vector>

#include "csg/diagnostics.h"

namespace isoforge::csg {

enum class Tok { Ident, Number, String, Punct, End };
struct Token {
    Tok kind = Tok::End;
    std::string text;
    double number = 0;
    int line = 0, col = 0;
};

/// The tokens of a scene text, ending with Tok::End; lexical errors go to `d`.
std::vector<Token> tokenize(std::string_view text, Diagnostics& d);

}  // namespace isoforge::csg
