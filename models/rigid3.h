#pragma once
// Rigid transform a_from_b, templated on the scalar. Stored as a 7-block
// [qx, qy, qz, qw, tx, ty, tz] (Eigen quaternion order, docs/conventions.md), so a pose is
// one Ceres parameter block with ProductManifold<EigenQuaternionManifold, EuclideanManifold<3>>.
//   x_in_a = a_from_b * x_in_b = q * x_in_b + t
#include <ceres/jet.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace owlcal::models {

template <typename T>
struct Rigid3 {
  Eigen::Quaternion<T> rotation = Eigen::Quaternion<T>::Identity();
  Eigen::Matrix<T, 3, 1> translation = Eigen::Matrix<T, 3, 1>::Zero();

  Rigid3() = default;
  Rigid3(const Eigen::Quaternion<T>& q, const Eigen::Matrix<T, 3, 1>& t) : rotation(q), translation(t) {}

  // Reads a 7-block [qx qy qz qw tx ty tz]; the quaternion is normalised.
  static Rigid3 Map(const T* p) {
    Eigen::Quaternion<T> q(p[3], p[0], p[1], p[2]);
    q.normalize();
    return Rigid3(q, Eigen::Matrix<T, 3, 1>(p[4], p[5], p[6]));
  }
  void ToArray(T* p) const {
    p[0] = rotation.x();
    p[1] = rotation.y();
    p[2] = rotation.z();
    p[3] = rotation.w();
    p[4] = translation.x();
    p[5] = translation.y();
    p[6] = translation.z();
  }

  Rigid3 Inverse() const {
    const Eigen::Quaternion<T> qi = rotation.conjugate();
    return Rigid3(qi, -(qi * translation));
  }
  Rigid3 operator*(const Rigid3& o) const {
    return Rigid3(rotation * o.rotation, rotation * o.translation + translation);
  }
  Eigen::Matrix<T, 3, 1> operator*(const Eigen::Matrix<T, 3, 1>& x) const { return rotation * x + translation; }

  template <typename U>
  Rigid3<U> cast() const {
    return Rigid3<U>(rotation.template cast<U>(), translation.template cast<U>());
  }
  Eigen::Matrix<T, 4, 4> Matrix() const {
    Eigen::Matrix<T, 4, 4> m = Eigen::Matrix<T, 4, 4>::Identity();
    m.template block<3, 3>(0, 0) = rotation.toRotationMatrix();
    m.template block<3, 1>(0, 3) = translation;
    return m;
  }
};

using Rigid3d = Rigid3<double>;

// Rotation about the y axis (down) by `angle` rad: positive turns +z towards +x (right).
template <typename T>
Eigen::Quaternion<T> RotY(const T& angle) {
  using ceres::cos;
  using ceres::sin;
  using std::cos;
  using std::sin;
  return Eigen::Quaternion<T>(cos(angle / T(2)), T(0), sin(angle / T(2)), T(0));
}
// Rotation about the x axis (right) by `angle` rad: positive turns +z towards -y (up).
template <typename T>
Eigen::Quaternion<T> RotX(const T& angle) {
  using ceres::cos;
  using ceres::sin;
  using std::cos;
  using std::sin;
  return Eigen::Quaternion<T>(cos(angle / T(2)), sin(angle / T(2)), T(0), T(0));
}

}  // namespace owlcal::models
