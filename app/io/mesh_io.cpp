#include "app/io/mesh_io.h"

#include "app/errors.h"
#include "app/io/atomic_file.h"
#include "app/io/hdf5_writer.h"
#include "model/fem/vtk_output.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <unordered_map>

namespace sigmaheart::app::io {

using namespace sigmaheart::model::fem;  // Mesh, Frame, the boundary tags

namespace {

// Whitespace tokeniser that remembers line numbers, for messages "file:line: expected ...".
class Lexer {
 public:
  Lexer(const std::string& text, std::string name) : name_(std::move(name)) {
    std::istringstream is(text);
    std::string line;
    while (std::getline(is, line)) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      lines_.push_back(line);
    }
  }
  bool at_end() {
    skip_space();
    return row_ >= lines_.size();
  }
  // Line of the next token.
  size_t line_no() {
    skip_space();
    return std::min(row_ + 1, lines_.size());
  }
  [[noreturn]] void fail(const std::string& what) const {
    std::ostringstream os;
    os << name_ << ":" << std::min(row_ + 1, lines_.size()) << ": " << what;
    throw MeshReadError(os.str());
  }
  std::string token(const char* expected) {
    skip_space();
    if (row_ >= lines_.size()) fail(std::string("unexpected end of file, expected ") + expected);
    const std::string& l = lines_[row_];
    size_t b = col_;
    if (l[b] == '"') {  // quoted name
      size_t e = l.find('"', b + 1);
      if (e == std::string::npos) fail("unterminated quoted string");
      col_ = e + 1;
      return l.substr(b + 1, e - b - 1);
    }
    size_t e = b;
    while (e < l.size() && !std::isspace(static_cast<unsigned char>(l[e]))) ++e;
    col_ = e;
    return l.substr(b, e - b);
  }
  long long integer(const char* expected) {
    const std::string t = token(expected);
    try {
      size_t used = 0;
      const long long v = std::stoll(t, &used);
      if (used != t.size()) throw std::invalid_argument(t);
      return v;
    } catch (const std::exception&) {
      fail(std::string("expected ") + expected + " (an integer), got '" + t + "'");
    }
  }
  // The three coordinates of a node.
  Eigen::Vector3d node_coordinates() {
    Eigen::Vector3d x;
    for (int d = 0; d < 3; ++d) x[d] = real("a node coordinate");
    return x;
  }
  double real(const char* expected) {
    const std::string t = token(expected);
    try {
      size_t used = 0;
      const double v = std::stod(t, &used);
      if (used != t.size()) throw std::invalid_argument(t);
      return v;
    } catch (const std::exception&) {
      fail(std::string("expected ") + expected + " (a number), got '" + t + "'");
    }
  }
  void expect(const std::string& word) {
    const std::string t = token(word.c_str());
    if (t != word) fail("expected '" + word + "', got '" + t + "'");
  }
  // Skips to the line after the next line equal to `word` (unknown sections).
  void skip_until(const std::string& word) {
    skip_space();
    while (row_ < lines_.size()) {
      if (lines_[row_].rfind(word, 0) == 0) {
        ++row_;
        col_ = 0;
        return;
      }
      ++row_;
      col_ = 0;
    }
    fail("missing " + word);
  }

