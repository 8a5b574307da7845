#include "frontend/cv_interop.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

namespace twocam::frontend {

cv::Mat asMat(const ImageU8& image) {
  // OpenCV's header API takes a non-const pointer; the caller promises not to write through it.
  return cv::Mat(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.data.data()));
}

cv::Mat asMat(const ImageF32& image) {
  return cv::Mat(image.height, image.width, CV_32FC1, const_cast<float*>(image.data.data()));
}

ImageU8 toImageU8(const cv::Mat& mat) {
  TWOCAM_CHECK(mat.type() == CV_8UC1) << "toImageU8 needs CV_8UC1, got type " << mat.type();
  ImageU8 out(mat.cols, mat.rows);
  for (int v = 0; v < mat.rows; ++v) std::copy_n(mat.ptr<uint8_t>(v), mat.cols, out.row(v));
  return out;
}

ImageF32 toImageF32(const cv::Mat& mat) {
  TWOCAM_CHECK(mat.type() == CV_32FC1) << "toImageF32 needs CV_32FC1, got type " << mat.type();
  ImageF32 out(mat.cols, mat.rows);
  for (int v = 0; v < mat.rows; ++v) std::copy_n(mat.ptr<float>(v), mat.cols, out.row(v));
  return out;
}

Status loadGrey(const std::string& path, ImageU8* image) {
  if (!std::filesystem::is_regular_file(path)) return Status::error(path + ": no such file");
  cv::Mat mat;
  try {
    mat = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    return Status::error(path + ": cannot read image (" + e.what() + ")");
  }
  if (mat.empty()) return Status::error(path + ": not a readable image file");
  *image = toImageU8(mat);
  return Status::ok();
}

}  // namespace twocam::frontend
