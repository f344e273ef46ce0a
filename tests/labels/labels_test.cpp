// Tests of the label module: masks, COCO RLE/annotations, sRGB curve, PNG and EXR writers.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <unistd.h>

#include <OpenImageIO/imageio.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "labels/classes.h"
#include "labels/coco.h"
#include "labels/image_io.h"
#include "labels/masks.h"

namespace fs = std::filesystem;
using namespace dg;

namespace {

// Builds a single-channel image from rows written top to bottom, as they appear in the source.
template <class T>
Image<T> fromRows(const std::vector<std::vector<int>>& rows) {
  Image<T> img(int(rows[0].size()), int(rows.size()), 1);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) img(x, y) = T(rows[y][x]);
  return img;
}

std::vector<uint32_t> U(std::initializer_list<uint32_t> v) { return v; }

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("dg_labels_test_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

std::string readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Classes

TEST(Classes, NamesAndDistinctColours) {
  EXPECT_STREQ(className(DefectClass::Dent), "dent");
  EXPECT_STREQ(className(DefectClass::Scratch), "scratch");
  EXPECT_STREQ(className(DefectClass::Rust), "rust");
  EXPECT_STREQ(className(DefectClass::Patina), "patina");
  std::set<std::vector<int>> colours;
  for (int c = 1; c <= kNumDefectClasses; ++c) {
    uint8_t rgb[3];
    classColor(DefectClass(c), rgb);
    colours.insert({rgb[0], rgb[1], rgb[2]});
    EXPECT_GT(int(rgb[0]) + rgb[1] + rgb[2], 100) << "class " << c << " colour too dark";
  }
  EXPECT_EQ(colours.size(), 4u);
  EXPECT_THROW(className(DefectClass(9)), std::logic_error);
}

// ---------------------------------------------------------------------------------------------
// Masks

namespace {
CoverageFrame smallFrame() {
  CoverageFrame f;
  f.dominant = fromRows<uint16_t>({{0, 1, 1, 2}, {2, 2, 1, 0}});
  f.coverage = Image<float>(4, 2, 1);
  const float cov[] = {0.9f, 0.5f, 0.4999f, 1.0f, 0.75f, 0.49f, 0.51f, 0.8f};
  for (int i = 0; i < 8; ++i) f.coverage.data[i] = cov[i];
  f.instances = {{1, DefectClass::Patina, {}}, {2, DefectClass::Rust, {}}};
  return f;
}
}  // namespace

TEST(Masks, ScratchesUseTheThinStructureThreshold) {
  CoverageFrame f = smallFrame();
  f.instances[0].cls = DefectClass::Scratch;  // instance 1: labelled from coverage 0.1 on
  f.coverage(1, 0) = 0.1f;
  f.coverage(2, 0) = 0.0999f;
  f.coverage(2, 1) = 0.3f;
  Image<uint16_t> m = instanceMask(f);
  EXPECT_EQ(m.data, (fromRows<uint16_t>({{0, 1, 0, 2}, {2, 0, 1, 0}}).data));
  Image<uint8_t> s = semanticMask(f);
  EXPECT_EQ(s.data, (fromRows<uint8_t>({{0, 2, 0, 3}, {3, 0, 2, 0}}).data));
  // The rust pixel at 0.49 still needs half the footprint.
  EXPECT_EQ(m(1, 1), 0);
}

TEST(Masks, InstanceMaskThresholdAtHalf) {
  CoverageFrame f = smallFrame();
  Image<uint16_t> m = instanceMask(f);
  // coverage 0.5 counts, 0.4999 and 0.49 do not; dominant 0 stays 0 whatever the coverage.
  Image<uint16_t> want = fromRows<uint16_t>({{0, 1, 0, 2}, {2, 0, 1, 0}});
  EXPECT_EQ(m.width, 4);
  EXPECT_EQ(m.height, 2);
  EXPECT_EQ(m.data, want.data);
}

TEST(Masks, SemanticMaskUsesInstanceClass) {
  CoverageFrame f = smallFrame();
  Image<uint8_t> s = semanticMask(f);
  Image<uint8_t> want = fromRows<uint8_t>({{0, 4, 0, 3}, {3, 0, 4, 0}});
  EXPECT_EQ(s.data, want.data);
}

TEST(Masks, SemanticMaskUnknownInstanceIsLogicError) {
  CoverageFrame f = smallFrame();
  f.dominant(3, 0) = 5;  // coverage 1.0, but 5 is not listed
  EXPECT_THROW(semanticMask(f), std::logic_error);
  // Below the threshold the pixel is background, so the unknown id is never looked up.
  f.coverage(3, 0) = 0.2f;
  EXPECT_NO_THROW(semanticMask(f));
}

TEST(Masks, MismatchedSizesAreLogicErrors) {
  CoverageFrame f = smallFrame();
  f.coverage = Image<float>(2, 4, 1, 1.0f);
  EXPECT_THROW(instanceMask(f), std::logic_error);
  EXPECT_THROW(semanticMask(f), std::logic_error);
}

TEST(Masks, BinaryMaskOf) {
  Image<uint16_t> inst = fromRows<uint16_t>({{0, 7, 7}, {300, 7, 0}});
  EXPECT_EQ(binaryMaskOf(inst, 7).data, fromRows<uint8_t>({{0, 1, 1}, {0, 1, 0}}).data);
  EXPECT_EQ(binaryMaskOf(inst, 300).data, fromRows<uint8_t>({{0, 0, 0}, {1, 0, 0}}).data);
  EXPECT_EQ(binaryMaskOf(inst, 9).data, std::vector<uint8_t>(6, 0));
}

// ---------------------------------------------------------------------------------------------
// RLE

TEST(Rle, StartsWithOneGivesLeadingZeroCount) {
  // w=3, h=2. Column-major order reads (0,0),(0,1),(1,0),(1,1),(2,0),(2,1) = 1,1,0,1,0,0.
  auto m = fromRows<uint8_t>({{1, 0, 0}, {1, 1, 0}});
  EXPECT_EQ(encodeRle(m), U({0, 2, 1, 1, 2}));  // row-major would give {0,1,2,2,1}
}

TEST(Rle, NonSquareCatchesTransposition) {
  // w=2, h=3: columns are (0,0,1) and (1,1,0) -> 0,0,1,1,1,0.
  auto m = fromRows<uint8_t>({{0, 1}, {0, 1}, {1, 0}});
  EXPECT_EQ(encodeRle(m), U({2, 3, 1}));  // row-major would give {1,1,1,2,1}
  // w=4, h=1: a single row is one long column sequence per pixel.
  EXPECT_EQ(encodeRle(fromRows<uint8_t>({{0, 1, 1, 0}})), U({1, 2, 1}));
  // w=1, h=4.
  EXPECT_EQ(encodeRle(fromRows<uint8_t>({{1}, {1}, {0}, {1}})), U({0, 2, 1, 1}));
}

TEST(Rle, AllZerosAllOnesAndEmpty) {
  EXPECT_EQ(encodeRle(Image<uint8_t>(4, 3, 1, 0)), U({12}));
  EXPECT_EQ(encodeRle(Image<uint8_t>(4, 3, 1, 1)), U({0, 12}));
  EXPECT_EQ(encodeRle(Image<uint8_t>(4, 3, 1, 255)), U({0, 12}));  // any non-zero is "set"
  Image<uint8_t> empty;
  empty.channels = 1;  // a 0x0 single-channel mask
  EXPECT_EQ(encodeRle(empty), U({0}));
}

TEST(Rle, CountsSumToPixelCount) {
  Image<uint8_t> m(13, 7, 1);
  for (size_t i = 0; i < m.data.size(); ++i) m.data[i] = uint8_t((i * 2654435761u >> 7) & 1);
  auto c = encodeRle(m);
  uint64_t sum = 0, ones = 0;
  for (size_t i = 0; i < c.size(); ++i) {
    sum += c[i];
    if (i % 2) ones += c[i];
    if (i > 0) {
      EXPECT_GT(c[i], 0u) << "only the first run may be empty";
    }
  }
  uint64_t want_ones = 0;
  for (uint8_t v : m.data) want_ones += v;
  EXPECT_EQ(sum, 13u * 7u);
  EXPECT_EQ(ones, want_ones);
}

// ---------------------------------------------------------------------------------------------
// COCO

TEST(Coco, Categories) {
  nlohmann::json c = cocoCategories();
  ASSERT_EQ(c.size(), 4u);
  const char* names[] = {"dent", "scratch", "rust", "patina"};
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(c[i]["id"], i + 1);
    EXPECT_EQ(c[i]["name"], names[i]);
    EXPECT_EQ(c[i]["supercategory"], "defect");
  }
}

