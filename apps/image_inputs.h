// The image files named on a command line: files as given, folders listed (not recursively),
// sorted by path. Shared by `owlcal detect` and `owlcal detect-tags`.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace owlcal::apps {

// True for the extensions OpenCV's imread reads here (case-insensitive).
bool IsImageFile(const std::filesystem::path& p);

// Throws UsageError for an input that is neither an image file nor a folder, and when no image
// is found at all.
std::vector<std::filesystem::path> ImageFilesIn(const std::vector<std::string>& inputs);

}  // namespace owlcal::apps
