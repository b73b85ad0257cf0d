// The codes' curves of the Arostica et al. 2025 benchmark bundled under configs/data/arostica-2025/
// (step1_ensemble.csv, step1_teams.csv; that folder's README says where they come from), read by
// the fast and slow tests of model/fem/arostica_benchmark.h.
#pragma once

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::model::fem::testing {

// Column `name` of configs/data/arostica-2025/`file` (header row of names, comma-separated
// numbers); std::runtime_error when the file or the column is missing.
inline std::vector<double> arostica_column(const std::string& file, const std::string& name) {
  std::ifstream f(std::string(SIGMAHEART_SOURCE_DIR) + "/configs/data/arostica-2025/" + file);
  if (!f) throw std::runtime_error("cannot open configs/data/arostica-2025/" + file);
  std::string line;
  std::getline(f, line);
  std::stringstream hs(line);
  std::string h;
  int col = -1;
  for (int i = 0; std::getline(hs, h, ','); ++i)
    if (h == name) col = i;
  if (col < 0) throw std::runtime_error("no column " + name + " in " + file);
  std::vector<double> out;
  while (std::getline(f, line)) {
    std::stringstream ls(line);
    std::string v;
    for (int i = 0; i <= col; ++i) std::getline(ls, v, ',');
    out.push_back(std::stod(v));
  }
  return out;
}

}  // namespace sigmaheart::model::fem::testing
