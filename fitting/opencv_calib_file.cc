#include "fitting/opencv_calib_file.h"

#include <cmath>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "io/atomic_file.h"
#include "io/xml_check.h"

namespace owlcal::fitting {
namespace {

cv::Mat Skew(const cv::Mat& t) {
  const double x = t.at<double>(0), y = t.at<double>(1), z = t.at<double>(2);
  return (cv::Mat_<double>(3, 3) << 0, -z, y, z, 0, -x, -y, x, 0);
}

// The comment every file carries: convention, unit and rectification.
std::string UnitComment(const OpenCvStereoCalibration& c, bool intr, bool extr) {
  std::string s = "owlcal stereo calibration (fields of OpenCV's stereo_calib sample and the Plymouth Owl course).";
  if (intr) s += " M1 D1 = left camera, M2 D2 = right camera (pixels; OpenCV distortion order).";
  if (extr) {
    s += " x_right = R x_left + T. Lengths (T, E, P2[0,3], Q[3,2]) in " + c.length_unit + ".";
    if (!c.R1.empty())
      s += " R1 R2 P1 P2 Q: cv::stereoRectify, CALIB_ZERO_DISPARITY, alpha = " +
           (std::isfinite(c.rectify_alpha) ? cv::format("%g", c.rectify_alpha) : std::string("unknown")) + ".";
  }
  return s;
}

void WriteFields(cv::FileStorage& fs, const OpenCvStereoCalibration& c, bool intr, bool extr) {
  fs.writeComment(UnitComment(c, intr, extr));
  if (!c.run_id.empty()) fs << "owlcal_run_id" << c.run_id;
  if (c.image_width > 0 && intr) {
    fs << "image_width" << c.image_width;
    fs << "image_height" << c.image_height;
  }
  auto put = [&](const char* name, const cv::Mat& m) {
    if (!m.empty()) fs << name << m;
  };
  if (intr) {
    put("M1", c.M1);
    put("D1", c.D1);
    put("M2", c.M2);
    put("D2", c.D2);
  }
  if (extr) {
    fs << "length_unit" << c.length_unit;
    put("R", c.R);
    put("T", c.T);
    put("E", c.E);
    put("F", c.F);
    put("R1", c.R1);
    put("R2", c.R2);
    put("P1", c.P1);
    put("P2", c.P2);
    put("Q", c.Q);
  }
}

void WriteFile(const std::string& path, const OpenCvStereoCalibration& c, bool intr, bool extr) {
  // Written in memory (the format follows the name's extension), then to disk checked and atomically.
  cv::FileStorage fs;
  std::string text;
  try {
    if (!fs.open(path, cv::FileStorage::WRITE | cv::FileStorage::MEMORY)) throw std::runtime_error("");
    WriteFields(fs, c, intr, extr);
    text = fs.releaseAndGetString();
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write OpenCV calibration file " + path + " " + e.what());
  }
  io::WriteFileAtomic(path, text);
}

double MetresPer(const std::string& unit) {
  if (unit == "m") return 1.0;
  if (unit == "mm") return 1e-3;
  if (unit == "cm") return 1e-2;
  return NAN;
}

void ReadFields(const cv::FileStorage& fs, const std::string& path, OpenCvStereoCalibration* c) {
  struct Field {
    const char* name;
    cv::Mat* m;
    int rows, cols;  // -1: any
  };
  const Field fields[] = {{"M1", &c->M1, 3, 3},
                          {"D1", &c->D1, -1, -1},
                          {"M2", &c->M2, 3, 3},
                          {"D2", &c->D2, -1, -1},
                          {"R", &c->R, 3, 3},
                          {"T", &c->T, -1, -1},
                          {"E", &c->E, 3, 3},
                          {"F", &c->F, 3, 3},
                          {"R1", &c->R1, 3, 3},
                          {"R2", &c->R2, 3, 3},
                          {"P1", &c->P1, 3, 4},
                          {"P2", &c->P2, 3, 4},
                          {"Q", &c->Q, 4, 4}};
  for (const Field& f : fields) {
    const cv::FileNode n = fs[f.name];
    if (n.empty()) continue;
    // Check the declared shape before OpenCV allocates it: rows/cols from the file went
    // straight to cv::Mat::create (fuzzing: "<cols>-</cols>" asked for 64 GB).
    const std::string where = "OpenCV calibration file " + path + ": field " + f.name;
    if (!n.isMap()) throw std::runtime_error(where + " is not a matrix (rows, cols, dt, data)");
    const cv::FileNode rows = n["rows"], cols = n["cols"], data = n["data"];
    if (!rows.isInt() || !cols.isInt() || int(rows) < 1 || int(cols) < 1 || int(rows) > 16 || int(cols) > 16)
      throw std::runtime_error(where + ": rows and cols must be integers in 1..16");
    if (!data.isSeq() || data.size() != size_t(int(rows)) * size_t(int(cols)))
      throw std::runtime_error(where + ": data holds " + std::to_string(data.isSeq() ? data.size() : 0) +
                               " values, rows x cols = " + std::to_string(int(rows) * int(cols)));
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception& e) {
      throw std::runtime_error("OpenCV calibration file " + path + ": field " + f.name + ": " + e.what());
    }
    if (m.empty()) continue;
    m.convertTo(m, CV_64F);
    if (m.channels() != 1)
      throw std::runtime_error("OpenCV calibration file " + path + ": field " + f.name + " has " +
                               std::to_string(m.channels()) + " channels, expected 1");
    if (!cv::checkRange(m))
      throw std::runtime_error("OpenCV calibration file " + path + ": field " + f.name +
                               " holds a NaN or infinite value");
    if (f.rows > 0 && (m.rows != f.rows || m.cols != f.cols))
      throw std::runtime_error("OpenCV calibration file " + path + ": field " + f.name + " is " +
                               std::to_string(m.rows) + "x" + std::to_string(m.cols) + ", expected " +
                               std::to_string(f.rows) + "x" + std::to_string(f.cols));
    if (std::string(f.name) == "T" && m.total() != 3)
      throw std::runtime_error("OpenCV calibration file " + path + ": field T has " + std::to_string(m.total()) +
                               " values, expected 3");
    if (f.name[0] == 'D') {
      const size_t k = m.total();
      if (k != 4 && k != 5 && k != 8 && k != 12 && k != 14)
        throw std::runtime_error("OpenCV calibration file " + path + ": field " + f.name + " has " + std::to_string(k) +
                                 " coefficients (4, 5, 8, 12 or 14 expected)");
      m = m.reshape(1, 1);
    }
    if (std::string(f.name) == "T") m = m.reshape(1, 3);
    *f.m = m;
  }
  for (const auto& [name, out] : {std::pair<const char*, int*>{"image_width", &c->image_width},
                                  std::pair<const char*, int*>{"image_height", &c->image_height}}) {
    const cv::FileNode n = fs[name];
    if (n.empty()) continue;
    if (!n.isInt() || int(n) < 1 || int(n) > 16384)
      throw std::runtime_error("OpenCV calibration file " + path + ": field " + name +
                               " is not an integer in 1..16384");
    *out = int(n);
  }
  // Camera matrices: positive focal lengths and the [0 0 1] last row.
  for (const auto& [name, m] : {std::pair<const char*, const cv::Mat*>{"M1", &c->M1}, {"M2", &c->M2}}) {
    if (m->empty()) continue;
    if (!(m->at<double>(0, 0) > 0 && m->at<double>(1, 1) > 0) || m->at<double>(2, 0) != 0 || m->at<double>(2, 1) != 0 ||
        m->at<double>(2, 2) != 1)
      throw std::runtime_error("OpenCV calibration file " + path + ": field " + name +
                               " is not a camera matrix (fx > 0, fy > 0, last row 0 0 1)");
  }
  if (!c->R.empty() && cv::norm(c->R.t() * c->R - cv::Mat::eye(3, 3, CV_64F)) > 1e-3)
    throw std::runtime_error("OpenCV calibration file " + path + ": field R is not a rotation (R^T R != I)");
  // The unit: stated by owlcal's files; else the course's mm when |T| > 1 (a stereo baseline
  // of more than 1 m is not an Owl), metres otherwise.
  c->rectify_alpha = NAN;
  if (const cv::FileNode id = fs["owlcal_run_id"]; !id.empty()) {
    if (!id.isString())
      throw std::runtime_error("OpenCV calibration file " + path + ": field owlcal_run_id is not a string");
    c->run_id = std::string(id);
  }
  if (fs["length_unit"].isString()) {
    c->length_unit = std::string(fs["length_unit"]);
  } else if (!c->T.empty()) {
    c->length_unit = cv::norm(c->T) > 1 ? "mm" : "m";
  }
}

}  // namespace

