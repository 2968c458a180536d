// The one entry point of the dlopen'ed decoder module (opencv_decoder.cpp), shared by it and its
// loader in image_io.cpp.
#pragma once

#include <cstddef>

namespace cv {
class Mat;
}

// cv::imread(path, flags) into *out (empty when OpenCV cannot read the file). Returns 0 with the
// reason in `error` when OpenCV throws.
extern "C" int panoscan_opencv_imread(const char* path, int flags, cv::Mat* out, char* error, std::size_t error_size);
using PanoscanOpencvImread = decltype(&panoscan_opencv_imread);
constexpr const char* kPanoscanOpencvImreadSymbol = "panoscan_opencv_imread";
