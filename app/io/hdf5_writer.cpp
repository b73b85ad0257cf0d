#include "app/io/hdf5_writer.h"

#include "app/errors.h"

#include <Eigen/Core>
#include <hdf5_hl.h>

#include <sstream>

namespace sigmaheart::app::io {

namespace {

// Closes an HDF5 handle at scope exit.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(Handle&& other) noexcept : id_(other.id_), close_(other.close_) { other.id_ = -1; }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle& operator=(Handle&&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

void quiet_hdf5() {
  // Errors are reported through exceptions with our own messages, not HDF5's stack dump.
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

Handle string_type() {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream s(path);
  while (std::getline(s, part, '/')) {
    if (!part.empty()) parts.push_back(part);
  }
  return parts;
}

std::string parent_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return (slash == std::string::npos || slash == 0) ? std::string("/") : path.substr(0, slash);
}

Handle group_creation_order() {
  Handle p(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_link_creation_order(p.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  H5Pset_attr_creation_order(p.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  return p;
}

std::vector<const char*> c_strings(const std::vector<std::string>& values) {
  std::vector<const char*> out;
  out.reserve(values.size());
  for (const auto& v : values) out.push_back(v.c_str());
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
Hdf5Writer::Hdf5Writer(const std::filesystem::path& path) : file_(path) {
  quiet_hdf5();
  Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  H5Pset_link_creation_order(fcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  H5Pset_attr_creation_order(fcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  id_ = H5Fcreate(file_.temp_path().c_str(), H5F_ACC_TRUNC, fcpl.get(), H5P_DEFAULT);
  if (id_ < 0) throw RunFailure("cannot create the HDF5 file " + file_.temp_path().string());
}

Hdf5Writer::~Hdf5Writer() {
  if (id_ >= 0) H5Fclose(id_);
}

void Hdf5Writer::commit() {
  if (id_ < 0) throw RunFailure("HDF5 file " + path().string() + " already committed");
  const herr_t flushed = H5Fflush(id_, H5F_SCOPE_GLOBAL);
  const herr_t closed = H5Fclose(id_);
  id_ = -1;
  if (flushed < 0 || closed < 0) throw RunFailure("cannot finish the HDF5 file " + path().string());
  file_.commit();
}

void Hdf5Writer::create_group(const std::string& path) {
  if (id_ < 0) throw RunFailure("write to a committed HDF5 file " + this->path().string());
  std::string walked;
  for (const auto& part : split_path(path)) {
    walked += "/" + part;
    const htri_t exists = H5Lexists(id_, walked.c_str(), H5P_DEFAULT);
    if (exists > 0) continue;
    Handle gcpl = group_creation_order();
    Handle g(H5Gcreate2(id_, walked.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), H5Gclose);
    if (!g.ok()) throw RunFailure("cannot create the group " + walked + " in " + this->path().string());
  }
}

void Hdf5Writer::write_dataset(const std::string& path, hid_t type, int rank, const hsize_t* dims,
                               const void* data) {
  create_group(parent_of(path));
  Handle space(rank == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(rank, dims, nullptr), H5Sclose);
  Handle set(H5Dcreate2(id_, path.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
             H5Dclose);
  if (!set.ok()) throw RunFailure("cannot create the dataset " + path + " in " + this->path().string());
  bool empty = false;
  for (int i = 0; i < rank; ++i) empty = empty || dims[i] == 0;
  if (!empty && H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    throw RunFailure("cannot write the dataset " + path + " in " + this->path().string());
  }
}

void Hdf5Writer::write_attribute(const std::string& object, const std::string& name, hid_t type,
                                 int rank, const hsize_t* dims, const void* data) {
  if (id_ < 0) throw RunFailure("write to a committed HDF5 file " + path().string());
  if (H5Aexists_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT) > 0) {
    H5Adelete_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT);
  }
  Handle space(rank == 0 ? H5Screate(H5S_SCALAR) : H5Screate_simple(rank, dims, nullptr), H5Sclose);
  Handle attr(H5Acreate_by_name(id_, object.c_str(), name.c_str(), type, space.get(), H5P_DEFAULT,
                                H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  bool empty = false;
  for (int i = 0; i < rank; ++i) empty = empty || dims[i] == 0;
  if (!attr.ok() || (!empty && H5Awrite(attr.get(), type, data) < 0)) {
    throw RunFailure("cannot write the attribute '" + name + "' of " + object + " in " +
                     path().string());
  }
}

void Hdf5Writer::write_text(const std::string& path, const std::string& text) {
  Handle t = string_type();
  const char* p = text.c_str();
  write_dataset(path, t.get(), 0, nullptr, &p);
}

void Hdf5Writer::write_strings(const std::string& path, const std::vector<std::string>& values) {
  Handle t = string_type();
  const auto ptrs = c_strings(values);
  const hsize_t dims[1] = {values.size()};
  write_dataset(path, t.get(), 1, dims, ptrs.data());
}

void Hdf5Writer::write_vector(const std::string& path,
                              const Eigen::Ref<const Eigen::VectorXd>& values,
                              const std::string& unit) {
  const Eigen::VectorXd contiguous = values;
  const hsize_t dims[1] = {static_cast<hsize_t>(contiguous.size())};
  write_dataset(path, H5T_NATIVE_DOUBLE, 1, dims, contiguous.data());
  if (!unit.empty()) set_attribute(path, "units", unit);
}

void Hdf5Writer::write_ints(const std::string& path, const std::vector<std::int64_t>& values) {
  const hsize_t dims[1] = {values.size()};
  write_dataset(path, H5T_NATIVE_INT64, 1, dims, values.data());
}

void Hdf5Writer::write_matrix(const std::string& path,
                              const Eigen::Ref<const Eigen::MatrixXd>& values,
                              const std::string& unit, const std::vector<std::string>& row_names,
                              const std::vector<std::string>& column_names) {
  if (!row_names.empty() && row_names.size() != static_cast<size_t>(values.rows())) {
    throw std::invalid_argument("write_matrix " + path + ": row_names size does not match rows");
  }
  if (!column_names.empty() && column_names.size() != static_cast<size_t>(values.cols())) {
    throw std::invalid_argument("write_matrix " + path + ": column_names size does not match columns");
  }
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> row_major = values;
  const hsize_t dims[2] = {static_cast<hsize_t>(values.rows()), static_cast<hsize_t>(values.cols())};
  write_dataset(path, H5T_NATIVE_DOUBLE, 2, dims, row_major.data());
  if (!unit.empty()) set_attribute(path, "units", unit);
  if (!row_names.empty()) set_attribute(path, "row_names", row_names);
  if (!column_names.empty()) set_attribute(path, "column_names", column_names);
}

void Hdf5Writer::set_attribute(const std::string& object, const std::string& name,
                               const std::string& value) {
  Handle t = string_type();
  const char* p = value.c_str();
  write_attribute(object, name, t.get(), 0, nullptr, &p);
}

void Hdf5Writer::set_attribute(const std::string& object, const std::string& name, double value) {
  write_attribute(object, name, H5T_NATIVE_DOUBLE, 0, nullptr, &value);
}

void Hdf5Writer::set_attribute(const std::string& object, const std::string& name,
                               std::int64_t value) {
  write_attribute(object, name, H5T_NATIVE_INT64, 0, nullptr, &value);
}

void Hdf5Writer::set_attribute(const std::string& object, const std::string& name,
                               const std::vector<std::string>& values) {
  Handle t = string_type();
  const auto ptrs = c_strings(values);
  const hsize_t dims[1] = {values.size()};
  write_attribute(object, name, t.get(), 1, dims, ptrs.data());
}

void Hdf5Writer::set_attribute(const std::string& object, const std::string& name,
                               const std::vector<double>& values) {
  const hsize_t dims[1] = {values.size()};
  write_attribute(object, name, H5T_NATIVE_DOUBLE, 1, dims, values.data());
}

void Hdf5Writer::attach_scale(const std::string& dataset, int dim, const std::string& scale,
                              const std::string& label) {
  if (id_ < 0) throw RunFailure("write to a committed HDF5 file " + path().string());
  Handle set(H5Dopen2(id_, dataset.c_str(), H5P_DEFAULT), H5Dclose);
  Handle sc(H5Dopen2(id_, scale.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok() || !sc.ok()) {
    throw RunFailure("cannot attach the dimension scale " + scale + " to " + dataset + " in " +
                     path().string() + ": no such dataset");
  }
  if (H5DSis_scale(sc.get()) <= 0 &&
      H5DSset_scale(sc.get(), label.empty() ? nullptr : label.c_str()) < 0) {
    throw RunFailure("cannot make " + scale + " a dimension scale in " + path().string());
  }
  if (H5DSattach_scale(set.get(), sc.get(), static_cast<unsigned>(dim)) < 0) {
    throw RunFailure("cannot attach the dimension scale " + scale + " to dimension " +
                     std::to_string(dim) + " of " + dataset + " in " + path().string());
  }
}

// ---------------------------------------------------------------------------------------------
namespace {

// Reads `count` variable-length strings from a dataset or attribute and frees HDF5's copies.
template <class ReadFn>
std::vector<std::string> read_vlen_strings(hid_t space, size_t count, ReadFn read) {
  Handle t = string_type();
  std::vector<char*> raw(count, nullptr);
  if (count > 0 && read(t.get(), raw.data()) < 0) return {};
  std::vector<std::string> out;
  out.reserve(count);
  for (char* s : raw) out.emplace_back(s ? s : "");
  if (count > 0) H5Dvlen_reclaim(t.get(), space, H5P_DEFAULT, raw.data());
  return out;
}

size_t element_count(hid_t space) {
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  return n < 0 ? 0 : static_cast<size_t>(n);
}

}  // namespace

Hdf5Reader::Hdf5Reader(const std::filesystem::path& path) : file_(path.string()) {
  quiet_hdf5();
  if (!std::filesystem::exists(path)) throw InputError(Location{file_, 0, 0}, "no such file");
  id_ = H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id_ < 0) throw InputError(Location{file_, 0, 0}, "not an HDF5 file");
}

Hdf5Reader::~Hdf5Reader() {
  if (id_ >= 0) H5Fclose(id_);
}

bool Hdf5Reader::exists(const std::string& path) const {
  if (path == "/") return true;
  std::string walked;
  for (const auto& part : split_path(path)) {
    walked += "/" + part;
    if (H5Lexists(id_, walked.c_str(), H5P_DEFAULT) <= 0) return false;
  }
  return true;
}

bool Hdf5Reader::has_attribute(const std::string& object, const std::string& name) const {
  return exists(object) && H5Aexists_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT) > 0;
}

std::vector<std::string> Hdf5Reader::members(const std::string& group) const {
  std::vector<std::string> names;
  Handle g(H5Gopen2(id_, group.c_str(), H5P_DEFAULT), H5Gclose);
  if (!g.ok()) throw InputError(Location{file_, 0, 0}, "no group " + group);
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->emplace_back(name);
    return 0;
  };
  if (H5Literate(g.get(), H5_INDEX_CRT_ORDER, H5_ITER_INC, nullptr, collect, &names) < 0) {
    names.clear();
    H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names);
  }
  return names;
}

std::string Hdf5Reader::read_text(const std::string& path) const {
  const auto all = read_strings(path);
  if (all.size() != 1) throw InputError(Location{file_, 0, 0}, path + " is not a single string");
  return all.front();
}

std::vector<std::string> Hdf5Reader::read_strings(const std::string& path) const {
  Handle set(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok()) throw InputError(Location{file_, 0, 0}, "no dataset " + path);
  Handle space(H5Dget_space(set.get()), H5Sclose);
  return read_vlen_strings(space.get(), element_count(space.get()), [&](hid_t t, char** buf) {
    return H5Dread(set.get(), t, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  });
}

Eigen::VectorXd Hdf5Reader::read_vector(const std::string& path) const {
  Handle set(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok()) throw InputError(Location{file_, 0, 0}, "no dataset " + path);
  Handle space(H5Dget_space(set.get()), H5Sclose);
  Eigen::VectorXd v(static_cast<Eigen::Index>(element_count(space.get())));
  if (v.size() > 0 &&
      H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) {
    throw InputError(Location{file_, 0, 0}, "cannot read " + path + " as numbers");
  }
  return v;
}

Eigen::MatrixXd Hdf5Reader::read_matrix(const std::string& path) const {
  Handle set(H5Dopen2(id_, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok()) throw InputError(Location{file_, 0, 0}, "no dataset " + path);
  Handle space(H5Dget_space(set.get()), H5Sclose);
  hsize_t dims[2] = {0, 0};
  if (H5Sget_simple_extent_ndims(space.get()) != 2) {
    throw InputError(Location{file_, 0, 0}, path + " is not a matrix");
  }
  H5Sget_simple_extent_dims(space.get(), dims, nullptr);
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m(
      static_cast<Eigen::Index>(dims[0]), static_cast<Eigen::Index>(dims[1]));
  if (m.size() > 0 &&
      H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, m.data()) < 0) {
    throw InputError(Location{file_, 0, 0}, "cannot read " + path + " as numbers");
  }
  return m;
}

std::vector<std::string> Hdf5Reader::strings_attribute(const std::string& object,
                                                       const std::string& name) const {
  Handle attr(H5Aopen_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  if (!attr.ok()) throw InputError(Location{file_, 0, 0}, object + " has no attribute '" + name + "'");
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  return read_vlen_strings(space.get(), element_count(space.get()), [&](hid_t t, char** buf) {
    return H5Aread(attr.get(), t, buf);
  });
}

std::string Hdf5Reader::string_attribute(const std::string& object, const std::string& name) const {
  const auto all = strings_attribute(object, name);
  if (all.size() != 1) {
    throw InputError(Location{file_, 0, 0}, "attribute '" + name + "' of " + object + " is not a string");
  }
  return all.front();
}

double Hdf5Reader::double_attribute(const std::string& object, const std::string& name) const {
  Handle attr(H5Aopen_by_name(id_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose);
  if (!attr.ok()) throw InputError(Location{file_, 0, 0}, object + " has no attribute '" + name + "'");
  double v = 0.0;
  if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &v) < 0) {
    throw InputError(Location{file_, 0, 0}, "attribute '" + name + "' of " + object + " is not a number");
  }
  return v;
}

}  // namespace sigmaheart::app::io
