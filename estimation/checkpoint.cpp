#include "estimation/checkpoint.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>

namespace sigmaheart::estimation {

namespace {

constexpr char kMagic[8] = {'S', 'H', 'C', 'K', 'P', 'T', '0', '1'};
constexpr std::uint32_t kRecordMagic = 0x31434552;  // "REC1" little-endian
constexpr std::size_t kHeaderSize = sizeof(kMagic) + sizeof(std::uint64_t);

template <typename T>
void put(std::vector<char>& buf, const T& value) {
  const char* p = reinterpret_cast<const char*>(&value);
  buf.insert(buf.end(), p, p + sizeof(T));
}

// Reads T at `pos` of `data` (size `n`); false when it does not fit.
template <typename T>
bool get(const char* data, std::size_t n, std::size_t& pos, T& value) {
  if (pos + sizeof(T) > n) return false;
  std::memcpy(&value, data + pos, sizeof(T));
  pos += sizeof(T);
  return true;
}

std::filesystem::path rank_file(const std::filesystem::path& path, int rank) {
  if (rank == 0) return path;
  std::filesystem::path p = path;
  p += ".rank" + std::to_string(rank);
  return p;
}

[[noreturn]] void io_error(const std::string& what, const std::filesystem::path& file) {
  throw std::runtime_error("checkpoint " + file.string() + ": " + what + ": " + std::strerror(errno));
}

}  // namespace

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t h = seed;
  for (std::size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

MemberCheckpoint::MemberCheckpoint(CheckpointOptions options)
    : options_(std::move(options)), file_(rank_file(options_.path, options_.rank)) {
  if (options_.path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(options_.path.parent_path(), ec);
  }
  if (options_.resume) {
    load_file(options_.path, options_.rank == 0);
    // The other ranks' files: path.rank1, path.rank2, ... (any count: the run may have had more).
    const std::filesystem::path dir = options_.path.has_parent_path() ? options_.path.parent_path() : ".";
    const std::string prefix = options_.path.filename().string() + ".rank";
    std::error_code ec;
    std::vector<std::filesystem::path> others;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind(prefix, 0) == 0 && name.size() > prefix.size() &&
          name.find_first_not_of("0123456789", prefix.size()) == std::string::npos) {
        others.push_back(entry.path());
      }
    }
    for (const auto& f : others) load_file(f, f.filename() == file_.filename());
  }
  // Open this rank's file: appended to after a resume (its tail already cut to the last good
  // record), started anew otherwise.
  const bool append = options_.resume && std::filesystem::exists(file_) &&
                      std::filesystem::file_size(file_) >= kHeaderSize;
  out_ = std::fopen(file_.c_str(), append ? "ab" : "wb");
  if (!out_) io_error("cannot open for writing", file_);
  if (!append) {
    std::vector<char> header(kMagic, kMagic + sizeof(kMagic));
    put(header, options_.fingerprint);
    if (std::fwrite(header.data(), 1, header.size(), out_) != header.size() || std::fflush(out_) != 0) {
      io_error("cannot write", file_);
    }
  }
}

MemberCheckpoint::~MemberCheckpoint() {
  if (out_) std::fclose(out_);
}