 private:
  void skip_space() {
    while (row_ < lines_.size()) {
      const std::string& l = lines_[row_];
      while (col_ < l.size() && std::isspace(static_cast<unsigned char>(l[col_]))) ++col_;
      if (col_ < l.size()) return;
      ++row_;
      col_ = 0;
    }
  }
  std::string name_;
  std::vector<std::string> lines_;
  size_t row_ = 0, col_ = 0;
};

struct RawElement {
  int type;
  int physical;
  std::vector<long long> nodes;
  size_t line;
};

int nodes_of_type(int type) {
  switch (type) {
    case 1: return 2;    // line
    case 2: return 3;    // triangle
    case 3: return 4;    // quad
    case 4: return 4;    // tetra
    case 5: return 8;    // hexa
    case 6: return 6;    // prism
    case 7: return 5;    // pyramid
    case 8: return 3;    // line3
    case 9: return 6;    // triangle6
    case 11: return 10;  // tetra10
    case 15: return 1;   // point
    default: return -1;
  }
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The header of a Gmsh 4.1 $Nodes or $Elements section, "numEntityBlocks numX minTag maxTag"
// (Gmsh reference manual, section "MSH file format"); returns numEntityBlocks.
long long read_v4_block_header(Lexer& lx, const std::string& what) {
  const long long blocks = lx.integer("the number of entity blocks");
  lx.integer(("the number of " + what + "s").c_str());
  lx.integer(("the minimum " + what + " tag").c_str());
  lx.integer(("the maximum " + what + " tag").c_str());
  return blocks;
}

// The node list of one element of `type` (its tags already read), started on source line `line`.
RawElement read_element_nodes(Lexer& lx, int type, int physical, size_t line) {
  const int nn = nodes_of_type(type);
  if (nn < 0) lx.fail("unsupported element type " + std::to_string(type));
  RawElement e{type, physical, std::vector<long long>(static_cast<size_t>(nn)), line};
  for (auto& v : e.nodes) v = lx.integer("an element node");
  return e;
}

}  // namespace

Mesh read_gmsh(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshReadError(path + ": cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_gmsh(ss.str(), path);
}

Mesh parse_gmsh(const std::string& text, const std::string& name) {
  Lexer lx(text, name);
  double version = 0;
  std::map<int, std::string> phys_names;  // physical id (dim 2 or 3) -> name
  std::unordered_map<long long, Eigen::Vector3d> coords;
  std::vector<RawElement> elems;
  std::map<std::pair<int, int>, int> entity_phys;  // (dim, entity) -> first physical tag (v4)
  bool have_nodes = false, have_elements = false;
  while (!lx.at_end()) {
    const std::string sec = lx.token("a section header like $MeshFormat");
    if (sec == "$MeshFormat") {
      version = lx.real("the format version");
      const long long ft = lx.integer("the file type (0 = ASCII)");
      lx.integer("the data size");
      if (ft != 0) lx.fail("binary gmsh files are not supported; export ASCII (gmsh -format msh22 or msh41)");
      if (!(version >= 2.0 && version < 3.0) && !(version >= 4.1 && version < 5.0))
        lx.fail("unsupported gmsh format version " + std::to_string(version) + " (expected 2.x or 4.1)");
      lx.expect("$EndMeshFormat");
    } else if (sec == "$PhysicalNames") {
      const long long n = lx.integer("the number of physical names");
      for (long long i = 0; i < n; ++i) {
        lx.integer("the physical dimension");
        const int tag = static_cast<int>(lx.integer("the physical tag"));
        phys_names[tag] = lx.token("a quoted physical name");
      }
      lx.expect("$EndPhysicalNames");
    } else if (sec == "$Entities") {
      const long long np = lx.integer("the number of points"), nc = lx.integer("the number of curves"),
                      ns = lx.integer("the number of surfaces"), nv = lx.integer("the number of volumes");
      const long long counts[4] = {np, nc, ns, nv};
      for (int dim = 0; dim < 4; ++dim)
        for (long long i = 0; i < counts[dim]; ++i) {
          const int tag = static_cast<int>(lx.integer("an entity tag"));
          const int nbox = dim == 0 ? 3 : 6;
          for (int k = 0; k < nbox; ++k) lx.real("an entity coordinate");
          const long long nph = lx.integer("the number of physical tags");
          for (long long k = 0; k < nph; ++k) {
            const int ph = static_cast<int>(lx.integer("a physical tag"));
            if (k == 0) entity_phys[{dim, tag}] = ph;
          }
          if (dim > 0) {
            const long long nb = lx.integer("the number of bounding entities");
            for (long long k = 0; k < nb; ++k) lx.integer("a bounding entity tag");
          }
        }
      lx.expect("$EndEntities");
    } else if (sec == "$Nodes") {
      have_nodes = true;
      if (version < 3.0) {
        const long long n = lx.integer("the number of nodes");
        for (long long i = 0; i < n; ++i) {
          const long long id = lx.integer("a node number");
          coords[id] = lx.node_coordinates();
        }
      } else {
        const long long nb = read_v4_block_header(lx, "node");
        for (long long b = 0; b < nb; ++b) {
          lx.integer("the entity dimension");
          lx.integer("the entity tag");
          const long long param = lx.integer("the parametric flag");
          const long long n = lx.integer("the number of nodes in the block");
          if (param != 0) lx.fail("parametric node coordinates are not supported");
          std::vector<long long> ids(static_cast<size_t>(n));
          for (auto& id : ids) id = lx.integer("a node tag");
          for (long long id : ids) coords[id] = lx.node_coordinates();
        }
      }
      lx.expect("$EndNodes");
    } else if (sec == "$Elements") {
      have_elements = true;
      if (version < 3.0) {
        const long long n = lx.integer("the number of elements");
        for (long long i = 0; i < n; ++i) {
          const size_t line = lx.line_no();
          lx.integer("an element number");
          const int type = static_cast<int>(lx.integer("an element type"));
          const int ntags = static_cast<int>(lx.integer("the number of tags"));
          int phys = 0;
          for (int k = 0; k < ntags; ++k) {
            const int t = static_cast<int>(lx.integer("an element tag"));
            if (k == 0) phys = t;
          }
          elems.push_back(read_element_nodes(lx, type, phys, line));
        }
      } else {
        const long long nb = read_v4_block_header(lx, "element");
        for (long long b = 0; b < nb; ++b) {
          const int dim = static_cast<int>(lx.integer("the entity dimension"));
          const int ent = static_cast<int>(lx.integer("the entity tag"));
          const int type = static_cast<int>(lx.integer("the element type"));
          const long long n = lx.integer("the number of elements in the block");
          if (nodes_of_type(type) < 0) lx.fail("unsupported element type " + std::to_string(type));
          auto it = entity_phys.find({dim, ent});
          const int phys = it == entity_phys.end() ? 0 : it->second;
          for (long long i = 0; i < n; ++i) {
            const size_t line = lx.line_no();
            lx.integer("an element tag");
            elems.push_back(read_element_nodes(lx, type, phys, line));
          }
        }
      }
      lx.expect("$EndElements");
    } else if (!sec.empty() && sec[0] == '$') {
      lx.skip_until("$End" + sec.substr(1));
    } else {
      lx.fail("expected a section header starting with '$', got '" + sec + "'");
    }
  }
  if (version == 0) throw MeshReadError(name + ": missing $MeshFormat");
  if (!have_nodes) throw MeshReadError(name + ": missing $Nodes");
  if (!have_elements) throw MeshReadError(name + ": missing $Elements");

  int order = 0;
  for (const auto& e : elems)
    if (e.type == 4 || e.type == 11) {
      const int o = e.type == 4 ? 1 : 2;
      if (order != 0 && o != order)
        throw MeshReadError(name + ":" + std::to_string(e.line) + ": mixed linear and quadratic tetrahedra");
      order = o;
    }
  if (order == 0) throw MeshReadError(name + ": no tetrahedra (types 4 or 11) in $Elements");
  const int npt = order == 1 ? 4 : 10;
  // Renumber: corners first.
  std::unordered_map<long long, int> idx;
  std::vector<long long> order_ids;
  auto add = [&](long long id, size_t line) {
    if (!coords.count(id)) throw MeshReadError(name + ":" + std::to_string(line) + ": element references undefined node " + std::to_string(id));
    if (idx.emplace(id, static_cast<int>(order_ids.size())).second) order_ids.push_back(id);
  };
  for (const auto& e : elems)
    if (e.type == 4 || e.type == 11)
      for (int a = 0; a < 4; ++a) add(e.nodes[static_cast<size_t>(a)], e.line);
  Mesh mesh;
  mesh.order = order;
  mesh.n_vertices = static_cast<int>(order_ids.size());
  for (const auto& e : elems)
    if (e.type == 11)
      for (int a = 4; a < 10; ++a) add(e.nodes[static_cast<size_t>(a)], e.line);
  mesh.nodes.resize(static_cast<Eigen::Index>(order_ids.size()), 3);
  for (size_t i = 0; i < order_ids.size(); ++i) mesh.nodes.row(static_cast<Eigen::Index>(i)) = coords[order_ids[i]].transpose();
  std::vector<std::array<int, 10>> tets;
  for (const auto& e : elems) {
    if (e.type != 4 && e.type != 11) continue;
    std::array<int, 10> t{};
    for (int a = 0; a < npt; ++a) t[static_cast<size_t>(a)] = idx[e.nodes[static_cast<size_t>(a)]];
    if (order == 2) std::swap(t[8], t[9]);  // gmsh: 8 = (2,3), 9 = (1,3); VTK: 8 = (1,3), 9 = (2,3)
    const Eigen::Vector3d x0 = mesh.nodes.row(t[0]), x1 = mesh.nodes.row(t[1]), x2 = mesh.nodes.row(t[2]),
                          x3 = mesh.nodes.row(t[3]);
    const double v = (x1 - x0).cross(x2 - x0).dot(x3 - x0);
    if (v == 0) throw MeshReadError(name + ":" + std::to_string(e.line) + ": degenerate tetrahedron (zero volume)");
    if (v < 0) {  // swap corners 1 and 2 (and the mid-edge nodes with them)
      std::swap(t[1], t[2]);
      if (order == 2) {
        std::swap(t[4], t[6]);
        std::swap(t[8], t[9]);
      }
    }
    tets.push_back(t);
    mesh.tet_tag.push_back(e.physical);
  }
  mesh.tets.resize(static_cast<Eigen::Index>(tets.size()), npt);
  for (size_t e = 0; e < tets.size(); ++e)
    for (int a = 0; a < npt; ++a) mesh.tets(static_cast<Eigen::Index>(e), a) = tets[e][static_cast<size_t>(a)];
  extract_boundary_faces(mesh);
  // Tags of boundary faces from the tagged triangles.
  auto surface_tag = [&](int phys) {
    auto it = phys_names.find(phys);
    if (it == phys_names.end()) return phys;
    const std::string n = lower(it->second);
    if (n.find("endo") != std::string::npos) return static_cast<int>(kEndocardium);
    if (n.find("epi") != std::string::npos) return static_cast<int>(kEpicardium);
    if (n.find("base") != std::string::npos) return static_cast<int>(kBase);
    return phys;
  };
  std::map<std::array<int, 3>, int> tri_tag;
  for (const auto& e : elems) {
    if (e.type != 2 && e.type != 9) continue;
    std::array<int, 3> s{};
    for (int a = 0; a < 3; ++a) {
      auto it = idx.find(e.nodes[static_cast<size_t>(a)]);
      if (it == idx.end() || it->second >= mesh.n_vertices)
        throw MeshReadError(name + ":" + std::to_string(e.line) + ": triangle corner " +
                            std::to_string(e.nodes[static_cast<size_t>(a)]) + " is not a tetrahedron corner");
      s[static_cast<size_t>(a)] = it->second;
    }
    std::sort(s.begin(), s.end());
    tri_tag[s] = surface_tag(e.physical);
  }
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    std::array<int, 3> s = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    std::sort(s.begin(), s.end());
    auto it = tri_tag.find(s);
    if (it != tri_tag.end()) mesh.face_tag[static_cast<size_t>(f)] = it->second;
  }
  for (const auto& [id, n] : phys_names) mesh.physical_names[n] = id;
  if (auto m = mesh.check(); !m.empty()) throw MeshReadError(name + ": " + m);
  return mesh;
}

namespace {
}  // namespace

void write_vtu(const std::string& path, const Mesh& mesh, const VtuFields& fields) {
  AtomicFile file{std::filesystem::path(path)};
  const std::string tmp = file.temp_path().string();
  {
    std::ofstream os(tmp);
    if (!os) throw std::runtime_error("cannot write " + tmp);
    os.precision(10);
    const int npt = mesh.nodes_per_tet();
    os << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
       << "<UnstructuredGrid><Piece NumberOfPoints=\"" << mesh.n_nodes() << "\" NumberOfCells=\"" << mesh.n_tets() << "\">\n";
    os << "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
    for (int n = 0; n < mesh.n_nodes(); ++n) os << mesh.nodes(n, 0) << ' ' << mesh.nodes(n, 1) << ' ' << mesh.nodes(n, 2) << '\n';
    os << "</DataArray></Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (int e = 0; e < mesh.n_tets(); ++e) {
      for (int a = 0; a < npt; ++a) os << mesh.tets(e, a) << ' ';
      os << '\n';
    }
    os << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (int e = 0; e < mesh.n_tets(); ++e) os << (e + 1) * npt << '\n';
    os << "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
    for (int e = 0; e < mesh.n_tets(); ++e) os << (npt == 4 ? 10 : 24) << '\n';
    os << "</DataArray>\n</Cells>\n<PointData>\n";
    if (fields.displacement) {
      os << "<DataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (int n = 0; n < mesh.n_nodes(); ++n)
        os << (*fields.displacement)[3 * n] << ' ' << (*fields.displacement)[3 * n + 1] << ' ' << (*fields.displacement)[3 * n + 2] << '\n';
      os << "</DataArray>\n";
    }
    if (fields.pressure) {
      Eigen::VectorXd p = Eigen::VectorXd::Zero(mesh.n_nodes());
      p.head(mesh.n_vertices) = *fields.pressure;
      if (npt == 10)
        for (int e = 0; e < mesh.n_tets(); ++e)
          for (int a = 0; a < 4; ++a)
            for (int b = a + 1; b < 4; ++b)
              p[mesh.tets(e, tet10_edge_slot(a, b))] = 0.5 * (p[mesh.tets(e, a)] + p[mesh.tets(e, b)]);
      os << "<DataArray type=\"Float64\" Name=\"hydrostatic_pressure\" format=\"ascii\">\n";
      for (int n = 0; n < mesh.n_nodes(); ++n) os << p[n] << '\n';
      os << "</DataArray>\n";
    }
    os << "</PointData>\n<CellData>\n";
    os << "<DataArray type=\"Int32\" Name=\"tag\" format=\"ascii\">\n";
    for (int e = 0; e < mesh.n_tets(); ++e) os << mesh.tet_tag[static_cast<size_t>(e)] << '\n';
    os << "</DataArray>\n";
    if (fields.fibres) {
      os << "<DataArray type=\"Float64\" Name=\"fibre\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (const auto& R : *fields.fibres) os << R(0, 0) << ' ' << R(1, 0) << ' ' << R(2, 0) << '\n';
      os << "</DataArray>\n";
    }
    if (fields.aha) {
      os << "<DataArray type=\"Int32\" Name=\"aha_segment\" format=\"ascii\">\n";
      for (int s : *fields.aha) os << s << '\n';
      os << "</DataArray>\n";
    }
    os << "</CellData>\n</Piece></UnstructuredGrid>\n</VTKFile>\n";
    if (!os) throw std::runtime_error("error while writing " + tmp);
  }
  file.commit();
}

