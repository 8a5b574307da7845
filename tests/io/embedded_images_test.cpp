// The filter that rewrites images stored inside a rawlog before MRPT reads them
// (src/io/embedded_images.h): JPEGs become the raw grey image they decode to, bad ones a
// rejected image, under every class-name spelling MRPT resolves to mrpt::img::CImage.

#include "io/embedded_images.h"

#include <gtest/gtest.h>
#include <mrpt/img/CImage.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/serialization/CArchive.h>

#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

namespace twocam::io::internal {
namespace {

constexpr int kWidth = 24;
constexpr int kHeight = 16;
// Mean |error| of a quality-95 JPEG of a smooth image [grey levels].
constexpr double kJpegGreyTol = 3.0;

cv::Mat smoothColour() {
  cv::Mat m(kHeight, kWidth, CV_8UC3);
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u)
      m.at<cv::Vec3b>(v, u) = cv::Vec3b(static_cast<uint8_t>(50 + 4 * u),
                                        static_cast<uint8_t>(80 + 5 * v),
                                        static_cast<uint8_t>(120 + u + v));
  return m;
}

/// MRPT's serialisation of a colour image as JPEG: [0x91]"mrpt::img::CImage"[version][data][0x88].
std::string jpegImageBytes() {
  const bool saved = mrpt::img::CImage::DISABLE_JPEG_COMPRESSION();
  mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(false);
  mrpt::io::CMemoryStream stream;
  auto arch = mrpt::serialization::archiveFrom(stream);
  arch << mrpt::img::CImage(smoothColour(), mrpt::img::DEEP_COPY);
  mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(saved);
  return std::string(static_cast<const char*>(stream.getRawBufferData()),
                     static_cast<size_t>(stream.getTotalBytesCount()));
}

const std::string kMrptName = "mrpt::img::CImage";

/// The same image under another class-name header (`header` replaces MRPT's [0x91]name).
std::string withHeader(const std::string& image, const std::string& header) {
  return header + image.substr(1 + kMrptName.size());
}

/// Runs the filter over every "Image" in `bytes`, as the reader's stream does.
std::string filtered(std::string bytes, std::optional<std::string>* rejection) {
  const FillFunction fill = [&](size_t size) { return bytes.size() >= size; };
  for (size_t at = bytes.find("Image"); at != std::string::npos;
       at = bytes.find("Image", filterEmbeddedImage(&bytes, at, fill, rejection))) {
  }
  return bytes;
}

/// Reads one object in MRPT's current format.
mrpt::img::CImage readImage(const std::string& bytes) {
  mrpt::io::CMemoryStream stream;
  stream.assignMemoryNotOwn(bytes.data(), bytes.size());
  auto arch = mrpt::serialization::archiveFrom(stream);
  mrpt::img::CImage image;
  arch >> image;
  return image;
}

double meanGreyError(const mrpt::img::CImage& image) {
  cv::Mat want;
  cv::cvtColor(smoothColour(), want, cv::COLOR_BGR2GRAY);
  const cv::Mat& got = image.asCvMatRef();
  double sum = 0.0;
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u)
      sum += std::abs(got.at<uint8_t>(v, u) - want.at<uint8_t>(v, u));
  return sum / (kWidth * kHeight);
}

TEST(EmbeddedImages, JpegBecomesItsRawGreyImage) {
  const std::string image = jpegImageBytes();
  ASSERT_NE(image.find(std::string("\xFF\xD8\xFF", 3)), std::string::npos) << "not a JPEG";
  std::optional<std::string> rejection;
  const std::string out = filtered(image, &rejection);
  EXPECT_FALSE(rejection.has_value());
  EXPECT_EQ(out.find(std::string("\xFF\xD8\xFF", 3)), std::string::npos) << "JPEG left for MRPT";
  const mrpt::img::CImage read = readImage(out);
  ASSERT_FALSE(read.isExternallyStored());
  ASSERT_EQ(read.asCvMatRef().type(), CV_8UC1);
  ASSERT_EQ(read.getWidth(), static_cast<size_t>(kWidth));
  ASSERT_EQ(read.getHeight(), static_cast<size_t>(kHeight));
  EXPECT_LT(meanGreyError(read), kJpegGreyTol);
}

