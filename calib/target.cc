#include "calib/target.h"

namespace owlcal::calib {

std::map<int, Eigen::Vector3d> TargetDefinition::Corners() const {
  std::map<int, Eigen::Vector3d> c;
  switch (kind) {
    case TargetKind::kChessboard:
      for (int r = 0; r < rows; ++r)
        for (int k = 0; k < cols; ++k) c[r * cols + k] = Eigen::Vector3d(k * square_m, r * square_m, 0);
      break;
    case TargetKind::kAprilGrid: {
      const double pitch = tag_size_m * (1.0 + tag_spacing);
      for (int r = 0; r < tag_rows; ++r)
        for (int k = 0; k < tag_cols; ++k) {
          const int id = first_id + r * tag_cols + k;
          const double x0 = k * pitch, y0 = r * pitch, s = tag_size_m;
          c[4 * id + 0] = Eigen::Vector3d(x0, y0, 0);
          c[4 * id + 1] = Eigen::Vector3d(x0 + s, y0, 0);
          c[4 * id + 2] = Eigen::Vector3d(x0 + s, y0 + s, 0);
          c[4 * id + 3] = Eigen::Vector3d(x0, y0 + s, 0);
        }
      break;
    }
    case TargetKind::kFixation:
      c[0] = Eigen::Vector3d::Zero();
      break;
  }
  return c;
}

int TargetDefinition::NumCorners() const { return int(Corners().size()); }

Eigen::Vector4d TargetDefinition::Extent() const {
  switch (kind) {
    case TargetKind::kChessboard:
      return {-square_m, cols * square_m, -square_m, rows * square_m};
    case TargetKind::kAprilGrid: {
      const double pitch = tag_size_m * (1.0 + tag_spacing);
      const double m = tag_size_m * tag_spacing;
      return {-m, (tag_cols - 1) * pitch + tag_size_m + m, -m, (tag_rows - 1) * pitch + tag_size_m + m};
    }
    case TargetKind::kFixation:
      return {-2 * fixation_radius_m, 2 * fixation_radius_m, -2 * fixation_radius_m, 2 * fixation_radius_m};
  }
  return {};
}

}  // namespace owlcal::calib
