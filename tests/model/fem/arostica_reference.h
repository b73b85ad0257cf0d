// The codes' curves of the Arostica et al. 2025 benchmark bundled under configs/data/arostica-2025/
// (step1_ensemble.csv, step1_teams.csv; that folder's README says where they come from), read by
// the fast and slow tests of model/fem/arostica_benchmark.h and of `sigmaheart benchmark arostica`.
#pragma once

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::model::fem::testing {

// Column `name` of the CSV file at `path` (header row of names, comma-separated numbers);
// std::runtime_error when the file or the column is missing.
inline std::vector<double> csv_column(const std::string& path, const std::string& name) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot open " + path);
  std::string line;
  std::getline(f, line);
  std::stringstream hs(line);
  std::string h;
  int col = -1;
  for (int i = 0; std::getline(hs, h, ','); ++i)
    if (h == name) col = i;
  if (col < 0) throw std::runtime_error("no column " + name + " in " + path);
  std::vector<double> out;
  while (std::getline(f, line)) {
    std::stringstream ls(line);
    std::string v;
    for (int i = 0; i <= col; ++i) std::getline(ls, v, ',');
    out.push_back(std::stod(v));
  }
  return out;
}

// Column `name` of configs/data/arostica-2025/`file`.
inline std::vector<double> arostica_column(const std::string& file, const std::string& name) {
  return csv_column(std::string(SIGMAHEART_SOURCE_DIR) + "/configs/data/arostica-2025/" + file, name);
}

}  // namespace sigmaheart::model::fem::testing
