// gmsh reader (v2 and v4.1, linear and quadratic, tags, errors), the legacy DOLFIN HDF5 reader
// (the Arostica et al. 2025 benchmark mesh bundled under configs/data/arostica-2025/) and the
// ParaView writer.
#include "app/io/hdf5_writer.h"
#include "app/io/mesh_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <fstream>
#include <sstream>

namespace sigmaheart::app::io {
namespace {

using namespace sigmaheart::model::fem;

// A generated mesh written in gmsh 2.2 format (gmsh node order: tet10 slots 8 and 9 swapped),
// with its tagged boundary triangles and physical names.
std::string to_gmsh_v2(const Mesh& m) {
  std::ostringstream os;
  os.precision(17);
  os << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n3\n2 11 \"Endocardium\"\n2 12 \"epi\"\n3 1 \"wall\"\n"
        "$EndPhysicalNames\n$Nodes\n"
     << m.n_nodes() << "\n";
  for (int n = 0; n < m.n_nodes(); ++n) os << n + 1 << ' ' << m.nodes(n, 0) << ' ' << m.nodes(n, 1) << ' ' << m.nodes(n, 2) << '\n';
  os << "$EndNodes\n$Elements\n";
  int tagged = 0;
  for (int t : m.face_tag) tagged += t != kNoTag;
  os << m.n_tets() + tagged << "\n";
  int id = 1;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    const int t = m.face_tag[static_cast<size_t>(f)];
    if (t == kNoTag) continue;
    os << id++ << ' ' << (m.order == 1 ? 2 : 9) << " 2 " << (t == kClamped ? 11 : 12) << " 1";
    // Reversed orientation on purpose: the reader must not depend on it.
    const int order3[3] = {0, 2, 1}, order6[6] = {0, 2, 1, 5, 4, 3};
    for (int a = 0; a < m.faces.cols(); ++a) os << ' ' << m.faces(f, m.order == 1 ? order3[a] : order6[a]) + 1;
    os << '\n';
  }
  for (Eigen::Index e = 0; e < m.tets.rows(); ++e) {
    os << id++ << ' ' << (m.order == 1 ? 4 : 11) << " 2 1 1";
    for (int a = 0; a < m.tets.cols(); ++a) {
      const int slot = a == 8 ? 9 : a == 9 ? 8 : a;
      os << ' ' << m.tets(e, slot) + 1;
    }
    os << '\n';
  }
  os << "$EndElements\n";
  return os.str();
}

TEST(MeshIo, ReadsGmsh2QuadraticTetrahedraWithPhysicalNames) {
  const Mesh ref = box_mesh(2, 1, 1, 2, 1, 1, 2);
  const Mesh m = parse_gmsh(to_gmsh_v2(ref), "box.msh");
  EXPECT_EQ(m.check(), "");
  EXPECT_EQ(m.order, 2);
  EXPECT_EQ(m.n_nodes(), ref.n_nodes());
  EXPECT_EQ(m.n_vertices, ref.n_vertices);
  EXPECT_NEAR(m.volume(), 2.0, 1e-12);
  int endo = 0, epi = 0;
  for (int t : m.face_tag) {
    endo += t == kEndocardium;  // "Endocardium" -> kEndocardium
    epi += t == kEpicardium;    // "epi" -> kEpicardium
  }
  EXPECT_EQ(endo, 2);  // the x = 0 square
  EXPECT_EQ(epi, 4);   // the z = 0 rectangle
  EXPECT_EQ(m.physical_names.at("wall"), 1);
}

TEST(MeshIo, ReadsGmsh2LinearTetrahedra) {
  const Mesh ref = box_mesh(1, 1, 1, 1, 1, 1, 1);
  const Mesh m = parse_gmsh(to_gmsh_v2(ref));
  EXPECT_EQ(m.check(), "");
  EXPECT_EQ(m.order, 1);
  EXPECT_NEAR(m.volume(), 1.0, 1e-12);
}

TEST(MeshIo, ReadsGmsh41WithEntities) {
  // One tetrahedron (volume entity 1, physical 5) and its bottom face (surface entity 2,
  // physical 3 named "base"); node 1 of the tetrahedron listed in negative orientation.
  const std::string text =
      "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
      "$PhysicalNames\n2\n2 3 \"base\"\n3 5 \"myocardium\"\n$EndPhysicalNames\n"
      "$Entities\n0 0 1 1\n"
      "2 0 0 0 1 1 0 1 3 0\n"
      "1 0 0 0 1 1 1 1 5 1 2\n"
      "$EndEntities\n"
      "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n"
      "$Elements\n2 2 1 2\n2 2 2 1\n1 1 2 3\n3 1 4 1\n2 1 3 2 4\n$EndElements\n";
  const Mesh m = parse_gmsh(text, "one.msh");
  EXPECT_EQ(m.check(), "");
  EXPECT_NEAR(m.volume(), 1.0 / 6.0, 1e-15);
  EXPECT_EQ(m.tet_tag[0], 5);
  int base = 0;
  for (int t : m.face_tag) base += t == kBase;
  EXPECT_EQ(base, 1);
}

void expect_error(const std::string& text, const std::string& fragment) {
  try {
    parse_gmsh(text, "bad.msh");
    ADD_FAILURE() << "no error for: " << fragment;
  } catch (const MeshReadError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(MeshIo, ErrorsNameFileLineAndWhatWasExpected) {
  expect_error("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 zero\n$EndNodes\n", "bad.msh:6: expected a node coordinate");
  expect_error("$MeshFormat\n2.2 1 8\n$EndMeshFormat\n", "binary");
  expect_error("$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", "unsupported gmsh format version");
  expect_error("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n",
               "bad.msh:10: element references undefined node 2");
  expect_error("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n0\n$EndNodes\n$Elements\n0\n$EndElements\n", "no tetrahedra");
  expect_error("hello\n", "expected a section header");
  EXPECT_THROW(read_gmsh("/nonexistent/x.msh"), MeshReadError);
}

TEST(MeshIo, WritesVtuAndPvd) {
  const Mesh m = box_mesh(1, 1, 1, 1, 1, 1, 2);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(3 * m.n_nodes(), 0.5);
  const Eigen::VectorXd p = Eigen::VectorXd::Zero(m.n_vertices);
  std::vector<int> aha(static_cast<size_t>(m.n_tets()), 7);
  VtuFields f;
  f.displacement = &u;
  f.pressure = &p;
  f.aha = &aha;
  const auto dir = std::filesystem::temp_directory_path() / "sigmaheart_fem_vtu_test";
  std::filesystem::create_directories(dir);
  write_vtu((dir / "s.vtu").string(), m, f);
  write_pvd((dir / "s.pvd").string(), {{0.0, "s.vtu"}});
  std::ifstream in(dir / "s.vtu");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  EXPECT_NE(text.find("NumberOfCells=\"6\""), std::string::npos);
  EXPECT_NE(text.find("Name=\"aha_segment\""), std::string::npos);
  EXPECT_NE(text.find("\n24\n"), std::string::npos);  // VTK_QUADRATIC_TETRA
  EXPECT_TRUE(std::filesystem::exists(dir / "s.pvd"));
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    EXPECT_NE(e.path().extension(), ".tmp") << e.path();  // the temporary was renamed
  }
  std::filesystem::remove_all(dir);
}

// The organisers' ellipsoid_0.005 (toolkit data/monoventricle_mesh, repacked with gzip): sizes,
// tags as the toolkit's gmsh script sets them (1 endo, 2 epi, 3 base), and every tagged vertex on
// its surface: the endocardium and epicardium on their ellipsoids (r_s 25 / 35 mm, r_l 90 / 97 mm,
// long axis x; note s.1.1), the base between the rings x = 90 * 5/17 mm and 97/4 mm.
TEST(MeshIo, ReadsTheArosticaBenchmarkMeshFromDolfinHdf5) {
  const Mesh m = read_dolfin_hdf5(std::string(SIGMAHEART_SOURCE_DIR) + "/configs/data/arostica-2025/ellipsoid_0.005.h5");
  EXPECT_EQ(m.order, 1);
  EXPECT_EQ(m.n_nodes(), 4577);
  EXPECT_EQ(m.n_tets(), 17625);
  EXPECT_EQ(m.check(), "");
  ASSERT_EQ(m.faces.rows(), 6230);
  std::map<int, int> count;
  for (int t : m.face_tag) ++count[t];
  EXPECT_EQ(count[kEndocardium], 2500);
  EXPECT_EQ(count[kEpicardium], 3474);
  EXPECT_EQ(count[kBase], 256);
  EXPECT_EQ(count[kNoTag], 0);
  const auto on_ellipsoid = [&](int v, double rs, double rl) {
    const double x = m.nodes(v, 0), r = std::hypot(m.nodes(v, 1), m.nodes(v, 2));
    return std::abs(x * x / (rl * rl) + r * r / (rs * rs) - 1.0);
  };
  double endo = 0, epi = 0, base_lo = 1, base_hi = -1;
  for (int v : m.nodes_with_tag(kEndocardium)) endo = std::max(endo, on_ellipsoid(v, 0.025, 0.090));
  for (int v : m.nodes_with_tag(kEpicardium)) epi = std::max(epi, on_ellipsoid(v, 0.035, 0.097));
  for (int v : m.nodes_with_tag(kBase)) {
    base_lo = std::min(base_lo, m.nodes(v, 0));
    base_hi = std::max(base_hi, m.nodes(v, 0));
  }
  EXPECT_LT(endo, 1e-6);
  EXPECT_LT(epi, 1e-6);
  EXPECT_NEAR(base_lo, 0.097 / 4, 1e-9);
  EXPECT_NEAR(base_hi, 0.090 * 5 / 17, 1e-9);
}

TEST(MeshIo, DolfinHdf5ErrorsNameTheFileTheDatasetAndWhatWasExpected) {
  const auto dir = std::filesystem::temp_directory_path() / "sigmaheart_dolfin_h5_test";
  std::filesystem::create_directories(dir);
  const auto message = [](const std::filesystem::path& p) {
    try {
      read_dolfin_hdf5(p.string());
    } catch (const MeshReadError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(dir / "none.h5"), (dir / "none.h5").string() + ": cannot open file");
  {
    std::ofstream(dir / "text.h5") << "not hdf5\n";
  }
  EXPECT_EQ(message(dir / "text.h5"), (dir / "text.h5").string() + ": not an HDF5 file");
  Eigen::MatrixXd xyz(4, 3);
  xyz << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  const auto write = [&](const std::string& name, const Eigen::MatrixXd& topology) {
    Hdf5Writer w(dir / name);
    w.create_group("/Mesh/mesh");
    w.write_matrix("/Mesh/mesh/geometry", xyz);
    if (topology.size() > 0) w.write_matrix("/Mesh/mesh/topology", topology);
    w.commit();
    return dir / name;
  };
  EXPECT_EQ(message(write("no_topology.h5", Eigen::MatrixXd())),
            (dir / "no_topology.h5").string() + ": dataset /Mesh/mesh/topology missing (expected a legacy DOLFIN HDF5 mesh)");
  Eigen::MatrixXd tri(1, 3);
  tri << 0, 1, 2;
  EXPECT_EQ(message(write("triangles.h5", tri)),
            (dir / "triangles.h5").string() + ": dataset /Mesh/mesh/topology has 3 columns, expected 4");
  Eigen::MatrixXd bad(1, 4);
  bad << 0, 1, 2, 7;
  EXPECT_EQ(message(write("index.h5", bad)),
            (dir / "index.h5").string() + ": /Mesh/mesh/topology row 0 names vertex 7, expected 0..3");
  Eigen::MatrixXd good(1, 4);
  good << 0, 2, 1, 3;  // negatively oriented: reordered
  const Mesh m = read_dolfin_hdf5(write("one.h5", good).string());
  EXPECT_EQ(m.n_tets(), 1);
  EXPECT_NEAR(m.volume(), 1.0 / 6.0, 1e-15);
  EXPECT_EQ(m.faces.rows(), 4);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sigmaheart::app::io
