#include "app/io/tracked_mesh_io.h"

#include "app/errors.h"

#include <Eigen/Geometry>
#include <vtkCallbackCommand.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDataArray.h>
#include <vtkDataSet.h>
#include <vtkDataSetReader.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkSTLReader.h>
#include <vtkSmartPointer.h>
#include <vtkXMLDataElement.h>
#include <vtkXMLDataParser.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>

namespace sigmaheart::app::io {

namespace {

using model::fem::Mesh;

[[noreturn]] void fail(const std::filesystem::path& file, int frame, const std::string& what) {
  throw InputError(file.string(), 0, 0, (frame >= 0 ? "frame " + std::to_string(frame) + ": " : std::string()) + what);
}

// The first error a VTK object reports (VTK prints and goes on; we stop).
struct ErrorCatcher {
  std::string message;
  vtkNew<vtkCallbackCommand> command;
  ErrorCatcher() {
    command->SetClientData(this);
    command->SetCallback([](vtkObject*, unsigned long, void* self, void* data) {
      auto* me = static_cast<ErrorCatcher*>(self);
      if (me->message.empty() && data) me->message = static_cast<const char*>(data);
    });
  }
  void watch(vtkObject* o) {
    o->AddObserver(vtkCommand::ErrorEvent, command);
    o->AddObserver(vtkCommand::WarningEvent, command);
  }
};

std::string lower_extension(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

// Reads a file with the reader its extension names; the dataset (kept alive by the smart pointer).
vtkSmartPointer<vtkDataSet> read_dataset(const std::filesystem::path& file, int frame) {
  vtkObject::GlobalWarningDisplayOff();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) fail(file, frame, "cannot open the file (expected a mesh file)");
  const std::string ext = lower_extension(file);
  ErrorCatcher errors;
  vtkSmartPointer<vtkDataSet> out;
  auto run = [&](auto reader) {
    errors.watch(reader);
    reader->SetFileName(file.string().c_str());
    reader->Update();
    out = reader->GetOutput();
  };
  if (ext == ".vtu") {
    run(vtkSmartPointer<vtkXMLUnstructuredGridReader>::New());
  } else if (ext == ".vtp") {
    run(vtkSmartPointer<vtkXMLPolyDataReader>::New());
  } else if (ext == ".vtk") {
    run(vtkSmartPointer<vtkDataSetReader>::New());
  } else if (ext == ".stl") {
    run(vtkSmartPointer<vtkSTLReader>::New());
  } else if (ext == ".obj") {
    run(vtkSmartPointer<vtkOBJReader>::New());
  } else {
    fail(file, frame, "unknown mesh format '" + ext + "' (expected .vtu, .vtp, .vtk, .stl, .obj, or a .pvd series)");
  }
  if (!errors.message.empty()) {
    std::string m = errors.message;
    while (!m.empty() && std::isspace(static_cast<unsigned char>(m.back()))) m.pop_back();
    fail(file, frame, "VTK could not read it: " + m.substr(0, 400));
  }
  if (!out || out->GetNumberOfPoints() == 0) fail(file, frame, "no points (expected a mesh)");
  return out;
}

// Cells as flat (type, ids...) records, triangles and tetrahedra split out.
struct Cells {
  std::vector<long long> signature;            // every usable cell: type, count, ids
  std::vector<std::array<int, 10>> tets;       // 4 or 10 ids
  std::vector<std::array<int, 6>> triangles;   // 3 or 6 ids
  std::vector<vtkIdType> triangle_cell;        // the VTK cell each triangle came from
  int tet_nodes = 0, tri_nodes = 0;
};

Cells read_cells(vtkDataSet* ds, const std::filesystem::path& file, int frame) {
  Cells c;
  vtkNew<vtkIdList> ids;
  auto order_check = [&](int& have, int want, const char* what) {
    if (have != 0 && have != want) fail(file, frame, std::string("mixed linear and quadratic ") + what + " (expected one order)");
    have = want;
  };
  for (vtkIdType i = 0; i < ds->GetNumberOfCells(); ++i) {
    const int type = ds->GetCellType(i);
    ds->GetCellPoints(i, ids);
    const vtkIdType n = ids->GetNumberOfIds();
    auto id = [&](vtkIdType k) { return static_cast<int>(ids->GetId(k)); };
    auto tri = [&](int a, int b, int d) {
      order_check(c.tri_nodes, 3, "triangles");
      c.triangles.push_back({a, b, d, 0, 0, 0});
      c.triangle_cell.push_back(i);
    };
    switch (type) {
      case VTK_VERTEX: case VTK_POLY_VERTEX: case VTK_LINE: case VTK_POLY_LINE: case VTK_EMPTY_CELL:
        continue;
      case VTK_TETRA: case VTK_QUADRATIC_TETRA: {
        const int want = type == VTK_TETRA ? 4 : 10;
        if (n != want) fail(file, frame, "cell " + std::to_string(i) + " has " + std::to_string(n) + " points");
        order_check(c.tet_nodes, want, "tetrahedra");
        std::array<int, 10> t{};
        for (int k = 0; k < want; ++k) t[static_cast<size_t>(k)] = id(k);
        c.tets.push_back(t);
        break;
      }
      case VTK_TRIANGLE: tri(id(0), id(1), id(2)); break;
      case VTK_QUADRATIC_TRIANGLE:
        order_check(c.tri_nodes, 6, "triangles");
        c.triangles.push_back({id(0), id(1), id(2), id(3), id(4), id(5)});
        c.triangle_cell.push_back(i);
        break;
      case VTK_QUAD: tri(id(0), id(1), id(2)); tri(id(0), id(2), id(3)); break;
      case VTK_POLYGON: for (vtkIdType k = 1; k + 1 < n; ++k) tri(id(0), id(k), id(k + 1)); break;
      case VTK_TRIANGLE_STRIP:
        for (vtkIdType k = 0; k + 2 < n; ++k) k % 2 ? tri(id(k + 1), id(k), id(k + 2)) : tri(id(k), id(k + 1), id(k + 2));
        break;
      default:
        fail(file, frame, "cell " + std::to_string(i) + " is of VTK type " + std::to_string(type) +
                              "; expected tetrahedra or triangles (or quads/polygons)");
    }
    c.signature.push_back(type);
    c.signature.push_back(n);
    for (vtkIdType k = 0; k < n; ++k) c.signature.push_back(ids->GetId(k));
  }
  if (c.tets.empty() && c.triangles.empty()) fail(file, frame, "no tetrahedra or triangles");
  return c;
}

Eigen::MatrixX3d read_points(vtkDataSet* ds, double unit, const std::filesystem::path& file, int frame) {
  Eigen::MatrixX3d x(ds->GetNumberOfPoints(), 3);
  for (vtkIdType i = 0; i < ds->GetNumberOfPoints(); ++i) {
    double p[3];
    ds->GetPoint(i, p);
    for (int d = 0; d < 3; ++d) {
      if (!std::isfinite(p[d])) fail(file, frame, "point " + std::to_string(i) + " has a non-finite coordinate");
      x(i, d) = p[d] * unit;
    }
  }
  return x;
}

vtkDataArray* array_of(vtkDataSet* ds, bool point, const std::string& name, int components, const std::filesystem::path& file,
                       int frame) {
  vtkDataArray* a = point ? ds->GetPointData()->GetArray(name.c_str()) : ds->GetCellData()->GetArray(name.c_str());
  const std::string kind = point ? "point" : "cell";
  if (!a) fail(file, frame, "no " + kind + " array '" + name + "'");
  if (a->GetNumberOfComponents() != components)
    fail(file, frame, kind + " array '" + name + "' has " + std::to_string(a->GetNumberOfComponents()) + " components; expected " +
                          std::to_string(components));
  return a;
}

double diagonal(const Eigen::MatrixX3d& x) { return (x.colwise().maxCoeff() - x.colwise().minCoeff()).norm(); }

}  // namespace

bool have_vtk() { return true; }

PvdSeries read_pvd_series(const std::filesystem::path& pvd) {
  vtkObject::GlobalWarningDisplayOff();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(pvd, ec)) fail(pvd, -1, "cannot open the file (expected a ParaView .pvd collection)");
  vtkNew<vtkXMLDataParser> parser;
  ErrorCatcher errors;
  errors.watch(parser);
  parser->SetFileName(pvd.string().c_str());
  if (!parser->Parse() || !errors.message.empty() || !parser->GetRootElement())
    fail(pvd, -1, "not an XML file (expected a ParaView .pvd collection)");
  vtkXMLDataElement* coll = parser->GetRootElement()->FindNestedElementWithName("Collection");
  if (!coll) fail(pvd, -1, "no <Collection> element (expected a ParaView .pvd collection)");
  PvdSeries s;
  for (int i = 0; i < coll->GetNumberOfNestedElements(); ++i) {
    vtkXMLDataElement* e = coll->GetNestedElement(i);
    if (std::string(e->GetName()) != "DataSet") continue;
    const std::string where = "DataSet " + std::to_string(s.files.size());
    const char* file = e->GetAttribute("file");
    if (!file) fail(pvd, -1, where + " has no file attribute");
    const char* part = e->GetAttribute("part");
    if (part && std::string(part) != "0" && std::string(part) != "")
      fail(pvd, -1, where + " is part " + part + "; expected one part per time step");
    double t = std::numeric_limits<double>::quiet_NaN();
    if (!e->GetScalarAttribute("timestep", t) || !std::isfinite(t)) fail(pvd, -1, where + " has no numeric timestep");
    if (!s.times.empty() && !(t > s.times.back()))
      fail(pvd, -1, where + " (" + file + "): timestep " + std::to_string(t) + " is not after the previous " +
                        std::to_string(s.times.back()) + "; times must increase strictly");
    s.times.push_back(t);
    s.files.push_back(pvd.parent_path() / file);
  }
  if (s.files.empty()) fail(pvd, -1, "no DataSet entries");
  return s;
}

