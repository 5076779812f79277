#include "core/rng.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace mm {

TEST(Rng, StreamsAreReproducibleAndIndependent) {
  Rng a = Rng::stream(42, 7, Purpose::kScene), b = Rng::stream(42, 7, Purpose::kScene);
  Rng c = Rng::stream(42, 7, Purpose::kGrasp), d = Rng::stream(42, 8, Purpose::kScene);
  for (int i = 0; i < 100; ++i) {
    const uint64_t x = a.next();
    EXPECT_EQ(x, b.next());
    EXPECT_NE(x, c.next());
    EXPECT_NE(x, d.next());
  }
}

TEST(Rng, UniformAndNormalMoments) {  // seed 3, 200k draws: mean/var within 5 sigma of the truth
  Rng r(3);
  const int n = 200000;
  double su = 0, sn = 0, sn2 = 0;
  for (int i = 0; i < n; ++i) {
    const double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    su += u;
    const double g = r.normal();
    sn += g, sn2 += g * g;
  }
  EXPECT_NEAR(su / n, 0.5, 5 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(sn / n, 0.0, 5 / std::sqrt(n));
  EXPECT_NEAR(sn2 / n, 1.0, 5 * std::sqrt(2.0 / n));
  for (int i = 0; i < 1000; ++i) EXPECT_LT(r.below(7), 7u);
}

TEST(Rng, BoxMullerNormalsAndUniformsInOneCallDrawWhatPairsOfCallsDraw) {
  // Odd counts leave a spare normal for the next call; both ways must carry it alike.
  Rng bulk(5), calls(5);
  for (const size_t n : {size_t{3}, size_t{640}, size_t{0}, size_t{1}, size_t{2}, size_t{7}}) {
    std::vector<double> g(n), u(n);
    bulk.boxMullerNormalsAndUniforms(g.data(), u.data(), n);
    for (size_t i = 0; i < n; ++i) {
      ASSERT_EQ(g[i], calls.normal()) << n << " " << i;
      ASSERT_EQ(u[i], calls.uniform()) << n << " " << i;
    }
  }
  EXPECT_EQ(bulk.next(), calls.next());
}

TEST(Rng, NormalsAndUniformsInOneCallDrawWhatOneAtATimeDraws) {
  // A row of pixels at once or a pixel at a time (camera_perception_test's reference): the same
  // numbers, the stream left at the same place.
  Rng bulk(5), single(5);
  for (const size_t n : {size_t{3}, size_t{640}, size_t{0}, size_t{1}, size_t{2}, size_t{7}}) {
    std::vector<double> g(n), u(n);
    bulk.normalsAndUniforms(g.data(), u.data(), n);
    for (size_t i = 0; i < n; ++i) {
      double g1, u1;
      single.normalsAndUniforms(&g1, &u1, 1);
      ASSERT_EQ(g[i], g1) << n << " " << i;
      ASSERT_EQ(u[i], u1) << n << " " << i;
    }
  }
  EXPECT_EQ(bulk.next(), single.next());
}

// Normals against the normal distribution, 2 million draws: the Kolmogorov-Smirnov distance
// within its 1% critical value (1.63 / sqrt(n)), and the share in each of 40 bins over [-4, 4]
// and in each tail within 5 binomial sigmas. The bins are narrower than the ziggurat's layers near
// the middle and reach past r = 3.44 (the tail's own sampler), so a wrong table, a wrong edge test
// or a wrong tail shows.
void expectNormal(const std::vector<double>& g) {
  const size_t n = g.size();
  auto cdf = [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); };
  std::vector<double> sorted = g;
  std::sort(sorted.begin(), sorted.end());
  double d = 0;
  for (size_t i = 0; i < n; ++i) {
    const double c = cdf(sorted[i]);
    d = std::max({d, c - static_cast<double>(i) / n, static_cast<double>(i + 1) / n - c});
  }
  EXPECT_LT(d, 1.63 / std::sqrt(static_cast<double>(n)));
  std::vector<double> edges{-INFINITY};
  for (int k = 0; k <= 40; ++k) edges.push_back(-4.0 + 0.2 * k);
  edges.push_back(INFINITY);
  for (size_t b = 0; b + 1 < edges.size(); ++b) {
    const double p = cdf(edges[b + 1]) - cdf(edges[b]);
    const auto count = std::count_if(g.begin(), g.end(), [&](double x) { return x >= edges[b] && x < edges[b + 1]; });
    EXPECT_NEAR(static_cast<double>(count), n * p, 5 * std::sqrt(n * p * (1 - p)) + 1) << "[" << edges[b] << ", " << edges[b + 1] << ")";
  }
  EXPECT_GT(std::count_if(g.begin(), g.end(), [](double x) { return std::abs(x) > 3.442619855899; }), 0) << "the tail is drawn";
}

TEST(Rng, ZigguratNormalsFollowTheNormalDistribution) {
  Rng r(11);
  std::vector<double> g(2000000);
  for (double& x : g) x = r.zigguratNormal();
  expectNormal(g);
}

// The pairs drawn from one 64-bit number: the normals normal, the uniforms uniform (20 bins within
// 5 sigmas), and the two of a pair unrelated (the uniform's mean in each of 8 bands of the normal
// within 5 sigmas of 1/2).
TEST(Rng, NormalsAndUniformsFromOneDrawAreNormalUniformAndIndependent) {
  Rng r(12);
  const size_t n = 2000000;
  std::vector<double> g(n), u(n);
  r.normalsAndUniforms(g.data(), u.data(), n);
  expectNormal(g);
  std::vector<long> bins(20);
  for (const double x : u) {
    ASSERT_GE(x, 0.0);
    ASSERT_LT(x, 1.0);
    ++bins[static_cast<size_t>(x * 20)];
  }
  for (const long c : bins) EXPECT_NEAR(static_cast<double>(c), n / 20.0, 5 * std::sqrt(n * 0.05 * 0.95));
  for (double lo = -2; lo < 2; lo += 0.5) {
    double sum = 0;
    long count = 0;
    for (size_t i = 0; i < n; ++i)
      if (g[i] >= lo && g[i] < lo + 0.5) sum += u[i], ++count;
    ASSERT_GT(count, 1000);
    EXPECT_NEAR(sum / count, 0.5, 5 * std::sqrt(1.0 / 12 / count)) << "normals in [" << lo << ", " << lo + 0.5 << ")";
  }
}

}  // namespace mm