TEST(Coco, ImageEntry) {
  nlohmann::json e = cocoImageEntry(12, "images/000012.png", 640, 480);
  EXPECT_EQ(e, nlohmann::json({{"id", 12}, {"file_name", "images/000012.png"}, {"width", 640},
                               {"height", 480}}));
}

TEST(Coco, AnnotationsAreaBboxRleAndOrder) {
  // 5 wide, 4 high. Instance 3 first in raster order but annotated after instance 1.
  auto inst = fromRows<uint16_t>({{3, 3, 0, 0, 0},
                                  {0, 3, 0, 1, 0},
                                  {0, 0, 0, 1, 1},
                                  {0, 0, 0, 0, 1}});
  std::vector<InstanceInfo> infos = {
      {3, DefectClass::Dent, {{"depth_mm", 0.25}}},
      {1, DefectClass::Scratch, {{"width_um", 40}, {"angle_deg", 30.0}}},
      {7, DefectClass::Rust, {}},  // placed but not visible: no annotation
  };
  int64_t next = 10;
  nlohmann::json a = cocoAnnotations(42, inst, infos, next);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(next, 12);

  const nlohmann::json& s = a[0];
  EXPECT_EQ(s["id"], 10);
  EXPECT_EQ(s["image_id"], 42);
  EXPECT_EQ(s["instance_id"], 1);
  EXPECT_EQ(s["category_id"], 2);
  EXPECT_EQ(s["iscrowd"], 0);
  EXPECT_EQ(s["area"], 4);
  EXPECT_TRUE(s["area"].is_number_integer());
  EXPECT_EQ(s["bbox"], nlohmann::json({3, 1, 2, 3}));
  EXPECT_EQ(s["segmentation"]["size"], nlohmann::json({4, 5}));
  // Column-major: columns 0..2 empty (12 zeros), column 3 = 0,1,1,0, column 4 = 0,0,1,1.
  EXPECT_EQ(s["segmentation"]["counts"], nlohmann::json({13, 2, 3, 2}));
  EXPECT_EQ(s["attributes"]["width_um"], 40);
  EXPECT_DOUBLE_EQ(s["attributes"]["angle_deg"].get<double>(), 30.0);

  const nlohmann::json& d = a[1];
  EXPECT_EQ(d["id"], 11);
  EXPECT_EQ(d["instance_id"], 3);
  EXPECT_EQ(d["category_id"], 1);
  EXPECT_EQ(d["area"], 3);
  EXPECT_EQ(d["bbox"], nlohmann::json({0, 0, 2, 2}));
  // Column 0 = 1,0,0,0; column 1 = 1,1,0,0; rest zeros: starts with a 1, so leading count 0.
  EXPECT_EQ(d["segmentation"]["counts"], nlohmann::json({0, 1, 3, 2, 14}));
  EXPECT_EQ(d["attributes"]["depth_mm"], 0.25);

  // The one-pass encoder must agree with encodeRle of the binary mask.
  for (const auto& ann : a) {
    auto want = encodeRle(binaryMaskOf(inst, uint16_t(ann["instance_id"].get<int>())));
    EXPECT_EQ(ann["segmentation"]["counts"].get<std::vector<uint32_t>>(), want);
  }
}