OpenCvStereoCalibration MakeOpenCvCalibration(const models::CameraIntrinsics& left,
                                              const models::CameraIntrinsics& right,
                                              const models::Rigid3d& right_from_left,
                                              const std::string& length_unit,
                                              double rectify_alpha) {
  if (left.width != right.width || left.height != right.height)
    throw std::runtime_error("OpenCV calibration: the two cameras have different image sizes (" +
                             std::to_string(left.width) + "x" + std::to_string(left.height) + " and " +
                             std::to_string(right.width) + "x" + std::to_string(right.height) + ")");
  OpenCvStereoCalibration c;
  for (int e = 0; e < 2; ++e) {
    const auto& p = (e == 0 ? left : right).params;
    cv::Mat M = (cv::Mat_<double>(3, 3) << p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
    cv::Mat D = cv::Mat(std::vector<double>(p.begin() + 4, p.end()), true).reshape(1, 1);
    (e == 0 ? c.M1 : c.M2) = M;
    (e == 0 ? c.D1 : c.D2) = D;
  }
  c.image_width = left.width;
  c.image_height = left.height;
  c.length_unit = length_unit;
  c.rectify_alpha = rectify_alpha;
  cv::eigen2cv(Eigen::Matrix3d(right_from_left.rotation.toRotationMatrix()), c.R);
  cv::eigen2cv(Eigen::Vector3d(right_from_left.translation), c.T);
  c.E = Skew(c.T) * c.R;
  c.F = c.M2.inv().t() * c.E * c.M1.inv();
  c.F /= c.F.at<double>(2, 2);
  cv::stereoRectify(c.M1,
                    c.D1,
                    c.M2,
                    c.D2,
                    cv::Size(c.image_width, c.image_height),
                    c.R,
                    c.T,
                    c.R1,
                    c.R2,
                    c.P1,
                    c.P2,
                    c.Q,
                    cv::CALIB_ZERO_DISPARITY,
                    rectify_alpha);
  return c;
}

OpenCvStereoCalibration ToOpenCvCalibration(const StereoFit& fit, double rectify_alpha) {
  return MakeOpenCvCalibration(fit.cameras[0], fit.cameras[1], fit.right_from_left, fit.length_unit, rectify_alpha);
}

OpenCvStereoCalibration ToOpenCvCalibration(const CalibrationResult& r, double rectify_alpha) {
  const models::CameraIntrinsics* cam[2] = {nullptr, nullptr};
  for (int e = 0; e < 2; ++e) {
    if (r.cameras[e])
      cam[e] = &*r.cameras[e];
    else if (r.head)
      cam[e] = &r.head->intrinsics[e];
    else
      throw std::runtime_error(std::string("OpenCV calibration: the result has no ") + (e ? "right" : "left") +
                               " camera");
  }
  if (!r.stereo) throw std::runtime_error("OpenCV calibration: the result has no stereo estimate (right_from_left)");
  std::string unit = "m";
  if (r.diagnostics.contains("stereo") && r.diagnostics["stereo"].contains("length_unit"))
    unit = r.diagnostics["stereo"]["length_unit"].get<std::string>();
  OpenCvStereoCalibration c = MakeOpenCvCalibration(*cam[0], *cam[1], r.stereo->right_from_left, unit, rectify_alpha);
  c.run_id = r.run_id;
  return c;
}

OpenCvStereoCalibration WithLengthUnit(const OpenCvStereoCalibration& c, const std::string& unit) {
  if (unit == c.length_unit) return c;
  const double from = MetresPer(c.length_unit), to = MetresPer(unit);
  if (!std::isfinite(from) || !std::isfinite(to))
    throw std::runtime_error("OpenCV calibration: cannot convert lengths from '" + c.length_unit + "' to '" + unit +
                             "'");
  const double k = from / to;
  OpenCvStereoCalibration o = c;
  auto scaled = [](const cv::Mat& m, double f) { return m.empty() ? m : cv::Mat(m * f); };
  o.T = scaled(c.T, k);
  o.E = scaled(c.E, k);
  if (!c.P2.empty()) {
    o.P2 = c.P2.clone();
    o.P2.at<double>(0, 3) *= k;
    o.P2.at<double>(1, 3) *= k;
  }
  if (!c.Q.empty()) {
    o.Q = c.Q.clone();
    o.Q.at<double>(3, 2) /= k;  // -1 / Tx
    o.Q.at<double>(3, 3) /= k;  // (cx1 - cx2) / Tx
  }
  o.length_unit = unit;
  return o;
}

void WriteOpenCvCalibration(const std::string& path, const OpenCvStereoCalibration& c) {
  WriteFile(path, c, true, true);
}

void WriteOpenCvSplitFiles(const std::string& intrinsics_path,
                           const std::string& extrinsics_path,
                           const OpenCvStereoCalibration& c) {
  const bool convertible = std::isfinite(MetresPer(c.length_unit));
  const OpenCvStereoCalibration mm = convertible ? WithLengthUnit(c, "mm") : c;
  WriteFile(intrinsics_path, mm, true, false);
  WriteFile(extrinsics_path, mm, false, true);
}

namespace {

// OpenCV's FileStorage parsers trust their input: a NUL byte made the XML parser read past the
// text, and a truncated XML declaration ("<?xml t_idversn=") made it dereference a null pointer
// (both found by fuzz/course_xml_fuzz). A calibration file is text, and XML must be well formed
// before FileStorage sees it.
void CheckFileStorageText(const std::string& text, const std::string& source) {
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw std::runtime_error("OpenCV calibration file " + source + ": not a text file (NUL byte at offset " +
                             std::to_string(nul) + ")");
  // OpenCV takes a file named *.xml as XML whatever it holds, and detects XML in memory by its
  // first character after a UTF-8 byte order mark and white space: check both ways (a BOM in
  // front of malformed XML got past a check of the first byte alone: fuzz/course_xml_fuzz).
  const size_t bom = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  const size_t first = text.find_first_not_of(" \t\r\n", bom);
  const bool xml_name = source.size() >= 4 && source.compare(source.size() - 4, 4, ".xml") == 0;
  if (xml_name || (first != std::string::npos && text[first] == '<')) {
    if (const std::string e = io::XmlWellFormedError(text); !e.empty())
      throw std::runtime_error("OpenCV calibration file " + source + ":" + e + " (not well-formed XML)");
  }
}

}  // namespace

OpenCvStereoCalibration ReadOpenCvCalibration(const std::string& path) {
  {
    std::ifstream in(path, std::ios::binary);
    if (in)
      CheckFileStorageText(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), path);
  }
  OpenCvStereoCalibration c;
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ)) throw std::runtime_error("cannot open");
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot open OpenCV calibration file " + path + ": " + e.what());
  }
  try {
    ReadFields(fs, path, &c);
  } catch (const cv::Exception& e) {  // a node of the wrong type (e.g. a string where a number belongs)
    throw std::runtime_error("OpenCV calibration file " + path + ": " + e.what());
  }
  return c;
}

