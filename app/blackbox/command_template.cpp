#include "app/blackbox/command_template.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <sys/stat.h>

namespace sigmaheart::app::blackbox {

namespace {

[[noreturn]] void bad(size_t column, const std::string& what) {
  throw std::invalid_argument("command template, column " + std::to_string(column + 1) + ": " +
                              what);
}

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "{" : ", {") + n + "}";
  return s;
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

}  // namespace

CommandTemplate CommandTemplate::parse(const std::string& text,
                                       const std::vector<std::string>& allowed) {
  CommandTemplate t;
  std::vector<Piece> word;
  bool in_word = false;
  auto literal = [&](char c) {
    if (word.empty() || word.back().placeholder) word.push_back({false, {}});
    word.back().text.push_back(c);
    in_word = true;
  };
  auto end_word = [&] {
    if (in_word) t.words_.push_back(std::move(word));
    word.clear();
    in_word = false;
  };
  char quote = 0;  // ' or " while inside quotes
  size_t quote_start = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quote == '\'') {
      if (c == '\'') {
        quote = 0;
        continue;
      }
    } else if (c == '\\') {
      if (i + 1 >= text.size()) bad(i, "a backslash at the end escapes nothing");
      literal(text[++i]);
      continue;
    } else if (quote == 0 && (c == '\'' || c == '"')) {
      quote = c;
      quote_start = i;
      in_word = true;  // '' is an empty argument
      continue;
    } else if (quote == '"' && c == '"') {
      quote = 0;
      continue;
    } else if (quote == 0 && is_blank(c)) {
      end_word();
      continue;
    }
    // Braces are placeholders everywhere, also inside quotes; a doubled brace is a literal one.
    if ((c == '{' || c == '}') && i + 1 < text.size() && text[i + 1] == c) {
      literal(c);
      ++i;
      continue;
    }
    if (c == '{') {
      const size_t close = text.find('}', i + 1);
      if (close == std::string::npos) bad(i, "'{' is never closed (write {{ for a literal brace)");
      const std::string name = text.substr(i + 1, close - i - 1);
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        bad(i, "unknown placeholder {" + name + "}; expected one of " + join(allowed) +
                   " (write {{ and }} for literal braces)");
      }
      word.push_back({true, name});
      in_word = true;
      if (std::find(t.used_.begin(), t.used_.end(), name) == t.used_.end()) t.used_.push_back(name);
      i = close;
      continue;
    }
    if (c == '}') bad(i, "'}' without a '{' (write }} for a literal brace)");
    literal(c);
  }
  if (quote != 0) bad(quote_start, std::string("the quote ") + quote + " is never closed");
  end_word();
  if (t.words_.empty()) throw std::invalid_argument("command template: empty command");
  for (const auto& p : t.words_.front()) {
    if (p.placeholder) t.program_placeholder_ = true;
    t.program_ += p.placeholder ? "{" + p.text + "}" : p.text;
  }
  return t;
}

std::vector<std::string> CommandTemplate::expand(
    const std::map<std::string, std::string>& values) const {
  std::vector<std::string> argv;
  argv.reserve(words_.size());
  for (const auto& w : words_) {
    std::string s;
    for (const auto& p : w) s += p.placeholder ? values.at(p.text) : p.text;
    argv.push_back(std::move(s));
  }
  return argv;
}

bool CommandTemplate::uses(const std::string& name) const {
  return std::find(used_.begin(), used_.end(), name) != used_.end();
}

namespace {

bool executable_file(const std::filesystem::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(p.c_str(), X_OK) == 0;
}

}  // namespace

std::optional<std::string> resolve_executable(const std::string& program,
                                              const std::string& base_directory, std::string& why) {
  namespace fs = std::filesystem;
  if (program.find('/') != std::string::npos) {
    fs::path p(program);
    if (p.is_relative() && !base_directory.empty()) p = fs::path(base_directory) / p;
    std::error_code ec;
    const fs::path abs = fs::absolute(p, ec).lexically_normal();
    if (executable_file(abs)) return abs.string();
    const char* state = !fs::exists(abs, ec)          ? "does not exist"
                        : fs::is_directory(abs, ec) ? "is a directory"
                                                    : "is not an executable file (chmod +x?)";
    why.assign(1, '\'').append(abs.string()).append("' ").append(state).append(
        " (a program path with '/' is relative to the config file's directory)");
    return std::nullopt;
  }
  const char* path_env = std::getenv("PATH");
  const std::string path = path_env ? path_env : "/usr/local/bin:/usr/bin:/bin";
  size_t start = 0;
  while (start <= path.size()) {
    const size_t end = std::min(path.find(':', start), path.size());
    const std::string dir = end > start ? path.substr(start, end - start) : std::string(".");
    const fs::path candidate = fs::path(dir) / program;
    if (executable_file(candidate)) {
      std::error_code ec;
      return fs::absolute(candidate, ec).string();
    }
    start = end + 1;
  }
  // (not "'" + program + ...: that trips a false -Wrestrict warning of GCC 12)
  why.assign(1, '\'').append(program).append("' is not an executable in any directory of $PATH");
  return std::nullopt;
}

}  // namespace sigmaheart::app::blackbox