TEST(Coco, OnePassRleMatchesEncodeRleOnBusyMask) {
  Image<uint16_t> inst(17, 11, 1);
  std::vector<InstanceInfo> infos;
  for (uint16_t id = 1; id <= 5; ++id) infos.push_back({id, DefectClass(1 + id % 4), nullptr});
  for (size_t i = 0; i < inst.data.size(); ++i) inst.data[i] = uint16_t((i * 40503u >> 5) % 6);
  inst(16, 10) = 4;  // last pixel set: no trailing zero run
  int64_t next = 1;
  nlohmann::json a = cocoAnnotations(0, inst, infos, next);
  ASSERT_EQ(a.size(), 5u);
  for (const auto& ann : a) {
    uint16_t id = uint16_t(ann["instance_id"].get<int>());
    Image<uint8_t> bin = binaryMaskOf(inst, id);
    EXPECT_EQ(ann["segmentation"]["counts"].get<std::vector<uint32_t>>(), encodeRle(bin)) << id;
    int area = 0, x0 = 99, y0 = 99, x1 = -1, y1 = -1;
    for (int y = 0; y < bin.height; ++y)
      for (int x = 0; x < bin.width; ++x)
        if (bin(x, y)) {
          ++area;
          x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
        }
    EXPECT_EQ(ann["area"], area);
    EXPECT_EQ(ann["bbox"], nlohmann::json({x0, y0, x1 - x0 + 1, y1 - y0 + 1}));
    EXPECT_TRUE(ann["attributes"].is_object());
  }
}

