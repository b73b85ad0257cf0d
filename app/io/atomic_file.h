// All-or-nothing output files (ARCHITECTURE.md, tier 2 of errors): everything is written to
// "<name>.tmp" in the same directory and renamed over <name> only on commit(), so a crash or an
// error never leaves a half-written file and an existing result is replaced only on success.
#pragma once

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>

namespace sigmaheart::app::io {

class AtomicFile {
 public:
  // Creates the parent directories of `path` if needed. Nothing is written yet.
  explicit AtomicFile(std::filesystem::path path);
  ~AtomicFile();  // removes the temporary file unless commit() succeeded
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const std::filesystem::path& temp_path() const { return temp_; }
  // Renames the temporary file over path(). Throws RunFailure when that fails.
  void commit();

 private:
  std::filesystem::path path_;
  std::filesystem::path temp_;
  bool committed_ = false;
};

// Writes a text file atomically: `fill` writes the content to the stream. Throws RunFailure
// when the file cannot be written.
void write_text_file(const std::filesystem::path& path,
                     const std::function<void(std::ostream&)>& fill);

}  // namespace sigmaheart::app::io
