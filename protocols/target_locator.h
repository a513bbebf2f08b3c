#pragma once
// Where a target is in an eye image: the TargetLocator interface the fixation loop
// (protocols/fixation.h) and the tracking protocols ask, and the locators that implement it.
#include <array>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/fixation_detector.h"
#include "calib/lk_tracker.h"
#include "calib/target.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

// The image's centre pixel (OpenCV convention: pixel centres at integers), where a fixated target
// is held.
inline Eigen::Vector2d ImageCentre(const cv::Mat& img) { return {(img.cols - 1) / 2.0, (img.rows - 1) / 2.0}; }

// Where is the target in one eye image (pixels, OpenCV convention)?
class TargetLocator {
 public:
  virtual ~TargetLocator() = default;
  // Called with the first frame of a loop (e.g. to cut a template); false = cannot start.
  virtual bool Prepare(const robot::StereoFrame& frame, std::string* why) {
    (void)frame;
    (void)why;
    return true;
  }
  virtual std::optional<Eigen::Vector2d> Locate(const cv::Mat& eye_image, int eye) = 0;
  // The apparent radius [px] of what the last Locate in this eye found (the fixation disc's
  // equivalent radius sqrt(area / pi)); nullopt when it found nothing or the locator does not
  // measure size. Ranging checks it against the target's known size (evaluation/ranging_eval.h).
  virtual std::optional<double> LastRadiusPx(int eye) const {
    (void)eye;
    return std::nullopt;
  }
  // Why the last Locate in this eye found nothing ("" when it found the target, or when the
  // locator does not say).
  virtual std::string LastReason(int eye) const {
    (void)eye;
    return "";
  }
  // A hint: the target is expected near px in this eye's next image (where the target is
  // predicted, or where another search found it). Locators that track from their last position
  // search there next; the others ignore it.
  virtual void Expect(int eye, const Eigen::Vector2d& px) {
    (void)eye;
    (void)px;
  }
  virtual std::string Name() const = 0;
};

// Fixation disc/blob (calib/fixation_detector.h).
std::unique_ptr<TargetLocator> MakeFixationLocator(const calib::FixationDetectorOptions& options = {});
// Template cut from the centre of the right eye's image at Prepare (the course's Owl-1 demo:
// the right eye looks at the target, the template is found in both eyes by NCC).
std::unique_ptr<TargetLocator> MakeTemplateLocator(int half_size = 20, double min_score = 0.6);
// The centre of an AprilTag (or chessboard) board found by calib::DetectTarget: the board
// centre mapped through the homography fitted to the detected corners (partial views work).
std::unique_ptr<TargetLocator> MakeBoardLocator(const calib::TargetDefinition& target);
// Lucas-Kanade tracking (calib/lk_tracker.h: pyramidal LK, forward-backward check, refinement
// against the first frame, appearance check). Prepare makes a seed locator (make_seed(), e.g. the
// fixation locator), finds the target in each eye with it and starts a track there; every Locate
// tracks from that eye's previous image. A lost track returns nullopt with LastReason (never the
// stale position). With `reacquire`, a lost eye asks a fresh seed (prepared on that image alone)
// at each later Locate, the frame it is lost included, and restarts the track where the seed finds
// the target; LastReason then starts with "reacquired". Without it the eye stays lost until the
// next Prepare.
std::unique_ptr<TargetLocator> MakeLkLocator(std::function<std::unique_ptr<TargetLocator>()> make_seed,
                                             const calib::LkTrackerOptions& options = {},
                                             bool reacquire = true);
// The target's appearance checked (the LK locator's check, calib/lk_tracker.h, for any locator):
// the first position the inner locator gives in each eye (its "first look", after construction or
// ForgetLook) keeps the window_px square patch around it as the reference; every later position
// must match it with a normalised correlation of at least min_ncc, else that eye's Locate is lost
// (nullopt, LastReason saying the NCC and where). A blob of the wall, a dark image corner or a
// background spot that the inner locator finds when the target is out of view or blurred by a
// saccade scores 0.1-0.8 against the fixation disc on its card; the disc itself 0.93-0.99 across
// the image (lens shading and distortion included), so nothing but the image decides that the
// target is lost. With `reacquire`, a target the inner locator loses or mistakes is searched
// for by NCC template matching of the reference patch (min_ncc), within 4 patches of its last
// checked (or Expect-ed) position first, then over the whole image; the inner
// locator is told to expect it there (Expect) and asked again; LastReason then starts with
// "reacquired".
struct AppearanceCheckOptions {
  // The patch (odd). 0: from the first look's radius r (LastRadiusPx): the odd size nearest 3.5 r,
  // inside the fixation disc's card (side 4 r) so that the wall it moves over stays out (a 41 px
  // patch at 1 m took the wall in and the disc fell to NCC 0.79 as it moved); 41 px when the
  // locator does not measure a radius.
  int window_px = 0;
  double min_ncc = 0.85;
  bool reacquire = true;

  bool Check(std::string* why) const;
};
class AppearanceCheckedLocator : public TargetLocator {
 public:
  AppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner, const AppearanceCheckOptions& options = {});
  bool Prepare(const robot::StereoFrame& frame, std::string* why) override { return inner_->Prepare(frame, why); }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& eye_image, int eye) override;
  std::optional<double> LastRadiusPx(int eye) const override {
    return found_[eye] ? inner_->LastRadiusPx(eye) : std::nullopt;
  }
  std::string LastReason(int eye) const override { return reason_[eye]; }
  void Expect(int eye, const Eigen::Vector2d& px) override {
    inner_->Expect(eye, px);
    has_last_[eye] = true;
    last_px_[eye] = px;
  }
  std::string Name() const override { return inner_->Name(); }
  // Drops the reference: the next position found becomes the first look.
  void ForgetLook();
  bool has_look(int eye) const { return !look_[eye].empty(); }
  // The NCC of the last position checked in this eye (NaN: none checked).
  double last_ncc(int eye) const { return ncc_[eye]; }

 private:
  std::optional<Eigen::Vector2d> Checked(const cv::Mat& image,
                                         int eye,
                                         const std::optional<Eigen::Vector2d>& p,
                                         std::string* why);
  std::unique_ptr<TargetLocator> inner_;
  AppearanceCheckOptions options_;
  cv::Mat look_[2];  // grey image of the first look
  Eigen::Vector2d look_px_[2];
  int window_px_[2] = {0, 0};        // the patch size in use
  cv::Mat templ_[2];                 // window_px square around the first look (rounded), for reacquisition
  Eigen::Vector2d templ_offset_[2];  // first look minus the template's centre
  bool found_[2] = {false, false};
  bool has_last_[2] = {false, false};
  Eigen::Vector2d last_px_[2];  // the last position that passed the check, or the expected one
  double ncc_[2] = {NAN, NAN};
  std::string reason_[2];
};
std::unique_ptr<AppearanceCheckedLocator> MakeAppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner,
                                                                       const AppearanceCheckOptions& options = {});
// A seed that returns the given pixel per eye ([kLeftEye], [kRightEye]; nullopt = none in that
// eye) for a tracker to start from: MakeLkLocator(MakePixelLocator(...)) fixates a salience
// candidate.
std::unique_ptr<TargetLocator> MakePixelLocator(const std::array<std::optional<Eigen::Vector2d>, 2>& px);

}  // namespace owlcal::protocols