TEST(Coco, ProgrammingErrors) {
  auto inst = fromRows<uint16_t>({{0, 2}, {2, 0}});
  std::vector<InstanceInfo> infos = {{1, DefectClass::Dent, {}}};
  int64_t next = 1;
  EXPECT_THROW(cocoAnnotations(0, inst, infos, next), std::logic_error);  // id 2 unknown
  infos.push_back({2, DefectClass::Rust, {}});
  int64_t zero = 0;
  EXPECT_THROW(cocoAnnotations(0, inst, infos, zero), std::logic_error);  // ids must start at 1
  EXPECT_EQ(cocoAnnotations(0, inst, infos, next).size(), 1u);
  EXPECT_EQ(cocoAnnotations(0, Image<uint16_t>(3, 3, 1, 0), infos, next).size(), 0u);
}

// ---------------------------------------------------------------------------------------------
// sRGB

TEST(Srgb, KnownValues) {
  EXPECT_NEAR(linearToSrgb(0.0031308f), 0.04045f, 1e-5f);
  EXPECT_FLOAT_EQ(linearToSrgb(0.0f), 0.0f);
  EXPECT_FLOAT_EQ(linearToSrgb(1.0f), 1.0f);
  EXPECT_NEAR(linearToSrgb(0.5f), 0.735357f, 1e-5f);
  EXPECT_NEAR(linearToSrgb(0.001f), 0.01292f, 1e-7f);  // linear segment
  EXPECT_NEAR(srgbToLinear(0.5f), 0.214041f, 1e-5f);
  EXPECT_NEAR(srgbToLinear(0.04045f), 0.0031308f, 1e-6f);
  // Clamping and NaN.
  EXPECT_FLOAT_EQ(linearToSrgb(-3.0f), 0.0f);
  EXPECT_FLOAT_EQ(linearToSrgb(7.0f), 1.0f);
  EXPECT_FLOAT_EQ(linearToSrgb(std::numeric_limits<float>::infinity()), 1.0f);
  EXPECT_FLOAT_EQ(linearToSrgb(std::nanf("")), 0.0f);
}

TEST(Srgb, RoundTripAndMonotone) {
  float prev = -1.0f;
  for (int i = 0; i <= 1000; ++i) {
    float v = float(i) / 1000.0f;
    float s = linearToSrgb(v);
    EXPECT_NEAR(srgbToLinear(s), v, 2e-6f) << v;
    EXPECT_GT(s, prev);
    prev = s;
  }
  // The two segments meet: no jump at the breakpoint.
  EXPECT_NEAR(linearToSrgb(0.0031307f), linearToSrgb(0.0031309f), 1e-5f);
}

// ---------------------------------------------------------------------------------------------
// PNG

