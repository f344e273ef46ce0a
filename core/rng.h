// Counter-based random numbers: every value is a pure function of (key, counter), so results do not
// depend on which thread, tile or shard computes them. Keys are derived from (seed, sample, pixel,
// purpose) by hashing; draws advance a counter. The mixing function is the 64-bit finaliser of
// SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014).
#pragma once
#include <cstdint>

namespace dg {

inline uint64_t mix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

inline uint64_t hashKey(uint64_t a, uint64_t b = 0, uint64_t c = 0, uint64_t d = 0) {
  uint64_t h = mix64(a);
  h = mix64(h ^ (b + 0x632be59bd9b4e019ull));
  h = mix64(h ^ (c + 0x85157af5ull));
  h = mix64(h ^ (d + 0x2545f4914f6cdd1dull));
  return h;
}

// Purposes, so that streams for different uses never overlap.
enum class Stream : uint64_t { Scene = 1, Pixel = 2, Mask = 3, Defect = 4, PixelPattern = 5, Test = 99 };

class Rng {
 public:
  Rng() = default;
  explicit Rng(uint64_t key) : key_(key) {}
  Rng(uint64_t seed, Stream s, uint64_t a = 0, uint64_t b = 0)
      : key_(hashKey(seed, uint64_t(s), a, b)) {}
  uint64_t next64() { return mix64(key_ ^ mix64(counter_++)); }
  uint32_t next32() { return uint32_t(next64() >> 32); }
  // Uniform in [0, 1).
  float uniform() { return float(next32() >> 8) * (1.0f / 16777216.0f); }
  double uniformD() { return double(next64() >> 11) * (1.0 / 9007199254740992.0); }
  uint64_t counter() const { return counter_; }
  void skipTo(uint64_t c) { counter_ = c; }
  uint64_t key() const { return key_; }

 private:
  uint64_t key_ = 0;
  uint64_t counter_ = 0;
};

}  // namespace dg
