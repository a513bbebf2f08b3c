#include "fitting/opencv_calib_file.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace {

using ::owlcal::test_data::SharedData;

StereoFit MakeFit() {
  StereoFit f;
  f.ok = true;
  f.cameras[0].params = {580, 581, 320, 240, -0.1, 0.05, 0.001, -0.001, 0.01};
  f.cameras[1].params = {579, 578, 318, 242, -0.11, 0.06, 0.0, 0.0, 0.0};
  f.right_from_left = models::Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())),
                                      Eigen::Vector3d(-0.064, 0.001, 0.0005));
  return f;
}

TEST(OpenCvCalibFile, WriteReadRoundTripYamlAndXml) {
  const OpenCvStereoCalibration c = ToOpenCvCalibration(MakeFit());
  // E = [T]x R and F are consistent: x_r^T F x_l = 0 for a projected point.
  for (const char* ext : {".yaml", ".xml"}) {
    const std::string p = (std::filesystem::temp_directory_path() / (std::string("owlcal_cv") + ext)).string();
    WriteOpenCvCalibration(p, c);
    const OpenCvStereoCalibration b = ReadOpenCvCalibration(p);
    ASSERT_TRUE(b.HasIntrinsics());
    ASSERT_TRUE(b.HasExtrinsics());
    EXPECT_EQ(cv::norm(b.M1 - c.M1), 0);
    EXPECT_EQ(cv::norm(b.D1 - c.D1), 0);
    EXPECT_EQ(cv::norm(b.T - c.T), 0);
    EXPECT_EQ(cv::norm(b.F - c.F), 0);
    EXPECT_EQ(cv::norm(b.P1 - c.P1), 0);
    EXPECT_EQ(cv::norm(b.Q - c.Q), 0);
    EXPECT_EQ(b.image_width, 640);
    EXPECT_EQ(b.length_unit, "m");
    std::filesystem::remove(p);
  }
  const cv::Mat xl = (cv::Mat_<double>(3, 1) << 0.1, -0.05, 1.0);
  cv::Mat xr = c.R * xl + c.T;
  const cv::Mat pl = c.M1 * xl / xl.at<double>(2);
  const cv::Mat pr = c.M2 * xr / xr.at<double>(2);
  EXPECT_NEAR(cv::Mat(pr.t() * c.F * pl).at<double>(0), 0.0, 1e-9);
}

TEST(OpenCvCalibFile, SplitFilesAreInMillimetresAndReadBackInMetres) {
  const OpenCvStereoCalibration c = ToOpenCvCalibration(MakeFit());
  const auto dir = std::filesystem::temp_directory_path() / "owlcal_cv_split";
  std::filesystem::create_directories(dir);
  WriteOpenCvSplitFiles((dir / "intrinsics.xml").string(), (dir / "extrinsics.xml").string(), c);
  cv::FileStorage fs((dir / "extrinsics.xml").string(), cv::FileStorage::READ);
  cv::Mat T, Q;
  fs["T"] >> T;
  fs["Q"] >> Q;
  EXPECT_DOUBLE_EQ(T.at<double>(0), -64.0);
  EXPECT_NEAR(Q.at<double>(3, 2), c.Q.at<double>(3, 2) / 1000, 1e-15);
  const OpenCvStereoCalibration b =
      ReadOpenCvSplitFiles((dir / "intrinsics.xml").string(), (dir / "extrinsics.xml").string());
  EXPECT_EQ(b.length_unit, "mm");
  const OpenCvStereoCalibration m = WithLengthUnit(b, "m");
  EXPECT_NEAR(cv::norm(m.T - c.T), 0, 1e-15);
  EXPECT_NEAR(cv::norm(m.Q - c.Q), 0, 1e-9);
  EXPECT_NEAR(cv::norm(m.P2 - c.P2), 0, 1e-9);
  EXPECT_THROW(WithLengthUnit(b, "square"), std::runtime_error);
  std::filesystem::remove_all(dir);
}

