#include "core/symmetry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/SVD>

namespace mm {

std::vector<Mat3> symmetryGroup(const std::vector<Mat3>& generators, size_t max) {
  std::vector<Mat3> group{Mat3::Identity()};
  auto known = [&](const Mat3& R) {
    return std::any_of(group.begin(), group.end(), [&](const Mat3& G) { return (G - R).norm() < 1e-6; });
  };
  for (size_t k = 0; k < group.size() && group.size() < max; ++k)
    for (const Mat3& g : generators) {
      const Eigen::JacobiSVD<Mat3> svd(group[k] * g, Eigen::ComputeFullU | Eigen::ComputeFullV);  // products drift
      const Mat3 R = svd.matrixU() * svd.matrixV().transpose();
      if (!known(R) && group.size() < max) group.push_back(R);
    }
  return group;
}

double symmetryResidual(const std::vector<Vec3>& vertices, const Mat3& S) {
  double worst = 0;
  for (const Vec3& v : vertices) {
    double best = std::numeric_limits<double>::infinity();
    for (const Vec3& w : vertices) best = std::min(best, (S * v - w).squaredNorm());
    worst = std::max(worst, best);
  }
  return std::sqrt(worst);
}

}  // namespace mm
