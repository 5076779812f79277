// The statistics the summary and the gate use, against values worked out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "campaign/stats.h"

namespace mm {
namespace {

TEST(Stats, WilsonIntervalMatchesThePublishedFormula) {
  // 100 of 100: [96.30%, 100%] (Wilson 1927; the interval the README quotes).
  const auto [lo, hi] = wilson95(100, 100);
  EXPECT_NEAR(lo, 0.9630, 5e-5);
  EXPECT_DOUBLE_EQ(hi, 1.0);
}

TEST(Stats, McNemarExactIsTheBinomialTestOfTheDiscordantPairs) {
  EXPECT_NEAR(mcnemarExactP(0, 6), 2.0 / 64, 1e-15);  // 2 * (1/2)^6
  EXPECT_NEAR(mcnemarExactP(6, 0), 2.0 / 64, 1e-15);
  EXPECT_NEAR(mcnemarExactP(1, 9), 22.0 / 1024, 1e-15);  // 2 * (1 + 10) / 2^10
  EXPECT_DOUBLE_EQ(mcnemarExactP(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(mcnemarExactP(5, 5), 1.0);
  EXPECT_LT(mcnemarExactP(0, 5), 0.07);  // five changed pairs cannot reach 0.05
  EXPECT_GT(mcnemarExactP(0, 5), 0.05);
}

TEST(Stats, MannWhitneyOnSeparatedAndTiedSamples) {
  std::vector<double> x, y;
  for (int i = 1; i <= 8; ++i) x.push_back(i), y.push_back(i + 8);
  const MannWhitney r = mannWhitneyU(x, y);
  EXPECT_DOUBLE_EQ(r.u, 0);
  // mean 32, variance 8*8/12*17; continuity-corrected z = -31.5 / sqrt(90.667) = -3.3082
  EXPECT_NEAR(r.z, -3.3082, 1e-4);
  EXPECT_NEAR(r.p, 0.000939, 2e-6);
  const MannWhitney same = mannWhitneyU(x, x);
  EXPECT_DOUBLE_EQ(same.u, 32);
  EXPECT_DOUBLE_EQ(same.p, 1.0);
  const MannWhitney ties = mannWhitneyU({1, 1, 1, 1}, {1, 1, 1, 1});
  EXPECT_DOUBLE_EQ(ties.p, 1.0);  // no spread: nothing to detect
}

TEST(Stats, MinimumDetectableRatioShrinksWithTheSample) {
  const double a = minimumDetectableRatio(10, 10, 0.3), b = minimumDetectableRatio(40, 40, 0.3);
  EXPECT_NEAR(std::log(a), 2.8016 * 0.3 * std::sqrt(0.2), 1e-3);
  EXPECT_LT(b, a);
  EXPECT_GT(b, 1.0);
}

TEST(Stats, ExactMomentsDoNotDependOnOrder) {
  ExactMoments f, r;
  std::vector<double> v;
  for (int i = 0; i < 1000; ++i) v.push_back(std::sin(i) * 7.3 + 8);
  for (double x : v) f.add(x);
  for (auto it = v.rbegin(); it != v.rend(); ++it) r.add(*it);
  EXPECT_EQ(f.get().mean, r.get().mean);
  EXPECT_EQ(f.get().std, r.get().std);
  const Moments m = moments(v);
  EXPECT_NEAR(f.get().mean, m.mean, 1e-9);
  EXPECT_NEAR(f.get().std, m.std, 1e-8);
}

}  // namespace
}  // namespace mm
