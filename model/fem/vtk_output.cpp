#include "model/fem/vtk_output.h"

#include <bit>
#include <charconv>
#include <cstring>
#include <ostream>
#include <sstream>
#include <stdexcept>

namespace sigmaheart::model::fem {
namespace {

void check_name(const std::string& name) {
  if (name.empty()) throw std::invalid_argument("VtuDocument: empty array name");
  for (char c : name)
    if (c == '"' || c == '<' || c == '>' || c == '&' || c == '\'' || static_cast<unsigned char>(c) < 0x20)
      throw std::invalid_argument("VtuDocument: array name '" + name + "' contains a character not allowed in XML attributes");
}

void check_size(const std::string& what, const std::string& name, Eigen::Index got, long expected) {
  if (got != expected)
    throw std::invalid_argument("VtuDocument: " + what + " '" + name + "' has " + std::to_string(got) + " values; expected " +
                                std::to_string(expected));
}

std::string shortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// A block of the appended section: its raw bytes.
struct Block {
  std::string xml;  // the <DataArray .../> tag without the offset attribute's value
  std::vector<char> bytes;
};

template <class T>
std::vector<char> raw(const T* data, size_t n) {
  std::vector<char> b(n * sizeof(T));
  if (n) std::memcpy(b.data(), data, b.size());
  return b;
}

}  // namespace

VtuDocument::VtuDocument(const Mesh& mesh) : mesh_(mesh) {}

void VtuDocument::set_points(const Eigen::MatrixX3d& points) {
  check_size("points", "Points", points.rows(), mesh_.n_nodes());
  mesh_.nodes = points;
}

void VtuDocument::add_point_data(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values, int components) {
  check_name(name);
  if (components < 1) throw std::invalid_argument("VtuDocument: '" + name + "' needs at least one component");
  check_size("point data", name, values.size(), static_cast<long>(mesh_.n_nodes()) * components);
  point_.push_back({name, components, false, std::vector<double>(values.data(), values.data() + values.size()), {}});
}

void VtuDocument::add_vertex_data(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values, int components) {
  check_name(name);
  if (components < 1) throw std::invalid_argument("VtuDocument: '" + name + "' needs at least one component");
  check_size("vertex data", name, values.size(), static_cast<long>(mesh_.n_vertices) * components);
  Eigen::VectorXd all = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(mesh_.n_nodes()) * components);
  all.head(values.size()) = values;
  if (mesh_.order == 2)
    for (int e = 0; e < mesh_.n_tets(); ++e)
      for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b) {
          const int m = mesh_.tets(e, tet10_edge_slot(a, b)), i = mesh_.tets(e, a), j = mesh_.tets(e, b);
          for (int c = 0; c < components; ++c)
            all[m * components + c] = 0.5 * (values[i * components + c] + values[j * components + c]);
        }
  point_.push_back({name, components, false, std::vector<double>(all.data(), all.data() + all.size()), {}});
}

void VtuDocument::add_cell_data(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& values, int components) {
  check_name(name);
  if (components < 1) throw std::invalid_argument("VtuDocument: '" + name + "' needs at least one component");
  check_size("cell data", name, values.size(), static_cast<long>(mesh_.n_tets()) * components);
  cell_.push_back({name, components, false, std::vector<double>(values.data(), values.data() + values.size()), {}});
}

void VtuDocument::add_cell_labels(const std::string& name, const std::vector<int>& labels) {
  check_name(name);
  check_size("cell labels", name, static_cast<Eigen::Index>(labels.size()), mesh_.n_tets());
  cell_.push_back({name, 1, true, {}, std::vector<std::int32_t>(labels.begin(), labels.end())});
}

