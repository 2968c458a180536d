// The k smallest of a short list of distinct 64-bit keys, by their positions in the list: the
// neighbour choice of a point among the candidates of its pixel window (recon's prepare_surface),
// where a comparison sort or std::nth_element spends most of its time in mispredicted branches.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace panoscan {

enum class SmallestKeysKernel {
  kFastest,  // up to 64 keys: an AVX-512 quickselect where the CPU has it; else kNthElement
  kNthElement,
};

// Writes the positions of the min(k, count) smallest of keys[0..count) to `positions`, in ascending
// order of position (not of key), and returns how many. The keys must be distinct, which makes the
// chosen set, and so the result, the same for every kernel. `scratch` is reused between calls.
std::size_t smallest_keys(const std::uint64_t* keys, std::size_t count, std::size_t k, std::uint32_t* positions,
                          std::vector<std::uint64_t>& scratch,
                          SmallestKeysKernel kernel = SmallestKeysKernel::kFastest);

// The same for up to 64 keys in slots: keys[s] takes part where bit s of `in_play` is set (other
// slots are not read), and the result has bit s set for each chosen slot.
std::uint64_t smallest_keys_mask(const std::uint64_t* keys, std::uint64_t in_play, std::size_t k,
                                 SmallestKeysKernel kernel = SmallestKeysKernel::kFastest);

}  // namespace panoscan
