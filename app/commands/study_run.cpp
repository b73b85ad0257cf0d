// StudyRun: checkpoint, outputs against inputs, failed results kept apart (app/commands/commands.h).
#include "app/commands/commands.h"
#include "app/errors.h"
#include "estimation/checkpoint.h"

#include <spdlog/spdlog.h>

#include <exception>
#include <fstream>
#include <iterator>

namespace sigmaheart::app {

namespace {

std::uint64_t fingerprint(const std::string& kind, const Config& config) {
  std::string text = "sigmaheart checkpoint\n" + kind + "\n" + config.file.text() + "\n";
  for (const auto& o : config.file.overrides()) text += "--set " + o + "\n";
  for (const auto& f : named_input_files()) {
    std::ifstream in(f, std::ios::binary);
    text += "file " + f.string() + "\n";
    text.append(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return estimation::fnv1a64(text.data(), text.size());
}

}  // namespace

StudyRun::StudyRun(const StudyOptions& o, const CommandContext& ctx, const Config& config, const std::string& kind)
    : output_(study_output(o, kind)), summary_(o.summary), root_(ctx.root()) {
  check_outputs({{"-o", output_}, {"--summary", summary_}}, named_input_files());
  checkpoint_path_ = output_;
  checkpoint_path_ += ".checkpoint";
  const bool exists = std::filesystem::exists(checkpoint_path_);
  if (o.resume && !exists) {
    if (root_) spdlog::warn("--resume: no checkpoint at {}; starting from the beginning", checkpoint_path_.string());
  } else if (!o.resume && exists && root_) {
    spdlog::warn("the checkpoint {} of an earlier, unfinished run is discarded (use --resume to continue it)",
                 checkpoint_path_.string());
  }
  estimation::CheckpointOptions co;
  co.path = checkpoint_path_;
  co.fingerprint = fingerprint(kind, config);
  co.resume = o.resume;
  co.rank = ctx.rank;
  try {
    checkpoint_ = std::make_unique<estimation::MemberCheckpoint>(co);
  } catch (const estimation::CheckpointMismatch& e) {
    throw InputError(Location{"--resume"}, e.what());
  } catch (const std::runtime_error& e) {
    throw RunFailure(e.what());
  }
  if (o.resume && checkpoint_->loaded() > 0 && root_) {
    spdlog::info("resuming from {}: {} finished member(s) recorded", checkpoint_path_.string(),
                 checkpoint_->loaded());
  }
}

StudyRun::~StudyRun() {
  if (finished_ || !checkpoint_) return;
  if (std::uncaught_exceptions() > 0 && root_) {
    checkpoint_->flush();
    spdlog::warn("{} finished member(s) are kept in {}; run the same command with --resume to continue",
                 checkpoint_->loaded() + checkpoint_->written(), checkpoint_path_.string());
  }
}

void StudyRun::attach(estimation::EnsembleOptions& ensemble, const std::string& scope) const {
  ensemble.checkpoint = checkpoint_.get();
  ensemble.checkpoint_scope = scope;
}

std::filesystem::path StudyRun::aside(const std::filesystem::path& file, bool succeeded) {
  return result_path(file, succeeded, &kept_note_);
}

std::filesystem::path StudyRun::output(bool succeeded) { return written_ = aside(output_, succeeded); }
std::filesystem::path StudyRun::summary(bool succeeded) { return aside(summary_, succeeded); }

int StudyRun::end(const CommandContext& ctx, bool succeeded, const std::string& failure) {
  finish();
  if (succeeded) return kExitOk;
  return stopped_early(ctx, failure + " " + written_.string() + kept_note_);
}

void StudyRun::finish() {
  finished_ = true;
  if (!checkpoint_) return;
  if (checkpoint_->reused() > 0 && root_) {
    spdlog::info("resumed: {} member(s) taken from the checkpoint, {} run now", checkpoint_->reused(),
                 checkpoint_->written());
  }
  checkpoint_->remove();
}

}  // namespace sigmaheart::app