TEST(Png, Rgb8ValuesRoundingAndChannelOrder) {
  TempDir dir;
  // 3 wide, 2 high: pixel (x, y) holds its own test colour.
  ImageF img(3, 2, 3, 0.0f);
  auto set = [&](int x, int y, float r, float g, float b) {
    img(x, y, 0) = r, img(x, y, 1) = g, img(x, y, 2) = b;
  };
  set(0, 0, 1.0f, 0.0f, 0.0f);
  set(1, 0, 0.5f, 0.01f, 0.2f);
  set(2, 0, 0.0031308f, 0.001f, 0.9f);
  set(0, 1, -1.0f, 5.0f, std::nanf(""));
  set(1, 1, 0.0f, 0.0f, 1.0f);
  set(2, 1, 1.0f, 1.0f, 1.0f);
  std::string p = dir.file("rgb8.png");
  writePngRgb8(p, img);
  cv::Mat m = cv::imread(p, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(m.type(), CV_8UC3);
  ASSERT_EQ(m.cols, 3);
  ASSERT_EQ(m.rows, 2);
  auto rgb = [&](int x, int y) {
    cv::Vec3b v = m.at<cv::Vec3b>(y, x);  // OpenCV reads BGR
    return std::vector<int>{v[2], v[1], v[0]};
  };
  EXPECT_EQ(rgb(0, 0), (std::vector<int>{255, 0, 0}));
  // 0.5 -> 0.735357*255 = 187.52 -> 188; 0.01 -> 25.46 -> 25; 0.2 -> 123.55 -> 124.
  EXPECT_EQ(rgb(1, 0), (std::vector<int>{188, 25, 124}));
  // 0.0031308 -> 10.31 -> 10; 0.001 -> 3.29 -> 3; 0.9 -> 243.45 -> 243.
  EXPECT_EQ(rgb(2, 0), (std::vector<int>{10, 3, 243}));
  EXPECT_EQ(rgb(0, 1), (std::vector<int>{0, 255, 0}));
  EXPECT_EQ(rgb(1, 1), (std::vector<int>{0, 0, 255}));
  EXPECT_EQ(rgb(2, 1), (std::vector<int>{255, 255, 255}));
}

TEST(Png, Rgb8DitherKeepsTheMeanAndTheExactCodes) {
  TempDir dir;
  // A flat 64 x 64 patch whose sRGB value lies between codes: 0.2 -> 123.55 (R), 0.01 -> 25.46 (G);
  // 0.5 -> 187.52 (B). Rounded, every pixel is 124, 25, 188; dithered, the means are the values.
  // A second row of patches holds values on a code (0 and 1) that dithering must keep.
  const int n = 64;
  ImageF img(n, n + 1, 3, 0.0f);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) img(x, y, 0) = 0.2f, img(x, y, 1) = 0.01f, img(x, y, 2) = 0.5f;
  for (int x = 0; x < n; ++x) img(x, n, 0) = 0.0f, img(x, n, 1) = 1.0f, img(x, n, 2) = 7.0f;
  auto means = [&](const std::string& p, std::vector<int>* last_row) {
    cv::Mat m = cv::imread(p, cv::IMREAD_UNCHANGED);
    EXPECT_EQ(m.type(), CV_8UC3);
    std::vector<double> sum(3, 0.0);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        for (int c = 0; c < 3; ++c) sum[size_t(c)] += m.at<cv::Vec3b>(y, x)[2 - c];
    if (last_row)
      for (int x = 0; x < n; ++x)
        for (int c = 0; c < 3; ++c) last_row->push_back(m.at<cv::Vec3b>(n, x)[2 - c]);
    for (double& v : sum) v /= double(n * n);
    return sum;
  };
  const double exact[3] = {double(linearToSrgb(0.2f)) * 255, double(linearToSrgb(0.01f)) * 255,
                           double(linearToSrgb(0.5f)) * 255};
  writePngRgb8(dir.file("round.png"), img);
  std::vector<double> r = means(dir.file("round.png"), nullptr);
  EXPECT_EQ(r, (std::vector<double>{124, 25, 188}));
  const uint64_t key = 42, other = 43;
  writePngRgb8(dir.file("d1.png"), img, &key);
  writePngRgb8(dir.file("d2.png"), img, &key);
  writePngRgb8(dir.file("d3.png"), img, &other);
  std::vector<int> kept;
  std::vector<double> d = means(dir.file("d1.png"), &kept);
  // 4096 pixels, each code off its value by at most 1 with variance p(1-p) <= 1/4: the mean's
  // standard deviation is under 0.008 codes. Rounded, the offsets are 0.45, 0.46 and 0.48.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(d[size_t(c)], exact[c], 0.04) << "channel " << c;
  for (size_t i = 0; i < kept.size(); ++i) ASSERT_EQ(kept[i], (i % 3) == 0 ? 0 : 255) << "value " << i;
  EXPECT_EQ(readBytes(dir.file("d1.png")), readBytes(dir.file("d2.png")));
  EXPECT_NE(readBytes(dir.file("d1.png")), readBytes(dir.file("d3.png")));
}

