// CSV: the one table reader and the observation reader on any bytes. A read either succeeds
// with finite numbers or throws std::runtime_error naming the source.
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "calib/csv.h"
#include "calib/observation_io.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  const std::string text = fuzz::Text(data, size);
  try {
    const calib::CsvTable t = calib::CsvTable::Parse(text, "fuzz.csv", {.trim = true, .allow_partial_tail = true});
    for (size_t r = 0; r < t.NumRows() && !t.Header().empty(); ++r) {
      try {
        const double v = t.Number(r, t.Header()[0]);
        OWLCAL_FUZZ_ASSERT(std::isfinite(v));
      } catch (const std::runtime_error&) {
      }
    }
  } catch (const std::runtime_error&) {
  }
  try {
    for (const calib::CornerObservation& o : calib::ReadObservationsCsv(fuzz::AsFile(data, size, ".csv")))
      OWLCAL_FUZZ_ASSERT(std::isfinite(o.pixel.x()) && std::isfinite(o.pixel.y()));
  } catch (const std::runtime_error&) {
  }
  return 0;
}
