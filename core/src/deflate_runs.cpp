// DEFLATE writers for literals and runs, and for literals and repeats of nearby 16-bit pixels (see
// deflate_runs.h). Why they exist: the simulator writes two PNGs per frame, and libdeflate's fastest
// level (1) spent most of a frame's time looking for matches of any kind. After PNG's Sub filter the
// matches a noisy colour frame has are runs (equal neighbouring pixels become runs of zeros); coding
// only those takes 1.2 instead of 2.8 ms per 640x480 frame for a file 5-13% larger. Quantised depth
// repeats a few values at short distances: matches with one of the 16 pixels before in the row or
// the pixel above take 1.5-1.6 instead of libdeflate's 1.9-2.0 ms for files 11-15% larger
// (sim/README.md has the measurements). zlib's Z_RLE strategy codes runs but is slower than
// libdeflate itself, and ISA-L's igzip did not give the same bytes for the same input (sim/README.md).
#include "deflate_runs.h"

#include <algorithm>
#include <array>
#include <memory>
#include <cstring>
#include <vector>

#include <libdeflate.h>
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "panoscan/core/cpu_features.h"

namespace panoscan::detail {

namespace {

constexpr int kLitLenSymbols = 286;  // 0-255 literals, 256 end of block, 257-285 lengths
constexpr int kEndOfBlock = 256;
constexpr int kMinRun = 3, kMaxRun = 258;
constexpr std::size_t kRunBlockTokens = 32768;
constexpr std::size_t kStoredMax = 65535;

// RFC 1951 3.2.5: the length symbols' base lengths and extra bits.
constexpr std::array<int, 29> kLengthBase = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                             31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
constexpr std::array<int, 29> kLengthExtra = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                              2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
// The order in which the code-length code's lengths are sent (RFC 1951 3.2.7).
constexpr std::array<int, 19> kCodeLengthOrder = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};

// A token: bits 0-8 the literal/length symbol, 9-13 a length's extra value.
using Token = std::uint16_t;

struct RunTable {
  Token token[kMaxRun + 1];  // by run length 3 .. 258
  RunTable() {
    for (int length = kMinRun; length <= kMaxRun; ++length) {
      int code = 28;
      while (kLengthBase[code] > length) --code;
      token[length] = Token(257 + code) | Token(length - kLengthBase[code]) << 9;
    }
  }
};
const RunTable kRuns;

// How many bytes from `at` (< end) equal `value`, at most `limit`.
inline std::size_t run_length(const std::uint8_t* at, const std::uint8_t* end, std::uint8_t value, std::size_t limit) {
  const std::size_t available = std::min<std::size_t>(limit, std::size_t(end - at));
  const std::uint64_t pattern = 0x0101010101010101ull * value;
  std::size_t n = 0;
  while (n + 8 <= available) {
    std::uint64_t word;
    std::memcpy(&word, at + n, 8);
    const std::uint64_t differ = word ^ pattern;
    if (differ) return n + std::size_t(__builtin_ctzll(differ)) / 8;  // little-endian: the first differing byte
    n += 8;
  }
  while (n < available && at[n] == value) ++n;
  return n;
}

// Bits appended least significant first (RFC 1951 3.1.1). Each put writes the accumulator's eight
// bytes and moves on by its whole bytes, without a branch (the literals' flushes were mispredicted);
// `out` has 8 bytes of room past the stream.
class BitWriter {
 public:
  explicit BitWriter(std::uint8_t* out) : out_(out) {}
  void put(std::uint64_t value, int count) {  // count <= 56
    acc_ |= value << bits_;
    bits_ += count;
    std::memcpy(out_, &acc_, 8);  // little-endian x86-64: the bytes in stream order
    out_ += bits_ >> 3;
    acc_ >>= bits_ & ~7;
    bits_ &= 7;
  }
  // Pads to a byte boundary; returns the end.
  std::uint8_t* finish() {
    if (bits_ > 0) *out_++ = std::uint8_t(acc_);
    acc_ = 0;
    bits_ = 0;
    return out_;
  }