void write_pvd(const std::string& path, const std::vector<std::pair<double, std::string>>& steps) {
  std::vector<PvdEntry> entries;
  for (const auto& [t, f] : steps) entries.push_back({t, f});
  write_text_file(std::filesystem::path(path), [&](std::ostream& os) { model::fem::write_pvd(os, entries); });
}

std::filesystem::path write_field_series(model::FieldOutput& fields,
                                         const std::vector<std::pair<double, model::State>>& states,
                                         const std::filesystem::path& dir, const std::string& name) {
  std::filesystem::create_directories(dir);
  std::vector<std::pair<double, std::string>> steps;
  for (size_t i = 0; i < states.size(); ++i) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "_%04zu.vtu", i);
    const std::string file = name + suffix;
    write_text_file(dir / file, [&](std::ostream& os) { fields.write_fields(states[i].second, os); });
    steps.emplace_back(states[i].first, file);
  }
  const std::filesystem::path pvd = dir / (name + ".pvd");
  write_pvd(pvd.string(), steps);
  return pvd;
}

Mesh read_dolfin_hdf5(const std::string& path) {
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw MeshReadError(path + ": cannot open file");
  }
  std::unique_ptr<Hdf5Reader> reader;
  try {
    reader = std::make_unique<Hdf5Reader>(path);
  } catch (const InputError&) {
    throw MeshReadError(path + ": not an HDF5 file");
  }
  const Hdf5Reader& h5 = *reader;
  // A two-dimensional dataset with `cols` columns (HDF5 converts integers to double exactly).
  const auto matrix = [&](const std::string& name, Eigen::Index cols) {
    if (!h5.exists(name)) throw MeshReadError(path + ": dataset " + name + " missing (expected a legacy DOLFIN HDF5 mesh)");
    Eigen::MatrixXd m;
    try {
      m = h5.read_matrix(name);
    } catch (const InputError& e) {
      throw MeshReadError(path + ": " + e.message());
    }
    if (m.cols() != cols)
      throw MeshReadError(path + ": dataset " + name + " has " + std::to_string(m.cols()) + " columns, expected " +
                          std::to_string(cols));
    return m;
  };
  // Entry (r, c) of `m` (dataset `name`) as a vertex index below nv.
  const auto vertex = [&](const Eigen::MatrixXd& m, const std::string& name, Eigen::Index r, Eigen::Index c,
                          Eigen::Index nv) {
    const double x = m(r, c);
    if (!(x >= 0 && x < static_cast<double>(nv) && x == std::floor(x)))
      throw MeshReadError(path + ": " + name + " row " + std::to_string(r) + " names vertex " +
                          (x == std::floor(x) ? std::to_string(static_cast<long long>(x)) : std::to_string(x)) +
                          ", expected 0.." + std::to_string(nv - 1));
    return static_cast<int>(x);
  };
  const Eigen::MatrixXd xyz = matrix("/Mesh/mesh/geometry", 3);
  const Eigen::MatrixXd tet = matrix("/Mesh/mesh/topology", 4);
  const Eigen::Index nv = xyz.rows(), nt = tet.rows();
  if (nv < 4 || nt < 1) throw MeshReadError(path + ": the mesh has no tetrahedra");
  for (Eigen::Index i = 0; i < nv; ++i)
    if (!xyz.row(i).allFinite()) throw MeshReadError(path + ": /Mesh/mesh/geometry row " + std::to_string(i) + " is not finite");
  Mesh m;
  m.order = 1;
  m.n_vertices = static_cast<int>(nv);
  m.nodes = xyz;
  m.tets.resize(nt, 4);
  m.tet_tag.assign(static_cast<size_t>(nt), 0);
  for (Eigen::Index e = 0; e < nt; ++e) {
    for (int a = 0; a < 4; ++a) m.tets(e, a) = vertex(tet, "/Mesh/mesh/topology", e, a, nv);
    Eigen::Matrix3d J;
    for (int d = 0; d < 3; ++d) J.col(d) = (m.nodes.row(m.tets(e, d + 1)) - m.nodes.row(m.tets(e, 0))).transpose();
    const double det = J.determinant();
    if (!(std::abs(det) > 0))
      throw MeshReadError(path + ": tetrahedron " + std::to_string(e) + " (/Mesh/mesh/topology) has zero volume");
    if (det < 0) std::swap(m.tets(e, 1), m.tets(e, 2));
  }
  extract_boundary_faces(m);
  // Facet markers: the first MeshFunction whose entities are triangles. Unset markers are 0 or
  // the all-ones value (2^64 - 1, read as a double >= 2^63).
  for (int k = 0; h5.exists("/MeshFunction/" + std::to_string(k)); ++k) {
    const std::string g = "/MeshFunction/" + std::to_string(k), topo = g + "/mesh/topology", vals = g + "/values";
    if (!h5.exists(topo)) continue;
    const Eigen::MatrixXd tri = h5.read_matrix(topo);
    if (tri.cols() != 3) continue;  // a cell or vertex function
    const Eigen::MatrixXd val = matrix(vals, 1);
    if (val.rows() != tri.rows())
      throw MeshReadError(path + ": " + vals + " has " + std::to_string(val.rows()) + " values for " +
                          std::to_string(tri.rows()) + " facets");
    std::map<std::array<int, 3>, int> tag;
    for (Eigen::Index f = 0; f < tri.rows(); ++f) {
      const double v = val(f, 0);
      if (v == 0.0 || v >= 9.2e18) continue;  // unset
      if (!(v > 0 && v <= 1e6 && v == std::floor(v)))
        throw MeshReadError(path + ": " + vals + " row " + std::to_string(f) + " is " + std::to_string(v) +
                            ", expected a small marker (or 0 / all ones for unset)");
      std::array<int, 3> s3{vertex(tri, topo, f, 0, nv), vertex(tri, topo, f, 1, nv), vertex(tri, topo, f, 2, nv)};
      std::sort(s3.begin(), s3.end());
      tag[s3] = static_cast<int>(v);
    }
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
      std::array<int, 3> s3{m.faces(f, 0), m.faces(f, 1), m.faces(f, 2)};
      std::sort(s3.begin(), s3.end());
      if (auto it = tag.find(s3); it != tag.end()) m.face_tag[static_cast<size_t>(f)] = it->second;
    }
    break;
  }
  if (const std::string c = m.check(); !c.empty()) throw MeshReadError(path + ": " + c);
  return m;
}

}  // namespace sigmaheart::app::io
