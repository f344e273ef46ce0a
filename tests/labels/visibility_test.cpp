// Per-instance contrast (labels/visibility.h) on images whose lightness is known.
#include <gtest/gtest.h>

#include <cmath>

#include "labels/visibility.h"

using namespace dg;

namespace {

// CIE L* of a grey whose linear value is v (Y = v, white 1).
double lstarOf(double v) {
  const double t = v > std::pow(6.0 / 29.0, 3) ? std::cbrt(v) : v / (3 * std::pow(6.0 / 29.0, 2)) + 4.0 / 29.0;
  return 116 * t - 16;
}

void fill(ImageF& img, int x0, int y0, int x1, int y1, float v) {
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < 3; ++c) img(x, y, c) = v;
}

}  // namespace

// A bright line on grey, a line of the background's own grey, and a dark square: their lightness
// against a ring of 2 pixels around each, with the other instances' pixels left out of the rings.
TEST(Visibility, ContrastOfKnownLinesAndSquares) {
  const int W = 40, H = 30;
  Image<uint16_t> inst(W, H, 1, 0);
  ImageF img(W, H, 3, 0.2f);
  // 1: a bright horizontal line, 2 px tall; 2: a line as grey as the background; 3: a dark square
  // right next to line 1 (its ring must not count line 1, nor line 1's count it).
  for (int x = 5; x < 35; ++x)
    for (int y = 5; y < 7; ++y) inst(x, y) = 1;
  fill(img, 5, 5, 35, 7, 0.6f);
  for (int y = 12; y < 28; ++y) inst(10, y) = 2;
  for (int y = 7; y < 11; ++y)
    for (int x = 20; x < 24; ++x) inst(x, y) = 3;
  fill(img, 20, 7, 24, 11, 0.05f);
  const std::vector<InstanceContrast> c = instanceContrast(inst, img, 2);
  ASSERT_EQ(c.size(), 3u);
  const double grey = lstarOf(0.2f);
  EXPECT_EQ(c[0].id, 1);
  EXPECT_EQ(c[0].mask_pixels, 60);
  // The ring of line 1: its 2-px border inside the image, less square 3's pixels: the 34 x 6 box
  // around it (x 3..36, y 3..8) minus the line (60) and the square's rows 7 and 8 (8 pixels).
  EXPECT_EQ(c[0].ring_pixels, 34 * 6 - 60 - 8);
  EXPECT_NEAR(c[0].mask_l, lstarOf(0.6f), 1e-9);
  EXPECT_NEAR(c[0].ring_l, grey, 1e-9);
  EXPECT_NEAR(c[0].delta_l, lstarOf(0.6f) - grey, 1e-9);
  EXPECT_NEAR(c[0].p90_abs_delta_l, lstarOf(0.6f) - grey, 1e-9);
  EXPECT_NEAR(c[1].delta_l, 0.0, 1e-9);
  EXPECT_EQ(c[1].ring_pixels, 5 * 20 - 16);  // x 8..12, y 10..29, less the line itself
  EXPECT_NEAR(c[2].delta_l, lstarOf(0.05f) - grey, 1e-9);
  EXPECT_LT(c[2].delta_l, -20);
}

// Values above the PNG's white count as white; a 90th percentile over a mixed instance.
TEST(Visibility, ClipsAtWhiteAndTakesTheNinetiethPercentile) {
  const int W = 20, H = 20;
  Image<uint16_t> inst(W, H, 1, 0);
  ImageF img(W, H, 3, 0.5f);
  // Ten pixels of instance 1 in a row: nine at the background's grey, one far above white.
  for (int x = 5; x < 15; ++x) inst(x, 10) = 1;
  for (int c = 0; c < 3; ++c) img(14, 10, c) = 40.0f;
  const std::vector<InstanceContrast> c = instanceContrast(inst, img, 1);
  ASSERT_EQ(c.size(), 1u);
  const double d = 100.0 - lstarOf(0.5f);
  EXPECT_NEAR(c[0].mask_l, lstarOf(0.5f) + d / 10, 1e-9);
  // Nine of ten pixels are 0 from the ring, one is d: the 90th percentile (nearest rank 9) is 0.
  EXPECT_NEAR(c[0].p90_abs_delta_l, 0.0, 1e-9);
  // With two bright pixels of ten, it is d.
  for (int c2 = 0; c2 < 3; ++c2) img(13, 10, c2) = 2.0f;
  EXPECT_NEAR(instanceContrast(inst, img, 1)[0].p90_abs_delta_l, d, 1e-9);
}

// An instance that fills its surroundings has no ring; the rest is left at zero.
TEST(Visibility, NoRingWhereTheInstanceFillsTheImage) {
  Image<uint16_t> inst(8, 8, 1, 7);
  ImageF img(8, 8, 3, 1.0f);
  const std::vector<InstanceContrast> c = instanceContrast(inst, img, 3);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c[0].id, 7);
  EXPECT_EQ(c[0].ring_pixels, 0);
  EXPECT_NEAR(c[0].mask_l, 100.0, 1e-9);
  EXPECT_EQ(c[0].delta_l, 0.0);
  EXPECT_THROW(instanceContrast(inst, ImageF(8, 7, 3), 3), std::logic_error);
  EXPECT_THROW(instanceContrast(inst, img, 0), std::logic_error);
}