 private:
  std::uint8_t* out_;
  std::uint64_t acc_ = 0;
  int bits_ = 0;
};

inline std::uint32_t reverse_bits(std::uint32_t code, int length) {
  std::uint32_t reversed = 0;
  for (int i = 0; i < length; ++i) reversed |= ((code >> i) & 1u) << (length - 1 - i);
  return reversed;
}

// Canonical codes (RFC 1951 3.2.2) of `lengths`, bit-reversed for the LSB-first stream.
void canonical_codes(const std::uint8_t* lengths, int count, std::uint32_t* codes) {
  int length_count[16] = {};
  for (int s = 0; s < count; ++s) ++length_count[lengths[s]];
  length_count[0] = 0;
  std::uint32_t next[16] = {};
  std::uint32_t code = 0;
  for (int bits = 1; bits < 16; ++bits) {
    code = (code + std::uint32_t(length_count[bits - 1])) << 1;
    next[bits] = code;
  }
  for (int s = 0; s < count; ++s) codes[s] = lengths[s] ? reverse_bits(next[lengths[s]]++, lengths[s]) : 0;
}

// The code lengths as code-length symbols (RFC 1951 3.2.7): 0-15 a length, 16 the previous length
// 3-6 times, 17 zero 3-10 times, 18 zero 11-138 times. Each entry: symbol | repeat extra << 8.
std::vector<std::uint32_t> code_length_symbols(const std::uint8_t* lengths, int count) {
  std::vector<std::uint32_t> symbols;
  for (int i = 0; i < count;) {
    const std::uint8_t length = lengths[i];
    int run = 1;
    while (i + run < count && lengths[i + run] == length) ++run;
    i += run;
    if (length == 0) {
      while (run >= 11) {
        const int n = std::min(run, 138);
        symbols.push_back(18u | std::uint32_t(n - 11) << 8);
        run -= n;
      }
      if (run >= 3) {
        symbols.push_back(17u | std::uint32_t(run - 3) << 8);
        run = 0;
      }
      while (run-- > 0) symbols.push_back(0);
    } else {
      symbols.push_back(length);
      --run;
      while (run >= 3) {
        const int n = std::min(run, 6);
        symbols.push_back(16u | std::uint32_t(n - 3) << 8);
        run -= n;
      }
      while (run-- > 0) symbols.push_back(length);
    }
  }
  return symbols;
}

constexpr int kRepeatExtraBits[3] = {2, 3, 7};  // symbols 16, 17, 18

// Writes data[begin, end) as stored blocks; `last`: the final block of the stream.
std::uint8_t* put_stored(BitWriter& writer, const std::uint8_t* begin, const std::uint8_t* end, bool last) {
  std::uint8_t* out = nullptr;
  do {
    const std::size_t n = std::min<std::size_t>(kStoredMax, std::size_t(end - begin));
    const bool final_chunk = last && begin + n == end;
    writer.put(final_chunk ? 1 : 0, 3);  // BFINAL, BTYPE 00
    out = writer.finish();
    const std::uint16_t len = std::uint16_t(n), nlen = std::uint16_t(~len);
    std::memcpy(out, &len, 2);
    std::memcpy(out + 2, &nlen, 2);
    std::memcpy(out + 4, begin, n);
    out += 4 + n;
    writer = BitWriter(out);
    begin += n;
  } while (begin < end);
  return out;
}

}  // namespace

