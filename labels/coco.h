// COCO detection/segmentation format (https://cocodataset.org/#format-data): categories, images and
// annotations with uncompressed RLE segmentation, integer bbox [x, y, w, h], area as pixel count,
// iscrowd 0, and each instance's physical parameters as extra fields.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "labels/masks.h"

namespace dg {

// Uncompressed COCO RLE of a binary mask: run lengths in column-major (Fortran) order, starting
// with a run of zeros (possibly of length 0).
std::vector<uint32_t> encodeRle(const Image<uint8_t>& binary);

nlohmann::json cocoCategories();
nlohmann::json cocoImageEntry(int image_id, const std::string& file_name, int width, int height);
// One annotation per instance that has at least one pixel in `instance`; ids are assigned from
// next_annotation_id, which is advanced. Instances are taken in ascending instance id.
nlohmann::json cocoAnnotations(int image_id, const Image<uint16_t>& instance,
                               const std::vector<InstanceInfo>& instances, int64_t& next_annotation_id);

}  // namespace dg