TEST(OpenCvCalibFile, ReadsTheCourseSplitFiles) {
  const std::string dir = SharedData() + "/owl-real/kit2020-chessboard/reference/";
  if (!std::filesystem::exists(dir + "intrinsics.xml")) GTEST_SKIP() << "no shared data at " << dir;
  const OpenCvStereoCalibration c = ReadOpenCvSplitFiles(dir + "intrinsics.xml", dir + "extrinsics.xml");
  ASSERT_TRUE(c.HasIntrinsics());
  ASSERT_TRUE(c.HasExtrinsics());
  EXPECT_NEAR(c.M1.at<double>(0, 0), 587.876, 0.01);
  EXPECT_EQ(c.D1.total(), 14u);
  EXPECT_NEAR(c.T.at<double>(0), -64.123, 0.01);
  EXPECT_EQ(c.length_unit, "mm");  // no length_unit node: |T| > 1 means the course's mm
  EXPECT_FALSE(c.Q.empty());
  std::string why;
  const auto cam = CameraFromOpenCv(c.M1, c.D1, 640, 480, &why);
  ASSERT_TRUE(cam.has_value()) << why;
  EXPECT_EQ(cam->model, models::DistortionModel::kOpenCv8);  // k6 is non-zero in the course file
  EXPECT_NEAR(cam->params[11], 0.0563457, 1e-6);
}

