#include "csg/openscad.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

extern char** environ;

namespace isoforge::csg {

namespace {

std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// A temporary directory removed when the export is done, whatever happens.
struct TempDir {
    std::filesystem::path path;
    TempDir() {
        std::string tmpl = (std::filesystem::temp_directory_path() / "isoforge-scad-XXXXXX").string();
        if (!mkdtemp(tmpl.data())) throw IoError("cannot make a temporary directory: " + std::string(strerror(errno)));
        path = tmpl;
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
};

/// OpenSCAD's "... in file F, line N" (F sometimes quoted, sometimes followed by ':'), split off the
/// message. (Parsed by hand: std::regex trips GCC 12's maybe-uninitialized warnings under -O1.)
Warning located(const std::string& path, std::string text) {
    Warning w;
    w.loc.file = path;
    const std::size_t at = text.find(" in file ");
    if (at != std::string::npos) {
        std::size_t p = at + 9;
        const bool quoted = p < text.size() && text[p] == '"';
        if (quoted) ++p;
        const std::size_t end = text.find(quoted ? '"' : ',', p);
        const std::string lineTag = ", line ";
        const std::size_t tag = end == std::string::npos ? end : text.find(lineTag, end);
        if (tag != std::string::npos && tag <= end + 1) {
            std::size_t q = tag + lineTag.size();
            int line = 0;
            while (q < text.size() && std::isdigit(static_cast<unsigned char>(text[q])) && line < 100000000)
                line = line * 10 + (text[q++] - '0');
            if (q < text.size() && text[q] == ':') ++q;
            w.loc.file = text.substr(p, end - p);
            w.loc.line = line;
            std::size_t from = at;
            if (from > 0 && text[from - 1] == ',') --from;
            text = text.substr(0, from) + text.substr(q);
        }
    }
    while (!text.empty() && (text.back() == ' ' || text.back() == ':')) text.pop_back();
    w.message = "openscad: " + text;
    return w;
}

}  // namespace

std::string openscadProgram() {
    const char* env = std::getenv("ISOFORGE_OPENSCAD");
    return env && *env ? env : "openscad";
}

ScadExport exportScad(const std::string& path, const std::vector<std::string>& defines) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw IoError(path + ": cannot open (no such file)");
    const TempDir tmp;
    const std::string out = (tmp.path / "model.csg").string(), log = (tmp.path / "openscad.log").string();
    const std::string deps = (tmp.path / "model.d").string();
    const std::string program = openscadProgram();
    std::vector<std::string> argv{program, "-o", out, "-d", deps};
    for (const std::string& d : defines) {
        argv.push_back("-D");
        argv.push_back(d);
    }
    argv.push_back(path);
    std::vector<char*> cargv;
    for (std::string& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);

    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    pid_t pid = 0;
    const int rc = posix_spawnp(&pid, program.c_str(), &actions, nullptr, cargv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc == ENOENT)
        throw IoError(path + ": reading .scad files needs OpenSCAD (Debian package openscad); '" + program +
                      "' was not found");
    if (rc != 0) throw IoError(path + ": cannot run " + program + ": " + strerror(rc));
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }

    ScadExport result;
    std::vector<Warning> errors;
    std::istringstream lines(slurp(log));
    for (std::string line; std::getline(lines, line);) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.rfind("ERROR: ", 0) == 0) {
            errors.push_back(located(path, line));
        } else if (line.rfind("WARNING: ", 0) == 0 || line.rfind("DEPRECATED: ", 0) == 0 ||
                   line.rfind("ECHO: ", 0) == 0 || line.rfind("TRACE: ", 0) == 0) {
            result.messages.push_back(located(path, line));
        }
    }
    const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0 && std::filesystem::is_regular_file(out, ec);
    if (!ok || !errors.empty()) {
        if (ok) {
            // OpenSCAD reports some errors and still exports what it could: keep them as warnings.
            result.messages.insert(result.messages.end(), errors.begin(), errors.end());
        } else {
            std::string all;
            for (const Warning& e : errors) all += (all.empty() ? "" : "\n") + e.loc.toString() + ": " + e.message;
            if (all.empty())
                all = path + ": openscad -o model.csg failed (" +
                      (WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                                         : std::string("killed by a signal")) +
                      ")";
            throw ParseError(all);
        }
    }
    result.csg = slurp(out);
    if (std::filesystem::is_regular_file(deps, ec)) result.dependencies = parseMakeDependencies(slurp(deps));
    if (result.dependencies.empty()) result.dependencies.push_back(path);
    return result;
}

std::vector<std::string> parseMakeDependencies(const std::string& text) {
    std::vector<std::string> out;
    std::string word;
    bool afterColon = false;
    const auto flush = [&] {
        if (afterColon && !word.empty()) out.push_back(word);
        word.clear();
    };
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (c == '\\' && i + 1 < text.size()) {
            const char n = text[i + 1];
            if (n == '\n' || n == '\r') {  // a continued line
                flush();
                ++i;
                if (n == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
                continue;
            }
            if (n == ' ' || n == '\\' || n == '#' || n == ':') {  // an escaped character of a name
                word += n;
                ++i;
                continue;
            }
            word += c;
        } else if (c == ':' && !afterColon &&
                   (i + 1 == text.size() || text[i + 1] == ' ' || text[i + 1] == '\t' || text[i + 1] == '\n')) {
            word.clear();  // the target
            afterColon = true;
        } else if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
            flush();
        } else {
            word += c;
        }
    }
    flush();
    return out;
}

}  // namespace isoforge::csg