TrackedMeshSeries read_tracked_meshes(const std::vector<std::filesystem::path>& files, const TrackedMeshReadOptions& o) {
  if (files.empty()) throw InputError("observe", 0, 0, "no mesh files");
  TrackedMeshSeries s;
  s.files = files;
  std::vector<long long> signature0;
  vtkIdType points0 = 0;
  std::vector<vtkIdType> triangle_cell;
  for (size_t k = 0; k < files.size(); ++k) {
    const int frame = static_cast<int>(k);
    const auto& file = files[k];
    vtkSmartPointer<vtkDataSet> ds = read_dataset(file, frame);
    Cells cells = read_cells(ds, file, frame);
    if (k == 0) {
      signature0 = std::move(cells.signature);
      points0 = ds->GetNumberOfPoints();
      Mesh& m = s.mesh;
      s.volume = !cells.tets.empty();
      if (s.volume) {
        m.order = cells.tet_nodes == 10 ? 2 : 1;
        m.tets.resize(static_cast<Eigen::Index>(cells.tets.size()), cells.tet_nodes);
        for (size_t e = 0; e < cells.tets.size(); ++e)
          for (int j = 0; j < cells.tet_nodes; ++j) m.tets(static_cast<Eigen::Index>(e), j) = cells.tets[e][static_cast<size_t>(j)];
      } else {
        m.order = cells.tri_nodes == 6 ? 2 : 1;
        m.tets.resize(0, m.order == 2 ? 10 : 4);
        m.faces.resize(static_cast<Eigen::Index>(cells.triangles.size()), cells.tri_nodes);
        for (size_t f = 0; f < cells.triangles.size(); ++f)
          for (int j = 0; j < cells.tri_nodes; ++j) m.faces(static_cast<Eigen::Index>(f), j) = cells.triangles[f][static_cast<size_t>(j)];
        m.face_tag.assign(cells.triangles.size(), model::fem::kNoTag);
      }
      m.nodes = read_points(ds, o.length_unit, file, frame);
      m.n_vertices = m.n_nodes();
      m.tet_tag.assign(static_cast<size_t>(m.n_tets()), 0);
      if (s.volume) {
        // Positive orientation (VTK order: swap corners 1, 2 and the mid-edge nodes they move).
        static constexpr std::array<int, 10> kSwap = {0, 2, 1, 3, 6, 5, 4, 7, 9, 8};
        for (Eigen::Index e = 0; e < m.tets.rows(); ++e) {
          const Eigen::Vector3d p0 = m.nodes.row(m.tets(e, 0));
          const double V = (m.nodes.row(m.tets(e, 1)).transpose() - p0)
                               .dot((m.nodes.row(m.tets(e, 2)).transpose() - p0).cross(m.nodes.row(m.tets(e, 3)).transpose() - p0));
          if (V < 0) {
            const Eigen::VectorXi row = m.tets.row(e);
            for (int j = 0; j < m.tets.cols(); ++j) m.tets(e, j) = row(kSwap[static_cast<size_t>(j)]);
          }
        }
        model::fem::extract_boundary_faces(m);
      }
      if (!o.point_label.empty()) {
        vtkDataArray* a = array_of(ds, true, o.point_label, 1, file, frame);
        s.point_label.resize(points0);
        for (vtkIdType i = 0; i < points0; ++i) s.point_label(i) = a->GetComponent(i, 0);
      }
      s.face_label = Eigen::VectorXd::Constant(m.faces.rows(), std::numeric_limits<double>::quiet_NaN());
      if (!o.cell_label.empty()) {
        vtkDataArray* a = array_of(ds, false, o.cell_label, 1, file, frame);
        if (cells.triangles.empty()) fail(file, frame, "cell array '" + o.cell_label + "' needs triangle cells (a labelled surface)");
        if (!s.volume) {
          for (size_t f = 0; f < cells.triangles.size(); ++f) s.face_label(static_cast<Eigen::Index>(f)) = a->GetComponent(cells.triangle_cell[f], 0);
        } else {
          // The labelled triangles name boundary faces of the tetrahedra (matched by their corners).
          std::map<std::array<int, 3>, double> label;
          for (size_t f = 0; f < cells.triangles.size(); ++f) {
            std::array<int, 3> key{cells.triangles[f][0], cells.triangles[f][1], cells.triangles[f][2]};
            std::sort(key.begin(), key.end());
            label[key] = a->GetComponent(cells.triangle_cell[f], 0);
          }
          for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
            std::array<int, 3> key{m.faces(f, 0), m.faces(f, 1), m.faces(f, 2)};
            std::sort(key.begin(), key.end());
            if (auto it = label.find(key); it != label.end()) s.face_label(f) = it->second;
          }
        }
      }
    } else {
      if (ds->GetNumberOfPoints() != points0)
        fail(file, frame, "has " + std::to_string(ds->GetNumberOfPoints()) + " points, frame 0 (" + files[0].string() + ") has " +
                              std::to_string(points0) + ": the connectivity must be the same in every frame");
      if (cells.signature != signature0) {
        const auto at = std::mismatch(cells.signature.begin(), cells.signature.end(), signature0.begin(), signature0.end());
        fail(file, frame, "its cells differ from frame 0's (" + files[0].string() + ") from entry " +
                              std::to_string(at.first - cells.signature.begin()) +
                              " of the connectivity on: the connectivity must be the same in every frame");
      }
    }
    s.points.push_back(k == 0 ? s.mesh.nodes : read_points(ds, o.length_unit, file, frame));
    if (!o.displacement.empty()) {
      vtkDataArray* a = array_of(ds, true, o.displacement, 3, file, frame);
      Eigen::MatrixX3d u(points0, 3);
      for (vtkIdType i = 0; i < points0; ++i)
        for (int d = 0; d < 3; ++d) {
          u(i, d) = a->GetComponent(i, d) * o.length_unit;
          if (!std::isfinite(u(i, d))) fail(file, frame, "displacement of point " + std::to_string(i) + " is not finite");
        }
      s.displacement.push_back(std::move(u));
    }
    const double ratio = diagonal(s.points.back()) / diagonal(s.points.front());
    if (!(ratio > 1.0 / 3.0 && ratio < 3.0))
      fail(file, frame, "its extent is " + std::to_string(ratio) + " times frame 0's: mixed units (m and mm?) or another mesh");
  }
  return s;
}

}  // namespace sigmaheart::app::io
