// The course's OpenCV FileStorage files (intrinsics.xml, extrinsics.xml, calibration.yaml):
// any text either reads into finite, well-shaped matrices or throws std::runtime_error.
#include <cstdint>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "fitting/opencv_calib_file.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  cv::setBreakOnError(false);
  try {
    const fitting::OpenCvStereoCalibration c = fitting::ParseOpenCvCalibration(fuzz::Text(data, size), "fuzz.xml");
    for (const cv::Mat* m : {&c.M1, &c.D1, &c.M2, &c.D2, &c.R, &c.T, &c.E, &c.F, &c.R1, &c.R2, &c.P1, &c.P2, &c.Q})
      OWLCAL_FUZZ_ASSERT(m->empty() || cv::checkRange(*m));
  } catch (const std::runtime_error&) {
  } catch (const cv::Exception&) {
    // FileStorage's own parser errors surface as cv::Exception from open(); converted above.
    __builtin_trap();
  }
  return 0;
}