TEST(Png, Rgb16Values) {
  TempDir dir;
  ImageF img(2, 1, 3, 0.0f);
  img(0, 0, 0) = 0.5f, img(0, 0, 1) = 0.01f, img(0, 0, 2) = 0.2f;
  img(1, 0, 0) = 1.0f, img(1, 0, 1) = 0.001f, img(1, 0, 2) = 0.0f;
  std::string p = dir.file("rgb16.png");
  writePngRgb16(p, img);
  cv::Mat m = cv::imread(p, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(m.type(), CV_16UC3);
  cv::Vec3w a = m.at<cv::Vec3w>(0, 0), b = m.at<cv::Vec3w>(0, 1);
  // 48191.62 -> 48192, 6543.85 -> 6544, 31753.62 -> 31754 (B,G,R order in OpenCV).
  EXPECT_EQ(a[2], 48192);
  EXPECT_EQ(a[1], 6544);
  EXPECT_EQ(a[0], 31754);
  EXPECT_EQ(b[2], 65535);
  EXPECT_EQ(b[1], 847);  // 846.71 -> 847
  EXPECT_EQ(b[0], 0);
}

TEST(Png, Gray8And16ExactNonSquare) {
  TempDir dir;
  Image<uint8_t> g8(7, 5, 1);
  Image<uint16_t> g16(7, 5, 1);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      g8(x, y) = uint8_t(x * 31 + y * 7);
      g16(x, y) = uint16_t(x * 9001 + y * 257 + 1);
    }
  writePngGray8(dir.file("g8.png"), g8);
  writePngGray16(dir.file("g16.png"), g16);
  cv::Mat m8 = cv::imread(dir.file("g8.png"), cv::IMREAD_UNCHANGED);
  cv::Mat m16 = cv::imread(dir.file("g16.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(m8.type(), CV_8UC1);
  ASSERT_EQ(m16.type(), CV_16UC1);
  ASSERT_EQ(m8.cols, 7);
  ASSERT_EQ(m8.rows, 5);
  ASSERT_EQ(m16.cols, 7);
  ASSERT_EQ(m16.rows, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 7; ++x) {
      EXPECT_EQ(m8.at<uint8_t>(y, x), g8(x, y)) << x << "," << y;
      EXPECT_EQ(m16.at<uint16_t>(y, x), g16(x, y)) << x << "," << y;
    }
}

TEST(Png, DeterministicBytesAndNameIndependent) {
  TempDir dir;
  Image<uint16_t> g(9, 4, 1);
  for (size_t i = 0; i < g.data.size(); ++i) g.data[i] = uint16_t(i * 1237);
  writePngGray16(dir.file("a.png"), g);
  writePngGray16(dir.file("b.tmp"), g);  // not a .png name: still a PNG
  std::string a = readBytes(dir.file("a.png"));
  ASSERT_GT(a.size(), 8u);
  EXPECT_EQ(a.substr(1, 3), "PNG");
  EXPECT_EQ(a, readBytes(dir.file("b.tmp")));
}

TEST(Png, IoFailureAndBadShapes) {
  TempDir dir;
  std::string bad = dir.file("no_such_dir/x.png");
  EXPECT_THROW(writePngGray8(bad, Image<uint8_t>(2, 2, 1)), std::runtime_error);
  EXPECT_THROW(writePngRgb8(bad, ImageF(2, 2, 3)), std::runtime_error);
  EXPECT_THROW(writePngRgb8(dir.file("x.png"), ImageF(2, 2, 4)), std::logic_error);
  EXPECT_THROW(writePngGray16(dir.file("x.png"), Image<uint16_t>(2, 2, 3)), std::logic_error);
}

// ---------------------------------------------------------------------------------------------
// EXR

namespace {
void makeExrLayers(ImageF& rgb, ImageF& normal, ImageF& depth) {
  rgb = ImageF(4, 3, 3), normal = ImageF(4, 3, 3), depth = ImageF(4, 3, 1);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      for (int c = 0; c < 3; ++c) {
        rgb(x, y, c) = 0.1f * x + 0.01f * y + 1000.0f * c;  // HDR values stay unclamped
        normal(x, y, c) = -0.5f + 0.25f * c + 0.001f * (x + 4 * y);
      }
      depth(x, y) = 123.5f + x - 2.0f * y;
    }
}
}  // namespace

TEST(Exr, ChannelNamesAndValuesReadBack) {
  TempDir dir;
  ImageF rgb, normal, depth;
  makeExrLayers(rgb, normal, depth);
  std::string p = dir.file("aov.exr");
  writeExr(p, 4, 3, {{"", {"R", "G", "B"}, &rgb}, {"normal", {"X", "Y", "Z"}, &normal},
                     {"depth", {"Z"}, &depth}});

  auto in = OIIO::ImageInput::open(p);
  ASSERT_TRUE(in) << OIIO::geterror();
  const OIIO::ImageSpec& spec = in->spec();
  EXPECT_EQ(spec.width, 4);
  EXPECT_EQ(spec.height, 3);
  ASSERT_EQ(spec.nchannels, 7);
  EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
  EXPECT_EQ(spec.get_string_attribute("compression"), "zip");
  // OpenImageIO would stamp the wall-clock time here; the writer pins it for reproducibility.
  EXPECT_EQ(spec.get_string_attribute("DateTime"), "1970:01:01 00:00:00");
  std::set<std::string> names(spec.channelnames.begin(), spec.channelnames.end());
  EXPECT_EQ(names, (std::set<std::string>{"R", "G", "B", "normal.X", "normal.Y", "normal.Z",
                                          "depth.Z"}));
  EXPECT_EQ(in->current_subimage(), 0);
  EXPECT_FALSE(in->seek_subimage(1, 0)) << "all layers must be in one part";
  ASSERT_TRUE(in->seek_subimage(0, 0));

  std::vector<float> px(4 * 3 * 7);
  ASSERT_TRUE(in->read_image(0, 0, 0, 7, OIIO::TypeDesc::FLOAT, px.data())) << in->geterror();
  std::map<std::string, int> idx;
  for (int c = 0; c < 7; ++c) idx[spec.channelnames[c]] = c;
  auto at = [&](const std::string& n, int x, int y) { return px[(y * 4 + x) * 7 + idx.at(n)]; };
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      EXPECT_EQ(at("R", x, y), rgb(x, y, 0));
      EXPECT_EQ(at("G", x, y), rgb(x, y, 1));
      EXPECT_EQ(at("B", x, y), rgb(x, y, 2));
      EXPECT_EQ(at("normal.X", x, y), normal(x, y, 0));
      EXPECT_EQ(at("normal.Y", x, y), normal(x, y, 1));
      EXPECT_EQ(at("normal.Z", x, y), normal(x, y, 2));
      EXPECT_EQ(at("depth.Z", x, y), depth(x, y));
    }
  EXPECT_FLOAT_EQ(at("B", 3, 2), 2000.32f);
  in->close();
}

