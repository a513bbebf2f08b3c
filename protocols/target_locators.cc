#include "protocols/target_locator.h"

#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "io/number_text.h"
#include "models/head_model.h"

namespace owlcal::protocols {
namespace {

class FixationLocator : public TargetLocator {
 public:
  explicit FixationLocator(const calib::FixationDetectorOptions& o) : options_(o) {}
  bool Prepare(const robot::StereoFrame&, std::string*) override {
    has_last_[0] = has_last_[1] = false;
    found_[0] = found_[1] = false;
    return true;
  }
  std::optional<double> LastRadiusPx(int eye) const override {
    if (!found_[eye]) return std::nullopt;
    return last_radius_[eye];
  }
  // Tracks: near the last position first (a textured background has dark spots that can
  // outscore a small, distant disc), the whole image when it is not there.
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int eye) override {
    const auto p = Find(image, eye);
    found_[eye] = p.has_value();
    return p;
  }
  // Tracks from px next: the blob of the last find's radius (else the size hint) closest to px,
  // or with no radius known the best blob, within the windows around px.
  void Expect(int eye, const Eigen::Vector2d& px) override {
    has_last_[eye] = true;
    last_[eye] = px;
    if (!(last_radius_[eye] > 0)) last_radius_[eye] = std::max(0.0, options_.size_hint_px);
  }
  std::string Name() const override { return "fixation"; }

 private:
  std::optional<Eigen::Vector2d> Find(const cv::Mat& image, int eye) {
    if (has_last_[eye]) {
      // Two windows around the last position; never jump to a far blob once tracking.
      for (int scale : {1, 2}) {
        const int half = scale * std::max(30, int(5 * last_radius_[eye]));
        const cv::Rect roi = cv::Rect(int(last_[eye].x()) - half, int(last_[eye].y()) - half, 2 * half, 2 * half) &
                             cv::Rect(0, 0, image.cols, image.rows);
        if (roi.width <= 8 || roi.height <= 8) continue;
        calib::FixationDetectorOptions o = options_;
        o.border_px = 0;
        o.expected_px = last_[eye] - Eigen::Vector2d(roi.x, roi.y);
        o.expected_radius_px = last_radius_[eye];
        // The disc may shrink to half its last size (it is moved away, or blurs into a smaller
        // thresholded blob while it moves); a far disc found at 3.1 px must not be lost at 2.9.
        if (o.size_hint_px <= 0 && last_radius_[eye] > 0)
          o.min_radius_px = std::min(o.min_radius_px, std::max(1.0, 0.5 * last_radius_[eye]));
        // The disc keeps its contrast; a background spot that a blurred, fast-moving disc
        // leaves alone in the window has far less (the sim's texture: ~0.35 of black-white).
        o.min_contrast = std::max(options_.min_contrast, 0.6 * last_contrast_[eye]);
        const calib::FixationDetection d = calib::DetectFixationTarget(image(roi), o);
        if (d.found) {
          last_[eye] = d.centre + Eigen::Vector2d(roi.x, roi.y);
          last_radius_[eye] = d.radius_px;
          last_contrast_[eye] = d.contrast;
          return last_[eye];
        }
      }
      return std::nullopt;
    }
    const calib::FixationDetection d = calib::DetectFixationTarget(image, options_);
    if (!d.found) return std::nullopt;
    has_last_[eye] = true;
    last_[eye] = d.centre;
    last_radius_[eye] = d.radius_px;
    last_contrast_[eye] = d.contrast;
    return d.centre;
  }

  calib::FixationDetectorOptions options_;
  bool has_last_[2] = {false, false};
  bool found_[2] = {false, false};
  Eigen::Vector2d last_[2];
  double last_radius_[2] = {0, 0};
  double last_contrast_[2] = {0, 0};
};

class TemplateLocator : public TargetLocator {
 public:
  TemplateLocator(int half, double min_score) : half_(half), min_score_(min_score) {}
  bool Prepare(const robot::StereoFrame& frame, std::string* why) override {
    const cv::Mat& img = frame.right;
    if (img.empty()) {
      if (why) *why = "template locator: the first frame has no right image";
      return false;
    }
    templ_ = calib::CutTemplate(img, ImageCentre(img), half_);
    cv::Scalar mean, sd;
    cv::meanStdDev(templ_, mean, sd);
    if (sd[0] < 5) {
      if (why) *why = "template locator: the right eye's centre has no texture (grey sd " + std::to_string(sd[0]) + ")";
      return false;
    }
    return true;
  }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int) override {
    if (templ_.empty()) return std::nullopt;
    const calib::TemplateMatch m = calib::MatchTemplateNcc(image, templ_, min_score_);
    if (!m.found) return std::nullopt;
    return m.centre;
  }
  std::string Name() const override { return "template"; }

