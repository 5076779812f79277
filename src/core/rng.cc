#include "core/rng.h"

#include <cmath>

namespace mm {

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

uint64_t mixSeed(uint64_t a, uint64_t b, uint64_t c) {
  uint64_t s = a;
  uint64_t h = splitmix64(s);
  s = h ^ b;
  h = splitmix64(s);
  s = h ^ c;
  return splitmix64(s);
}

Rng::Rng(uint64_t seed) {
  uint64_t s = seed;
  for (auto& w : s_) w = splitmix64(s);
}

Rng Rng::stream(uint64_t campaign_seed, uint64_t trial, Purpose purpose) {
  return Rng(mixSeed(campaign_seed, trial, static_cast<uint64_t>(purpose)));
}

Rng Rng::stream(uint64_t campaign_seed, uint64_t trial, Purpose purpose, uint64_t sub) {
  return Rng(mixSeed(mixSeed(campaign_seed, trial, static_cast<uint64_t>(purpose)), sub, 0x5eed));
}

static inline uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

uint64_t Rng::next() {  // xoshiro256** (Blackman & Vigna 2018)
  const uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double Rng::uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

uint64_t Rng::below(uint64_t n) {
  if (n <= 1) return 0;
  const uint64_t limit = UINT64_MAX - UINT64_MAX % n;  // rejection: no modulo bias
  uint64_t x;
  do x = next(); while (x >= limit);
  return x % n;
}

double Rng::normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u1;
  do u1 = uniform(); while (u1 <= 0.0);
  const double u2 = uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2.0 * M_PI * u2);
  has_spare_ = true;
  return r * std::cos(2.0 * M_PI * u2);
}

void Rng::normalsAndUniforms(double* normals, double* uniforms, size_t n) {
  size_t i = 0;
  if (n > 0 && has_spare_) {  // the pair drawn last time ends here
    normals[i] = normal();
    uniforms[i++] = uniform();
  }
  // normal(), uniform(), normal() (the spare), uniform(), a pair at a time: the same numbers.
  for (; i + 1 < n; i += 2) {
    double u1;
    do u1 = uniform(); while (u1 <= 0.0);
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    normals[i] = r * std::cos(2.0 * M_PI * u2);
    uniforms[i] = uniform();
    normals[i + 1] = r * std::sin(2.0 * M_PI * u2);
    uniforms[i + 1] = uniform();
  }
  if (i < n) {
    normals[i] = normal();
    uniforms[i] = uniform();
  }
}

}  // namespace mm
