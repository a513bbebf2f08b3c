// owlcal detect-tags IMAGES... --out tags.csv: free-standing AprilTags on arbitrary images
// (calib/apriltag_free.h): one row per tag with family, id, corners and decision margin.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "apps/command_registry.h"
#include "apps/image_inputs.h"
#include "calib/apriltag_free.h"
#include "reports/table.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct DetectTagsOptions {
  std::vector<std::string> inputs;
  std::string out;
  std::vector<std::string> families = {"tag36h11"};
  double decimate = 2.0;
  double blur = 0.0;
  bool no_refine_edges = false;
  int max_hamming = 1;
  double min_margin = 0;
};

int RunDetectTags(const DetectTagsOptions& a) {
  calib::AprilTagOptions o;
  o.families = a.families;
  o.quad_decimate = a.decimate;
  o.quad_sigma = a.blur;
  o.refine_edges = !a.no_refine_edges;
  o.max_hamming = a.max_hamming;
  o.min_decision_margin = a.min_margin;
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  const std::vector<fs::path> files = ImageFilesIn(a.inputs);
  std::ostringstream csv;
  csv << std::setprecision(10)
      << "image,family,id,hamming,decision_margin,x0,y0,x1,y1,x2,y2,x3,y3,centre_x,centre_y,id_count,status\n";
  int total = 0, unreadable = 0, repeated = 0;
  for (const fs::path& p : files) {
    const cv::Mat img = cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
    if (img.empty()) {
      // A row, not a silent skip: the file is named with its status.
      csv << p.string() << ",,,,,,,,,,,,,,,0,unreadable\n";
      std::cerr << "warning: " << p << ": cannot read image\n";
      ++unreadable;
      continue;
    }
    const auto tags = calib::DetectAprilTags(img, o);
    std::cout << p.filename().string() << ": " << tags.size() << " tags";
    for (const auto& t : tags) {
      csv << p.string() << "," << t.family << "," << t.id << "," << t.hamming << "," << t.decision_margin;
      for (const auto& c : t.corners) csv << "," << c.x() << "," << c.y();
      csv << "," << t.centre.x() << "," << t.centre.y() << "," << t.id_count << ","
          << (t.repeated_id ? "repeated_id" : "ok") << "\n";
      std::cout << " " << t.family << ":" << t.id << (t.repeated_id ? "(repeated)" : "");
      repeated += t.repeated_id;
    }
    std::cout << "\n";
    total += static_cast<int>(tags.size());
  }
  reports::WriteTextFile(a.out, csv.str());
  std::cout << total << " tags in " << files.size() << " images (" << repeated << " with a repeated id, all kept; "
            << unreadable << " images unreadable); written to " << a.out << "\n";
  return unreadable == 0 ? kExitOk : kExitFailed;
}

const bool kDetectTagsRegistered = RegisterCommand(
    "detect-tags",
    "Detect free-standing AprilTags (any of the families libapriltag 3.3 ships) in image files or\n"
    "folders and write one CSV row per tag: image, family, id, hamming, decision_margin, corners x0 y0 .. x3 y3\n"
    "(top-left, top-right, bottom-right, bottom-left of the upright tag; OpenCV pixel convention, i.e.\n"
    "libapriltag's corners - 0.5 px), centre, id_count and status. A repeated id is kept every time it occurs\n"
    "(status repeated_id); `owlcal detect` with an AprilGrid target rejects repeated ids instead.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<DetectTagsOptions>();
      cmd->add_option("inputs", o->inputs, "image files and/or folders")->required();
      cmd->add_option("--out", o->out, "CSV to write")->required();
      cmd->add_option("--family",
                      o->families,
                      "tag family, repeatable: tag36h11 tag36h10 tag25h9 tag16h5 tagCircle21h7 tagCircle49h12 "
                      "tagCustom48h12 tagStandard41h12 tagStandard52h13, or all")
          ->capture_default_str();
      cmd->add_option("--quad-decimate", o->decimate, "libapriltag quad_decimate (1 = full resolution)")
          ->capture_default_str();
      cmd->add_option("--quad-sigma", o->blur, "Gaussian blur before quad detection [px]")->capture_default_str();
      cmd->add_flag(
          "--no-refine-edges", o->no_refine_edges, "turn libapriltag's refine_edges off (corners ~0.85 px worse)");
      cmd->add_option("--max-hamming", o->max_hamming, "bits corrected (0..2)")->capture_default_str();
      cmd->add_option("--min-margin", o->min_margin, "drop tags with a lower decision margin")->capture_default_str();
      return [o] { return RunDetectTags(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
