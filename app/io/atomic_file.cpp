#include "app/io/atomic_file.h"

#include "app/errors.h"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <vector>

#include <atomic>
#include <fstream>
#include <string>
#include <system_error>

namespace sigmaheart::app::io {

namespace {
std::atomic<bool> g_writes_outputs{true};
std::atomic<long> g_scratch_files{0};
std::atomic<long> g_temp_files{0};
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
  if (path_.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path_.parent_path(), ec);
    if (ec) {
      throw RunFailure("cannot create the directory " + path_.parent_path().string() + ": " +
                       ec.message());
    }
  }
  remove_stale_temporaries(path_);
  temp_ = path_.parent_path() / temporary_name(path_.filename().string(), ::getpid(),
                                               g_temp_files.fetch_add(1));
}

std::string temporary_name(const std::string& name, long pid, long serial) {
  std::string out(1, '.');  // appended piecewise: "." + name trips a false -Wrestrict of GCC 12
  out.append(name).append(".sigmaheart-").append(std::to_string(pid));
  out.append("-").append(std::to_string(serial)).append(".tmp");
  return out;
}

int remove_stale_temporaries(const std::filesystem::path& path) {
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
  std::string prefix(1, '.');
  prefix.append(path.filename().string()).append(".sigmaheart-");
  std::error_code ec;
  std::vector<std::filesystem::path> stale;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) != 0 || name.size() < prefix.size() + 5 ||
        name.compare(name.size() - 4, 4, ".tmp") != 0) {
      continue;
    }
    const std::string rest = name.substr(prefix.size());
    const long pid = std::strtol(rest.c_str(), nullptr, 10);
    // A writer whose process is gone (killed, or on another machine's now-dead job) left it;
    // kill(pid, 0) fails with ESRCH exactly then. Files of live processes are left alone.
    if (pid > 0 && pid != ::getpid() && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      stale.push_back(entry.path());
    }
  }
  for (const auto& f : stale) std::filesystem::remove(f, ec);
  return static_cast<int>(stale.size());
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
