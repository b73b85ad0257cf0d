// Observation operators: a Trajectory in, a named observation vector z out (docs/estimation.md s.5).
// Units: z is SI (m^3, Pa, s, m^3/s, Pa/s, "1" for fractions); the names and units of z are those
// of outputs(). Clinical units appear only at the I/O boundary (app/), never here.
#pragma once

#include "model/simulator.h"

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace sigmaheart::observers {

class Observer {
 public:
  virtual ~Observer() = default;

  // Names and SI units of the entries of z, in order. Same names as the ObservationSet uses.
  virtual std::vector<model::Channel> outputs() const = 0;
  int size() const { return static_cast<int>(outputs().size()); }

  // Fills z (size() entries). A trajectory the observer cannot read (missing channel, too few
  // samples, no ejection found) is a non-ok Status, never an exception.
  virtual model::Status observe(const model::Trajectory& trajectory,
                                Eigen::Ref<Eigen::VectorXd> z) const = 0;

  virtual std::unique_ptr<Observer> clone() const = 0;
};

// The check every observe() starts with: ok when z has `expected` entries, else kInvalidArgument
// "<who>: z has N entries, expected M".
inline model::Status check_z_size(const std::string& who, Eigen::Index z_size, size_t expected) {
  if (z_size == static_cast<Eigen::Index>(expected)) return model::Status::Ok();
  return model::Status::Error(model::StatusCode::kInvalidArgument,
                              who + ": z has " + std::to_string(z_size) + " entries, expected " +
                                  std::to_string(expected));
}

// Measured values with their noise, in SI, in the order of names. Frame times are those of the
// curves the values came from (empty for typed-in indices).
struct ObservationSet {
  std::vector<std::string> names;
  std::vector<std::string> units;     // SI units, as Observer::outputs()
  std::vector<std::string> display_units;  // units the user gave (mL, mmHg...), for reports
  Eigen::VectorXd y;                  // measured values [SI]
  Eigen::MatrixXd R;                  // noise covariance [SI^2], symmetric positive definite
  Eigen::VectorXd frame_times;        // [s], may be empty

  int size() const { return static_cast<int>(y.size()); }
  // Empty when consistent (sizes agree, R symmetric positive definite, y finite), else a message.
  std::string validate() const;
  // A copy restricted to the given names, in that order (throws std::invalid_argument naming the
  // first missing one).
  ObservationSet select(const std::vector<std::string>& wanted) const;
};

}  // namespace sigmaheart::observers
