#include "csg/lexer.h"

#include <cctype>
#include <charconv>

namespace isoforge::csg {

namespace {

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

}  // namespace

std::vector<Token> tokenize(std::string_view text, Diagnostics& d) {
    return Lexer(text, d).run();
}

}  // namespace isoforge::csg
