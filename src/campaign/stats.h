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

}  // namespace mm
