#pragma once
// Dense stereo depth, the course's stereo_match exercise done with a calibration: rectify a raw
// pair (evaluation/range_images_ranging.h: RectifyRig, CALIB_ZERO_DISPARITY), compute the disparity
// with OpenCV's StereoSGBM, and turn it into depth and a point cloud.
//
// Frames and units: everything is in the LEFT RECTIFIED camera frame (OpenCV's
// reprojectImageTo3D with Q: x right, y down, z forward; the raw left camera is R1^T of it),
// metres. Disparity d = x_left - x_right [px] in the rectified images; OpenCV's fixed-point map
// holds 16 d (CV_16S, "16-bit disparity", what the course's students read off). Depth
// Z = f B / d with f the rectified focal length and B = |T| (CALIB_ZERO_DISPARITY puts both
// principal points on the same column, so no offset term). Invalid pixels are NaN.
//
// Depth at a region (DepthAtRoi): the median disparity of the valid pixels in the ROI, turned
// into depth by triangulating the ROI centre through the raw cameras
// (evaluation::TriangulateRectified, which also gives the calibration's share of sigma). Its
// sigma combines
//   matching: sigma_d = hypot(1.2533 s / sqrt(N_eff), subpixel_floor_px), where s is the
//     robust (1.4826 MAD) scatter of the disparities about a plane fitted to the ROI (a tilted
//     surface is not noise), N_eff = valid pixels / block_size^2 (neighbouring disparities
//     share their matching windows), 1.2533 the median's efficiency; sigma_Z = Z / d sigma_d;
//   calibration: J C J^T over the rig's covariance (NaN for a rig without one, e.g. an OpenCV file).
// A ROI with less than `min_valid_fraction` valid pixels is refused (ok = false, message).
//
// Usage:
//   const fitting::StereoRig rig = fitting::LoadStereoRig("kit-cal/results.json");
//   const fitting::Rectification rect = fitting::RectifyRig(rig, options.rectify_alpha);
//   evaluation::DepthMaps maps = evaluation::ComputeDepth(left, right, rect, options);
//   evaluation::RoiDepth d = evaluation::DepthAtRoi(maps, cv::Rect(288, 216, 64, 48), rig, rect, options);
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "evaluation/range_images_ranging.h"

namespace owlcal::evaluation {

// cv::StereoSGBM's parameters. Defaults for 640x480 Owl frames: 192 disparities reach down to
// ~0.2 m at f ~ 580 px, B ~ 65 mm (d = f B / Z = 126 px at 0.3 m); a 7 px block; P1, P2 as in
// OpenCV's stereo_match sample (8 and 32 x channels x block^2).
struct SgbmOptions {
  int min_disparity = 0;
  int num_disparities = 192;  // > 0, multiple of 16
  int block_size = 7;         // odd, 1..31
  int p1 = 0, p2 = 0;         // 0 = 8 / 32 * block_size^2 (grey images)
  int disp12_max_diff = 1;    // left-right check [px]; < 0 disables it
  int pre_filter_cap = 63;
  int uniqueness_ratio = 10;  // [%]
  int speckle_window_size = 100;
  int speckle_range = 2;      // [px]: OpenCV multiplies it by 16 internally
  std::string mode = "sgbm";  // sgbm (5 directions), hh (8 directions), 3way, hh4

  bool Check(std::string* why) const;
  int P1() const { return p1 > 0 ? p1 : 8 * block_size * block_size; }
  int P2() const { return p2 > 0 ? p2 : 32 * block_size * block_size; }
};

struct DepthOptions {
  SgbmOptions sgbm;
  double rectify_alpha = -1;        // cv::stereoRectify alpha (-1: OpenCV's default, as range-images)
  double subpixel_floor_px = 0.1;   // SGBM's sub-pixel bias ("pixel locking")
  double min_valid_fraction = 0.3;  // of a ROI's pixels, else DepthAtRoi refuses
  double max_depth_m = 20;          // farther points are left out of the point cloud

