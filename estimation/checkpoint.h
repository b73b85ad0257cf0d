// Checkpoint and resume of ensembles (docs/architecture.md s.5, "Checkpoint and resume").
//
// Every estimator in sigmaheart is deterministic: the same config and seed make the same ensemble
// calls with the same members, whatever the thread or rank count. So a run can be resumed by
// replaying it from the start and looking every member up in a record of the members an earlier
// run finished: the estimator's own arithmetic is repeated (milliseconds), the forward runs are
// not, and the result is bit for bit that of an uninterrupted run.
//
// A member is keyed by (scope, instance, call, member): `scope` names an independent stream of
// work (a case of a specificity study; empty for a single estimator), `instance` counts the
// Ensembles built in that scope, `call` the evaluate()/map_rows() calls of that Ensemble and
// `member` the row. The record holds the member's Status and row (failed members too: a failure is
// deterministic and its handling belongs to the estimator's policy).
//
// File format: an append-only log, so a kill at any moment leaves every record written before it
// intact. Header: 8 bytes "SHCKPT01", the run's 64-bit fingerprint. Records: magic "REC1", payload
// length (u32), payload (key, status code, message, width, doubles; little-endian host order),
// FNV-1a-64 of the payload. Reading stops at the first truncated or corrupt record; the writer
// truncates the file there before appending. Each flush() ends with fsync.
//
// Ranks: each rank appends to its own file (rank 0: `path`, rank r: `path.rank<r>`); a resume
// reads all of them, so a run may be resumed on a different number of ranks. A distributed
// ensemble's rows are gathered on every rank and recorded by rank 0 only.
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace sigmaheart::estimation {

// The checkpoint on disk belongs to another run (different command, config or overrides).
class CheckpointMismatch : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// 64-bit FNV-1a of bytes (the fingerprint and the record checksum).
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed = 0xcbf29ce484222325ULL);

struct CheckpointOptions {
  std::filesystem::path path;   // rank 0's file; other ranks add ".rank<r>"
  std::uint64_t fingerprint = 0;
  bool resume = false;          // load the records of an earlier run (all ranks' files)
  int rank = 0;                 // this process's rank
};

class MemberCheckpoint {
 public:
  struct Record {
    model::Status status;
    Eigen::VectorXd row;
  };

  // Opens the file for appending. With resume, first loads every rank's file (a missing file is
  // an empty checkpoint; a file with another fingerprint throws CheckpointMismatch; a header cut
  // short counts as empty). Without resume, starts this rank's file anew. Throws
  // std::runtime_error when the file cannot be created.
  explicit MemberCheckpoint(CheckpointOptions options);
  ~MemberCheckpoint();
  MemberCheckpoint(const MemberCheckpoint&) = delete;
  MemberCheckpoint& operator=(const MemberCheckpoint&) = delete;

  // Thread-safe. The instance number of the next Ensemble built in `scope` (0, 1, ...).
  int next_instance(const std::string& scope);
  static std::string key(const std::string& scope, int instance, long call, int member);

  // The record of an earlier run, nullptr when there is none. Thread-safe.
  const Record* find(const std::string& key) const;
  // Buffers a record; flush() writes the buffer. Thread-safe.
  void add(const std::string& key, const model::Status& status, const Eigen::Ref<const Eigen::VectorXd>& row);
  // Appends the buffered records, flushes and fsyncs. Throws std::runtime_error on an I/O error.
  void flush();

  int loaded() const { return static_cast<int>(records_.size()); }  // records of earlier runs
  int reused() const;   // lookups that found a record
  int written() const;  // records this process appended
  void note_reused(int n);

  // This rank's file.
  const std::filesystem::path& file() const { return file_; }
  // Closes and deletes this rank's file (rank 0 also deletes files of ranks that no longer run).
  void remove();

 private:
  void load_file(const std::filesystem::path& file, bool own);

  CheckpointOptions options_;
  std::filesystem::path file_;
  std::FILE* out_ = nullptr;
  std::unordered_map<std::string, Record> records_;
  std::vector<char> pending_;
  std::map<std::string, int> instances_;
  mutable std::mutex mutex_;
  int reused_ = 0;
  int written_ = 0;
  int pending_count_ = 0;
};

}  // namespace sigmaheart::estimation