TEST(Exr, SameInputGivesIdenticalBytes) {
  TempDir dir;
  ImageF rgb, normal, depth;
  makeExrLayers(rgb, normal, depth);
  std::vector<ExrLayer> layers = {{"", {"R", "G", "B"}, &rgb}, {"depth", {"Z"}, &depth}};
  writeExr(dir.file("a.exr"), 4, 3, layers);
  writeExr(dir.file("b.tmp"), 4, 3, layers);  // extension-independent too
  std::string a = readBytes(dir.file("a.exr"));
  ASSERT_GT(a.size(), 100u);
  EXPECT_EQ(a, readBytes(dir.file("b.tmp")));
}

TEST(Exr, ErrorsAndBadLayers) {
  TempDir dir;
  ImageF rgb(4, 3, 3), small(2, 2, 3);
  EXPECT_THROW(writeExr(dir.file("no_such_dir/a.exr"), 4, 3, {{"", {"R", "G", "B"}, &rgb}}),
               std::runtime_error);
  EXPECT_THROW(writeExr(dir.file("a.exr"), 4, 3, {{"", {"R", "G"}, &rgb}}), std::logic_error);
  EXPECT_THROW(writeExr(dir.file("a.exr"), 4, 3, {{"", {"R", "G", "B"}, &small}}), std::logic_error);
  EXPECT_THROW(writeExr(dir.file("a.exr"), 4, 3, {{"", {"R", "G", "B"}, nullptr}}), std::logic_error);
  EXPECT_THROW(writeExr(dir.file("a.exr"), 4, 3,
                        {{"", {"R", "G", "B"}, &rgb}, {"", {"R", "G", "B"}, &rgb}}),
               std::logic_error);
}
