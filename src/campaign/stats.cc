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

SignedRank wilcoxonSignedRank(const std::vector<double>& differences) {
  SignedRank r;
  std::vector<double> a;
  for (double d : differences)
    if (d != 0 && std::isfinite(d)) a.push_back(d);
  const size_t n = a.size();
  r.n = static_cast<long>(n);
  if (n == 0) return r;
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t i, size_t j) { return std::abs(a[i]) < std::abs(a[j]); });
  // Doubled ranks (integers even with ties: a tie group's mean rank times two).
  std::vector<long> rank2(n);
  double tie_term = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && std::abs(a[order[j]]) == std::abs(a[order[i]])) ++j;
    const long doubled = static_cast<long>(i + 1 + j);  // 2 x ((i+1) + j) / 2
    for (size_t k = i; k < j; ++k) rank2[order[k]] = doubled;
    const double t = static_cast<double>(j - i);
    tie_term += t * t * t - t;
    i = j;
  }
  long w2 = 0, total2 = 0;
  for (size_t i = 0; i < n; ++i) {
    total2 += rank2[i];
    if (a[i] > 0) w2 += rank2[i];
  }
  r.w_plus = w2 / 2.0;
  if (n <= 50) {
    // The number of sign assignments giving each doubled sum, by dynamic programming (2^n of them).
    std::vector<double> ways(static_cast<size_t>(total2) + 1, 0.0);
    ways[0] = 1;
    for (size_t i = 0; i < n; ++i)
      for (long s = total2; s >= rank2[i]; --s) ways[static_cast<size_t>(s)] += ways[static_cast<size_t>(s - rank2[i])];
    const double all = std::ldexp(1.0, static_cast<int>(n));
    // Two-sided: the tail at least as far from the centre as the observed sum, both sides.
    const long lo = std::min(w2, total2 - w2);
    double tail = 0;
    for (long s = 0; s <= lo; ++s) tail += ways[static_cast<size_t>(s)];
    r.p = std::min(1.0, 2 * tail / all);
    return r;
  }
  const double nn = static_cast<double>(n);
  const double mean = nn * (nn + 1) / 4, var = nn * (nn + 1) * (2 * nn + 1) / 24 - tie_term / 48;
  if (var <= 0) return r;
  const double d = r.w_plus - mean;
  const double z = (std::abs(d) > 0.5 ? d - std::copysign(0.5, d) : 0.0) / std::sqrt(var);
  r.p = std::erfc(std::abs(z) / std::sqrt(2.0));
  return r;
}

namespace {

// z of a two-sided alpha: erfc(z / sqrt 2) = alpha, by bisection (erfc falls monotonically).
double zTwoSided(double alpha) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double mid = (lo + hi) / 2;
    (std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

}  // namespace

double minimumDetectablePairedRatio(long n, double log_ratio_sd, double alpha) {
  if (n <= 0) return INFINITY;
  return std::exp((zTwoSided(alpha) + 0.8416212335729143) * log_ratio_sd / std::sqrt(static_cast<double>(n)));
}


}  // namespace mm
