#include "protocols/alignment_step.h"

#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "protocols/image_motion.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

void RunAlignmentStep(RunContext& run, const Protocol& p, const AlignmentStep& s) {
  run.Send(run.config().Centre());
  run.Settle(s.settle);
  const calib::TargetDefinition* def = nullptr;
  if (auto it = p.targets.find(p.target); it != p.targets.end()) def = &it->second;
  for (int i = 0; i < s.frames; ++i) {
    robot::StereoFrame f = run.Grab();
    const int64_t index = run.Record(f);
    std::string method = "phase-correlation";
    double roll = NAN, dy = NAN, dx = NAN;
    int corners = 0;
    if (def && def->kind == calib::TargetKind::kChessboard) {
      std::vector<cv::Point2f> c[2];
      bool ok = true;
      for (int e = 0; e < 2 && ok; ++e) {
        cv::Mat grey;
        cv::cvtColor(e == 0 ? f.left : f.right, grey, cv::COLOR_BGR2GRAY);
        ok = cv::findChessboardCorners(
            grey,
            cv::Size(def->cols, def->rows),
            c[e],
            cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK);
        if (ok)
          cv::cornerSubPix(grey,
                           c[e],
                           cv::Size(5, 5),
                           cv::Size(-1, -1),
                           cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.01));
      }
      if (ok) {
        method = "chessboard";
        corners = int(c[0].size());
        double ang[2];
        for (int e = 0; e < 2; ++e) {
          // Mean direction of the rows (first -> last corner of each row).
          double sx = 0, sy = 0;
          for (int r = 0; r < def->rows; ++r) {
            const cv::Point2f a = c[e][r * def->cols], b = c[e][r * def->cols + def->cols - 1];
            sx += b.x - a.x;
            sy += b.y - a.y;
          }
          ang[e] = std::atan2(sy, sx) * 180.0 / M_PI;
        }
        roll = ang[0] - ang[1];
        double sdx = 0, sdy = 0;
        for (size_t k = 0; k < c[0].size(); ++k) {
          sdx += c[0][k].x - c[1][k].x;
          sdy += c[0][k].y - c[1][k].y;
        }
        dx = sdx / c[0].size();
        dy = sdy / c[0].size();
      }
    }
    if (method != "chessboard") {
      const Shift sh = ThumbShift(MotionThumb(f.right, 2), MotionThumb(f.left, 2), 2);
      dx = sh.px.x();
      dy = sh.px.y();
    }
    run.writer().AppendRow("alignment.csv",
                           "step_index,frame_index,method,roll_deg,vertical_offset_px,horizontal_offset_px,corners",
                           {std::to_string(run.step_index()),
                            std::to_string(index),
                            method,
                            calib::CsvFixed(roll, 4),
                            calib::CsvFixed(dy, 3),
                            calib::CsvFixed(dx, 3),
                            std::to_string(corners)});
    if (run.options().progress && i == 0)
      *run.options().progress << "  alignment (" << method << "): roll " << FixedText(roll, 3)
                              << " deg, vertical offset " << FixedText(dy, 2) << " px (left - right)\n";
  }
}

}  // namespace owlcal::protocols
