// What `personalize` writes: the HDF5 results file (kind "personalize", every filter step; read by
// scripts/sigmaplot_regional.py), the JSON summary and the terminal table, all from the
// RoukfSummary (which carries every number shown) and the problem it solved.
#pragma once

#include "app/io/results.h"
#include "app/personalize_setup.h"
#include "estimation/roukf/roukf.h"

#include <filesystem>
#include <string>

namespace sigmaheart::app::io {

struct RoukfResults {
  const PersonalizeProblem* problem = nullptr;
  const estimation::RoukfSummary* summary = nullptr;
  const model::ParameterSpace* space = nullptr;  // the simulator's parameters
  int threads = 1;
  // The estimate (the prior where the filter produced none) and its delta-method std.
  Eigen::VectorXd value() const;
  Eigen::VectorXd std() const;
};

// The results file (written atomically; provenance.end_utc is set here).
void write_roukf_h5(const std::filesystem::path& path, const RoukfResults& results,
                    Provenance provenance);
// The JSON summary, with a `provenance` key (provenance_json, app/io/results.h).
void write_roukf_json(const std::filesystem::path& path, const std::string& name,
                      const RoukfResults& results, const Provenance& provenance);
// The brief report and one line per parameter (Pa shown as kPa), with the truth when given.
std::string roukf_report(const RoukfResults& results);

}  // namespace sigmaheart::app::io