OpenCvStereoCalibration ParseOpenCvCalibration(const std::string& text, const std::string& source) {
  CheckFileStorageText(text, source);
  OpenCvStereoCalibration c;
  cv::FileStorage fs;
  try {
    if (!fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY)) throw std::runtime_error("not a FileStorage");
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read OpenCV calibration file " + source + ": " + e.what());
  }
  try {
    ReadFields(fs, source, &c);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("OpenCV calibration file " + source + ": " + e.what());
  }
  return c;
}

OpenCvStereoCalibration ReadOpenCvSplitFiles(const std::string& intrinsics_path, const std::string& extrinsics_path) {
  OpenCvStereoCalibration c = ReadOpenCvCalibration(intrinsics_path);
  const OpenCvStereoCalibration e = ReadOpenCvCalibration(extrinsics_path);
  if (c.run_id != e.run_id) {
    auto id = [](const std::string& s) { return s.empty() ? std::string("none") : "'" + s + "'"; };
    throw std::runtime_error(intrinsics_path + " (owlcal run id " + id(c.run_id) + ") and " + extrinsics_path +
                             " (owlcal run id " + id(e.run_id) +
                             ") were written by different runs: calibrate again into a fresh folder");
  }
  for (auto [dst, src] : {std::pair{&c.R, &e.R},
                          {&c.T, &e.T},
                          {&c.E, &e.E},
                          {&c.F, &e.F},
                          {&c.R1, &e.R1},
                          {&c.R2, &e.R2},
                          {&c.P1, &e.P1},
                          {&c.P2, &e.P2},
                          {&c.Q, &e.Q}})
    if (dst->empty()) *dst = *src;
  c.length_unit = e.length_unit;
  c.rectify_alpha = e.rectify_alpha;
  return c;
}

