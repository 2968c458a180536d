#include "panoscan/core/image_io.h"

#include <cstring>
#include <initializer_list>
#include <map>
#include <fstream>
#include <mutex>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>  // the IMREAD_ flags only: the decoders are opencv_decoder.cpp's

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/error.h"
#include "panoscan/core/module.h"
#include "opencv_decoder.h"
#include "png_decode.h"

namespace fs = std::filesystem;

namespace panoscan {

namespace {

void check_shape(const fs::path& path, int width, int height, int channels, std::size_t size) {
  if (width <= 0 || height <= 0 || size != std::size_t(width) * height * channels)
    throw make_error(path.string(), "image",
                     "inconsistent image buffer (" + std::to_string(width) + "x" + std::to_string(height) + "x" +
                         std::to_string(channels) + ")");
}

// The container format by its first bytes ("" if none of the 8-bit ones read_rgb accepts).
std::string sniff_image_format(const fs::path& path) {
  unsigned char head[12] = {};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(head), sizeof head);
  const std::streamsize got = in.gcount();
  auto starts = [&](std::initializer_list<unsigned char> magic) {
    if (got < std::streamsize(magic.size())) return false;
    std::size_t i = 0;
    for (unsigned char byte : magic)
      if (head[i++] != byte) return false;
    return true;
  };
  if (starts({0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'})) return "PNG";
  if (starts({0xff, 0xd8, 0xff})) return "JPEG";
  if (starts({'B', 'M'})) return "BMP";
  if (starts({'I', 'I', '*', 0}) || starts({'M', 'M', 0, '*'})) return "TIFF";
  if (starts({'R', 'I', 'F', 'F'}) && got >= 12 && std::memcmp(head + 8, "WEBP", 4) == 0) return "WebP";
  if (got >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6') return "PNM";
  return "";
}

// OpenCV's imread from the decoder module (opencv_decoder.cpp), loaded on the first call; `path`:
// the image that needed it, for the error when the module cannot be loaded.
PanoscanOpencvImread opencv_imread(const fs::path& path) {
  static std::once_flag once;
  static PanoscanOpencvImread imread = nullptr;
  static std::string load_error;
  std::call_once(once, [] {
    imread = reinterpret_cast<PanoscanOpencvImread>(
        load_module_symbol(PANOSCAN_OPENCV_DECODER, kPanoscanOpencvImreadSymbol, &load_error));
  });
  if (imread == nullptr)
    throw make_error(path.string(), "", "cannot load OpenCV's image decoders (" + load_error + ")");
  return imread;
}

// Decodes with OpenCV, but only formats PanoScan reads: OpenCV picks the decoder by content, and
// would hand an EXR or HDR file named .png to decoders whose headers can demand gigabytes (found by
// fuzz/panorama_fuzz.cpp: an EXR as flags.png). `png_only`: depth images (the scan format's PNG).
cv::Mat decode(const fs::path& path, int flags, bool png_only) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw make_error(path.string(), "", "image file not found");
  const std::string format = sniff_image_format(path);
  if (png_only ? format != "PNG" : format.empty())
    throw make_error(path.string(), "format",
                     png_only ? "not a PNG file" : "not a PNG, JPEG, BMP, TIFF, WebP or PNM image");
  cv::Mat mat;
  char error[512] = {};
  if (!opencv_imread(path)(path.string().c_str(), flags, &mat, error, sizeof error))
    throw make_error(path.string(), "", std::string("cannot decode image: ") + error);
  if (mat.empty()) throw make_error(path.string(), "", "not a readable image (corrupt or unsupported format)");
  return mat;
}

// A regular file whose first bytes are PNG's signature (the fast decoder's precondition; anything
// else takes decode()'s checks and messages).
bool is_png(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec) && sniff_image_format(path) == "PNG";
}

}  // namespace

// Encoded by png_encode.cpp (libdeflate); decoded by png_decode.cpp (libdeflate) for the layouts
// scans hold, by OpenCV for the others.
void write_png(const fs::path& path, const ImageU8& image, int compression) {
  check_shape(path, image.width, image.height, image.channels, image.data.size());
  if (image.channels != 1 && image.channels != 3)
    throw make_error(path.string(), "channels", "8-bit PNG needs 1 or 3 channels");
  write_file_atomic(path, encode_png(image, compression));
}

void write_png16(const fs::path& path, const ImageU16& image, int compression) {
  check_shape(path, image.width, image.height, 1, image.data.size());
  write_file_atomic(path, encode_png16(image, compression));
}

std::string image_file_format(const fs::path& path) { return sniff_image_format(path); }

PngHeader read_png_header(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw make_error(path.string(), "", "image file not found");
  if (sniff_image_format(path) != "PNG") throw make_error(path.string(), "format", "not a PNG file");
  // Signature (8 bytes), then the IHDR chunk: length 13, "IHDR", width, height (big-endian 32-bit),
  // bit depth, colour type, compression, filter, interlace.
  unsigned char head[29] = {};
  std::ifstream in(path, std::ios::binary);
  in.read(reinterpret_cast<char*>(head), sizeof head);
  if (in.gcount() != std::streamsize(sizeof head) || std::memcmp(head + 12, "IHDR", 4) != 0)
    throw make_error(path.string(), "header", "truncated PNG header (no IHDR chunk)");
  auto be32 = [&](int at) {
    return (std::uint32_t(head[at]) << 24) | (std::uint32_t(head[at + 1]) << 16) | (std::uint32_t(head[at + 2]) << 8) |
           std::uint32_t(head[at + 3]);
  };
  const std::uint32_t width = be32(16), height = be32(20);
  if (width == 0 || height == 0 || width > 0x7fffffffu || height > 0x7fffffffu)
    throw make_error(path.string(), "header", "invalid PNG size " + std::to_string(width) + "x" + std::to_string(height));
  PngHeader header;
  header.width = int(width);
  header.height = int(height);
  header.bit_depth = head[24];
  switch (head[25]) {
    case 0: header.channels = 1; break;
    case 2: header.channels = 3; break;
    case 3: header.channels = 3; break;
    case 4: header.channels = 2; break;
    case 6: header.channels = 4; break;
    default: throw make_error(path.string(), "header", "invalid PNG colour type " + std::to_string(head[25]));
  }
  if (header.bit_depth != 1 && header.bit_depth != 2 && header.bit_depth != 4 && header.bit_depth != 8 &&
      header.bit_depth != 16)
    throw make_error(path.string(), "header", "invalid PNG bit depth " + std::to_string(header.bit_depth));
  return header;
}

ImageU8 read_rgb(const fs::path& path) {
  DecodedPng png;
  if (is_png(path) && decode_png_fast(path, &png) && png.bit_depth == 8) {
    // Grey is replicated; RGBA drops alpha (as below).
    ImageU8 image(png.width, png.height, 3);
    for (int y = 0; y < png.height; ++y) {
      const unsigned char* src = png.row(y);
      std::uint8_t* dst = image.row(y);
      if (png.channels == 3) {
        std::memcpy(dst, src, std::size_t(png.width) * 3);
        continue;
      }
      for (int x = 0; x < png.width; ++x, src += png.channels, dst += 3)
        dst[0] = src[0], dst[1] = src[png.channels == 1 ? 0 : 1], dst[2] = src[png.channels == 1 ? 0 : 2];
    }
    return image;
  }
  cv::Mat mat = decode(path, cv::IMREAD_UNCHANGED, false);
  if (mat.depth() != CV_8U) throw make_error(path.string(), "bit depth", "expected an 8-bit colour image");
  const int channels = mat.channels();
  if (channels != 1 && channels != 3 && channels != 4)
    throw make_error(path.string(), "channels", "unsupported channel count " + std::to_string(channels));
  // Grey is replicated; BGR(A) is swapped to RGB; alpha is dropped.
  ImageU8 image(mat.cols, mat.rows, 3);
  for (int y = 0; y < mat.rows; ++y) {
    const std::uint8_t* src = mat.ptr<std::uint8_t>(y);
    std::uint8_t* dst = image.row(y);
    for (int x = 0; x < mat.cols; ++x) {
      const std::uint8_t* p = src + std::size_t(x) * channels;
      dst[3 * x + 0] = channels == 1 ? p[0] : p[2];
      dst[3 * x + 1] = channels == 1 ? p[0] : p[1];
      dst[3 * x + 2] = p[0];
    }
  }
  return image;
}

ImageU16 read_png16(const fs::path& path) {
  DecodedPng png;
  if (is_png(path) && decode_png_fast(path, &png) && png.bit_depth == 16 && png.channels == 1) {
    ImageU16 image(png.width, png.height, 1);
    for (int y = 0; y < png.height; ++y) {
      const unsigned char* src = png.row(y);
      std::uint16_t* dst = image.row(y);
      for (int x = 0; x < png.width; ++x) dst[x] = std::uint16_t((src[2 * x] << 8) | src[2 * x + 1]);
    }
    return image;
  }
  cv::Mat mat = decode(path, cv::IMREAD_UNCHANGED, true);
  if (mat.depth() != CV_16U || mat.channels() != 1)
    throw make_error(path.string(), "format",
                     "expected a 16-bit single-channel depth image, found " + std::to_string(mat.channels()) +
                         " channel(s) of " + (mat.depth() == CV_8U ? "8" : "other") + "-bit data");
  ImageU16 image(mat.cols, mat.rows, 1);
  for (int y = 0; y < mat.rows; ++y) std::memcpy(image.row(y), mat.ptr(y), std::size_t(mat.cols) * 2);
  return image;
}

namespace {

// The EXR pixel type that stores an image's samples: float as FLOAT; int32 as UINT, by bit pattern
// (OpenEXR has no signed integer type), so -1 is stored as 4294967295.
template <typename T>
struct ExrSample;
template <>
struct ExrSample<float> {
  static constexpr Imf::PixelType kType = Imf::FLOAT;
};
template <>
struct ExrSample<std::int32_t> {
  static constexpr Imf::PixelType kType = Imf::UINT;
};

template <typename T>
void write_exr_channels(const fs::path& path, const Image<T>& image, const std::vector<std::string>& channel_names) {
  static_assert(sizeof(T) == 4, "FLOAT and UINT samples are 4 bytes");
  check_shape(path, image.width, image.height, image.channels, image.data.size());
  if (channel_names.size() != std::size_t(image.channels))
    throw make_error(path.string(), "channels", "channel names do not match the image");
  write_via_temp(path, [&](const fs::path& temp) {
    try {
      Imf::Header header(image.width, image.height);
      Imf::FrameBuffer frame_buffer;
      const std::size_t pixel_stride = sizeof(T) * image.channels;
      for (int c = 0; c < image.channels; ++c) {
        header.channels().insert(channel_names[c], Imf::Channel(ExrSample<T>::kType));
        char* base = reinterpret_cast<char*>(const_cast<T*>(image.data.data() + c));
        frame_buffer.insert(channel_names[c],
                            Imf::Slice(ExrSample<T>::kType, base, pixel_stride, pixel_stride * image.width));
      }
      Imf::OutputFile file(temp.string().c_str(), header);
      file.setFrameBuffer(frame_buffer);
      file.writePixels(image.height);
    } catch (const std::exception& e) {
      throw make_error(path.string(), "", std::string("EXR write failed: ") + e.what());
    }
  });
}

}  // namespace

void write_exr(const fs::path& path, const ImageF32& image, const std::vector<std::string>& channel_names) {
  write_exr_channels(path, image, channel_names);
}

void write_exr_i32(const fs::path& path, const ImageI32& image, const std::vector<std::string>& channel_names) {
  write_exr_channels(path, image, channel_names);
}

namespace {

// Walks the attributes of an EXR file's header (OpenEXR file layout: magic 20000630, version word,
// then name\0 type\0 int32 size and the value, until an empty name) before OpenEXR sees it, and
// refuses what OpenEXR 3.1 would turn into a huge allocation (found by fuzz/panorama_fuzz.cpp): an
// attribute size beyond the file; a typed value whose layout disagrees with its declared size
// (OpenEXR parses those by their layout, so a mismatch shifts every later field, sizes included);
// a preview whose width x height disagrees with its size; an ID manifest (compressed, with its own
// declared sizes; PanoScan never writes one).
void check_exr_header(const fs::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  const std::uintmax_t file_size = fs::file_size(path, ec);
  if (ec) throw make_error(file, "", "cannot read the size of the EXR file");
  std::ifstream in(path, std::ios::binary);
  auto u32_at = [](const unsigned char* b) {
    return std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 | std::uint32_t(b[3]) << 24;
  };
  auto read_u32 = [&](const std::string& field) {
    unsigned char b[4];
    if (!in.read(reinterpret_cast<char*>(b), 4)) throw make_error(file, field, "EXR header truncated");
    return u32_at(b);
  };
  std::size_t max_name = 31;  // OpenEXR's limit for names and type names, 255 with the long-names flag
  auto read_name = [&](const std::string& field) {
    std::string name;
    char c = 0;
    while (in.get(c) && c != '\0') {
      name.push_back(c);
      if (name.size() > max_name) throw make_error(file, field, "EXR header name too long");
    }
    if (!in) throw make_error(file, field, "EXR header truncated");
    return name;
  };
  if (read_u32("magic") != 20000630u) throw make_error(file, "magic", "not an OpenEXR file");
  const std::uint32_t version = read_u32("version");
  if (version & 0x1000u) throw make_error(file, "version", "multi-part EXR files are not supported");
  if (version & 0x400u) max_name = 255;
  // Sizes of OpenEXR's fixed-layout attribute types.
  static const std::map<std::string, std::uint32_t> fixed = {
      {"box2i", 16},         {"box2f", 16},  {"chromaticities", 32}, {"compression", 1}, {"double", 8},
      {"envmap", 1},         {"float", 4},   {"int", 4},             {"keycode", 28},    {"lineOrder", 1},
      {"m33f", 36},          {"m44f", 64},   {"m33d", 72},           {"m44d", 128},      {"rational", 8},
      {"tiledesc", 9},       {"timecode", 8}, {"v2i", 8},            {"v2f", 8},         {"v2d", 16},
      {"v3i", 12},           {"v3f", 12},    {"v3d", 24},            {"deepImageState", 1}};
  for (int attribute = 0;; ++attribute) {
    const std::string name = read_name("header");
    if (name.empty()) return;
    if (attribute > 1000) throw make_error(file, "header", "more than 1000 attributes");
    const std::string type = read_name(name);
    const std::uint32_t size = read_u32(name);
    const std::uintmax_t position = std::uintmax_t(in.tellg());
    if (size > 0x7fffffffu || position + size > file_size)
      throw make_error(file, name, "attribute size " + std::to_string(size) + " exceeds the file");
    std::vector<unsigned char> value(size);
    if (size > 0 && !in.read(reinterpret_cast<char*>(value.data()), size))
      throw make_error(file, name, "EXR header truncated");
    const auto layout_error = [&](const std::string& what) {
      return make_error(file, name, "attribute of type " + type + " with size " + std::to_string(size) + ": " + what);
    };
    if (const auto it = fixed.find(type); it != fixed.end()) {
      if (size != it->second) throw layout_error("expected size " + std::to_string(it->second));
    } else if (type == "chlist") {
      // Entries name\0 + 16 bytes, then an empty name, exactly filling the value.
      std::size_t at = 0;
      while (true) {
        std::size_t end = at;
        while (end < size && value[end] != 0) ++end;
        if (end >= size) throw layout_error("channel list not terminated");
        if (end == at) break;
        if (end - at > max_name) throw layout_error("channel name too long");
        at = end + 1 + 16;
        if (at > size) throw layout_error("channel entry truncated");
      }
      if (at + 1 != size) throw layout_error("channel list does not fill its size");
    } else if (type == "preview") {
      if (size < 8) throw layout_error("preview header truncated");
      const std::uint64_t pixels = std::uint64_t(u32_at(value.data())) * u32_at(value.data() + 4);
      if (8 + 4 * pixels != size) throw layout_error("preview size disagrees with its width x height");
    } else if (type == "stringvector") {
      for (std::size_t at = 0; at < size;) {
        if (at + 4 > size) throw layout_error("string length truncated");
        const std::uint32_t length = u32_at(value.data() + at);
        if (length > size - at - 4) throw layout_error("string exceeds the attribute");
        at += 4 + length;
      }
    } else if (type == "idmanifest") {
      throw layout_error("ID manifests are not supported");
    }
  }
}

}  // namespace

namespace {

std::string pixel_type_text(Imf::PixelType type) {
  switch (type) {
    case Imf::UINT: return "32-bit unsigned integer (UINT)";
    case Imf::HALF: return "16-bit float (HALF)";
    case Imf::FLOAT: return "32-bit float (FLOAT)";
    default: return "unknown";
  }
}

// `exact_type`: refuse channels of another pixel type instead of letting OpenEXR convert them (ids
// must not pass through a float).
template <typename T>
Image<T> read_exr_channels(const fs::path& path, const std::vector<std::string>& channel_names, int expected_width,
                           int expected_height, bool exact_type) {
  static_assert(sizeof(T) == 4, "FLOAT and UINT samples are 4 bytes");
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw make_error(path.string(), "", "EXR file not found");
  check_exr_header(path);
  try {
    Imf::InputFile file(path.string().c_str());
    const Imath::Box2i window = file.header().dataWindow();
    // The header's size is checked before anything is allocated: a corrupt or hostile header must
    // give an Error, not an allocation of gigabytes (found by fuzz/panorama_fuzz.cpp).
    const std::int64_t width64 = std::int64_t(window.max.x) - window.min.x + 1;
    const std::int64_t height64 = std::int64_t(window.max.y) - window.min.y + 1;
    if (width64 < 1 || height64 < 1 || width64 > kMaxExrSide || height64 > kMaxExrSide ||
        width64 * height64 > kMaxExrPixels)
      throw make_error(path.string(), "dataWindow",
                       "size " + std::to_string(width64) + "x" + std::to_string(height64) + " out of range (at most " +
                           std::to_string(kMaxExrSide) + " per side and " + std::to_string(kMaxExrPixels) + " pixels)");
    const int width = int(width64), height = int(height64);
    if ((expected_width > 0 && width != expected_width) || (expected_height > 0 && height != expected_height))
      throw make_error(path.string(), "dataWindow",
                       "size " + std::to_string(width) + "x" + std::to_string(height) + ", expected " +
                           std::to_string(expected_width) + "x" + std::to_string(expected_height));
    Image<T> image(width, height, static_cast<int>(channel_names.size()));
    Imf::FrameBuffer frame_buffer;
    const std::size_t pixel_stride = sizeof(T) * image.channels;
    for (int c = 0; c < image.channels; ++c) {
      const Imf::Channel* channel = file.header().channels().findChannel(channel_names[c]);
      if (!channel) throw make_error(path.string(), "channel " + channel_names[c], "missing from the EXR file");
      if (exact_type && channel->type != ExrSample<T>::kType)
        throw make_error(
            path.string(), "channel " + channel_names[c],
            "holds " + pixel_type_text(channel->type) + " samples, expected " + pixel_type_text(ExrSample<T>::kType));
      // The slice base points at pixel (0, 0) of the data window's coordinate system.
      char* base = reinterpret_cast<char*>(image.data.data() + c) -
                   (std::ptrdiff_t(window.min.x) + std::ptrdiff_t(window.min.y) * width) * std::ptrdiff_t(pixel_stride);
      frame_buffer.insert(channel_names[c], Imf::Slice(ExrSample<T>::kType, base, pixel_stride, pixel_stride * width));
    }
    file.setFrameBuffer(frame_buffer);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw make_error(path.string(), "", std::string("not a readable EXR file: ") + e.what());
  }
}

}  // namespace

ImageF32 read_exr(const fs::path& path, const std::vector<std::string>& channel_names, int expected_width,
                  int expected_height) {
  return read_exr_channels<float>(path, channel_names, expected_width, expected_height, false);
}

ImageI32 read_exr_i32(const fs::path& path, const std::vector<std::string>& channel_names, int expected_width,
                      int expected_height) {
  return read_exr_channels<std::int32_t>(path, channel_names, expected_width, expected_height, true);
}

}  // namespace panoscan
