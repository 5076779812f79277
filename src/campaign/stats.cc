#include "campaign/stats.h"

#include <algorithm>
#include <cmath>

namespace mm {

std::pair<double, double> wilson95(long k, long n) {
  if (n <= 0) return {0.0, 1.0};
  const double z = 1.959963984540054, p = static_cast<double>(k) / n, z2 = z * z;
  const double denom = 1 + z2 / n;
  const double center = (p + z2 / (2.0 * n)) / denom;
  const double half = z * std::sqrt(p * (1 - p) / n + z2 / (4.0 * n * n)) / denom;
  return {std::max(0.0, center - half), std::min(1.0, center + half)};
}

Moments moments(const std::vector<double>& v) {
  Moments m;
  m.n = static_cast<long>(v.size());
  if (v.empty()) return m;
  double s = 0;
  for (double x : v) s += x;
  m.mean = s / v.size();
  double ss = 0;
  for (double x : v) ss += (x - m.mean) * (x - m.mean);
  m.std = std::sqrt(ss / v.size());
  m.min = *std::min_element(v.begin(), v.end());
  m.max = *std::max_element(v.begin(), v.end());
  return m;
}

void ExactMoments::add(double x) {
  if (!std::isfinite(x)) return;
  const Int128 q = static_cast<Int128>(std::llround(x * 1e9));
  if (n_ == 0 || x < min_) min_ = x;
  if (n_ == 0 || x > max_) max_ = x;
  ++n_;
  sum_ += q;
  sum_sq_ += q * q;
}

Moments ExactMoments::get() const {
  Moments m;
  m.n = n_;
  if (n_ == 0) return m;
  // n*sum_sq - sum^2 from the exact sums, in long double (64-bit mantissa; the integer products
  // could overflow): the same inputs give the same result in any order.
  const long double var_num = static_cast<long double>(n_) * static_cast<long double>(sum_sq_) -
                              static_cast<long double>(sum_) * static_cast<long double>(sum_);
  m.mean = static_cast<double>(sum_) / 1e9 / n_;
  m.std = std::sqrt(std::max(0.0, static_cast<double>(var_num))) / 1e9 / n_;
  m.min = min_, m.max = max_;
  return m;
}

}  // namespace mm
