// The statistics the summary and the gate use, against values worked out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "campaign/stats.h"

namespace mm {
namespace {

TEST(Stats, WilsonIntervalMatchesThePublishedFormula) {
  // 100 of 100: [96.30%, 100%] (Wilson 1927; the interval the quickstart reports).
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

TEST(Stats, WilcoxonSignedRankIsExactOnSmallSamples) {
  // Eight positive differences: only the all-plus and all-minus signings reach W+ = 36: p = 2/256.
  const SignedRank all_up = wilcoxonSignedRank({1, 2, 3, 4, 5, 6, 7, 8});
  EXPECT_DOUBLE_EQ(all_up.w_plus, 36);
  EXPECT_DOUBLE_EQ(all_up.p, 2.0 / 256);
  EXPECT_DOUBLE_EQ(wilcoxonSignedRank({1, -1, 2, -2, 0}).p, 1.0);  // symmetric; the zero dropped
  // Against every signing counted out (2^10), ties included (|d| = 3 three times, 5 twice).
  const std::vector<double> d = {-3, 1, 3, 5, -5, 2, 3, 7, 8, -0.5};
  const SignedRank r = wilcoxonSignedRank(d);
  std::vector<double> abs_sorted;
  for (double x : d) abs_sorted.push_back(std::abs(x));
  std::vector<double> rank(d.size());
  for (size_t i = 0; i < d.size(); ++i) {
    double below = 0, equal = 0;
    for (double y : abs_sorted) below += y < std::abs(d[i]), equal += y == std::abs(d[i]);
    rank[i] = below + (equal + 1) / 2;
  }
  double w = 0, total = 0;
  for (size_t i = 0; i < d.size(); ++i) total += rank[i], w += d[i] > 0 ? rank[i] : 0;
  EXPECT_DOUBLE_EQ(r.w_plus, w);
  long extreme = 0;
  for (unsigned mask = 0; mask < (1u << d.size()); ++mask) {
    double s = 0;
    for (size_t i = 0; i < d.size(); ++i) s += (mask >> i & 1) ? rank[i] : 0;
    extreme += std::abs(s - total / 2) >= std::abs(w - total / 2) - 1e-9;
  }
  EXPECT_NEAR(r.p, extreme / 1024.0, 1e-12);
  // Past 50 pairs the normal approximation; at the seam the two agree closely.
  std::vector<double> many;
  for (int i = 1; i <= 50; ++i) many.push_back(i % 3 == 0 ? -i : i);
  const double exact = wilcoxonSignedRank(many).p;
  many.push_back(0.25);  // 51 pairs: the approximation (one tiny extra difference barely moves it)
  EXPECT_NEAR(wilcoxonSignedRank(many).p, exact, 0.1 * exact + 0.005);
}

TEST(Stats, MinimumDetectableRatioShrinksWithTheSample) {
  const double a = minimumDetectablePairedRatio(10, 0.3), b = minimumDetectablePairedRatio(40, 0.3);
  EXPECT_NEAR(std::log(a), 2.8016 * 0.3 / std::sqrt(10.0), 1e-3);  // (z_0.975 + z_0.8) sd / sqrt n
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
