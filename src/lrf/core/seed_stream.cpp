#include "lrf/core/seed_stream.h"

namespace lrf {

// The three inputs spread over 64 bits by odd multipliers, then a xor-shift-multiply finaliser so that
// neighbouring steps give unrelated seeds. (The Gaussian trainer's view order and splits have used this
// function since its first release: their fixed-seed results stay as they were.)
uint64_t stream_seed(uint64_t run_seed, SeedStream stream, uint64_t index) {
  uint64_t x = run_seed * 0x9E3779B97F4A7C15ull ^
               (static_cast<uint64_t>(stream) + 0x632BE59BD9B4E019ull) * 0xBF58476D1CE4E5B9ull ^ index;
  x ^= x >> 31;
  x *= 0x94D049BB133111EBull;
  x ^= x >> 29;
  return x;
}

}  // namespace lrf
