#pragma once
// Helpers shared by the fuzz targets: the input as text, and as a file for path-based readers.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

namespace owlcal::fuzz {

inline std::string Text(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// Writes the input to a file of this process (one per target and process) and returns its path.
inline std::string AsFile(const uint8_t* data, size_t size, const std::string& ext) {
  static const std::string path = "/tmp/owlcal_fuzz_" + std::to_string(::getpid()) + ext;
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), std::streamsize(size));
  return path;
}

// Aborts (a finding) when an invariant of a successful read is broken.
#define OWLCAL_FUZZ_ASSERT(cond)                                                        \
  do {                                                                                  \
    if (!(cond)) {                                                                      \
      std::fprintf(stderr, "%s:%d: invariant failed: %s\n", __FILE__, __LINE__, #cond); \
      __builtin_trap();                                                                 \
    }                                                                                   \
  } while (0)

}  // namespace owlcal::fuzz
