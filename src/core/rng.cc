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

namespace {

// The ziggurat of the normal density's right half, f(x) = exp(-x^2/2) (unnormalized): 128 layers
// of equal area v, layer 0 the base (a rectangle under f(r) widened by the tail beyond r to area v),
// layer i >= 1 the rectangle [0, x[i]) x [f(x[i]), f(x[i+1])]. The constants r and v are the
// published ones for 128 layers (Marsaglia & Tsang 2000, Table 1). ratio[i] = x[i+1] / x[i]: a
// point of layer i below it lies under f whatever its height.
struct Ziggurat {
  static constexpr int kLayers = 128;
  static constexpr double kR = 3.442619855899, kV = 9.91256303526217e-3;
  double x[kLayers + 1];
  double ratio[kLayers];
  Ziggurat() {
    double f = std::exp(-0.5 * kR * kR);
    x[0] = kV / f;
    x[1] = kR;
    for (int i = 2; i < kLayers; ++i) {
      x[i] = std::sqrt(-2 * std::log(kV / x[i - 1] + f));
      f = std::exp(-0.5 * x[i] * x[i]);
    }
    x[kLayers] = 0;
    for (int i = 0; i < kLayers; ++i) ratio[i] = x[i + 1] / x[i];
  }
};

const Ziggurat& ziggurat() {
  static const Ziggurat z;
  return z;
}

}  // namespace

double Rng::zigguratNormal() {
  // One 64-bit draw: its low 7 bits pick the layer, its top 53 a point across it in [-1, 1).
  const uint64_t b = next();
  const int i = static_cast<int>(b & (Ziggurat::kLayers - 1));
  const double u = static_cast<double>(b >> 11) * 0x1.0p-52 - 1.0;
  const Ziggurat& z = ziggurat();
  return std::abs(u) < z.ratio[i] ? u * z.x[i] : zigguratBeyondCore(i, u);
}

double Rng::zigguratBeyondCore(int i, double u) {
  const Ziggurat& z = ziggurat();
  for (;;) {
    if (i == 0) {  // the tail beyond r (Marsaglia 1964)
      double t, y;
      do {
        double u1, u2;
        do u1 = uniform(); while (u1 <= 0.0);
        do u2 = uniform(); while (u2 <= 0.0);
        t = std::log(u1) / Ziggurat::kR;
        y = std::log(u2);
      } while (-2 * y < t * t);
      return u < 0 ? t - Ziggurat::kR : Ziggurat::kR - t;
    }
    // The layer's edge, beyond x[i+1]: under f only where a uniform height says so.
    const double x = u * z.x[i];
    const double f0 = std::exp(-0.5 * (z.x[i] * z.x[i] - x * x)), f1 = std::exp(-0.5 * (z.x[i + 1] * z.x[i + 1] - x * x));
    if (f1 + uniform() * (f0 - f1) < 1.0) return x;
    const uint64_t b = next();  // rejected: a draw afresh, as zigguratNormal's
    i = static_cast<int>(b & (Ziggurat::kLayers - 1));
    u = static_cast<double>(b >> 11) * 0x1.0p-52 - 1.0;
    if (std::abs(u) < z.ratio[i]) return u * z.x[i];
  }
}

void Rng::normalsAndUniforms(double* normals, double* uniforms, size_t n) {
  const Ziggurat& z = ziggurat();
  for (size_t k = 0; k < n; ++k) {
    // One 64-bit draw for both where it can: the layer from bits 0-6, the uniform from bits 7-30,
    // the point across the layer from bits 31-63.
    const uint64_t b = next();
    uniforms[k] = static_cast<double>((b >> 7) & 0xFFFFFF) * 0x1.0p-24;
    const int i = static_cast<int>(b & (Ziggurat::kLayers - 1));
    const double u = static_cast<double>(b >> 31) * 0x1.0p-32 - 1.0;
    normals[k] = std::abs(u) < z.ratio[i] ? u * z.x[i] : zigguratBeyondCore(i, u);
  }
}

void Rng::boxMullerNormalsAndUniforms(double* normals, double* uniforms, size_t n) {
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