void VtuDocument::write(std::ostream& os) const {
  const int np = mesh_.n_nodes(), nc = mesh_.n_tets(), npc = mesh_.nodes_per_tet();
  std::vector<Block> blocks;
  // Points: node-major x y z.
  {
    std::vector<double> p(static_cast<size_t>(np) * 3);
    for (int n = 0; n < np; ++n)
      for (int c = 0; c < 3; ++c) p[static_cast<size_t>(3 * n + c)] = mesh_.nodes(n, c);
    blocks.push_back({"<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\"", raw(p.data(), p.size())});
  }
  {
    std::vector<std::int64_t> conn(static_cast<size_t>(nc) * static_cast<size_t>(npc)), off(static_cast<size_t>(nc));
    std::vector<std::uint8_t> types(static_cast<size_t>(nc), npc == 4 ? 10 : 24);  // VTK_TETRA, VTK_QUADRATIC_TETRA
    for (int e = 0; e < nc; ++e) {
      for (int a = 0; a < npc; ++a) conn[static_cast<size_t>(e * npc + a)] = mesh_.tets(e, a);
      off[static_cast<size_t>(e)] = static_cast<std::int64_t>(e + 1) * npc;
    }
    blocks.push_back({"<DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\"", raw(conn.data(), conn.size())});
    blocks.push_back({"<DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\"", raw(off.data(), off.size())});
    blocks.push_back({"<DataArray type=\"UInt8\" Name=\"types\" format=\"appended\"", raw(types.data(), types.size())});
  }
  auto array_block = [](const VtuArray& a) {
    std::string tag = std::string("<DataArray type=\"") + (a.is_int32 ? "Int32" : "Float64") + "\" Name=\"" + a.name +
                      "\" NumberOfComponents=\"" + std::to_string(a.components) + "\" format=\"appended\"";
    return Block{tag, a.is_int32 ? raw(a.int32.data(), a.int32.size()) : raw(a.float64.data(), a.float64.size())};
  };
  for (const auto& a : point_) blocks.push_back(array_block(a));
  for (const auto& a : cell_) blocks.push_back(array_block(a));

  std::vector<std::uint64_t> offset(blocks.size());
  std::uint64_t pos = 0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    offset[k] = pos;
    pos += sizeof(std::uint64_t) + blocks[k].bytes.size();
  }
  auto tag = [&](size_t k) { return blocks[k].xml + " offset=\"" + std::to_string(offset[k]) + "\"/>\n"; };
  const char* order = std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian";
  os << "<?xml version=\"1.0\"?>\n"
     << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"" << order << "\" header_type=\"UInt64\">\n"
     << "<UnstructuredGrid>\n<Piece NumberOfPoints=\"" << np << "\" NumberOfCells=\"" << nc << "\">\n"
     << "<Points>\n" << tag(0) << "</Points>\n<Cells>\n" << tag(1) << tag(2) << tag(3) << "</Cells>\n<PointData>\n";
  size_t k = 4;
  for (size_t i = 0; i < point_.size(); ++i) os << tag(k++);
  os << "</PointData>\n<CellData>\n";
  for (size_t i = 0; i < cell_.size(); ++i) os << tag(k++);
  os << "</CellData>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";
  for (const auto& b : blocks) {
    const std::uint64_t n = b.bytes.size();
    os.write(reinterpret_cast<const char*>(&n), sizeof n);
    os.write(b.bytes.data(), static_cast<std::streamsize>(b.bytes.size()));
  }
  os << "\n</AppendedData>\n</VTKFile>\n";
  if (!os) throw std::runtime_error("VtuDocument: error while writing the stream");
}

std::string VtuDocument::str() const {
  std::ostringstream os;
  write(os);
  return os.str();
}

void write_pvd(std::ostream& os, const std::vector<PvdEntry>& entries) {
  os << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
  for (const auto& e : entries) {
    check_name(e.file);
    os << "<DataSet timestep=\"" << shortest(e.time) << "\" group=\"\" part=\"0\" file=\"" << e.file << "\"/>\n";
  }
  os << "</Collection>\n</VTKFile>\n";
  if (!os) throw std::runtime_error("write_pvd: error while writing the stream");
}

}  // namespace sigmaheart::model::fem
