// The `observe:` section of a config (`sigmaheart observe`, docs/models.md s.5.1), parsed and
// checked in one place, every error at file:line:column:
//
//   name: patient-07
//   observe:
//     meshes: tracking/lv.pvd      # a .pvd series, a list of files, or a glob ("frames/lv_*.vtk")
//     # images: seg/lv_4d.nii.gz   # or NIfTI label images: one 4D file or a list of 3D files
//     units: mm                    # mesh coordinates and landmarks (m, cm, mm); images: landmarks only
//     displacement: {array: displacement, points: deformed}   # points: reference = one mesh + displacements
//     reference: first-frame       # or undeformed: the segments are assigned on points - displacement
//     endocardium: auto            # auto | surface | inner | {point_label: NAME, value: 1} | {cell_label: NAME, value: 1}
//     label: 1                     # images: the LV blood-pool label
//     subdivision: [2, 2, 8]       # images: sub-samples per voxel for the sector boundaries
//     heights: landmarks           # images: h between the apex and base landmarks, or extent (the pool's)
//     landmarks:
//       apex: [0, 0, -45]
//       base: rim                  # or >= 3 points on the base plane (images: required)
//       rv_anterior: [20, 0, 0]
//       rv_inferior: [-10, 17, 0]  # optional
//       tolerance: 15 mm           # how far from the surface a landmark may lie
//     timing:
//       heart_rate: 60 bpm         # frames spread over one period when the files carry no times
//       time_unit: s               # of the .pvd timesteps
//       trigger_offset: 0 ms       # frame 0's time after the ECG trigger (R wave)
//       end_diastole: max-volume   # or a frame index (from 0)
//     pressure: {file: p.csv, column: P_lv}   # optional: merged at the frame times
//     checks: {jump_fraction: 0.25, sum_tolerance: 0.01}
//     apical_cap: 0                # segment 17 also takes h below this fraction of L
#pragma once

#include "app/config_node.h"
#include "app/io/tracked_mesh_io.h"
#include "model/fem/label_volumes.h"
#include "model/fem/tracked_volumes.h"
#include "observers/volume_curves.h"

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sigmaheart::app {

enum class ObserveSource { kMeshes, kImages };
enum class EndoChoice { kAuto, kSurface, kInner, kPointLabel, kCellLabel };

struct ObserveSetup {
  std::string name;                               // `name:`, else the config's stem
  std::filesystem::path config;
  ObserveSource source = ObserveSource::kMeshes;
  std::vector<std::filesystem::path> files;       // one per frame (meshes) or per image file
  std::vector<double> file_times;                 // [s] from a .pvd (empty otherwise)
  std::filesystem::path series;                   // the .pvd, when given
  Location files_at;                              // where meshes:/images: is written
  // Meshes.
  io::TrackedMeshReadOptions read;                // units, arrays to read
  bool points_are_reference = false;              // one mesh + a displacement per frame
  bool reference_undeformed = false;              // segments assigned on the undeformed mesh
  EndoChoice endocardium = EndoChoice::kAuto;
  double endo_value = 1.0;
  // Images.
  int label = 1;
  model::fem::SectorOptions sectors;
  // Both.
  model::fem::Landmarks landmarks;                // [m]
  std::map<std::string, Location> landmark_at;    // "apex", "base[1]", ... -> where written
  model::fem::TrackedOptions tracked;
  double length_unit = 1e-3;                      // [m] per unit of coordinates and landmarks
  double heart_rate = 0.0;                        // [1/s]; 0: not given
  double trigger_offset = 0.0;                    // [s]
  int end_diastole = -1;                          // frame, -1: largest V_lv
  Location end_diastole_at;
  std::filesystem::path pressure_file;            // empty: none
  std::string pressure_column = "P_lv";
  Location pressure_at;
  observers::VolumeCheckOptions checks;
};

// Parses `observe:` of a config file (after --set overrides). InputError at the offending key.
ObserveSetup parse_observe(const ConfigFile& file);

}  // namespace sigmaheart::app
