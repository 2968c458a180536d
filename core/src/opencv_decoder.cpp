// OpenCV's image decoders, loaded only when an image is not one of the scan format's PNGs (a JPEG
// of a recording, a BMP, a TIFF, a PNG layout png_decode.cpp does not read). Debian builds
// opencv_imgcodecs with GDAL, DICOM and more: linked into every program it pulled in ~90 shared
// libraries of its own and cost ~0.08 s of every process's start. image_io.cpp dlopens this module
// on first use instead.
#include <cstddef>
#include <cstdio>
#include <exception>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "opencv_decoder.h"

extern "C" int panoscan_opencv_imread(const char* path, int flags, cv::Mat* out, char* error, std::size_t error_size) {
  try {
    *out = cv::imread(path, flags);
    return 1;
  } catch (const std::exception& e) {  // cv::Exception, bad_alloc
    std::snprintf(error, error_size, "%s", e.what());
    return 0;
  }
}
