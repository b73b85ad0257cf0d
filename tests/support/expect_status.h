// A failed Status as two GoogleTest expectations: its code, and words its message must contain
// (the failure tests of the black-box models and the simulators).
#pragma once

#include "model/simulator.h"

#include <gtest/gtest.h>

#include <string>

namespace sigmaheart::testing {

// EXPECT_EQ(status.code, code) and EXPECT_NE(status.message.find(words), npos), each failure
// showing the whole message.
inline void expect_status(const model::Status& status, model::StatusCode code, const std::string& words) {
  EXPECT_EQ(status.code, code) << status.message;
  EXPECT_NE(status.message.find(words), std::string::npos) << status.message;
}

}  // namespace sigmaheart::testing
