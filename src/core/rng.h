// Seeded random streams. Every random choice in a trial draws from a stream derived from
// (campaign seed, trial index, purpose), so outcomes do not depend on worker count or order.
// The generator and the distributions are our own (splitmix64 + xoshiro256**), so the same seed
// gives the same numbers with any standard library.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace mm {

/// What a stream is used for; each purpose gets an independent stream.
enum class Purpose : uint32_t {
  kScene = 1, kPerception = 2, kGrasp = 3, kIk = 4, kPlanner = 5, kFaults = 6, kMisc = 7,
  kCamera = 8,  ///< a camera's sensor noise
};

uint64_t splitmix64(uint64_t& state);
/// Mixes several integers into one seed (order matters).
uint64_t mixSeed(uint64_t a, uint64_t b, uint64_t c = 0);

class Rng {
 public:
  explicit Rng(uint64_t seed);
  /// The stream for (campaign seed, trial index, purpose).
  static Rng stream(uint64_t campaign_seed, uint64_t trial, Purpose purpose);
  /// A sub-stream of a purpose (one per fault kind, say): independent of every other.
  static Rng stream(uint64_t campaign_seed, uint64_t trial, Purpose purpose, uint64_t sub);

  uint64_t next();
  /// Uniform in [0, 1).
  double uniform();
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n).
  uint64_t below(uint64_t n);
  /// Standard normal (Box–Muller).
  double normal();
  /// Standard normal by the ziggurat (Marsaglia & Tsang 2000; 128 layers, the tail and the layers'
  /// edges as in Doornik 2005): all but about 1.3% of draws take one next(), a multiply and a
  /// comparison, no logarithm or sine. Other numbers than normal()'s, drawn about four times
  /// faster (5 against 21 ns a draw on a 2-core EPYC VM).
  double zigguratNormal();
  /// n standard normals (the ziggurat's) and n uniforms in [0, 1) with 24 bits (a float's
  /// precision), each pair from one 64-bit draw but where the normal falls outside its layer's
  /// core (about 1.3%; it draws on there as zigguratNormal does): a depth image's noise, a pair per
  /// pixel, at about a third of boxMullerNormalsAndUniforms's cost.
  void normalsAndUniforms(double* normals, double* uniforms, size_t n);
  /// n draws of normal() then uniform() in turn, into normals[i] and uniforms[i]: the same numbers
  /// as n such pairs of calls, in one call (a depth image's noise as drawn before the ziggurat).
  void boxMullerNormalsAndUniforms(double* normals, double* uniforms, size_t n);
  double normal(double mean, double std) { return mean + std * normal(); }
  /// A 32-bit seed for a library that takes one (OMPL).
  uint32_t seed32() { return static_cast<uint32_t>(next() >> 32) | 1u; }

 private:
  double zigguratBeyondCore(int layer, double u);  ///< the ziggurat's rare path: a layer's edge or the tail

  uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace mm
