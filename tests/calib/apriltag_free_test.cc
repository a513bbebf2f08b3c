// Free-standing AprilTags (calib/apriltag_free.h): every family libapriltag 3.3 ships, on
// rendered tags whose corners are known exactly (<= 0.1 px after the -0.5 px convention), on a
// photo-like composite against libapriltag called directly, and repeated ids.
#include "calib/apriltag_free.h"

#include <cstdlib>
#include <map>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "tests/shared_data.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagStandard41h12.h>
}

namespace owlcal::calib {
namespace {

// Cells of tag `id` of `family` as apriltag_to_image draws them (one pixel per cell).
cv::Mat TagCells(const std::string& family, int id) {
  apriltag_family_t* f = nullptr;
  void (*destroy)(apriltag_family_t*) = nullptr;
  if (family == "tag36h11") f = tag36h11_create(), destroy = tag36h11_destroy;
  if (family == "tag25h9") f = tag25h9_create(), destroy = tag25h9_destroy;
  if (family == "tagStandard41h12") f = tagStandard41h12_create(), destroy = tagStandard41h12_destroy;
  if (family == "tagCircle21h7") f = tagCircle21h7_create(), destroy = tagCircle21h7_destroy;
  if (!f) throw std::invalid_argument(family);
  image_u8_t* im = apriltag_to_image(f, id);
  cv::Mat cells(im->height, im->width, CV_8U);
  for (int y = 0; y < im->height; ++y)
    for (int x = 0; x < im->width; ++x) cells.at<uint8_t>(y, x) = im->buf[y * im->stride + x];
  free(im->buf);  // image_u8_destroy is not exported by Debian's libapriltag
  free(im);
  destroy(f);
  return cells;
}

// Draws `cells` into `image` (8-bit grey) through H (cell coordinates -> image coordinates with
// (0,0) at the top-left pixel's CORNER): each pixel is the mean of s x s sub-samples, so
// edges are exact area averages. Pixels outside the tag keep their value.
void DrawTag(const cv::Mat& cells, const cv::Matx33d& H, cv::Mat* image, int s = 8) {
  const cv::Matx33d Hinv = H.inv();
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (double u : {0, cells.cols})
    for (double v : {0, cells.rows}) {
      const cv::Vec3d p = H * cv::Vec3d(u, v, 1);
      x0 = std::min(x0, p[0] / p[2]), x1 = std::max(x1, p[0] / p[2]);
      y0 = std::min(y0, p[1] / p[2]), y1 = std::max(y1, p[1] / p[2]);
    }
  const int ya = std::max(0, int(y0) - 1), yb = std::min(image->rows, int(y1) + 2);
  const int xa = std::max(0, int(x0) - 1), xb = std::min(image->cols, int(x1) + 2);
  for (int y = ya; y < yb; ++y) {
    for (int x = xa; x < xb; ++x) {
      double sum = 0;
      int inside = 0;
      for (int j = 0; j < s; ++j) {
        for (int i = 0; i < s; ++i) {
          const cv::Vec3d c = Hinv * cv::Vec3d(x + (i + 0.5) / s, y + (j + 0.5) / s, 1);
          const double u = c[0] / c[2], v = c[1] / c[2];
          if (u < 0 || v < 0 || u >= cells.cols || v >= cells.rows) {
            sum += image->at<uint8_t>(y, x);
            continue;
          }
          ++inside;
          sum += cells.at<uint8_t>(static_cast<int>(v), static_cast<int>(u));
        }
      }
      if (inside) image->at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(sum / (s * s));
    }
  }
}

// Image position (OpenCV convention) of cell coordinate (u, v).
Eigen::Vector2d Expected(const cv::Matx33d& H, double u, double v) {
  const cv::Vec3d p = H * cv::Vec3d(u, v, 1);
  return Eigen::Vector2d(p[0] / p[2] - 0.5, p[1] / p[2] - 0.5);
}

// Cell -> image: `cell_px` pixels per cell, rotated, mild perspective, tag centre at (cx, cy).
cv::Matx33d TagHomography(double cell_px, double angle_deg, double cx, double cy, double persp, int total_width) {
  const double a = angle_deg * M_PI / 180, h = total_width / 2.0;
  const cv::Matx33d R(cell_px * std::cos(a),
                      -cell_px * std::sin(a),
                      0,
                      cell_px * std::sin(a),
                      cell_px * std::cos(a),
                      0,
                      persp,
                      0.3 * persp,
                      1);
  return cv::Matx33d(1, 0, cx, 0, 1, cy, 0, 0, 1) * R * cv::Matx33d(1, 0, -h, 0, 1, -h, 0, 0, 1);
}

TEST(AprilTagFree, EveryShippedFamilyIsOffered) {
  const auto names = AprilTagFamilyNames();
  EXPECT_EQ(names.size(), 9u);
  for (const char* f : {"tag36h11",
                        "tag36h10",
                        "tag25h9",
                        "tag16h5",
                        "tagCircle21h7",
                        "tagCircle49h12",
                        "tagCustom48h12",
                        "tagStandard41h12",
                        "tagStandard52h13"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), f), names.end()) << f;
    double a, b;
    int w;
    AprilTagQuadCells(f, &a, &b, &w);
    EXPECT_GT(b, a) << f;
    EXPECT_LE(b, w) << f;
  }
  double a, b;
  int w;
  AprilTagQuadCells("tag36h11", &a, &b, &w);
  EXPECT_EQ(a, 1);
  EXPECT_EQ(b, 9);
  EXPECT_EQ(w, 10);
}