void huffman_code_lengths(const std::uint32_t* freq, int count, int max_length, std::uint8_t* lengths) {
  std::vector<std::uint64_t> weight(freq, freq + count);
  std::fill(lengths, lengths + count, std::uint8_t(0));
  std::vector<int> used;
  for (int s = 0; s < count; ++s)
    if (weight[s]) used.push_back(s);
  // A complete code needs two symbols: add the first unused ones with the least weight.
  for (int s = 0; used.size() < 2 && s < count; ++s)
    if (!weight[s]) {
      weight[s] = 1;
      used.push_back(s);
    }
  std::sort(used.begin(), used.end());
  const int n = int(used.size());
  for (;;) {
    // Huffman's construction with two queues over the leaves sorted by (weight, symbol): ties broken
    // by symbol, so the lengths depend only on the weights.
    std::vector<int> leaves(used);
    std::stable_sort(leaves.begin(), leaves.end(), [&](int a, int b) { return weight[a] < weight[b]; });
    std::vector<std::uint64_t> node_weight(2 * n - 1);
    std::vector<int> parent(2 * n - 1, -1);
    for (int i = 0; i < n; ++i) node_weight[i] = weight[leaves[i]];
    int next_leaf = 0, next_inner = n, made = n;
    const auto take = [&] {
      if (next_leaf < n && (next_inner >= made || node_weight[next_leaf] <= node_weight[next_inner]))
        return next_leaf++;
      return next_inner++;
    };
    while (made < 2 * n - 1) {
      const int a = take(), b = take();
      node_weight[made] = node_weight[a] + node_weight[b];
      parent[a] = parent[b] = made;
      ++made;
    }
    std::vector<int> depth(2 * n - 1, 0);
    int deepest = 0;
    for (int i = 2 * n - 3; i >= 0; --i) {
      depth[i] = depth[parent[i]] + 1;
      if (i < n) deepest = std::max(deepest, depth[i]);
    }
    if (deepest <= max_length) {
      for (int i = 0; i < n; ++i) lengths[leaves[i]] = std::uint8_t(depth[i]);
      return;
    }
    // Too deep: flatten the weights and build again (rare: a few symbols far rarer than the rest).
    for (int s : used) weight[s] = (weight[s] >> 1) | 1;
  }
}

std::size_t zlib_runs_bound(std::size_t size) {
  // Every block stored (5 bytes per 65535 and a byte of padding) or a dynamic block no larger; a
  // block has kRunBlockTokens tokens of at least a byte each, but the last.
  const std::size_t blocks = size / kStoredMax + size / kRunBlockTokens + 2;
  return 2 + size + 8 * blocks + 4 + 32;
}

