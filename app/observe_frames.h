// The work of `sigmaheart observe` between the config and the writers: reads the frames the setup
// names (app/io/tracked_mesh_io, app/io/label_image_io) and computes the volume curves with the
// libraries (model/fem/tracked_volumes.h, label_volumes.h), frame times after the ECG trigger.
#pragma once

#include "app/observe_setup.h"
#include "observers/volume_curves.h"

#include <string>
#include <vector>

namespace sigmaheart::app {

struct ObservedFrames {
  observers::VolumeCurves curves;   // times after the ECG trigger [s], volumes [m^3]
  std::vector<std::string> notes;   // what was found, one line each (provenance and the terminal)
  // Tracked meshes: the element quality at the frame where it is worst.
  bool has_quality = false;
  double worst_quality = 1.0;
  int worst_quality_frame = 0;
  int worst_element = -1;
  int inverted = 0;                 // inverted elements at that frame
};

// Throws InputError (the file, the frame, or the landmark's key) for input that does not fit.
ObservedFrames observe_frames(const ObserveSetup& setup);

}  // namespace sigmaheart::app
