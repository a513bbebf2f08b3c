// Detection time per 640x480 image for each detector (classic chessboard, classic with
// FAST_CHECK on an image without a board, findChessboardCornersSB, AprilTag decimate 1/2).
// Prints figures; asserts nothing.
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

#include "calib/detector.h"
#include "owlcal_version.h"

using namespace owlcal;

namespace {

double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// A 6x6 tag36h11 AprilGrid (ids 0..35, spacing 0.3) rendered into a 640x480 image, slightly tilted.
cv::Mat AprilGridImage() {
  apriltag_family_t* tf = tag36h11_create();
  const int cell = 4;                                                   // px per tag bit at the board scale
  const int tag_px = 10 * cell, pitch = int(tag_px * 1.3 * 0.8 + 0.5);  // tags incl. white rim; gap 0.3*8 cells
  cv::Mat board(6 * pitch + 40, 6 * pitch + 40, CV_8U, cv::Scalar(255));
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      image_u8_t* im = apriltag_to_image(tf, r * 6 + c);
      cv::Mat t(im->height, im->width, CV_8U);
      for (int y = 0; y < im->height; ++y)
        for (int x = 0; x < im->width; ++x) t.at<uint8_t>(y, x) = im->buf[y * im->stride + x];
      free(im->buf);
      free(im);
      cv::Mat big;
      cv::resize(t, big, cv::Size(tag_px, tag_px), 0, 0, cv::INTER_NEAREST);
      big.copyTo(board(cv::Rect(20 + c * pitch, 20 + r * pitch, tag_px, tag_px)));
    }
  tag36h11_destroy(tf);
  const std::vector<cv::Point2f> src = {
      {0, 0}, {float(board.cols), 0}, {float(board.cols), float(board.rows)}, {0, float(board.rows)}};
  const std::vector<cv::Point2f> dst = {{150, 40}, {520, 70}, {500, 440}, {130, 420}};
  cv::Mat img;
  cv::warpPerspective(board,
                      img,
                      cv::getPerspectiveTransform(src, dst),
                      cv::Size(640, 480),
                      cv::INTER_AREA,
                      cv::BORDER_CONSTANT,
                      cv::Scalar(200));
  return img;
}

void Time(const char* name,
          const std::vector<cv::Mat>& images,
          const calib::TargetDefinition& t,
          const calib::DetectorOptions& o) {
  int found = 0;
  const double t0 = Now();
  for (const cv::Mat& img : images) found += calib::DetectTarget(img, t, o).found;
  const double ms = 1e3 * (Now() - t0) / images.size();
  std::printf("  %-42s %8.2f ms/image  (found %d of %zu)\n", name, ms, found, images.size());
}

}  // namespace

int main() {
  const std::string dir = std::string(OWLCAL_DATA_DIR) + "/opencv-stereo-chessboard/";
  std::vector<cv::Mat> boards;
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char name[32];
    std::snprintf(name, sizeof(name), "left%02d.jpg", i);
    const cv::Mat img = cv::imread(dir + name, cv::IMREAD_GRAYSCALE);
    if (!img.empty()) boards.push_back(img);
  }
  if (boards.empty()) {
    std::printf("detect_bench: no images in %s\n", dir.c_str());
    return 1;
  }
  cv::Mat noise(480, 640, CV_8U);
  cv::randu(noise, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(9, 9), 3);
  const std::vector<cv::Mat> empty(5, noise);
  std::printf("detect_bench: 640x480 images (OpenCV sample left*.jpg, 9x6 chessboard)\n");
  calib::TargetDefinition chess;
  calib::DetectorOptions classic, fast, sb;
  fast.fast_check = true;
  sb.chessboard_method = calib::ChessboardMethod::kSectorBased;
  Time("chessboard classic + cornerSubPix(5x5)", boards, chess, classic);
  Time("chessboard sb", boards, chess, sb);
  Time("chessboard classic, NO board in image", empty, chess, classic);
  Time("chessboard classic + FAST_CHECK, NO board", empty, chess, fast);
  calib::TargetDefinition grid;
  grid.kind = calib::TargetKind::kAprilGrid;
  const std::vector<cv::Mat> tags(10, AprilGridImage());
  calib::DetectorOptions d1, d2;
  d1.apriltag_decimate = 1;
  Time("aprilgrid 6x6 decimate 2 (refine_edges)", tags, grid, d2);
  Time("aprilgrid 6x6 decimate 1 (refine_edges)", tags, grid, d1);
  const auto det = calib::DetectTarget(tags[0], grid, d2);
  std::printf("  aprilgrid: %zu corners (%s)\n", det.pixels.size(), det.message.c_str());
  return 0;
}
