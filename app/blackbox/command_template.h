// The command line of an external simulator, written as a template (docs/architecture.md s.9):
//
//   command: "./model.py --params {params} --out {output}"
//
// The template is split into words the way a POSIX shell splits a simple command (blanks
// separate words; '...' and "..." quote, a backslash escapes the next character outside single
// quotes) but no shell runs it: no pipes, redirections, globs or variables, so a parameter value
// or a path with a space can never become two arguments or a second command. Placeholders are
// replaced inside each word after splitting: {params}, {output}, {dir}, {member}, and for the
// steppable protocol {state_in}, {state_out}, {t_end}. Anything else in braces, an unclosed brace
// or quote, or an empty command is a template error. `{{` and `}}` stand for literal braces.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app::blackbox {

class CommandTemplate {
 public:
  // Parses `text`, allowing only the placeholders in `allowed` (names without braces). Throws
  // std::invalid_argument with a message naming the column (1-based) of the first error.
  static CommandTemplate parse(const std::string& text, const std::vector<std::string>& allowed);

  // The argument vector with every placeholder replaced by values.at(name) (std::out_of_range
  // for a placeholder without a value).
  std::vector<std::string> expand(const std::map<std::string, std::string>& values) const;

  // The program word as written (before any expansion; may hold placeholders).
  const std::string& program() const { return program_; }
  bool program_has_placeholder() const { return program_placeholder_; }
  // The placeholders used anywhere in the template.
  const std::vector<std::string>& used() const { return used_; }
  bool uses(const std::string& name) const;

 private:
  // A word is a sequence of pieces: literal text or a placeholder name.
  struct Piece {
    bool placeholder = false;
    std::string text;
  };
  std::vector<std::vector<Piece>> words_;
  std::string program_;
  bool program_placeholder_ = false;
  std::vector<std::string> used_;
};

// The executable a program word names: a word with a '/' is a path (relative ones resolved
// against `base_directory`, then made absolute); a bare name is looked up in $PATH. nullopt when
// there is no such regular file with execute permission for this process; `why` then says
// what was looked at.
std::optional<std::string> resolve_executable(const std::string& program,
                                              const std::string& base_directory, std::string& why);

}  // namespace sigmaheart::app::blackbox
