// How much each labelled instance stands out in the image it was rendered into.
//
// Masks come from the defects' geometry, never from the image (docs/output.md), so a defect that
// the lighting leaves invisible is labelled all the same: a dent seen head-on under a dome, wash
// swirls whose walls face away from a low bar light. A detector trained on such labels learns to
// find what cannot be seen. The contrast below lets a user tell them apart (drop them, or keep
// them as hard negatives): the lightness of an instance's pixels against the background just
// around it, as the written image shows them.
#pragma once
#include <cstdint>
#include <vector>

#include "core/image.h"

namespace dg {

struct InstanceContrast {
  uint16_t id = 0;
  int64_t mask_pixels = 0;  // the instance's pixels in the instance mask
  int64_t ring_pixels = 0;  // unlabelled pixels within ring_px of them (Chebyshev distance)
  double mask_l = 0;        // mean CIE L* of the instance's pixels
  double ring_l = 0;        // mean CIE L* of the ring (meaningless when ring_pixels == 0)
  double delta_l = 0;       // mask_l - ring_l
  double p90_abs_delta_l = 0;  // 90th percentile over the instance's pixels of |L* - ring_l|
};

// Every instance that has pixels in `instance`, in ascending id. `linear` is the image as written
// (linear RGB, 3 channels, exposure applied): each pixel's lightness is L* = 116 f(Y) - 16 of the
// luminance of its values clipped to [0, 1] (Rec. 709 / sRGB primaries, white = full scale), so
// what the PNG cannot show (above its white) does not count. The ring holds the pixels no instance
// labels within ring_px of the instance; with none (the instance fills its surroundings), only
// mask_l is meaningful.
std::vector<InstanceContrast> instanceContrast(const Image<uint16_t>& instance, const ImageF& linear,
                                               int ring_px);

// The ring width the dataset writer uses (docs/output.md): close enough that the background is
// lit as the defect's surroundings are, wide enough to hold a few dozen pixels along a thin line.
constexpr int kContrastRingPixels = 3;

}  // namespace dg