void MemberCheckpoint::load_file(const std::filesystem::path& file, bool own) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return;  // no checkpoint yet
  const std::vector<char> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t n = data.size();
  if (n < kHeaderSize || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
    if (n >= sizeof(kMagic) && std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
      throw CheckpointMismatch(file.string() + " is not a sigmaheart checkpoint");
    }
    return;  // header cut short by a kill: nothing was recorded
  }
  std::size_t pos = sizeof(kMagic);
  std::uint64_t fingerprint = 0;
  get(data.data(), n, pos, fingerprint);
  if (fingerprint != options_.fingerprint) {
    throw CheckpointMismatch(file.string() +
                             " was written by a different run (another command, config or --set); "
                             "remove it or run without --resume");
  }
  std::size_t good = pos;
  while (true) {
    std::uint32_t magic = 0, length = 0;
    std::size_t p = pos;
    if (!get(data.data(), n, p, magic) || magic != kRecordMagic || !get(data.data(), n, p, length)) break;
    if (p + length + sizeof(std::uint64_t) > n) break;
    const char* payload = data.data() + p;
    std::uint64_t sum = 0;
    std::size_t q = p + length;
    get(data.data(), n, q, sum);
    if (sum != fnv1a64(payload, length)) break;
    // Payload: key length (u16), key, status code (i32), message length (u32), message, width
    // (u32), doubles.
    std::size_t r = 0;
    std::uint16_t key_length = 0;
    std::int32_t code = 0;
    std::uint32_t msg_length = 0, width = 0;
    if (!get(payload, length, r, key_length) || r + key_length > length) break;
    std::string key(payload + r, key_length);
    r += key_length;
    if (!get(payload, length, r, code) || !get(payload, length, r, msg_length) || r + msg_length > length) break;
    Record rec;
    rec.status.code = static_cast<model::StatusCode>(code);
    rec.status.message.assign(payload + r, msg_length);
    r += msg_length;
    if (!get(payload, length, r, width) || r + std::size_t{width} * sizeof(double) != length) break;
    rec.row.resize(width);
    std::memcpy(rec.row.data(), payload + r, std::size_t{width} * sizeof(double));
    records_[std::move(key)] = std::move(rec);
    pos = q;
    good = q;
  }
  if (own && good < n) {
    // A record cut short by a kill: drop it before appending after it.
    std::error_code ec;
    std::filesystem::resize_file(file, good, ec);
    if (ec) throw std::runtime_error("checkpoint " + file.string() + ": cannot cut its damaged tail: " + ec.message());
  }
}

int MemberCheckpoint::next_instance(const std::string& scope) {
  std::lock_guard<std::mutex> lock(mutex_);
  return instances_[scope]++;
}

std::string MemberCheckpoint::key(const std::string& scope, int instance, long call, int member) {
  return scope + "/" + std::to_string(instance) + "/" + std::to_string(call) + "/" + std::to_string(member);
}

const MemberCheckpoint::Record* MemberCheckpoint::find(const std::string& key) const {
  // records_ is only written in the constructor, so lookups need no lock.
  const auto it = records_.find(key);
  return it == records_.end() ? nullptr : &it->second;
}

void MemberCheckpoint::add(const std::string& key, const model::Status& status,
                           const Eigen::Ref<const Eigen::VectorXd>& row) {
  std::vector<char> payload;
  put(payload, static_cast<std::uint16_t>(key.size()));
  payload.insert(payload.end(), key.begin(), key.end());
  put(payload, static_cast<std::int32_t>(status.code));
  put(payload, static_cast<std::uint32_t>(status.message.size()));
  payload.insert(payload.end(), status.message.begin(), status.message.end());
  put(payload, static_cast<std::uint32_t>(row.size()));
  for (Eigen::Index i = 0; i < row.size(); ++i) put(payload, row(i));
  std::lock_guard<std::mutex> lock(mutex_);
  put(pending_, kRecordMagic);
  put(pending_, static_cast<std::uint32_t>(payload.size()));
  pending_.insert(pending_.end(), payload.begin(), payload.end());
  put(pending_, fnv1a64(payload.data(), payload.size()));
  ++pending_count_;
}

void MemberCheckpoint::flush() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!out_ || pending_.empty()) return;
  if (std::fwrite(pending_.data(), 1, pending_.size(), out_) != pending_.size() || std::fflush(out_) != 0) {
    io_error("cannot write", file_);
  }
  ::fsync(::fileno(out_));
  written_ += pending_count_;
  pending_count_ = 0;
  pending_.clear();
}

int MemberCheckpoint::reused() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return reused_;
}
int MemberCheckpoint::written() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return written_;
}
void MemberCheckpoint::note_reused(int n) {
  std::lock_guard<std::mutex> lock(mutex_);
  reused_ += n;
}

void MemberCheckpoint::remove() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (out_) std::fclose(out_);
  out_ = nullptr;
  std::error_code ec;
  std::filesystem::remove(file_, ec);
  if (options_.rank == 0) {
    const std::filesystem::path dir = options_.path.has_parent_path() ? options_.path.parent_path() : ".";
    const std::string prefix = options_.path.filename().string() + ".rank";
    std::vector<std::filesystem::path> stale;
    for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
      if (entry.path().filename().string().rfind(prefix, 0) == 0) stale.push_back(entry.path());
    }
    for (const auto& f : stale) std::filesystem::remove(f, ec);
  }
}

}  // namespace sigmaheart::estimation