namespace {

// RFC 1951 3.2.5: the distance codes' base distances and extra bits.
constexpr std::array<int, 30> kDistanceBase = {1,    2,    3,    4,    5,    7,    9,    13,    17,    25,
                                               33,   49,   65,   97,   129,  193,  257,  385,   513,   769,
                                               1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
constexpr std::array<int, 30> kDistanceExtra = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                                6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};
constexpr int kDistanceCodes = 30;

// The tokens of the two coders. Runs: bits 0-8 the literal/length symbol, 9-13 a length's extra
// value; every match is at distance 1. Repeats: the same, and bits 14-18 a match's distance code,
// 19-31 its extra value.
using RepeatToken = std::uint32_t;

RepeatToken repeat_distance_fields(int distance) {
  int code = kDistanceCodes - 1;
  while (kDistanceBase[code] > distance) --code;
  return RepeatToken(code) << 14 | RepeatToken(distance - kDistanceBase[code]) << 19;
}

// Writes `count` tokens of data[block_begin, block_end) as one dynamic-Huffman block, or as stored
// blocks where those are smaller; `last`: the stream's final block. kDistances: the tokens carry
// their distances (RepeatToken), else every match is at distance 1 (Token).
template <bool kDistances, typename AnyToken>
void put_block(BitWriter& writer, const AnyToken* tokens, std::size_t count, const std::uint8_t* block_begin,
               const std::uint8_t* block_end, bool last) {
  // The histogram in four tables: consecutive equal symbols would otherwise wait on each other's
  // increments.
  std::uint32_t partial[4][kLitLenSymbols] = {};
  std::size_t t = 0;
  for (; t + 4 <= count; t += 4)
    for (int k = 0; k < 4; ++k) ++partial[k][tokens[t + k] & 511u];
  for (; t < count; ++t) ++partial[0][tokens[t] & 511u];
  std::uint32_t lit_freq[kLitLenSymbols];
  for (int sym = 0; sym < kLitLenSymbols; ++sym)
    lit_freq[sym] = partial[0][sym] + partial[1][sym] + partial[2][sym] + partial[3][sym];
  lit_freq[kEndOfBlock] = 1;
  std::uint32_t dist_freq[kDistanceCodes] = {};
  if constexpr (kDistances) {
    for (std::size_t i = 0; i < count; ++i)
      if ((tokens[i] & 511u) > unsigned(kEndOfBlock)) ++dist_freq[(tokens[i] >> 14) & 31u];
  } else {
    dist_freq[0] = 1;  // distance 1 only (the code gets a second, unused one-bit code below)
  }

  std::uint8_t lit_length[kLitLenSymbols], dist_length[kDistanceCodes];
  huffman_code_lengths(lit_freq, kLitLenSymbols, 15, lit_length);
  huffman_code_lengths(dist_freq, kDistanceCodes, 15, dist_length);
  int lit_count = kLitLenSymbols;
  while (lit_count > 257 && lit_length[lit_count - 1] == 0) --lit_count;
  int dist_count = kDistanceCodes;
  while (dist_count > 1 && dist_length[dist_count - 1] == 0) --dist_count;
  std::uint8_t all_lengths[kLitLenSymbols + kDistanceCodes];
  std::copy(lit_length, lit_length + lit_count, all_lengths);
  std::copy(dist_length, dist_length + dist_count, all_lengths + lit_count);
  const std::vector<std::uint32_t> cl_symbols = code_length_symbols(all_lengths, lit_count + dist_count);
  std::uint32_t cl_freq[19] = {};
  for (std::uint32_t s : cl_symbols) ++cl_freq[s & 255u];
  std::uint8_t cl_length[19];
  huffman_code_lengths(cl_freq, 19, 7, cl_length);
  int cl_count = 19;
  while (cl_count > 4 && cl_length[kCodeLengthOrder[cl_count - 1]] == 0) --cl_count;

  // The dynamic block's size in bits against storing the bytes.
  std::uint64_t dynamic_bits = 3 + 5 + 5 + 4 + 3 * std::uint64_t(cl_count);
  for (std::uint32_t s : cl_symbols)
    dynamic_bits += cl_length[s & 255u] + (s >= 16 ? kRepeatExtraBits[(s & 255u) - 16] : 0);
  for (int s = 0; s < kLitLenSymbols; ++s) {
    std::uint64_t bits = lit_length[s];
    if (s > kEndOfBlock) bits += std::uint64_t(kLengthExtra[s - 257]);
    dynamic_bits += bits * lit_freq[s];
  }
  if constexpr (kDistances) {
    for (int d = 0; d < kDistanceCodes; ++d)
      dynamic_bits += std::uint64_t(dist_length[d] + kDistanceExtra[d]) * dist_freq[d];
  } else {
    for (int s = kEndOfBlock + 1; s < kLitLenSymbols; ++s) dynamic_bits += std::uint64_t(dist_length[0]) * lit_freq[s];
  }
  const std::size_t block_bytes = std::size_t(block_end - block_begin);
  const std::uint64_t stored_bits = (block_bytes + 5 * (block_bytes / kStoredMax + 1)) * 8 + 8;
  if (dynamic_bits >= stored_bits) {
    writer = BitWriter(put_stored(writer, block_begin, block_end, last));
    return;
  }

  std::uint32_t lit_code[kLitLenSymbols], dist_code[kDistanceCodes], cl_code[19];
  canonical_codes(lit_length, kLitLenSymbols, lit_code);
  canonical_codes(dist_length, kDistanceCodes, dist_code);
  canonical_codes(cl_length, 19, cl_code);
  writer.put(last ? 1 : 0, 1);
  writer.put(2, 2);  // BTYPE 10: dynamic Huffman codes
  writer.put(std::uint32_t(lit_count - 257), 5);
  writer.put(std::uint32_t(dist_count - 1), 5);
  writer.put(std::uint32_t(cl_count - 4), 4);
  for (int i = 0; i < cl_count; ++i) writer.put(cl_length[kCodeLengthOrder[i]], 3);
  for (std::uint32_t s : cl_symbols) {
    const std::uint32_t symbol = s & 255u;
    writer.put(cl_code[symbol], cl_length[symbol]);
    if (symbol >= 16) writer.put(s >> 8, kRepeatExtraBits[symbol - 16]);
  }
  // A token's bits: its code and a length's extra bits, then a match's distance code and extra
  // bits; without a branch on the kind of token.
  std::uint8_t token_bits[kLitLenSymbols];
  for (int sym = 0; sym < kLitLenSymbols; ++sym)
    token_bits[sym] = std::uint8_t(lit_length[sym] + (sym > kEndOfBlock ? kLengthExtra[sym - 257] : 0));
  // A local writer: the caller's, reached through a reference, had to be reloaded after every
  // byte store (a store through std::uint8_t* may alias it), which made the loops 20% slower.
  BitWriter local = writer;
  if constexpr (kDistances) {
    std::uint8_t dist_bits[kDistanceCodes];
    for (int d = 0; d < kDistanceCodes; ++d) dist_bits[d] = std::uint8_t(dist_length[d] + kDistanceExtra[d]);
    for (std::size_t i = 0; i < count; ++i) {
      const RepeatToken token = tokens[i];
      const std::uint32_t symbol = token & 511u, distance = (token >> 14) & 31u;
      // All ones for a match, else 0: a literal's token has no distance fields to write.
      const std::uint64_t match = 0 - std::uint64_t(symbol > unsigned(kEndOfBlock));
      const int bits = token_bits[symbol];
      const std::uint64_t distance_value = dist_code[distance] | std::uint64_t(token >> 19) << dist_length[distance];
      local.put(lit_code[symbol] | std::uint64_t((token >> 9) & 31u) << lit_length[symbol] |
                    ((distance_value << bits) & match),
                bits + int(dist_bits[distance] & std::uint8_t(match)));
    }
  } else {
    // dist_code[0] is 0: distance code 0's bits after a length are zeros. Two tokens per put (at most
    // 2 x 21 bits): the writer's state is a chain of dependent steps, half as long this way.
    for (int sym = kEndOfBlock + 1; sym < kLitLenSymbols; ++sym) token_bits[sym] += dist_length[0];
    const auto value = [&](std::size_t i) {
      return lit_code[tokens[i] & 511u] | std::uint64_t(tokens[i] >> 9) << lit_length[tokens[i] & 511u];
    };
    std::size_t i = 0;
    for (; i + 2 <= count; i += 2) {
      const int first_bits = token_bits[tokens[i] & 511u];
      local.put(value(i) | value(i + 1) << first_bits, first_bits + token_bits[tokens[i + 1] & 511u]);
    }
    if (i < count) local.put(value(i), token_bits[tokens[i] & 511u]);
  }
  writer = local;
  writer.put(lit_code[kEndOfBlock], lit_length[kEndOfBlock]);
}

std::uint8_t* put_zlib_header(std::uint8_t* out) {
  *out++ = 0x78;  // CMF: deflate, 32 KB window
  *out++ = 0x01;  // FLG: fastest, no dictionary; (CMF * 256 + FLG) % 31 == 0
  return out;
}

std::size_t put_zlib_trailer(BitWriter& writer, const std::uint8_t* data, std::size_t size, std::uint8_t* out) {
  std::uint8_t* cursor = writer.finish();
  const std::uint32_t adler = libdeflate_adler32(1, data, size);
  const std::uint8_t trailer[4] = {std::uint8_t(adler >> 24), std::uint8_t(adler >> 16), std::uint8_t(adler >> 8),
                                   std::uint8_t(adler)};
  std::memcpy(cursor, trailer, 4);
  return std::size_t(cursor + 4 - out);
}

}  // namespace

