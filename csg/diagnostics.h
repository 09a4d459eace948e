#pragma once
/// @file Internal to csg/: errors and warnings collected while a scene is read, each with its
/// file:line:column, thrown together at the end.

#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "csg/scene.h"

namespace isoforge::csg {

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

}  // namespace isoforge::csg
