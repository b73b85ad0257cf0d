#include "app/io/atomic_file.h"

#include "app/errors.h"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <string>
#include <system_error>

namespace sigmaheart::app::io {

namespace {
std::atomic<bool> g_writes_outputs{true};
std::atomic<long> g_scratch_files{0};
}  // namespace

bool writes_outputs() { return g_writes_outputs.load(); }

OutputRankScope::OutputRankScope(bool writes) : previous_(g_writes_outputs.exchange(writes)) {}
OutputRankScope::~OutputRankScope() { g_writes_outputs.store(previous_); }

AtomicFile::AtomicFile(std::filesystem::path path) : path_(std::move(path)) {
  if (!writes_outputs()) {
    discard_ = true;
    std::error_code ec;
    std::filesystem::path dir = std::filesystem::temp_directory_path(ec);
    if (ec) dir = ".";
    temp_ = dir / ("sigmaheart-discard-" + std::to_string(::getpid()) + "-" +
                   std::to_string(g_scratch_files.fetch_add(1)) + path_.extension().string());
    return;
  }
  temp_ = path_;
  temp_ += ".tmp";
  if (path_.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path_.parent_path(), ec);
    if (ec) {
      throw RunFailure("cannot create the directory " + path_.parent_path().string() + ": " +
                       ec.message());
    }
  }
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
}

void AtomicFile::commit() {
  std::error_code ec;
  if (discard_) {
    std::filesystem::remove(temp_, ec);
    committed_ = true;
    return;
  }
  std::filesystem::rename(temp_, path_, ec);  // atomic replacement on POSIX file systems
  if (ec) throw RunFailure("cannot rename " + temp_.string() + " to " + path_.string() + ": " + ec.message());
  committed_ = true;
}

void write_text_file(const std::filesystem::path& path,
                     const std::function<void(std::ostream&)>& fill) {
  AtomicFile file(path);
  {
    std::ofstream out(file.temp_path(), std::ios::binary | std::ios::trunc);
    if (!out) throw RunFailure("cannot write " + file.temp_path().string());
    fill(out);
    out.flush();
    if (!out) throw RunFailure("error while writing " + file.temp_path().string());
  }
  file.commit();
}

}  // namespace sigmaheart::app::io
