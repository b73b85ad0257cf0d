#include "app/io/observe_h5.h"

#include "app/io/hdf5_writer.h"

namespace sigmaheart::app::io {

void write_observe_h5(const std::filesystem::path& path, const Provenance& provenance, const model::Trajectory& observed,
                      const observers::VolumeChecks& checks, const ObservedFrames& frames) {
  Hdf5Writer h5(path);
  write_trajectory(h5, "/observed", observed);
  h5.create_group("/checks");
  h5.set_attribute("/checks", "edv", checks.edv * 1e6);
  h5.set_attribute("/checks", "esv", checks.esv * 1e6);
  h5.set_attribute("/checks", "ef", checks.ef);
  h5.set_attribute("/checks", "end_diastole", checks.end_diastole);
  h5.set_attribute("/checks", "end_systole", checks.end_systole);
  h5.set_attribute("/checks", "max_sum_error", checks.max_sum_error);
  h5.set_attribute("/checks", "status", checks.ok() ? "ok" : "tracking-failure");
  Eigen::VectorXd ef(observers::kAhaSegments);
  for (int s = 0; s < observers::kAhaSegments; ++s) ef(s) = checks.regional_ef[static_cast<size_t>(s)];
  h5.write_vector("/checks/regional_ef", ef, "1");
  std::vector<std::string> findings;
  for (const auto& f : checks.findings)
    findings.push_back("frame " + std::to_string(f.frame) + ", segment " + std::to_string(f.segment) + ": " + f.what);
  h5.write_strings("/checks/findings", findings);
  h5.create_group("/frames");
  h5.write_strings("/frames/notes", frames.notes);
  if (frames.has_quality) {
    h5.set_attribute("/frames", "worst_quality", frames.worst_quality);
    h5.set_attribute("/frames", "worst_quality_frame", frames.worst_quality_frame);
    h5.set_attribute("/frames", "inverted", frames.inverted);
  }
  Provenance p = provenance;
  p.end_utc = utc_now();
  write_provenance(h5, p);
  h5.commit();
}

}  // namespace sigmaheart::app::io
