// A DEFLATE writer for literals and runs (see deflate_runs.h). Why it exists: the simulator writes two
// PNGs per frame, and libdeflate's fastest level (1) spent most of a colour frame's 2.8 ms looking for
// matches that noisy colour rarely has. After PNG's Sub filter the matches such a frame does have are
// runs (equal neighbouring pixels become runs of zeros); coding only those with per-block Huffman codes
// takes 1.2 ms for a file 5-13% larger (sim/README.md has the measurements; depth, whose matches are
// not only runs, stays libdeflate's). zlib's Z_RLE strategy codes the same tokens but is slower than
// libdeflate itself, and ISA-L's igzip did not give the same bytes for the same input (sim/README.md).
#include "deflate_runs.h"

#include <algorithm>
#include <array>
#include <memory>
#include <cstring>
#include <vector>

#include <libdeflate.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

std::size_t zlib_compress_runs(const std::uint8_t* data, std::size_t size, std::uint8_t* out) {
  std::uint8_t* cursor = out;
  *cursor++ = 0x78;  // CMF: deflate, 32 KB window
  *cursor++ = 0x01;  // FLG: fastest, no dictionary; (CMF * 256 + FLG) % 31 == 0
  BitWriter writer(cursor);

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
    const bool last = at == end;
    lit_freq[kEndOfBlock] = 1;

    std::uint8_t lit_length[kLitLenSymbols];
    huffman_code_lengths(lit_freq, kLitLenSymbols, 15, lit_length);
    int lit_count = kLitLenSymbols;
    while (lit_count > 257 && lit_length[lit_count - 1] == 0) --lit_count;
    // Distance codes 0 and 1 of one bit each (a complete code); only code 0 (distance 1) is used.
    constexpr int kDistCount = 2;
    std::uint8_t all_lengths[kLitLenSymbols + kDistCount];
    std::copy(lit_length, lit_length + lit_count, all_lengths);
    all_lengths[lit_count] = all_lengths[lit_count + 1] = 1;
    const std::vector<std::uint32_t> cl_symbols = code_length_symbols(all_lengths, lit_count + kDistCount);
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
      if (s > kEndOfBlock) bits += std::uint64_t(kLengthExtra[s - 257]) + 1;  // extra bits, distance code
      dynamic_bits += bits * lit_freq[s];
    }
    const std::size_t block_bytes = std::size_t(at - block_begin);
    const std::uint64_t stored_bits = (block_bytes + 5 * (block_bytes / kStoredMax + 1)) * 8 + 8;
    if (dynamic_bits >= stored_bits) {
      writer = BitWriter(put_stored(writer, block_begin, at, last));
      continue;
    }

    std::uint32_t lit_code[kLitLenSymbols], cl_code[19];
    canonical_codes(lit_length, kLitLenSymbols, lit_code);
    canonical_codes(cl_length, 19, cl_code);
    writer.put(last ? 1 : 0, 1);
    writer.put(2, 2);  // BTYPE 10: dynamic Huffman codes
    writer.put(std::uint32_t(lit_count - 257), 5);
    writer.put(kDistCount - 1, 5);
    writer.put(std::uint32_t(cl_count - 4), 4);
    for (int i = 0; i < cl_count; ++i) writer.put(cl_length[kCodeLengthOrder[i]], 3);
    for (std::uint32_t s : cl_symbols) {
      const std::uint32_t symbol = s & 255u;
      writer.put(cl_code[symbol], cl_length[symbol]);
      if (symbol >= 16) writer.put(s >> 8, kRepeatExtraBits[symbol - 16]);
    }
    // A token's bits: its code, a length's extra bits, then distance code 0 (one 0 bit); without a
    // branch on the kind of token.
    std::uint8_t token_bits[kLitLenSymbols];
    for (int sym = 0; sym < kLitLenSymbols; ++sym)
      token_bits[sym] = std::uint8_t(lit_length[sym] + (sym > kEndOfBlock ? kLengthExtra[sym - 257] + 1 : 0));
    for (std::size_t i = 0; i < count; ++i) {
      const std::uint32_t symbol = tokens[i] & 511u;
      writer.put(lit_code[symbol] | std::uint64_t(tokens[i] >> 9) << lit_length[symbol], token_bits[symbol]);
    }
    writer.put(lit_code[kEndOfBlock], lit_length[kEndOfBlock]);
  } while (at < end);
  cursor = writer.finish();
  const std::uint32_t adler = libdeflate_adler32(1, data, size);
  const std::uint8_t trailer[4] = {std::uint8_t(adler >> 24), std::uint8_t(adler >> 16), std::uint8_t(adler >> 8),
                                   std::uint8_t(adler)};
  std::memcpy(cursor, trailer, 4);
  return std::size_t(cursor + 4 - out);
}

}  // namespace panoscan::detail