// Every spelling of the class name that MRPT's registry resolves to CImage: without namespace,
// the old alias, another namespace, and a name cut short by a NUL (MRPT reads it as a C string).
TEST(EmbeddedImages, CorruptJpegIsRejectedUnderEveryNameMrptAccepts) {
  std::string image = jpegImageBytes();
  const size_t jpeg = image.find(std::string("\xFF\xD8\xFF", 3));
  ASSERT_NE(jpeg, std::string::npos);
  std::memset(image.data() + jpeg, 0, 16);
  for (const std::string& header : {std::string("\x91") + kMrptName,
                                    std::string("\x86") + "CImage",
                                    std::string("\x8a") + "CMRPTImage",
                                    std::string("\x8d") + "other::CImage",
                                    std::string("\x89") + std::string("CImage\0\0\0", 9)}) {
    std::optional<std::string> rejection;
    const std::string out = filtered(withHeader(image, header), &rejection);
    ASSERT_TRUE(rejection.has_value()) << header;
    EXPECT_NE(rejection->find("embedded image is not a JPEG"), std::string::npos) << *rejection;
    const mrpt::img::CImage read = readImage(out);
    ASSERT_TRUE(read.isExternallyStored());
    EXPECT_EQ(rejectedImageReason(read.getExternalStorageFile()), rejection);
  }
}

// A JPEG header may declare up to 65535 x 65535 pixels whatever its size: one that declares far
// more pixels than its bytes can code is refused before decoding (a few hundred bytes asked for
// a 64 Mpx decode).
TEST(EmbeddedImages, JpegDeclaringMorePixelsThanItsBytesHoldIsRejected) {
  std::string image = jpegImageBytes();
  const size_t frame = image.find(std::string("\xFF\xC0", 2));
  ASSERT_NE(frame, std::string::npos) << "no baseline frame header";
  image[frame + 5] = static_cast<char>(0x10);  // height 4096 + 16
  image[frame + 7] = static_cast<char>(0x3F);  // width 16128 + 24
  std::optional<std::string> rejection;
  filtered(image, &rejection);
  ASSERT_TRUE(rejection.has_value());
  EXPECT_NE(rejection->find("embedded JPEG declares 16152x4112 pixels in"), std::string::npos)
      << *rejection;
}

// MRPT before 0.5.5: [n][0 0 0][name][int32 version][data], no end flag.
TEST(EmbeddedImages, OldHeaderFormatIsFilteredToo) {
  const std::string image = jpegImageBytes();
  const size_t version_at = 1 + kMrptName.size();
  const int32_t version = static_cast<uint8_t>(image[version_at]);
  const std::string old = std::string("\x11\0\0\0", 4) + kMrptName +
                          std::string(reinterpret_cast<const char*>(&version), 4) +
                          image.substr(version_at + 1, image.size() - version_at - 2);
  std::optional<std::string> rejection;
  const std::string out = filtered(old, &rejection);
  EXPECT_FALSE(rejection.has_value());
  EXPECT_EQ(out.find(std::string("\xFF\xD8\xFF", 3)), std::string::npos);
  const mrpt::img::CImage read = readImage(out);
  EXPECT_EQ(read.getWidth(), static_cast<size_t>(kWidth));
  EXPECT_LT(meanGreyError(read), kJpegGreyTol);
}

// "Image" in other bytes (a string, another class) is left as it is.
TEST(EmbeddedImages, OtherBytesAreLeftAlone) {
  const std::string bytes = std::string("\xa3mrpt::obs::CObservationStereoImages\x06", 37) +
                            "Image Image\x86"
                            "CImagf";
  std::optional<std::string> rejection;
  EXPECT_EQ(filtered(bytes, &rejection), bytes);
  EXPECT_FALSE(rejection.has_value());
  EXPECT_FALSE(rejectedImageReason("left_000001.png").has_value());
}

TEST(EmbeddedImages, JpegFrameSize) {
  const std::string image = jpegImageBytes();
  const size_t jpeg = image.find(std::string("\xFF\xD8\xFF", 3));
  ASSERT_NE(jpeg, std::string::npos);
  const auto size = jpegFrameSize(image.substr(jpeg));
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->first, static_cast<uint32_t>(kWidth));
  EXPECT_EQ(size->second, static_cast<uint32_t>(kHeight));
  EXPECT_FALSE(jpegFrameSize(std::string("\xFF\xD8\xFF\xD9", 4)).has_value());
  EXPECT_FALSE(jpegFrameSize("not a jpeg").has_value());
}

}  // namespace
}  // namespace twocam::io::internal
