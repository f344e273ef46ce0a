// Turning the renderer's per-pixel defect coverage into label masks.
//
// The renderer hands over, per pixel, the instance that covers the largest fraction of the pixel's
// footprint and that fraction. A pixel belongs to an instance when the fraction is at least 0.5.
#pragma once
#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "labels/classes.h"

namespace dg {

struct InstanceInfo {
  uint16_t id = 0;            // 1-based instance id, as in the instance mask
  DefectClass cls = DefectClass::Dent;
  nlohmann::json attributes;  // physical parameters (mm, degrees, ...), copied into COCO
};

struct CoverageFrame {
  Image<uint16_t> dominant;  // instance id with the largest coverage, 0 = none
  Image<float> coverage;     // that instance's coverage fraction in [0, 1]
  std::vector<InstanceInfo> instances;  // every instance placed in the sample (visible or not)
};

// A pixel is labelled with its dominant instance when that instance covers at least this fraction
// of the pixel's footprint on the visible surface. Scratches are thin structures, usually narrower
// than a pixel: they are labelled where their visible groove facets cover at least
// kScratchMaskCoverage (docs/output.md).
constexpr float kMaskCoverageThreshold = 0.5f;
constexpr float kScratchMaskCoverage = 0.1f;
inline float maskCoverageThreshold(DefectClass c) {
  return c == DefectClass::Scratch ? kScratchMaskCoverage : kMaskCoverageThreshold;
}

Image<uint16_t> instanceMask(const CoverageFrame& f);                // 16-bit ids, 0 = background
Image<uint8_t> semanticMask(const CoverageFrame& f);                 // class id per pixel
Image<uint8_t> binaryMaskOf(const Image<uint16_t>& instance, uint16_t id);  // 1 where id

}  // namespace dg
