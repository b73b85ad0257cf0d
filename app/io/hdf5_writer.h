// Results files in HDF5 (docs/architecture.md, "Results files"), through the HDF5 C API.
//
// Hdf5Writer writes one file atomically (AtomicFile: "<name>.tmp", renamed on commit()). Paths
// are absolute inside the file ("/trajectories/simulated/V_lv"); missing parent groups are
// created. Strings are variable-length UTF-8 (h5py reads them as str). Matrices are stored row
// by row (row-major, as numpy sees them) with optional `row_names` / `column_names` attributes.
// Convention of sigmaheart results: every numeric dataset has a `units` attribute naming the
// unit its numbers are in. Errors throw RunFailure naming the object and the file.
//
// Hdf5Reader reads back what the writer writes (tests, and commands that start from a result).
#pragma once

#include "app/io/atomic_file.h"

#include <Eigen/Core>
#include <hdf5.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::app::io {

class Hdf5Writer {
 public:
  explicit Hdf5Writer(const std::filesystem::path& path);
  ~Hdf5Writer();  // closes; the temporary file is removed unless commit() ran
  Hdf5Writer(const Hdf5Writer&) = delete;
  Hdf5Writer& operator=(const Hdf5Writer&) = delete;

  // Closes the file and renames it into place. No writes after this.
  void commit();
  const std::filesystem::path& path() const { return file_.path(); }

  void create_group(const std::string& path);  // and its parents; fine if it exists

  void write_text(const std::string& path, const std::string& text);  // scalar string
  void write_strings(const std::string& path, const std::vector<std::string>& values);
  // 1-D doubles; `unit` (if not empty) becomes the `units` attribute.
  void write_vector(const std::string& path, const Eigen::Ref<const Eigen::VectorXd>& values,
                    const std::string& unit = "");
  void write_ints(const std::string& path, const std::vector<std::int64_t>& values);
  // 2-D doubles (rows x cols); names (if given) must match the dimensions.
  void write_matrix(const std::string& path, const Eigen::Ref<const Eigen::MatrixXd>& values,
                    const std::string& unit = "", const std::vector<std::string>& row_names = {},
                    const std::vector<std::string>& column_names = {});

  // Attributes of an existing group or dataset ("/" for the root). Replaced if present.
  void set_attribute(const std::string& object, const std::string& name, const std::string& value);
  void set_attribute(const std::string& object, const std::string& name, const char* value) {
    set_attribute(object, name, std::string(value));
  }
  void set_attribute(const std::string& object, const std::string& name, double value);
  void set_attribute(const std::string& object, const std::string& name, std::int64_t value);
  void set_attribute(const std::string& object, const std::string& name, int value) {
    set_attribute(object, name, static_cast<std::int64_t>(value));
  }
  void set_attribute(const std::string& object, const std::string& name,
                     const std::vector<std::string>& values);
  void set_attribute(const std::string& object, const std::string& name,
                     const std::vector<double>& values);

  // HDF5 dimension scales (H5DS, hdf5_hl), which h5py (`dims`), netCDF-4 and xarray read as
  // coordinates: makes the 1-D dataset `scale` a dimension scale named `label` (the first time)
  // and attaches it to dimension `dim` (0 = rows) of `dataset`. Both must exist.
  void attach_scale(const std::string& dataset, int dim, const std::string& scale,
                    const std::string& label = "");

 private:
  void write_dataset(const std::string& path, hid_t type, int rank, const hsize_t* dims,
                     const void* data);
  void write_attribute(const std::string& object, const std::string& name, hid_t type, int rank,
                       const hsize_t* dims, const void* data);

  AtomicFile file_;
  hid_t id_ = -1;
};

class Hdf5Reader {
 public:
  // Throws InputError when the file is missing or is not HDF5.
  explicit Hdf5Reader(const std::filesystem::path& path);
  ~Hdf5Reader();
  Hdf5Reader(const Hdf5Reader&) = delete;
  Hdf5Reader& operator=(const Hdf5Reader&) = delete;

  bool exists(const std::string& path) const;  // group or dataset
  bool has_attribute(const std::string& object, const std::string& name) const;
  // Names of the members of a group, in creation order where recorded (else alphabetical).
  std::vector<std::string> members(const std::string& group) const;

  std::string read_text(const std::string& path) const;
  std::vector<std::string> read_strings(const std::string& path) const;
  Eigen::VectorXd read_vector(const std::string& path) const;
  Eigen::MatrixXd read_matrix(const std::string& path) const;

  std::string string_attribute(const std::string& object, const std::string& name) const;
  double double_attribute(const std::string& object, const std::string& name) const;
  std::vector<std::string> strings_attribute(const std::string& object,
                                             const std::string& name) const;

 private:
  std::string file_;
  hid_t id_ = -1;
};

}  // namespace sigmaheart::app::io