TEST(OpenCvCalibFile, BadShapesAndMissingFilesNameThePath) {
  const std::string p = (std::filesystem::temp_directory_path() / "owlcal_cv_bad.yaml").string();
  {
    cv::FileStorage fs(p, cv::FileStorage::WRITE);
    fs << "M1" << cv::Mat::eye(2, 2, CV_64F);
  }
  try {
    ReadOpenCvCalibration(p);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("M1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
  }
  std::filesystem::remove(p);
  EXPECT_THROW(ReadOpenCvCalibration("/nonexistent/x.yaml"), std::runtime_error);
  cv::Mat D = (cv::Mat_<double>(1, 14) << 0.1, 0, 0, 0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0);
  std::string why;
  EXPECT_FALSE(CameraFromOpenCv(cv::Mat::eye(3, 3, CV_64F), D, 640, 480, &why).has_value());
  EXPECT_NE(why.find("thin prism"), std::string::npos);
}

// Regression: the course XML reader validates what it reads.
TEST(OpenCvCalibFile, RefusesNonFiniteValuesBadCameraMatricesAndSizes) {
  auto error_of = [](const std::string& body) {
    try {
      ParseOpenCvCalibration("%YAML:1.0\n---\n" + body, "bad.yml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string m_ok =
      "M1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [500., 0., 320., 0., 500., 240., 0., 0., 1.]\n";
  EXPECT_EQ(error_of(m_ok), "");
  std::string e = error_of(
      "M1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [0., 0., 320., 0., 500., 240., 0., 0., 1.]\n");
  EXPECT_NE(e.find("bad.yml: field M1 is not a camera matrix"), std::string::npos) << e;
  e = error_of(
      "M1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [.nan, 0., 320., 0., 500., 240., 0., 0., 1.]\n");
  EXPECT_NE(e.find("bad.yml: field M1 holds a NaN or infinite value"), std::string::npos) << e;
  e = error_of("R: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [2., 0., 0., 0., 1., 0., 0., 0., 1.]\n");
  EXPECT_NE(e.find("field R is not a rotation"), std::string::npos) << e;
  e = error_of(m_ok + "image_width: 1000000\n");
  EXPECT_NE(e.find("field image_width is not an integer in 1..16384"), std::string::npos) << e;
  e = error_of(m_ok + "image_height: \"tall\"\n");
  EXPECT_NE(e.find("field image_height"), std::string::npos) << e;
  const std::string xml =
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n<M2 type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>"
      "<data>500. 0. 320. 0. 500. 240. 0. 0. 1.</data></M2>\n</opencv_storage>\n";
  EXPECT_FALSE(ParseOpenCvCalibration(xml, "x.xml").M2.empty());
  EXPECT_THROW(ParseOpenCvCalibration("<?xml version=\"1.0\"?>\n<opencv_storage><M2", "x.xml"), std::runtime_error);
}

// Found by fuzz/course_xml_fuzz: NUL bytes inside the text crashed OpenCV's XML parser.
TEST(OpenCvCalibFile, NulBytesAreRefusedBeforeOpenCvParses) {
  std::string text = "<?xml version=";
  text += std::string(10, '\0');
  text += "\n<opencv_storage>\n<R type_id=\"opencv-matrix\">\n</R>\n</opencv_storage>\n";
  try {
    ParseOpenCvCalibration(text, "nul.xml");
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("nul.xml: not a text file (NUL byte at offset 14)"), std::string::npos)
        << e.what();
  }
  const std::string p =
      (std::filesystem::temp_directory_path() / ("owlcal_nul_" + std::to_string(::getpid()) + ".xml")).string();
  std::ofstream(p, std::ios::binary) << text;
  EXPECT_THROW(ReadOpenCvCalibration(p), std::runtime_error);
  std::filesystem::remove(p);
}

// Found by fuzz/course_xml_fuzz: a truncated XML declaration made OpenCV's parser dereference a
// null pointer. Malformed or truncated XML is refused, naming the line, before OpenCV parses it.
TEST(OpenCvCalibFile, MalformedXmlIsRefusedBeforeOpenCvParses) {
  const std::string good =
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n<M2 "
      "type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>d</dt>\n"
      "<data>500. 0. 320. 0. 500. 240. 0. 0. 1.</data></M2>\n</opencv_storage>\n";
  EXPECT_FALSE(ParseOpenCvCalibration(good, "x.xml").M2.empty());
  for (size_t cut : {size_t{16}, size_t{30}, good.size() / 2, good.size() - 3}) {
    EXPECT_THROW(ParseOpenCvCalibration(good.substr(0, cut), "x.xml"), std::runtime_error) << cut;
  }
  // The second: a UTF-8 byte order mark in front of a malformed tag.
  EXPECT_THROW(ParseOpenCvCalibration("\xEF\xBB\xBF<?xml version=\"0.0\"?>\n<opencv_storal version=", "x.txt"),
               std::runtime_error);
  EXPECT_FALSE(ParseOpenCvCalibration("\xEF\xBB\xBF" + good, "x.txt").M2.empty());
  EXPECT_THROW(ParseOpenCvCalibration("not xml <", "x.xml"), std::runtime_error);
  try {
    ParseOpenCvCalibration("<?xml t_idversn=", "crash.xml");
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("crash.xml:1:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not well-formed XML"), std::string::npos) << e.what();
  }
}

// Found by fuzz/course_xml_fuzz: a matrix whose declared rows/cols are garbage or huge made
// OpenCV allocate 64 GB before anything was checked.
TEST(OpenCvCalibFile, DeclaredMatrixShapeIsCheckedBeforeAllocating) {
  auto xml = [](const std::string& rows, const std::string& cols, const std::string& data) {
    return "<?xml version=\"1.0\"?>\n<opencv_storage>\n<P1 type_id=\"opencv-matrix\"><rows>" + rows + "</rows><cols>" +
           cols + "</cols><dt>d</dt><data>" + data + "</data></P1>\n</opencv_storage>\n";
  };
  const std::string twelve = "1. 0. 2. 0. 0. 1. 2. 0. 0. 0. 1. 0.";
  EXPECT_FALSE(ParseOpenCvCalibration(xml("3", "4", twelve), "x.xml").P1.empty());
  for (const auto& [rows, cols] :
       {std::pair<std::string, std::string>{"4", "-"}, {"4", "-1"}, {"100000", "100000"}, {"3", "5"}, {"0", "4"}}) {
    try {
      ParseOpenCvCalibration(xml(rows, cols, twelve), "x.xml");
      ADD_FAILURE() << rows << "x" << cols << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("x.xml: field P1"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace owlcal::fitting