 private:
  int half_;
  double min_score_;
  cv::Mat templ_;
};

class BoardLocator : public TargetLocator {
 public:
  explicit BoardLocator(const calib::TargetDefinition& t) : target_(t), corners_(t.Corners()) {
    const Eigen::Vector4d e = t.Extent();
    centre_ = cv::Point2d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2);
  }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int) override {
    calib::DetectorOptions opt;
    opt.fast_check = true;
    const calib::TargetDetection d = calib::DetectTarget(image, target_, opt);
    if (!d.found || d.pixels.size() < 4) return std::nullopt;
    std::vector<cv::Point2d> board, pix;
    for (size_t i = 0; i < d.corner_ids.size(); ++i) {
      auto it = corners_.find(d.corner_ids[i]);
      if (it == corners_.end()) continue;
      board.emplace_back(it->second.x(), it->second.y());
      pix.emplace_back(d.pixels[i].x(), d.pixels[i].y());
    }
    if (board.size() < 4) return std::nullopt;
    const cv::Mat h = cv::findHomography(board, pix);
    if (h.empty()) return std::nullopt;
    std::vector<cv::Point2d> in = {centre_}, out;
    cv::perspectiveTransform(in, out, h);
    return Eigen::Vector2d(out[0].x, out[0].y);
  }
  std::string Name() const override { return "board"; }

 private:
  calib::TargetDefinition target_;
  std::map<int, Eigen::Vector3d> corners_;
  cv::Point2d centre_;
};

class PixelLocator : public TargetLocator {
 public:
  explicit PixelLocator(const std::array<std::optional<Eigen::Vector2d>, 2>& px) : px_(px) {}
  std::optional<Eigen::Vector2d> Locate(const cv::Mat&, int eye) override { return px_[eye]; }
  std::string LastReason(int eye) const override { return px_[eye] ? "" : "no seed pixel in this eye"; }
  std::string Name() const override { return "pixel"; }

 private:
  std::array<std::optional<Eigen::Vector2d>, 2> px_;
};

