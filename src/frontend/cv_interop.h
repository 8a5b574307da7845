#pragma once
/// Adapters between TwoCam's plain images and OpenCV matrices, for tests, benchmarks,
/// tools and the OpenCV-based parts of the frontend (rectification). The hot path never
/// needs them: it works on ImageU8 directly.

#include <opencv2/core/mat.hpp>
#include <string>

#include "common/image.h"
#include "common/status.h"

namespace twocam::frontend {

/// A cv::Mat header over the image's pixels (no copy). Valid while `image` lives unchanged.
cv::Mat asMat(const ImageU8& image);
cv::Mat asMat(const ImageF32& image);

/// Deep copies of an 8-bit single-channel or 32-bit float single-channel matrix.
/// CHECK-fails on any other type (a programmer error, not bad input).
ImageU8 toImageU8(const cv::Mat& mat);
ImageF32 toImageF32(const cv::Mat& mat);

/// Loads an image file as 8-bit grey (colour files are converted with OpenCV's luma weights).
/// Fails with a message naming the path when the file is missing or not a readable image.
Status loadGrey(const std::string& path, ImageU8* image);

}  // namespace twocam::frontend