TEST(AprilTagFree, OptionsNameTheBadField) {
  AprilTagOptions o;
  std::string why;
  EXPECT_TRUE(o.Check(&why)) << why;
  o.families = {"tag37h11"};
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("tag37h11"), std::string::npos) << why;
  o.families = {"tagStandard52h13"};
  o.max_hamming = 2;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("max_hamming"), std::string::npos) << why;
  o = AprilTagOptions();
  o.quad_decimate = 0.5;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("quad_decimate"), std::string::npos) << why;
  EXPECT_THROW(DetectAprilTags(cv::Mat(), AprilTagOptions()), std::invalid_argument);
}

// Renders one tag of each of four families (classic and reversed-border layouts, through
// apriltag_to_image cells) at several poses, edges along the pixel grid included, sharp and
// blurred; corners within 0.1 px of the truth after the -0.5 px convention, with the library's
// defaults (decimate 2, refine_edges) and at full resolution. The library's own corners are
// up to 0.4 px off on grid-aligned edges (what refine_corners is for).
TEST(AprilTagFree, CornersWithinATenthOfAPixelOnRenderedTags) {
  double worst = 0, worst_library = 0;
  for (const std::string family : {"tag36h11", "tag25h9", "tagStandard41h12", "tagCircle21h7"}) {
    const int id = family == "tag36h11" ? 101 : 17;
    const cv::Mat cells = TagCells(family, id);
    double first, last;
    int total;
    AprilTagQuadCells(family, &first, &last, &total);
    ASSERT_EQ(cells.cols, total);
    for (double angle : {0.0, 17.0, -33.0}) {
      for (double persp : {0.0, 0.0005}) {
        for (double blur : {0.0, 0.8}) {
          const cv::Matx33d H = TagHomography(12, angle, 163.3, 118.7, persp, total);
          cv::Mat img(240, 320, CV_8U, cv::Scalar(255));
          DrawTag(cells, H, &img);
          if (blur > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), blur);
          for (double decimate : {1.0, 2.0}) {
            AprilTagOptions o;
            o.families = {family};
            o.quad_decimate = decimate;
            const auto tags = DetectAprilTags(img, o);
            ASSERT_EQ(tags.size(), 1u) << family << " angle " << angle;
            EXPECT_EQ(tags[0].family, family);
            EXPECT_EQ(tags[0].id, id);
            EXPECT_EQ(tags[0].hamming, 0);
            EXPECT_GT(tags[0].decision_margin, 50);
            EXPECT_FALSE(tags[0].repeated_id);
            const Eigen::Vector2d expect[4] = {
                Expected(H, first, first), Expected(H, last, first), Expected(H, last, last), Expected(H, first, last)};
            EXPECT_TRUE(tags[0].corners_refined);
            for (int k = 0; k < 4; ++k) {
              const double e = (tags[0].corners[k] - expect[k]).norm();
              worst = std::max(worst, e);
              worst_library = std::max(worst_library, (tags[0].library_corners[k] - expect[k]).norm());
              EXPECT_LE(e, 0.1) << family << " corner " << k << " angle " << angle << " persp " << persp << " blur "
                                << blur << " decimate " << decimate << ": got " << tags[0].corners[k].transpose()
                                << ", expected " << expect[k].transpose();
            }
            const Eigen::Vector2d centre = Expected(H, total / 2.0, total / 2.0);
            EXPECT_LE((tags[0].centre - centre).norm(), 0.1);
          }
        }
      }
    }
  }
  std::cout << "worst corner error on rendered tags: " << worst << " px (libapriltag's own corners: " << worst_library
            << " px)\n";
}

