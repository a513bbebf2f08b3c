#include "apps/image_inputs.h"

#include <algorithm>
#include <cctype>

#include "apps/command_registry.h"

namespace owlcal::apps {

namespace fs = std::filesystem;

bool IsImageFile(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e == ".jpg" || e == ".jpeg" || e == ".png" || e == ".bmp" || e == ".pgm" || e == ".ppm" || e == ".tif" ||
         e == ".tiff";
}

std::vector<fs::path> ImageFilesIn(const std::vector<std::string>& inputs) {
  std::vector<fs::path> files;
  for (const std::string& in : inputs) {
    if (fs::is_directory(in)) {
      for (const auto& e : fs::directory_iterator(in))
        if (e.is_regular_file() && IsImageFile(e.path())) files.push_back(e.path());
    } else if (fs::is_regular_file(in)) {
      files.push_back(in);
    } else {
      throw UsageError("input '" + in + "' is neither an image file nor a folder");
    }
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) throw UsageError("no images found in the inputs");
  return files;
}

}  // namespace owlcal::apps
