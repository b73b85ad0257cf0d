// All-or-nothing output files (docs/architecture.md, tier 2 of errors): everything is written to a
// hidden temporary file in the same directory, ".<name>.sigmaheart-<pid>-<serial>.tmp" (unique, so
// two runs writing next to each other never collide), and renamed over <name> only on commit(), so
// a crash or an error never leaves a half-written file and an existing result is replaced only on
// success. An error or a signal that ends the command removes the temporary file (destructor); one
// left by a SIGKILL is removed by the next writer of the same name once its process is gone.
//
// Under several ranks (docs/architecture.md, "Parallelism") every rank runs the same command, but only
// the root writes: run_cli opens an OutputRankScope(false) on the other ranks, where AtomicFile
// writes to a private scratch file in the system temporary directory that commit() removes.
// Writers therefore need no rank guard and never collide on the same file.
#pragma once

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>

namespace sigmaheart::app::io {

// Whether this process writes output files (true unless an OutputRankScope(false) is open).
bool writes_outputs();

// Sets writes_outputs() for its lifetime (process-wide; restores the previous value).
class OutputRankScope {
 public:
  explicit OutputRankScope(bool writes);
  ~OutputRankScope();
  OutputRankScope(const OutputRankScope&) = delete;
  OutputRankScope& operator=(const OutputRankScope&) = delete;

 private:
  bool previous_;
};

class AtomicFile {
 public:
  // Creates the parent directories of `path` if needed. Nothing is written yet. When
  // !writes_outputs(), temp_path() is a scratch file elsewhere and `path` is never touched.
  explicit AtomicFile(std::filesystem::path path);
  ~AtomicFile();  // removes the temporary file unless commit() succeeded
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const std::filesystem::path& temp_path() const { return temp_; }
  // Renames the temporary file over path() (removes it when !writes_outputs()). Throws
  // RunFailure when that fails.
  void commit();

 private:
  std::filesystem::path path_;
  std::filesystem::path temp_;
  bool committed_ = false;
  bool discard_ = false;
};

// The temporary name of `name` for process `pid` (what AtomicFile uses; exposed for tests).
std::string temporary_name(const std::string& name, long pid, long serial);
// Removes the temporaries of `path` left by processes that no longer exist; returns how many.
int remove_stale_temporaries(const std::filesystem::path& path);

// Writes a text file atomically: `fill` writes the content to the stream. Throws RunFailure
// when the file cannot be written.
void write_text_file(const std::filesystem::path& path,
                     const std::function<void(std::ostream&)>& fill);

}  // namespace sigmaheart::app::io