class LkLocator : public TargetLocator {
 public:
  LkLocator(std::function<std::unique_ptr<TargetLocator>()> make_seed, const calib::LkTrackerOptions& o, bool reacquire)
      : make_seed_(std::move(make_seed)), options_(o), reacquire_(reacquire) {}
  bool Prepare(const robot::StereoFrame& frame, std::string* why) override {
    std::unique_ptr<TargetLocator> seed = make_seed_();
    if (!seed->Prepare(frame, why)) return false;
    seed_name_ = seed->Name();
    for (int e = 0; e < 2; ++e) {
      first_[e] = cv::Mat();
      const cv::Mat& img = e == models::kLeftEye ? frame.left : frame.right;
      if (!Start(*seed, img, e, "")) lost_base_[e] = reason_[e];
    }
    return true;
  }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& image, int eye) override {
    // The frame the track started on: the seed's position.
    if (tracker_[eye].tracking() && image.data == start_[eye].data) {
      reason_[eye].clear();
      return tracker_[eye].position();
    }
    std::string lost;
    if (tracker_[eye].tracking()) {
      const calib::LkUpdate u = tracker_[eye].Track(image);
      if (u.ok) {
        reason_[eye].clear();
        start_[eye] = cv::Mat();
        return u.px;
      }
      lost = lost_base_[eye] = u.reason;
    } else {
      lost = "lost earlier: " + lost_base_[eye];
    }
    if (reacquire_) {
      std::unique_ptr<TargetLocator> seed = make_seed_();
      robot::StereoFrame alone;
      alone.left = image;
      alone.right = image;
      const bool prepared = seed->Prepare(alone, nullptr);
      if (prepared && expect_[eye]) seed->Expect(eye, *expect_[eye]);
      expect_[eye].reset();
      if (prepared && Start(*seed, image, eye, lost)) return tracker_[eye].position();
      lost += "; not reacquired: " + reason_[eye];
    }
    reason_[eye] = lost;
    return std::nullopt;
  }
  std::string LastReason(int eye) const override { return reason_[eye]; }
  // The seed's radius of the target where the track last (re)started; nullopt while lost.
  std::optional<double> LastRadiusPx(int eye) const override {
    if (!reason_[eye].empty() && reason_[eye].rfind("reacquired", 0) != 0) return std::nullopt;
    return radius_[eye] > 0 ? std::optional<double>(radius_[eye]) : std::nullopt;
  }
  // A lost track's next reacquisition asks the seed there first (a tracking track ignores it).
  void Expect(int eye, const Eigen::Vector2d& px) override {
    if (!tracker_[eye].tracking()) expect_[eye] = px;
  }
  std::string Name() const override { return "lk"; }

 private:
  // Starts eye's track where the seed finds the target; `after` = why the old one was lost.
  bool Start(TargetLocator& seed, const cv::Mat& img, int eye, const std::string& after) {
    if (after.empty()) tracker_[eye] = calib::LkTracker(options_);
    start_[eye] = cv::Mat();
    const std::optional<Eigen::Vector2d> p = img.empty() ? std::nullopt : seed.Locate(img, eye);
    if (!p) {
      const std::string r = seed.LastReason(eye);
      reason_[eye] = "the " + seed_name_ + " seed did not find the target" + (r.empty() ? "" : " (" + r + ")");
      return false;
    }
    // A reacquired target must look like the one the track started on (the seed's whole-image
    // search finds disc-like blobs on a textured wall when the target is out of view).
    if (!after.empty() && !first_[eye].empty()) {
      const double ncc = calib::PatchNcc(first_[eye], first_px_[eye], img, *p, options_.reacquire_window_px);
      if (ncc < options_.min_reacquire_ncc) {
        reason_[eye] = "the " + seed_name_ + " seed found a blob at (" + io::FixedText(p->x(), 1) + ", " +
                       io::FixedText(p->y(), 1) + ") that does not look like the target (NCC " + io::FixedText(ncc, 2) +
                       ")";
        return false;
      }
    }
    if (const std::optional<double> r = seed.LastRadiusPx(eye)) radius_[eye] = *r;
    std::string why;
    const bool resume = !after.empty() && !first_[eye].empty();
    if (!(resume ? tracker_[eye].Resume(img, *p, &why) : tracker_[eye].Start(img, *p, &why))) {
      reason_[eye] = why;
      return false;
    }
    start_[eye] = img;
    if (after.empty()) {
      first_[eye] = img;
      first_px_[eye] = *p;
    }
    reason_[eye] = after.empty() ? "" : "reacquired by the " + seed_name_ + " seed after: " + after;
    return true;
  }

  std::function<std::unique_ptr<TargetLocator>()> make_seed_;
  calib::LkTrackerOptions options_;
  bool reacquire_;
  std::string seed_name_ = "seed";
  calib::LkTracker tracker_[2];
  cv::Mat start_[2];  // the image each track started on (its seed position is the answer there)
  cv::Mat first_[2];  // the image and position of the first start since Prepare (the target's look)
  Eigen::Vector2d first_px_[2];
  std::string reason_[2] = {"not prepared", "not prepared"};
  std::string lost_base_[2] = {"not prepared", "not prepared"};  // why the track was (last) lost
  std::optional<Eigen::Vector2d> expect_[2];                     // Expect's hint for a reacquisition
  double radius_[2] = {0, 0};
};

}  // namespace

std::unique_ptr<TargetLocator> MakeFixationLocator(const calib::FixationDetectorOptions& options) {
  return std::make_unique<FixationLocator>(options);
}
std::unique_ptr<TargetLocator> MakeTemplateLocator(int half_size, double min_score) {
  return std::make_unique<TemplateLocator>(half_size, min_score);
}
std::unique_ptr<TargetLocator> MakeBoardLocator(const calib::TargetDefinition& target) {
  return std::make_unique<BoardLocator>(target);
}
std::unique_ptr<TargetLocator> MakeLkLocator(std::function<std::unique_ptr<TargetLocator>()> make_seed,
                                             const calib::LkTrackerOptions& options,
                                             bool reacquire) {
  return std::make_unique<LkLocator>(std::move(make_seed), options, reacquire);
}
std::unique_ptr<TargetLocator> MakePixelLocator(const std::array<std::optional<Eigen::Vector2d>, 2>& px) {
  return std::make_unique<PixelLocator>(px);
}

}  // namespace owlcal::protocols
