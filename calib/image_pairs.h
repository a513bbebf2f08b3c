#pragma once
// Stereo image pairs from a folder a student already has.
//
// Layouts (ImagePairOptions::side_by_side):
//   separate files (default): left<KEY>.<ext> and right<KEY>.<ext> (case-insensitive prefix,
//     e.g. left0.jpg / right0.jpg, left30cm.jpg / right30cm.jpg); a file without its partner is
//     listed in `unpaired`. `left*` is the robot's left eye.
//   side_by_side: every image file is one 1280x480 stream frame; split by
//     calib::SplitStereoFrame: left eye = columns 0-639 (after the optional mirror flip).
// mirror:
//   separate files: each image is flipped horizontally on loading (the 2017-2019 capture
//     helpers saved mirrored halves, e.g. darvill2019-chessboard; calibrating them unflipped
//     gives T_x > 0);
//   side_by_side: the whole frame is flipped before splitting (the 2020-2024 owl.h
//     convention for raw Pi-camera frames, whose halves are mirrored and whose columns 0-639
//     are the RIGHT eye).
// swap: exchange the eyes after everything else.
// Pairs are sorted by the number in their key (natural order), then by key.
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/detector.h"
#include "calib/observation.h"
#include "calib/target.h"

namespace owlcal::calib {

// Largest image file read, in pixels: 50 megapixels is beyond any camera the suite serves (the
// Owl's frames are 1280x480) and bounds what one file costs to detect in.
inline constexpr int64_t kMaxImagePixels = 50'000'000;

struct ImagePairOptions {
  bool side_by_side = false;
  bool mirror = false;
  bool swap = false;
  int64_t max_pixels = kMaxImagePixels;  // a larger image is refused, naming the file
};

struct ImagePair {
  std::string key;        // "0", "30cm", or the frame's file stem
  std::string left_path;  // side_by_side: both paths are the frame
  std::string right_path;
};

struct ImagePairList {
  std::vector<ImagePair> pairs;
  std::vector<std::string> unpaired;  // files with no partner
};

// Lists the pairs in `dir`. Throws naming the folder if it cannot be read or holds no pair.
ImagePairList ListImagePairs(const std::string& dir, const ImagePairOptions& options);

// Loads one pair as BGR images of one eye each, applying mirror / swap. Throws naming the
// file when it cannot be decoded, or when a side-by-side frame's width is odd.
void LoadImagePair(const ImagePair& pair, const ImagePairOptions& options, cv::Mat* left, cv::Mat* right);

// Detection of a target in every pair: frame_index = position in `list.pairs`, eye 0 = left.
struct PairDetection {
  std::string key;
  bool found[2] = {false, false};
  std::string message[2];  // why not found
};
struct DetectedImageSet {
  std::vector<CornerObservation> observations;
  std::vector<PairDetection> pairs;
  int width = 0, height = 0;  // image size of one eye (all images must agree)
};
// Throws naming the file when an image cannot be read or its size differs from the first.
DetectedImageSet DetectImagePairs(const ImagePairList& list,
                                  const ImagePairOptions& options,
                                  const TargetDefinition& target,
                                  const DetectorOptions& detector);

}  // namespace owlcal::calib
