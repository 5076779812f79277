// Small statistics for campaign summaries.
#pragma once
#include <utility>
#include <vector>

namespace mm {

/// Wilson score interval for k successes in n trials at 95% (z = 1.96). Wilson 1927.
std::pair<double, double> wilson95(long k, long n);

struct Moments {
  long n = 0;
  double mean = 0, std = 0, min = 0, max = 0;
};
/// Mean, population standard deviation, min and max (zeros when empty).
Moments moments(const std::vector<double>& v);

/// Running moments in constant memory whose result does not depend on the order of the values
/// (a campaign's trials arrive in any order from its workers, its shards in any order at a merge):
/// values are summed as exact integers of 1e-9 (their squares of 1e-18), so the sums are exact and
/// associative; the mean and deviation agree with moments() to ~1e-9 of a unit. The sum of squares
/// holds 1e7 values of magnitude up to ~1e5 (it overflows past ~1.7e38 / 1e18); non-finite values
/// are skipped.
class ExactMoments {
 public:
  void add(double x);
  Moments get() const;

 private:
  long n_ = 0;
  __extension__ typedef __int128 Int128;
  Int128 sum_ = 0, sum_sq_ = 0;
  double min_ = 0, max_ = 0;
};

}  // namespace mm
