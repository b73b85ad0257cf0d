// A bench case's name as a GoogleTest parameter name (letters, digits and '_' only): the
// parameterised foreign benches name their instances by case ("elastance-healthy" ->
// "elastance_healthy").
#pragma once

#include <string>

namespace sigmaheart::testing {

inline std::string case_test_name(std::string name) {
  for (char& ch : name) {
    if (ch == '-') ch = '_';
  }
  return name;
}

}  // namespace sigmaheart::testing