std::size_t zlib_compress_runs(const std::uint8_t* data, std::size_t size, std::uint8_t* out) {
  BitWriter writer(put_zlib_header(out));
  const std::unique_ptr<Token[]> tokens(new Token[kRunBlockTokens]);
  const std::uint8_t* at = data;
  const std::uint8_t* const end = data + size;
  do {
    // Tokenise one block: a byte equal to the one before it starts a run.
    const std::uint8_t* const block_begin = at;
    // Sixteen bytes at a time where there is room: the positions whose byte and the next two equal
    // the byte before (a run of at least three) from one compare with the bytes one back; the bytes
    // before the first such position are literals, without a branch each (noisy images have equal
    // neighbours at random, a mispredicted branch per byte). Where none of the first 14 starts a
    // run, 14 literals. (Eight bytes at a time in a 64-bit word took six literals a step.)
    std::size_t count = 0;
    if (at == data && at < end) tokens[count++] = *at++;
#if defined(__SSE2__)
    while (count + 16 <= kRunBlockTokens && end - at >= 16) {
      const __m128i bytes = _mm_loadu_si128(reinterpret_cast<const __m128i*>(at));
      const __m128i previous = _mm_loadu_si128(reinterpret_cast<const __m128i*>(at - 1));
      const unsigned equal = unsigned(_mm_movemask_epi8(_mm_cmpeq_epi8(bytes, previous)));  // bit k: at[k] == at[k-1]
      const unsigned starts = equal & (equal >> 1) & (equal >> 2) & 0x3FFFu;                // k, k+1, k+2 (k < 14)
      const int literals = starts ? __builtin_ctz(starts) : 14;
      // All sixteen as tokens (a byte widened to 16 bits is its literal token), then keep `literals`.
      const __m128i zero = _mm_setzero_si128();
      _mm_storeu_si128(reinterpret_cast<__m128i*>(&tokens[count]), _mm_unpacklo_epi8(bytes, zero));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(&tokens[count + 8]), _mm_unpackhi_epi8(bytes, zero));
      count += literals;
      at += literals;
      if (starts) {
        // The run's bytes within the window are the set bits of `equal` from the start on; only a run
        // that reaches the window's end is followed further (the loop's exit was mispredicted once a
        // run, and most runs are short).
        std::size_t run = std::size_t(__builtin_ctz(~(equal >> literals)));
        if (run == std::size_t(16 - literals)) run += run_length(at + run, end, at[-1], kMaxRun - run);
        tokens[count++] = kRuns.token[run];
        at += run;
      }
    }
#else
    constexpr std::uint64_t kLow7 = 0x7F7F7F7F7F7F7F7Full;
    while (count + 8 <= kRunBlockTokens && end - at >= 8) {
      std::uint64_t bytes, previous;
      std::memcpy(&bytes, at, 8);
      std::memcpy(&previous, at - 1, 8);
      const std::uint64_t x = bytes ^ previous;
      const std::uint64_t zero = ~(((x & kLow7) + kLow7) | x | kLow7);  // 0x80 where byte k equals byte k - 1
      const std::uint64_t starts = zero & (zero >> 8) & (zero >> 16);   // bytes k, k+1, k+2 (k < 6)
      const int literals = starts ? __builtin_ctzll(starts) / 8 : 6;
      for (int k = 0; k < 8; ++k) tokens[count + k] = at[k];  // all eight, then keep `literals`
      count += literals;
      at += literals;
      if (starts) {
        const std::size_t run = run_length(at, end, at[-1], kMaxRun);
        tokens[count++] = kRuns.token[run];
        at += run;
      }
    }
#endif
    // The last few bytes of the block or of the data one at a time.
    while (at < end && count < kRunBlockTokens) {
      if (*at == at[-1]) {
        const std::size_t run = run_length(at, end, at[-1], kMaxRun);
        if (run >= std::size_t(kMinRun)) {
          tokens[count++] = kRuns.token[run];
          at += run;
          continue;
        }
      }
      tokens[count++] = *at++;
    }
    put_block<false>(writer, tokens.get(), count, block_begin, at, at == end);
  } while (at < end);
  return put_zlib_trailer(writer, data, size, out);
}

