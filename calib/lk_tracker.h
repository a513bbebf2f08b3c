#pragma once
// A Lucas-Kanade point tracker (course notes, "Feature and object motion" and Annex 7's
// LKdemo.cpp: OpenCV's pyramidal calcOpticalFlowPyrLK, Bouguet 2001) that follows one target
// point from frame to frame and says, every frame, whether it still has it.
//
// Each Track(image):
//   1. Frame to frame: pyramidal LK moves the point from the previous image to this one
//      (window_px square, pyramid_levels levels; the course's demo uses 31 px and 3 levels).
//   2. Forward-backward check (Kalal et al. 2010): the point is tracked back from this image to
//      the previous one; the track is kept only when it comes back within max_fb_error_px.
//   3. Against the reference: the point is refined by LK from the track's first image (the
//      template at Start) to this one, started at step 1's position, so the position does not
//      drift as a random walk of frame-to-frame errors; a refinement that moves it by more than
//      max_refine_px is not used (the target changed its look) and step 1's position stands.
//   4. Appearance: the normalised correlation between the reference patch and this image's patch
//      at the new position must be at least min_ncc (an occluder or a jump to the background
//      drops it).
//   5. The point (with a margin of half the window) must lie inside the image.
// A failed check loses the track: Track returns ok = false with the reason, position() keeps
// the last good position for the record only, and every later Track says "lost" until Start is
// called again. A lost track never gives a position.
//
// Pixels in OpenCV's convention (docs/conventions.md): (0,0) is the centre of the top-left pixel.
//
// Usage:
// Resume restarts a lost track from another detector's position with the same reference.
//
//   calib::LkTracker lk;
//   if (lk.Start(first_grey, seed_px, &why))
//     for (const cv::Mat& img : frames) { auto u = lk.Track(img); if (!u.ok) log(u.reason); }
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace owlcal::calib {

struct LkTrackerOptions {
  // LK window (odd). The course's LKdemo uses 31; on the virtual Owl's disc (radius 7 px at 1 m on
  // a 30 px card) a 31 px window takes in the wall around the card, which slides against the card
  // as the eye turns (the camera sits ahead of the pan axis) and pulled the track by 0.12-0.28 px
  // RMS; 21 px keeps it within 0.02-0.035 px (tests/pipeline/tracking_study_test.cc).
  int window_px = 21;
  int pyramid_levels = 3;
  double max_fb_error_px = 0.5;  // forward-backward error that still counts as tracked
  double max_refine_px = 2.0;    // largest correction the reference refinement may make
  double min_ncc = 0.6;          // reference patch against the tracked patch
  // A target found again after a lost track (protocols/fixation.h MakeLkLocator) must match the
  // first reference patch at least this well: a dark blob of the wall scores 0.6-0.8 against a disc.
  double min_reacquire_ncc = 0.85;
  int reacquire_window_px = 41;  // the patch compared there (odd): with the target's surround
  double min_texture = 4.0;      // grey-level standard deviation of the patch at Start

  bool Check(std::string* why) const;
};

struct LkUpdate {
  bool ok = false;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  // valid when ok
  double fb_error_px = -1;                       // forward-backward error (-1: not measured)
  double ncc = -1;                               // appearance score (-1: not measured)
  std::string reason;                            // why the track is lost (empty when ok)
};

// Normalised cross-correlation (-1..1; 0 when either is flat) of the window_px square patches of
// two images (8-bit grey or BGR) centred on pa and pb (sub-pixel): the tracker's appearance check.
double PatchNcc(
    const cv::Mat& a, const Eigen::Vector2d& pa, const cv::Mat& b, const Eigen::Vector2d& pb, int window_px);

class LkTracker {
 public:
  explicit LkTracker(const LkTrackerOptions& options = {}) : options_(options) {}
  // Starts a track at px in image (8-bit grey or BGR). False (and why) when the point is too
  // close to the border or its patch has no texture to track.
  bool Start(const cv::Mat& image, const Eigen::Vector2d& px, std::string* why);
  // Restarts a lost track at px in image, keeping the reference (the image and point of the last
  // Start): the target found again by some detector is refined against its first look at once and
  // at every later frame, so a detector's offset on a blurred frame does not stay in the track.
  // False (and why) as Start, or when there is no reference (call Start).
  bool Resume(const cv::Mat& image, const Eigen::Vector2d& px, std::string* why);
  // Tracks into the next image; see the header comment.
  LkUpdate Track(const cv::Mat& image);
  bool tracking() const { return tracking_; }
  void Stop(const std::string& reason);
  const Eigen::Vector2d& position() const { return px_; }  // the last good position
  const std::string& lost_reason() const { return lost_reason_; }

 private:
  LkTrackerOptions options_;
  bool tracking_ = false;
  std::string lost_reason_ = "not started";
  cv::Mat ref_, prev_;
  Eigen::Vector2d ref_px_ = Eigen::Vector2d::Zero(), px_ = Eigen::Vector2d::Zero();
};

}  // namespace owlcal::calib
