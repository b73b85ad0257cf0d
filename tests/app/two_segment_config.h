// Config text on the two-segment test model ("test-two-segment", tests/support/two_segment_model.h)
// for the command tests that personalise it from a synthesized regional.csv.
#pragma once

#include <string>

namespace sigmaheart::testing {

// The simulator section.
inline const char* const kTwoSegmentSimulator =
    "simulator:\n"
    "  model: test-two-segment\n"
    "  numerics: {dt: 1 ms, output_every: 5}\n";

// A config named `name`: the simulator section and a personalize section that estimates both
// segments' sigma0 (log prior 50 kPa, 50 %) from regional.csv (all channels, 0.3 mL noise, 20
// spin-up beats); `rest` follows the estimate block (the filter line, truth, ...).
inline std::string two_segment_personalize(const std::string& name, const std::string& rest) {
  return "name: " + name + "\n" + kTwoSegmentSimulator + R"(personalize:
  observations:
    file: regional.csv
    channels: all
    noise: 0.3 mL
    start_beats: 20
  estimate:
    sigma0: {segments: all, prior: 5.0e4, spread: 50 %, transform: log}
)" + rest;
}

}  // namespace sigmaheart::testing
