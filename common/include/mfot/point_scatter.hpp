#pragma once
// A point set's first and second moments, summed in double precision: its centroid, its direction
// of least spread (the normal of its least-squares plane, the smallest eigenvector of the scatter) and
// its spreads along its principal axes.

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <cstddef>

namespace mfot {

class PointScatter {
 public:
  void add(const Eigen::Vector3f& p) {
    const Eigen::Vector3d q = p.cast<double>();
    sum_ += q;
    outer_.noalias() += q * q.transpose();
    ++count_;
  }
  std::size_t count() const { return count_; }
  // Both need count() >= 1; a plane's normal needs count() >= 3 points not on one line.
  Eigen::Vector3d centroid() const { return sum_ / static_cast<double>(count_); }
  Eigen::Vector3d least_spread_direction() const {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance());
    return solver.eigenvectors().col(0);  // eigenvalues ascending
  }
  // The standard deviations along the principal axes, ascending (needs count() >= 1).
  Eigen::Vector3d spreads() const {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance(), Eigen::EigenvaluesOnly);
    return solver.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  }

 private:
  Eigen::Matrix3d covariance() const {
    const Eigen::Vector3d c = centroid();
    return outer_ / static_cast<double>(count_) - c * c.transpose();
  }
  Eigen::Vector3d sum_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer_ = Eigen::Matrix3d::Zero();
  std::size_t count_ = 0;
};

}  // namespace mfot
