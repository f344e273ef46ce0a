// COCO annotations with uncompressed RLE masks.
//
// Format: https://cocodataset.org/#format-data. The RLE convention is the one of the reference
// implementation (cocoapi, MaskApi/maskApi.c, rleEncode): the mask is read in column-major
// (Fortran) order, i.e. down each column, left to right; counts alternate zeros/ones and always
// start with a run of zeros, which is 0 when the first pixel is set. pycocotools turns such a
// {"size": [h, w], "counts": [...]} dict into its compressed form with frPyObjects.
#include "labels/coco.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace dg {

std::vector<uint32_t> encodeRle(const Image<uint8_t>& binary) {
  if (binary.channels != 1 || binary.data.size() != size_t(binary.width) * binary.height)
    throw std::logic_error("encodeRle: mask must be a single-channel image");
  std::vector<uint32_t> counts;
  uint8_t current = 0;  // runs start with zeros
  uint32_t run = 0;
  for (int x = 0; x < binary.width; ++x) {
    for (int y = 0; y < binary.height; ++y) {
      uint8_t v = binary(x, y) != 0 ? 1 : 0;
      if (v != current) {
        counts.push_back(run);
        run = 0;
        current = v;
      }
      ++run;
    }
  }
  counts.push_back(run);  // an empty mask gives {0}, as cocoapi does
  return counts;
}

nlohmann::json cocoCategories() {
  nlohmann::json cats = nlohmann::json::array();
  for (int id = 1; id <= kNumDefectClasses; ++id) {
    cats.push_back({{"id", id},
                    {"name", className(DefectClass(id))},
                    {"supercategory", "defect"}});
  }
  return cats;
}

nlohmann::json cocoImageEntry(int image_id, const std::string& file_name, int width, int height) {
  if (width <= 0 || height <= 0)
    throw std::logic_error("cocoImageEntry: image " + std::to_string(image_id) +
                           " has non-positive size " + std::to_string(width) + "x" +
                           std::to_string(height));
  return {{"id", image_id}, {"file_name", file_name}, {"width", width}, {"height", height}};
}

namespace {

struct InstanceStats {
  int64_t area = 0;
  int xmin = 0, ymin = 0, xmax = -1, ymax = -1;
  // Runs of this instance in column-major pixel index: [start, end).
  std::vector<std::pair<uint64_t, uint64_t>> runs;
};

}  // namespace

nlohmann::json cocoAnnotations(int image_id, const Image<uint16_t>& instance,
                               const std::vector<InstanceInfo>& instances,
                               int64_t& next_annotation_id) {
  if (instance.channels != 1 || instance.data.size() != size_t(instance.width) * instance.height)
    throw std::logic_error("cocoAnnotations: instance mask must be a single-channel image");
  // pycocotools' COCOeval stores matched ground-truth ids and treats 0 as "unmatched", so an
  // annotation id of 0 would silently spoil evaluation; its loadRes also numbers from 1.
  if (next_annotation_id < 1)
    throw std::logic_error("cocoAnnotations: annotation ids must start at 1, got " +
                           std::to_string(next_annotation_id));

  const int w = instance.width, h = instance.height;
  uint16_t max_id = 0;
  for (uint16_t v : instance.data) max_id = std::max(max_id, v);
  std::vector<InstanceStats> stats(size_t(max_id) + 1);

  // One column-major pass collects area, box and the runs of every instance at once.
  uint64_t k = 0;
  for (int x = 0; x < w; ++x) {
    for (int y = 0; y < h; ++y, ++k) {
      uint16_t id = instance(x, y);
      if (id == 0) continue;
      InstanceStats& s = stats[id];
      if (s.area == 0) {
        s.xmin = s.xmax = x;
        s.ymin = s.ymax = y;
      } else {
        s.xmin = std::min(s.xmin, x);
        s.xmax = std::max(s.xmax, x);
        s.ymin = std::min(s.ymin, y);
        s.ymax = std::max(s.ymax, y);
      }
      ++s.area;
      if (!s.runs.empty() && s.runs.back().second == k)
        s.runs.back().second = k + 1;
      else
        s.runs.push_back({k, k + 1});
    }
  }
  const uint64_t n = uint64_t(w) * uint64_t(h);

  nlohmann::json out = nlohmann::json::array();
  for (size_t id = 1; id < stats.size(); ++id) {
    const InstanceStats& s = stats[id];
    if (s.area == 0) continue;
    auto info = std::find_if(instances.begin(), instances.end(),
                             [&](const InstanceInfo& in) { return in.id == id; });
    if (info == instances.end())
      throw std::logic_error("cocoAnnotations: image " + std::to_string(image_id) +
                             ": instance id " + std::to_string(id) +
                             " appears in the mask but not in the instance list");
    int cls = int(info->cls);
    if (cls < 1 || cls > kNumDefectClasses)
      throw std::logic_error("cocoAnnotations: instance " + std::to_string(id) +
                             " has invalid class " + std::to_string(cls));

    nlohmann::json counts = nlohmann::json::array();
    uint64_t prev_end = 0;
    for (const auto& r : s.runs) {
      counts.push_back(r.first - prev_end);  // zeros before this run (0 if it starts the mask)
      counts.push_back(r.second - r.first);  // ones
      prev_end = r.second;
    }
    counts.push_back(n - prev_end);  // trailing zeros, possibly 0; keeps the zero/one alternation
    // Drop a trailing zero-length run: cocoapi's encoder never emits one.
    if (counts.back().get<uint64_t>() == 0) counts.erase(counts.size() - 1);

    nlohmann::json attributes;
    if (info->attributes.is_null())
      attributes = nlohmann::json::object();
    else if (info->attributes.is_object())
      attributes = info->attributes;
    else
      throw std::logic_error("cocoAnnotations: attributes of instance " + std::to_string(id) +
                             " must be a JSON object");

    out.push_back({{"id", next_annotation_id++},
                   {"image_id", image_id},
                   {"category_id", cls},
                   {"segmentation", {{"size", {h, w}}, {"counts", counts}}},
                   {"area", s.area},
                   {"bbox", {s.xmin, s.ymin, s.xmax - s.xmin + 1, s.ymax - s.ymin + 1}},
                   {"iscrowd", 0},
                   {"instance_id", int(id)},
                   {"attributes", attributes}});
  }
  return out;
}

}  // namespace dg
