#pragma once
// Pinhole camera with OpenCV's 5- or 8-coefficient lens distortion, templated on the scalar
// so Ceres can differentiate it. Conventions (docs/conventions.md, Pixels): camera frame x right,
// y down, z forward; pixel (0,0) is the centre of the top-left pixel, as in OpenCV.
//
// params (kNumParams = 4 + N):
//   fx, fy, cx, cy [px], then OpenCV's distortion vector in OpenCV's order:
//   N = 5: k1, k2, p1, p2, k3
//   N = 8: k1, k2, p1, p2, k3, k4, k5, k6   (rational model)
// Projection is exactly cv::projectPoints with cameraMatrix [fx 0 cx; 0 fy cy; 0 0 1] and
// that distortion vector.
//
// Usage:
//   double p[OpenCvCamera<5>::kNumParams] = {585, 585, 320, 240, -0.1, 0.05, 0, 0, 0};
//   double pix[2];
//   if (OpenCvCamera<5>::Project(p, point_in_cam, pix)) { ... }
#include <array>
#include <cmath>
#include <string>
#include <variant>
#include <vector>

#include <ceres/jet.h>

namespace owlcal::models {

template <int N>
struct OpenCvCamera {
  static_assert(N == 5 || N == 8, "OpenCV distortion has 5 or 8 coefficients here");
  static constexpr int kNumDistortion = N;
  static constexpr int kNumParams = 4 + N;

  // Distorts normalised coordinates (x, y) = (X/Z, Y/Z) into (xd, yd).
  template <typename T>
  static void Distort(const T* params, const T& x, const T& y, T* xd, T* yd) {
    const T* d = params + 4;
    const T r2 = x * x + y * y;
    const T r4 = r2 * r2;
    const T r6 = r4 * r2;
    T radial = T(1) + d[0] * r2 + d[1] * r4 + d[4] * r6;
    if constexpr (N == 8) {
      radial = radial / (T(1) + d[5] * r2 + d[6] * r4 + d[7] * r6);
    }
    const T a1 = T(2) * x * y;
    *xd = x * radial + d[2] * a1 + d[3] * (r2 + T(2) * x * x);
    *yd = y * radial + d[2] * (r2 + T(2) * y * y) + d[3] * a1;
  }

  // Projects a camera-frame point to a pixel; false if the point is not in front.
  template <typename T>
  static bool Project(const T* params, const T* point_in_cam, T* pixel) {
    if (point_in_cam[2] < T(1e-9)) return false;
    const T x = point_in_cam[0] / point_in_cam[2];
    const T y = point_in_cam[1] / point_in_cam[2];
    T xd, yd;
    Distort(params, x, y, &xd, &yd);
    pixel[0] = params[0] * xd + params[2];
    pixel[1] = params[1] * yd + params[3];
    return true;
  }

  // Pixel -> normalised ray (x, y, 1) by Gauss-Newton on Distort (double only). Returns
  // false if it did not converge to 1e-12 (far outside the valid field of the lens).
  static bool Unproject(const double* params, const double* pixel, double* ray) {
    const double xd = (pixel[0] - params[2]) / params[0];
    const double yd = (pixel[1] - params[3]) / params[1];
    double x = xd, y = yd;
    for (int it = 0; it < 50; ++it) {
      using J = ceres::Jet<double, 2>;
      J jx(x, 0), jy(y, 1), ox, oy;
      J jp[kNumParams];
      for (int i = 0; i < kNumParams; ++i) jp[i] = J(params[i]);
      Distort(jp, jx, jy, &ox, &oy);
      const double ex = ox.a - xd, ey = oy.a - yd;
      const double a = ox.v[0], b = ox.v[1], c = oy.v[0], d = oy.v[1];
      const double det = a * d - b * c;
      if (std::abs(det) < 1e-12) return false;
      const double dx = (d * ex - b * ey) / det;
      const double dy = (-c * ex + a * ey) / det;
      x -= dx;
      y -= dy;
      if (std::abs(dx) + std::abs(dy) < 1e-15) break;
    }
    double cx, cy;
    Distort(params, x, y, &cx, &cy);
    if (std::abs(cx - xd) + std::abs(cy - yd) > 1e-12) return false;
    ray[0] = x;
    ray[1] = y;
    ray[2] = 1.0;
    return true;
  }
};

using Camera5 = OpenCvCamera<5>;
using Camera8 = OpenCvCamera<8>;

// Run-time choice of the camera model: this enum, dispatched to the templated models by
// VisitCameraModel below (everything else is templated on the model).
enum class DistortionModel { kOpenCv5, kOpenCv8 };

// A camera as data: model, image size and parameter vector (fx fy cx cy dist...).
struct CameraIntrinsics {
  DistortionModel model = DistortionModel::kOpenCv5;
  int width = 640;
  int height = 480;
  std::vector<double> params = {585, 585, 319.5, 239.5, 0, 0, 0, 0, 0};

  int NumDistortion() const { return model == DistortionModel::kOpenCv5 ? 5 : 8; }
  // cv::Mat-free accessors for the OpenCV distortion vector.
  std::vector<double> Distortion() const { return {params.begin() + 4, params.end()}; }

  bool Project(const double* point_in_cam, double* pixel) const {
    return model == DistortionModel::kOpenCv5 ? Camera5::Project(params.data(), point_in_cam, pixel)
                                              : Camera8::Project(params.data(), point_in_cam, pixel);
  }
  bool Unproject(const double* pixel, double* ray) const {
    return model == DistortionModel::kOpenCv5 ? Camera5::Unproject(params.data(), pixel, ray)
                                              : Camera8::Unproject(params.data(), pixel, ray);
  }
};

// Calls f.template operator()<Camera5>() or <Camera8>() for a run-time model.
template <typename F>
decltype(auto) VisitCameraModel(DistortionModel model, F&& f) {
  if (model == DistortionModel::kOpenCv5) return f.template operator()<Camera5>();
  return f.template operator()<Camera8>();
}

}  // namespace owlcal::models
