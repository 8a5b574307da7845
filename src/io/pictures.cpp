#include "io/pictures.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace twocam::io {

namespace {

cv::Mat greyToBgr(const ImageU8& img, double scale) {
  const cv::Mat m(img.height, img.width, CV_8UC1, const_cast<uint8_t*>(img.data.data()));
  cv::Mat small, bgr;
  cv::resize(m, small, cv::Size(), scale, scale, cv::INTER_AREA);
  cv::cvtColor(small, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/// Inverse depth colour-coded (near = warm), black where there is no depth.
cv::Mat depthToBgr(const ImageF32& depth, int width, int height, double scale) {
  if (depth.empty())
    return cv::Mat(static_cast<int>(height * scale),
                   static_cast<int>(width * scale),
                   CV_8UC3,
                   cv::Scalar(0, 0, 0));
  float max_inv = 0.0f;
  for (float z : depth.data)
    if (z > 0.0f) max_inv = std::max(max_inv, 1.0f / z);
  cv::Mat inv(depth.height, depth.width, CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u) {
      const float z = depth(u, v);
      if (z > 0.0f && max_inv > 0.0f)
        inv.at<uint8_t>(v, u) =
            static_cast<uint8_t>(std::lround(1.0 + 254.0 * (1.0f / z) / max_inv));
    }
  cv::Mat colour, mask = inv == 0, small;
  cv::applyColorMap(inv, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), mask);
  cv::resize(colour, small, cv::Size(), scale, scale, cv::INTER_NEAREST);
  return small;
}

}  // namespace

Status writeContactSheet(const std::vector<ContactSheetRow>& rows,
                         const std::string& path,
                         double scale) {
  if (rows.empty()) return Status::error("contact sheet: no frames");
  std::vector<cv::Mat> lines;
  for (const ContactSheetRow& r : rows) {
    cv::Mat l = greyToBgr(r.left, scale), rr = greyToBgr(r.right, scale);
    cv::Mat d = depthToBgr(r.depth, r.left.width, r.left.height, scale);
    cv::Mat line;
    cv::hconcat(std::vector<cv::Mat>{l, rr, d}, line);
    cv::putText(line,
                r.label,
                cv::Point(6, 18),
                cv::FONT_HERSHEY_SIMPLEX,
                0.5,
                cv::Scalar(0, 255, 255),
                1,
                cv::LINE_AA);
    cv::putText(line,
                "left",
                cv::Point(6, line.rows - 8),
                cv::FONT_HERSHEY_SIMPLEX,
                0.45,
                cv::Scalar(0, 255, 255),
                1,
                cv::LINE_AA);
    cv::putText(line,
                "right",
                cv::Point(l.cols + 6, line.rows - 8),
                cv::FONT_HERSHEY_SIMPLEX,
                0.45,
                cv::Scalar(0, 255, 255),
                1,
                cv::LINE_AA);
    cv::putText(line,
                "true depth (near = red)",
                cv::Point(2 * l.cols + 6, line.rows - 8),
                cv::FONT_HERSHEY_SIMPLEX,
                0.45,
                cv::Scalar(255, 255, 255),
                1,
                cv::LINE_AA);
    lines.push_back(line);
  }
  cv::Mat sheet;
  cv::vconcat(lines, sheet);
  try {
    if (!cv::imwrite(path, sheet)) return Status::error("cannot write '" + path + "'");
  } catch (const cv::Exception& e) {
    return Status::error("cannot write '" + path + "': " + e.what());
  }
  return Status::ok();
}

}  // namespace twocam::io
