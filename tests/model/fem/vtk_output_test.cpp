// Binary VTU and PVD documents (model/fem/vtk_output.h), read back by a small parser of the XML
// header and the appended block: byte counts, offsets and values exact.
#include "model/fem/vtk_output.h"

#include "model/fem/mesh.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sigmaheart::model::fem {
namespace {

struct ParsedArray {
  std::string type;
  int components = 1;
  std::uint64_t offset = 0;
  std::uint64_t bytes = 0;  // the byte count stored in the appended block
  std::vector<char> data;
};

std::string attribute(const std::string& tag, const std::string& key) {
  const std::regex re(key + "=\"([^\"]*)\"");
  std::smatch m;
  return std::regex_search(tag, m, re) ? m[1].str() : std::string();
}

// Arrays by name, read through their offsets into the appended block.
std::map<std::string, ParsedArray> parse_vtu(const std::string& doc) {
  const std::string marker = "<AppendedData encoding=\"raw\">\n_";
  const auto start = doc.find(marker);
  if (start == std::string::npos) throw std::runtime_error("no appended data");
  const size_t base = start + marker.size();
  const std::string header = doc.substr(0, start);
  std::map<std::string, ParsedArray> out;
  const std::regex tag_re("<DataArray [^>]*/>");
  for (auto it = std::sregex_iterator(header.begin(), header.end(), tag_re); it != std::sregex_iterator(); ++it) {
    const std::string tag = it->str();
    ParsedArray a;
    a.type = attribute(tag, "type");
    const std::string nc = attribute(tag, "NumberOfComponents");
    a.components = nc.empty() ? 1 : std::stoi(nc);
    EXPECT_EQ(attribute(tag, "format"), "appended");
    a.offset = std::stoull(attribute(tag, "offset"));
    std::memcpy(&a.bytes, doc.data() + base + a.offset, sizeof a.bytes);
    const char* p = doc.data() + base + a.offset + sizeof(std::uint64_t);
    a.data.assign(p, p + a.bytes);
    out[attribute(tag, "Name")] = a;
  }
  return out;
}

template <class T>
std::vector<T> values(const ParsedArray& a) {
  std::vector<T> v(a.data.size() / sizeof(T));
  std::memcpy(v.data(), a.data.data(), v.size() * sizeof(T));
  return v;
}

TEST(VtkOutput, QuadraticVtuReadsBackExactly) {
  const Mesh m = box_mesh(2e-3, 1e-3, 1e-3, 2, 1, 1, 2);  // 12 quadratic tetrahedra
  VtuDocument doc(m);
  Eigen::VectorXd u(3 * m.n_nodes());
  for (int k = 0; k < u.size(); ++k) u[k] = 1e-6 * k + 1.0 / 3.0;
  Eigen::VectorXd t(m.n_vertices);
  for (int k = 0; k < t.size(); ++k) t[k] = 0.001 * k;
  Eigen::VectorXd ta(m.n_tets());
  for (int k = 0; k < ta.size(); ++k) ta[k] = 1e3 * std::sqrt(k + 1.0);
  std::vector<int> aha(static_cast<size_t>(m.n_tets()));
  for (int k = 0; k < m.n_tets(); ++k) aha[static_cast<size_t>(k)] = k % 17 + 1;
  doc.add_point_data("displacement", u, 3);
  doc.add_vertex_data("activation_time", t);
  doc.add_cell_data("active_stress", ta);
  doc.add_cell_labels("aha_segment", aha);
  const std::string s = doc.str();

  EXPECT_NE(s.find("header_type=\"UInt64\""), std::string::npos);
  EXPECT_NE(s.find("NumberOfPoints=\"" + std::to_string(m.n_nodes()) + "\" NumberOfCells=\"12\""), std::string::npos);
  const auto a = parse_vtu(s);
  ASSERT_EQ(a.size(), 8u);
  // Byte counts: n entities x components x size of the type.
  EXPECT_EQ(a.at("Points").bytes, static_cast<std::uint64_t>(m.n_nodes()) * 3 * 8);
  EXPECT_EQ(a.at("connectivity").bytes, 12u * 10 * 8);
  EXPECT_EQ(a.at("offsets").bytes, 12u * 8);
  EXPECT_EQ(a.at("types").bytes, 12u);
  EXPECT_EQ(a.at("displacement").bytes, static_cast<std::uint64_t>(m.n_nodes()) * 3 * 8);
  EXPECT_EQ(a.at("activation_time").bytes, static_cast<std::uint64_t>(m.n_nodes()) * 8);
  EXPECT_EQ(a.at("active_stress").bytes, 12u * 8);
  EXPECT_EQ(a.at("aha_segment").bytes, 12u * 4);
  EXPECT_EQ(a.at("aha_segment").type, "Int32");
  EXPECT_EQ(a.at("displacement").components, 3);

  const auto pts = values<double>(a.at("Points"));
  for (int n = 0; n < m.n_nodes(); ++n)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(pts[static_cast<size_t>(3 * n + c)], m.nodes(n, c));
  const auto conn = values<std::int64_t>(a.at("connectivity"));
  const auto off = values<std::int64_t>(a.at("offsets"));
  const auto types = values<std::uint8_t>(a.at("types"));
  for (int e = 0; e < 12; ++e) {
    EXPECT_EQ(off[static_cast<size_t>(e)], 10 * (e + 1));
    EXPECT_EQ(types[static_cast<size_t>(e)], 24);  // VTK_QUADRATIC_TETRA
    for (int k = 0; k < 10; ++k) EXPECT_EQ(conn[static_cast<size_t>(10 * e + k)], m.tets(e, k));
  }
  const auto ur = values<double>(a.at("displacement"));
  for (int k = 0; k < u.size(); ++k) EXPECT_EQ(ur[static_cast<size_t>(k)], u[k]);
  // Vertex data: vertices exact, mid-edge nodes the mean of their edge ends.
  const auto tr = values<double>(a.at("activation_time"));
  for (int k = 0; k < m.n_vertices; ++k) EXPECT_EQ(tr[static_cast<size_t>(k)], t[k]);
  for (int e = 0; e < m.n_tets(); ++e)
    EXPECT_EQ(tr[static_cast<size_t>(m.tets(e, tet10_edge_slot(1, 3)))], 0.5 * (t[m.tets(e, 1)] + t[m.tets(e, 3)]));
  const auto tar = values<double>(a.at("active_stress"));
  for (int k = 0; k < ta.size(); ++k) EXPECT_EQ(tar[static_cast<size_t>(k)], ta[k]);
  const auto ar = values<std::int32_t>(a.at("aha_segment"));
  for (int k = 0; k < m.n_tets(); ++k) EXPECT_EQ(ar[static_cast<size_t>(k)], aha[static_cast<size_t>(k)]);
  // The block ends right after the last array.
  const auto& last = a.at("aha_segment");
  const size_t end = s.find("<AppendedData encoding=\"raw\">\n_") + 31 + last.offset + 8 + last.bytes;
  EXPECT_EQ(s.substr(end), "\n</AppendedData>\n</VTKFile>\n");
}

TEST(VtkOutput, LinearCellsAndDeformedPoints) {
  const Mesh m = box_mesh(1e-3, 1e-3, 1e-3, 1, 1, 1, 1);
  VtuDocument doc(m);
  Eigen::MatrixX3d x = m.nodes;
  x.col(2) *= 2.0;
  doc.set_points(x);
  const auto a = parse_vtu(doc.str());
  const auto types = values<std::uint8_t>(a.at("types"));
  ASSERT_EQ(types.size(), 6u);
  for (auto t : types) EXPECT_EQ(t, 10);  // VTK_TETRA
  const auto pts = values<double>(a.at("Points"));
  for (int n = 0; n < m.n_nodes(); ++n) EXPECT_EQ(pts[static_cast<size_t>(3 * n + 2)], 2.0 * m.nodes(n, 2));
  // Refilled for the next step of a series: the old fields are gone, the new one is there.
  doc.add_cell_data("a", Eigen::VectorXd::Ones(6));
  doc.clear_data();
  doc.add_vertex_data("b", Eigen::VectorXd::Constant(m.n_vertices, 2.5));
  const auto c = parse_vtu(doc.str());
  EXPECT_EQ(c.size(), 5u);
  EXPECT_EQ(c.count("a"), 0u);
  EXPECT_EQ(values<double>(c.at("b")), std::vector<double>(static_cast<size_t>(m.n_nodes()), 2.5));
}

TEST(VtkOutput, RejectsWrongSizesAndNames) {
  const Mesh m = box_mesh(1e-3, 1e-3, 1e-3, 1, 1, 1, 1);
  VtuDocument doc(m);
  try {
    doc.add_point_data("u", Eigen::VectorXd::Zero(5), 3);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("has 5 values; expected 24"), std::string::npos) << e.what();
  }
  EXPECT_THROW(doc.add_cell_data("a\"b", Eigen::VectorXd::Zero(6)), std::invalid_argument);
  EXPECT_THROW(doc.add_cell_labels("aha", std::vector<int>(5, 1)), std::invalid_argument);
  EXPECT_THROW(doc.set_points(Eigen::MatrixX3d::Zero(3, 3)), std::invalid_argument);
}

TEST(VtkOutput, PvdListsFilesAndTimesExactly) {
  const std::vector<PvdEntry> steps = {{0.0, "beat_0000.vtu"}, {0.1, "beat_0001.vtu"}, {1.0 / 3.0, "beat_0002.vtu"}};
  std::ostringstream os;
  write_pvd(os, steps);
  const std::string s = os.str();
  EXPECT_NE(s.find("type=\"Collection\""), std::string::npos);
  const std::regex re("<DataSet timestep=\"([^\"]*)\" group=\"\" part=\"0\" file=\"([^\"]*)\"/>");
  size_t k = 0;
  for (auto it = std::sregex_iterator(s.begin(), s.end(), re); it != std::sregex_iterator(); ++it, ++k) {
    ASSERT_LT(k, steps.size());
    EXPECT_EQ(std::stod((*it)[1].str()), steps[k].time);  // exact round trip
    EXPECT_EQ((*it)[2].str(), steps[k].file);
  }
  EXPECT_EQ(k, steps.size());
}

}  // namespace
}  // namespace sigmaheart::model::fem