namespace {

constexpr int kRepeatPixels = 16;  // matches with the 1st .. 16th pixel before in the row
constexpr std::uint32_t kAboveBit = 1u << kRepeatPixels;
constexpr std::size_t kUnrolled = 6;  // a run's first pixels extended without a branch

#if defined(__x86_64__) && defined(__GNUC__)
// repeat_candidates' window loop for pixels [first, pixels) (first >= 16), one 16-lane compare each:
// the same masks as the SSE2 loop's.
__attribute__((target("avx512bw,avx512vl"))) void repeat_candidates_avx512(const std::uint8_t* row, std::size_t pixels,
                                                                           std::size_t first,
                                                                           std::uint32_t* candidates) {
  for (std::size_t x = first; x < pixels; ++x) {
    std::uint16_t value;
    std::memcpy(&value, row + 2 * x, 2);
    const __m256i window = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(row + 2 * (x - kRepeatPixels)));
    candidates[x] = std::uint32_t(_mm256_cmpeq_epi16_mask(window, _mm256_set1_epi16(short(value))));
  }
}
#endif

// Which of the pixels before pixel x of a row of 16-bit samples (raw, 2 bytes each) equal it: bit j
// for the pixel 16 - j before (j = 0 .. 15, those before the row's start never set), and kAboveBit
// where the same pixel of the row above (`above`, null for the first row) equals it.
void repeat_candidates(const std::uint8_t* row, const std::uint8_t* above, std::size_t pixels,
                       std::uint32_t* candidates) {
  const auto pixel = [](const std::uint8_t* at) {
    std::uint16_t value;
    std::memcpy(&value, at, 2);
    return value;
  };
  std::size_t x = 0;
  // The first pixels one by one: fewer than 16 pixels precede them.
  for (; x < pixels && x < std::size_t(kRepeatPixels); ++x) {
    const std::uint16_t value = pixel(row + 2 * x);
    std::uint32_t mask = 0;
    for (std::size_t back = 1; back <= x; ++back)
      mask |= std::uint32_t(pixel(row + 2 * (x - back)) == value) << (kRepeatPixels - back);
    candidates[x] = mask;
  }
#if defined(__x86_64__) && defined(__GNUC__)
  if (cpu::has_avx512bw()) {
    repeat_candidates_avx512(row, pixels, x, candidates);
    x = pixels;
  }
#endif
#if defined(__SSE2__)
  // The sixteen pixels before as two 8-lane compares, packed to one byte per lane.
  for (; x < pixels; ++x) {
    const __m128i value = _mm_set1_epi16(short(pixel(row + 2 * x)));
    const std::uint8_t* window = row + 2 * (x - kRepeatPixels);
    const __m128i first = _mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(window)), value);
    const __m128i second = _mm_cmpeq_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(window + 16)), value);
    candidates[x] = std::uint32_t(_mm_movemask_epi8(_mm_packs_epi16(first, second)));
  }
