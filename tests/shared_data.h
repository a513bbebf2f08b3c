#pragma once
// Where the real images of ../shared/data are: $OWLCAL_SHARED_DATA (ctest sets it), else the
// folder CMake found at configure time (OWLCAL_SHARED_DATA, a compile definition).
#include <cstdlib>
#include <string>

namespace owlcal::test_data {

inline std::string SharedData() {
  const char* env = std::getenv("OWLCAL_SHARED_DATA");
  return env && *env ? env : OWLCAL_SHARED_DATA;
}

}  // namespace owlcal::test_data