std::optional<models::CameraIntrinsics> CameraFromOpenCv(
    const cv::Mat& M, const cv::Mat& D, int width, int height, std::string* why) {
  auto fail = [&](const std::string& m) -> std::optional<models::CameraIntrinsics> {
    if (why) *why = m;
    return std::nullopt;
  };
  if (M.rows != 3 || M.cols != 3) return fail("camera matrix is not 3x3");
  cv::Mat m, d;
  M.convertTo(m, CV_64F);
  D.convertTo(d, CV_64F);
  d = d.reshape(1, 1);
  std::vector<double> dist(d.begin<double>(), d.end<double>());
  for (size_t i = 8; i < dist.size(); ++i)
    if (dist[i] != 0) return fail("distortion coefficient " + std::to_string(i) + " (thin prism / tilt) is non-zero");
  if (std::abs(m.at<double>(0, 1)) > 1e-9) return fail("camera matrix has skew");
  bool rational = false;
  for (size_t i = 5; i < std::min<size_t>(8, dist.size()); ++i) rational = rational || dist[i] != 0;
  dist.resize(rational ? 8 : 5, 0.0);
  models::CameraIntrinsics c;
  c.model = rational ? models::DistortionModel::kOpenCv8 : models::DistortionModel::kOpenCv5;
  c.width = width;
  c.height = height;
  c.params = {m.at<double>(0, 0), m.at<double>(1, 1), m.at<double>(0, 2), m.at<double>(1, 2)};
  c.params.insert(c.params.end(), dist.begin(), dist.end());
  return c;
}

}  // namespace owlcal::fitting