// A photo-like composite: tags of two families, one id three times, drawn with perspective onto
// a real Owl image, blurred, noisy and JPEG-compressed. The free-standing detector must return
// exactly what libapriltag returns when called directly (same ids and margins; corners = the
// library's, reordered and shifted by -0.5 px), keep all three copies of the repeated id, and
// the grid detector must reject every copy of it.
TEST(AprilTagFree, MatchesTheRawLibraryOnAPhotoAndKeepsRepeatedIds) {
  cv::Mat img = cv::imread(test_data::SharedData() + "/owl-real/kit2020-chessboard/left3.jpg", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty());
  struct Placement {
    std::string family;
    int id;
    double cell_px, angle, cx, cy, persp;
  };
  const std::vector<Placement> placements = {
      {"tag36h11", 5, 7, 10, 80, 80, 0.001},
      {"tag36h11", 5, 5, -20, 560, 90, -0.0008},
      {"tag36h11", 5, 6, 40, 300, 420, 0.0005},
      {"tag36h11", 23, 4.5, 5, 540, 400, 0.0},
      {"tag25h9", 3, 8, -12, 120, 380, 0.0006},
  };
  for (const auto& p : placements) {
    const cv::Mat cells = TagCells(p.family, p.id);
    DrawTag(cells, TagHomography(p.cell_px, p.angle, p.cx, p.cy, p.persp, cells.cols), &img, 4);
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.7);
  std::mt19937 rng(13);
  std::normal_distribution<double> noise(0, 2.0);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(img.at<uint8_t>(y, x) + noise(rng));
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", img, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80});
  img = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);

  AprilTagOptions o;
  o.families = {"tag36h11", "tag25h9"};
  const auto tags = DetectAprilTags(img, o);
  std::map<std::pair<std::string, int>, int> count;
  for (const auto& t : tags) ++count[{t.family, t.id}];
  EXPECT_EQ((count[{"tag36h11", 5}]), 3);
  EXPECT_EQ((count[{"tag36h11", 23}]), 1);
  EXPECT_EQ((count[{"tag25h9", 3}]), 1);
  for (const auto& t : tags) {
    EXPECT_EQ(t.repeated_id, t.family == "tag36h11" && t.id == 5) << t.family << " " << t.id;
    EXPECT_EQ(t.id_count, (count[{t.family, t.id}]));
  }
  // Deterministic order: family, id, centre y, centre x.
  for (size_t i = 1; i < tags.size(); ++i) {
    const auto& a = tags[i - 1];
    const auto& b = tags[i];
    EXPECT_TRUE(a.family < b.family ||
                (a.family == b.family && (a.id < b.id || (a.id == b.id && a.centre.y() <= b.centre.y()))));
  }

  // The raw library, called directly with the same settings.
  apriltag_family_t* f36 = tag36h11_create();
  apriltag_family_t* f25 = tag25h9_create();
  apriltag_detector_t* td = apriltag_detector_create();
  apriltag_detector_add_family_bits(td, f36, 1);
  apriltag_detector_add_family_bits(td, f25, 1);
  td->quad_decimate = 2.0f;
  td->refine_edges = true;
  td->nthreads = 1;
  image_u8_t im{img.cols, img.rows, static_cast<int>(img.step[0]), img.data};
  zarray_t* raw = apriltag_detector_detect(td, &im);
  ASSERT_EQ(zarray_size(raw), static_cast<int>(tags.size()));
  int matched = 0;
  for (int i = 0; i < zarray_size(raw); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(raw, i, &d);
    for (const auto& t : tags) {
      if (t.family != d->family->name || t.id != d->id) continue;
      if ((t.library_corners[0] - Eigen::Vector2d(d->p[3][0] - 0.5, d->p[3][1] - 0.5)).norm() > 1e-9) continue;
      ++matched;
      EXPECT_DOUBLE_EQ(t.decision_margin, d->decision_margin);
      for (int k = 0; k < 4; ++k) {
        EXPECT_NEAR(t.library_corners[k].x(), d->p[3 - k][0] - 0.5, 1e-9);
        EXPECT_NEAR(t.library_corners[k].y(), d->p[3 - k][1] - 0.5, 1e-9);
        EXPECT_LT((t.corners[k] - t.library_corners[k]).norm(), 0.6);  // refined, same corner
      }
    }
  }
  EXPECT_EQ(matched, zarray_size(raw));
  // Without owlcal's refinement the corners are exactly the library's.
  AprilTagOptions plain = o;
  plain.refine_corners = false;
  for (const auto& t : DetectAprilTags(img, plain)) {
    EXPECT_FALSE(t.corners_refined);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(t.corners[k], t.library_corners[k]);
  }
  apriltag_detections_destroy(raw);
  apriltag_detector_destroy(td);
  tag36h11_destroy(f36);
  tag25h9_destroy(f25);

  // A grid of ids 0..35 rejects all three copies of id 5 (an odd count: each copy, not pairs).
  TargetDefinition grid;
  grid.kind = TargetKind::kAprilGrid;
  const TargetDetection g = DetectTarget(img, grid, DetectorOptions());
  ASSERT_TRUE(g.found) << g.message;
  for (int id : g.corner_ids) EXPECT_NE(id / 4, 5) << g.message;
  EXPECT_EQ(g.corner_ids.size(), 4u) << g.message;  // only tag 23
  EXPECT_NE(g.message.find("repeated ids rejected"), std::string::npos) << g.message;
}

}  // namespace
}  // namespace owlcal::calib

