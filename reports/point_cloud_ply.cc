#include "reports/point_cloud_ply.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "io/atomic_file.h"

namespace owlcal::reports {

int WritePointCloudPly(const std::string& path,
                       const evaluation::DepthMaps& maps,
                       double max_depth_m,
                       const std::string& source,
                       bool binary) {
  struct Vertex {
    float x, y, z;
    uint8_t grey;
  };
  std::vector<Vertex> v;
  const cv::Mat& z = maps.depth_m;
  for (int r = 0; r < z.rows; ++r)
    for (int c = 0; c < z.cols; ++c) {
      const float d = z.at<float>(r, c);
      if (!std::isfinite(d) || d <= 0 || d > max_depth_m) continue;
      // Pinhole of the rectified left camera: X = (u - cx) Z / f, Y = (v - cy) Z / f.
      v.push_back({float((c - maps.cx) * d / maps.focal_px),
                   float((r - maps.cy) * d / maps.focal_px),
                   d,
                   maps.left_rect.empty() ? uint8_t(200) : maps.left_rect.at<uint8_t>(r, c)});
    }
  std::ostringstream out(std::ios::binary);
  std::string src = source;
  for (char& ch : src)
    if (ch == '\n' || ch == '\r') ch = ' ';
  out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
      << "comment owlcal depth: left rectified camera frame (x right, y down, z forward), metres\n"
      << "comment calibration: " << src << "\n"
      << "element vertex " << v.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  if (binary) {
    // x86 and ARM (the Pi) are little-endian; memcpy keeps the float bytes as they are.
    std::vector<char> buf(v.size() * 15);
    for (size_t i = 0; i < v.size(); ++i) {
      char* p = buf.data() + 15 * i;
      std::memcpy(p, &v[i].x, 4);
      std::memcpy(p + 4, &v[i].y, 4);
      std::memcpy(p + 8, &v[i].z, 4);
      p[12] = p[13] = p[14] = char(v[i].grey);
    }
    out.write(buf.data(), std::streamsize(buf.size()));
  } else {
    for (const Vertex& p : v)
      out << p.x << " " << p.y << " " << p.z << " " << int(p.grey) << " " << int(p.grey) << " " << int(p.grey) << "\n";
  }
  io::WriteFileAtomic(path, out.str());
  return int(v.size());
}

}  // namespace owlcal::reports