#else
  for (; x < pixels; ++x) {
    const std::uint16_t value = pixel(row + 2 * x);
    std::uint32_t mask = 0;
    for (int j = 0; j < kRepeatPixels; ++j)
      mask |= std::uint32_t(pixel(row + 2 * (x - kRepeatPixels + j)) == value) << j;
    candidates[x] = mask;
  }
#endif
  if (above)
    for (x = 0; x < pixels; ++x)
      candidates[x] |= std::uint32_t(pixel(row + 2 * x) == pixel(above + 2 * x)) << kRepeatPixels;
}

}  // namespace

std::size_t zlib_compress_repeats16(const std::uint8_t* data, std::size_t rows, std::size_t row_pixels,
                                    std::uint8_t* out) {
  const std::size_t stride = 1 + 2 * row_pixels, size = rows * stride;
  BitWriter writer(put_zlib_header(out));
  // A block ends after the row that reaches kRunBlockTokens tokens (a row is at most 2 per pixel
  // and its filter byte).
  const std::size_t capacity = kRunBlockTokens + stride + 1;  // + 1: a literal's second token past a match
  const std::unique_ptr<RepeatToken[]> tokens(new RepeatToken[capacity]);
  const std::unique_ptr<std::uint32_t[]> candidates(new std::uint32_t[row_pixels + kUnrolled]);
  // A match's distance fields by candidate bit: bit j the pixel 16 - j before, kAboveBit the row
  // above (one stride back; only where the window reaches it).
  RepeatToken distance_fields[kRepeatPixels + 1];
  for (int j = 0; j < kRepeatPixels; ++j) distance_fields[j] = repeat_distance_fields(2 * (kRepeatPixels - j));
  const bool above_in_window = stride <= 32768;
  distance_fields[kRepeatPixels] = above_in_window ? repeat_distance_fields(int(stride)) : 0;
  const std::uint8_t* block_begin = data;
  std::size_t count = 0;
  for (std::size_t y = 0; y < rows; ++y) {
    const std::uint8_t* line = data + y * stride;
    tokens[count++] = line[0];  // the row's filter byte
    const std::uint8_t* row = line + 1;
    repeat_candidates(row, y > 0 && above_in_window ? row - stride : nullptr, row_pixels, candidates.get());
    std::fill(candidates.get() + row_pixels, candidates.get() + row_pixels + kUnrolled, 0u);  // no match continues
    for (std::size_t x = 0; x < row_pixels;) {
      // Greedy: the longest run of pixels that repeat one candidate, two pixels (4 bytes) at least,
      // 129 (258 bytes) at most; the nearest candidate among the longest (the cheapest distance).
      // Without a branch on the kind of token or on where a run ends (both are at random in noisy
      // depth: a branch was mispredicted about once a token): the first kUnrolled pixels of a run
      // are extended unconditionally (the candidates past the row are 0), and the pixel's two
      // literals are written and then overwritten where it starts a match.
      const std::uint32_t first = candidates[x] & candidates[x + 1];
      std::uint32_t running = first, alive = first != 0;
      std::size_t length = 2;
      for (std::size_t step = 2; step < kUnrolled; ++step) {
        const std::uint32_t still = running & candidates[x + step];
        alive &= still != 0;
        length += alive;
        running = alive ? still : running;
      }
      if (alive)
        for (; length < std::size_t(kMaxRun / 2); ++length) {
          const std::uint32_t still = running & candidates[x + length];
          if (!still) break;
          running = still;
        }
      // The nearest pixel within the row (the highest bit below kAboveBit), else the row above; as
      // arithmetic, which the compiler keeps free of branches.
      const std::uint32_t within_row = running & (kAboveBit - 1);
      const int bit = 31 - __builtin_clz(within_row | std::uint32_t(within_row == 0) << kRepeatPixels);
      const RepeatToken match = kRuns.token[2 * length] | distance_fields[bit];
      const RepeatToken literal = row[2 * x];
      const std::uint32_t is_match = first != 0;
      tokens[count] = literal ^ ((literal ^ match) & (0u - is_match));
      tokens[count + 1] = row[2 * x + 1];
      count += 2 - is_match;
      x += 1 + (length - 1) * is_match;
    }
    if (count >= kRunBlockTokens || y + 1 == rows) {
      const std::uint8_t* block_end = line + stride;
      put_block<true>(writer, tokens.get(), count, block_begin, block_end, y + 1 == rows);
      block_begin = block_end;
      count = 0;
    }
  }
  if (rows == 0) put_block<true>(writer, tokens.get(), 0, data, data, true);
  return put_zlib_trailer(writer, data, size, out);
}

}  // namespace panoscan::detail