namespace owlcal::calib {
namespace {

// Noise sigma 2 grey levels and JPEG quality 80 (the detector conditions of docs/conventions.md, Facts): the refined
// corners' RMS error over several poses stays within 0.1 px and below libapriltag's own.
TEST(AprilTagFree, RefinedCornersBeatTheLibraryUnderNoiseAndJpeg) {
  const cv::Mat cells = TagCells("tag36h11", 0);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 2.0);
  double se_refined = 0, se_library = 0;
  int n = 0;
  for (double angle : {0.0, 8.0, 23.0, 41.0, -15.0, 90.0}) {
    for (double cell_px : {6.0, 10.0}) {
      const cv::Matx33d H = TagHomography(cell_px, angle, 321.4, 237.2, 0.0004, cells.cols);
      cv::Mat img(480, 640, CV_8U, cv::Scalar(200));
      DrawTag(cells, H, &img, 6);
      cv::GaussianBlur(img, img, cv::Size(0, 0), 0.6);
      for (int y = 0; y < img.rows; ++y)
        for (int x = 0; x < img.cols; ++x)
          img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(img.at<uint8_t>(y, x) + noise(rng));
      std::vector<uint8_t> jpeg;
      cv::imencode(".jpg", img, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80});
      img = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
      const auto tags = DetectAprilTags(img, AprilTagOptions());
      ASSERT_EQ(tags.size(), 1u) << "angle " << angle << " cell " << cell_px;
      const Eigen::Vector2d expect[4] = {Expected(H, 1, 1), Expected(H, 9, 1), Expected(H, 9, 9), Expected(H, 1, 9)};
      for (int k = 0; k < 4; ++k) {
        se_refined += (tags[0].corners[k] - expect[k]).squaredNorm();
        se_library += (tags[0].library_corners[k] - expect[k]).squaredNorm();
        ++n;
      }
    }
  }
  const double rms_refined = std::sqrt(se_refined / n), rms_library = std::sqrt(se_library / n);
  std::cout << "noise 2 + JPEG 80: corner RMS refined " << rms_refined << " px, libapriltag " << rms_library << " px\n";
  EXPECT_LE(rms_refined, 0.1);
  EXPECT_LT(rms_refined, rms_library);
}

}  // namespace
}  // namespace owlcal::calib
