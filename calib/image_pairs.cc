#include "calib/image_pairs.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"

namespace owlcal::calib {
namespace {

namespace fs = std::filesystem;

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool IsImage(const fs::path& p) {
  const std::string e = Lower(p.extension().string());
  return e == ".jpg" || e == ".jpeg" || e == ".png" || e == ".bmp" || e == ".tif" || e == ".tiff" || e == ".ppm" ||
         e == ".pgm";
}

// Leading number of a key ("30cm" -> 30), or a large value for keys without one.
double KeyNumber(const std::string& k) {
  size_t i = 0;
  while (i < k.size() && !std::isdigit(static_cast<unsigned char>(k[i]))) ++i;
  if (i == k.size()) return 1e300;
  return std::stod(k.substr(i));
}

}  // namespace

ImagePairList ListImagePairs(const std::string& dir, const ImagePairOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw std::runtime_error(dir + ": not a folder of images");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && IsImage(e.path())) files.push_back(e.path());
  if (ec) throw std::runtime_error(dir + ": cannot list: " + ec.message());
  ImagePairList out;
  if (options.side_by_side) {
    for (const auto& f : files) out.pairs.push_back({f.stem().string(), f.string(), f.string()});
  } else {
    std::map<std::string, std::string> lefts, rights;
    for (const auto& f : files) {
      const std::string stem = f.stem().string(), low = Lower(stem);
      if (low.rfind("left", 0) == 0)
        lefts[stem.substr(4)] = f.string();
      else if (low.rfind("right", 0) == 0)
        rights[stem.substr(5)] = f.string();
      else
        out.unpaired.push_back(f.string());
    }
    for (const auto& [k, l] : lefts) {
      auto it = rights.find(k);
      if (it == rights.end()) {
        out.unpaired.push_back(l);
        continue;
      }
      out.pairs.push_back({k, l, it->second});
    }
    for (const auto& [k, r] : rights)
      if (!lefts.count(k)) out.unpaired.push_back(r);
  }
  std::sort(out.pairs.begin(), out.pairs.end(), [](const ImagePair& a, const ImagePair& b) {
    const double na = KeyNumber(a.key), nb = KeyNumber(b.key);
    return na != nb ? na < nb : a.key < b.key;
  });
  std::sort(out.unpaired.begin(), out.unpaired.end());
  if (out.pairs.empty())
    throw std::runtime_error(
        dir + (options.side_by_side ? ": no image files (side-by-side frames)" : ": no left*/right* image pairs"));
  return out;
}

void LoadImagePair(const ImagePair& pair, const ImagePairOptions& options, cv::Mat* left, cv::Mat* right) {
  auto read = [&](const std::string& p) {
    cv::Mat m = cv::imread(p, cv::IMREAD_COLOR);
    if (m.empty()) throw std::runtime_error(p + ": cannot decode image");
    if (static_cast<int64_t>(m.total()) > options.max_pixels)
      throw std::runtime_error(p + ": image " + std::to_string(m.cols) + "x" + std::to_string(m.rows) + " (" +
                               std::to_string(m.total()) + " pixels) is larger than the limit of " +
                               std::to_string(options.max_pixels) + " pixels; scale it down");
    return m;
  };
  if (options.side_by_side) {
    const cv::Mat frame = read(pair.left_path);
    if (frame.cols % 2 != 0)
      throw std::runtime_error(pair.left_path + ": side-by-side frame width " + std::to_string(frame.cols) + " is odd");
    SplitStereoFrame(frame, options.mirror, options.swap, left, right);
    return;
  }
  cv::Mat l = read(pair.left_path), r = read(pair.right_path);
  if (options.mirror) {
    cv::flip(l, l, 1);
    cv::flip(r, r, 1);
  }
  if (options.swap) std::swap(l, r);
  *left = l;
  *right = r;
}

DetectedImageSet DetectImagePairs(const ImagePairList& list,
                                  const ImagePairOptions& options,
                                  const TargetDefinition& target,
                                  const DetectorOptions& detector) {
  DetectedImageSet out;
  for (size_t i = 0; i < list.pairs.size(); ++i) {
    const ImagePair& pair = list.pairs[i];
    cv::Mat img[2];
    LoadImagePair(pair, options, &img[0], &img[1]);
    PairDetection pd;
    pd.key = pair.key;
    for (int e = 0; e < 2; ++e) {
      if (out.width == 0) {
        out.width = img[e].cols;
        out.height = img[e].rows;
      } else if (img[e].cols != out.width || img[e].rows != out.height) {
        throw std::runtime_error((e == 0 ? pair.left_path : pair.right_path) + ": image size " +
                                 std::to_string(img[e].cols) + "x" + std::to_string(img[e].rows) + " differs from " +
                                 std::to_string(out.width) + "x" + std::to_string(out.height));
      }
      const TargetDetection d = DetectTarget(img[e], target, detector);
      pd.found[e] = d.found;
      pd.message[e] = d.message;
      if (d.found) {
        const auto obs = DetectionToObservations(d, target, static_cast<int>(i), e);
        out.observations.insert(out.observations.end(), obs.begin(), obs.end());
      }
    }
    out.pairs.push_back(pd);
  }
  return out;
}

}  // namespace owlcal::calib
