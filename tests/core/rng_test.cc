#include "core/rng.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace mm
