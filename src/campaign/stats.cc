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

double mcnemarExactP(long b, long c) {
  const long n = b + c, k = std::min(b, c);
  if (n == 0) return 1.0;
  // P(X <= k) for X ~ Binomial(n, 1/2), summed in logs (n may be large).
  double tail = 0;
  for (long i = 0; i <= k; ++i)
    tail += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) - n * std::log(2.0));
  return std::min(1.0, 2 * tail);
}

MannWhitney mannWhitneyU(const std::vector<double>& x, const std::vector<double>& y) {
  MannWhitney r;
  const double n1 = x.size(), n2 = y.size(), n = n1 + n2;
  if (x.empty() || y.empty()) return r;
  // Ranks of the pooled sample, ties given their mean rank.
  std::vector<std::pair<double, int>> all;
  for (double v : x) all.push_back({v, 0});
  for (double v : y) all.push_back({v, 1});
  std::sort(all.begin(), all.end());
  double rank_sum_x = 0, tie_term = 0;
  for (size_t i = 0; i < all.size();) {
    size_t j = i;
    while (j < all.size() && all[j].first == all[i].first) ++j;
    const double mean_rank = (i + 1 + j) / 2.0, t = static_cast<double>(j - i);
    for (size_t k = i; k < j; ++k)
      if (all[k].second == 0) rank_sum_x += mean_rank;
    tie_term += t * t * t - t;
    i = j;
  }
  r.u = rank_sum_x - n1 * (n1 + 1) / 2;
  const double mean = n1 * n2 / 2, var = n1 * n2 / 12 * ((n + 1) - tie_term / (n * (n - 1)));
  if (var <= 0) return r;
  const double d = r.u - mean;
  r.z = (std::abs(d) > 0.5 ? d - std::copysign(0.5, d) : 0.0) / std::sqrt(var);
  r.p = std::erfc(std::abs(r.z) / std::sqrt(2.0));
  return r;
}

double minimumDetectableRatio(long n1, long n2, double log_sd, double alpha) {
  if (n1 <= 0 || n2 <= 0) return INFINITY;
  // z of a two-sided alpha: erfc(z / sqrt 2) = alpha, by bisection (erfc falls monotonically).
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double mid = (lo + hi) / 2;
    (std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  const double z_alpha = (lo + hi) / 2, z_power = 0.8416212335729143;  // power 0.8
  return std::exp((z_alpha + z_power) * log_sd * std::sqrt(1.0 / n1 + 1.0 / n2));
}

}  // namespace mm