  bool Check(std::string* why) const;
};

struct DepthMaps {
  cv::Mat left_rect, right_rect;  // rectified grey images (CV_8U)
  cv::Mat disparity16;            // CV_16S, 16 d as StereoSGBM returns it; invalid = (min_disparity - 1) * 16
  cv::Mat disparity_px;           // CV_32F d, NaN where invalid
  cv::Mat depth_m;                // CV_32F Z, NaN where invalid
  double focal_px = 0, baseline_m = 0;
  double cx = 0, cy = 0;  // rectified principal point of the left image
  int num_valid = 0;
};

// Rectifies and matches one raw pair (8-bit grey or BGR, the calibration's image size).
// Throws std::invalid_argument for empty images, a size other than the rectification's, or
// options failing Check.
DepthMaps ComputeDepth(const cv::Mat& left_raw,
                       const cv::Mat& right_raw,
                       const fitting::Rectification& rect,
                       const DepthOptions& options);

// StereoSGBM on an already rectified pair (8-bit grey or BGR): the CV_16S map of 16 d.
cv::Mat SgbmDisparity16(const cv::Mat& left_rect, const cv::Mat& right_rect, const SgbmOptions& options);

// A second matcher's opinion of one template's disparity: of the valid pixels of `roi` in the
// 16-bit map, the share within tolerance_px of disparity_px, and their median [px].
struct RoiAgreement {
  int num_pixels = 0, num_valid = 0;
  double agreeing_fraction = std::numeric_limits<double>::quiet_NaN();
  double median_px = std::numeric_limits<double>::quiet_NaN();
  double valid_fraction() const { return num_pixels ? double(num_valid) / num_pixels : 0.0; }
};
RoiAgreement DisparityAgreement(const cv::Mat& disparity16,
                                const SgbmOptions& options,
                                const cv::Rect& roi,
                                double disparity_px,
                                double tolerance_px);

struct RoiDepth {
  bool ok = false;
  std::string message;  // why not
  cv::Rect roi;         // as used (clipped to the image)
  int num_pixels = 0, num_valid = 0;
  double disparity_px = 0;        // median
  double disparity16 = 0;         // median of the 16-bit map (the students' number)
  double scatter_px = 0;          // robust scatter about the ROI's plane
  double sigma_disparity_px = 0;  // of the median (see above)
  double depth_m = 0;             // at the ROI centre, median disparity
  double sigma_match_m = 0, sigma_calib_m = std::numeric_limits<double>::quiet_NaN(), sigma_m = 0;
  double valid_fraction() const { return num_pixels ? double(num_valid) / num_pixels : 0.0; }
};

RoiDepth DepthAtRoi(const DepthMaps& maps,
                    const cv::Rect& roi,
                    const fitting::StereoRig& rig,
                    const fitting::Rectification& rect,
                    const DepthOptions& options);

// The truth depth of the raw LEFT camera (camera z [m], e.g. the virtual Owl's renderer) as a
// depth map in the left rectified frame, on the rectified pixel grid (nearest neighbour; NaN
// where the rectified pixel has no raw pixel or no truth).
cv::Mat RectifyTruthDepth(const fitting::Rectification& rect, const cv::Mat& depth_z_raw_left);

// Colour images for people: disparity (TURBO over [min, min + num) px) and depth (TURBO over
// [near, far] m, nearer = warmer); invalid pixels black.
cv::Mat ColourDisparity(const DepthMaps& maps, const SgbmOptions& sgbm);
cv::Mat ColourDepth(const cv::Mat& depth_m, double near_m, double far_m);
// Depth in millimetres as CV_16U (0 = invalid, clipped at 65535), for 16-bit PNGs.
cv::Mat DepthMillimetres16(const cv::Mat& depth_m);

// The students' measure: the 16-bit disparity at the target times the true distance is
// (ideally) constant, K = 16 f B. Fitted as the mean of the products; each distance is then
// estimated as K / disp16 (and, honestly, leave-one-out: K from the other rows).
struct DisparityConstantFit {
  int num_rows = 0;
  double k_disp16_m = 0;                           // mean of disp16 * distance [16 px * m]
  double k_cv_pct = 0;                             // coefficient of variation of the products [%]
  double k_calibration = 0;                        // 16 f B from the calibration, for comparison
  std::vector<double> estimate_m, loo_estimate_m;  // per row (NaN when the row had no disparity)
  double mean_abs_pct = 0, max_abs_pct = 0, loo_mean_abs_pct = 0;
};
DisparityConstantFit FitDisparityConstant(const std::vector<double>& disparity16,
                                          const std::vector<double>& true_m,
                                          double focal_px,
                                          double baseline_m);

// One pair of `owlcal depth`: where it came from, its true distance (NaN unknown), the depth at
// its ROI and, with a true distance, range-images' template ranging on the same ROI.
struct DepthPairResult {
  std::string name, left_path, right_path;  // left == right: one side-by-side frame
  double true_m = std::numeric_limits<double>::quiet_NaN();
  cv::Rect roi;  // requested (empty: 64 x 48 px at the image centre)
  RoiDepth depth;
  std::optional<RangeMeasurement> templ;  // with a true distance only
  double valid_fraction_image = 0;        // pixels with a depth
  int points = 0;                         // written to cloud.ply
};

}  // namespace owlcal::evaluation
