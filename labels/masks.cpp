// Label masks from the renderer's per-pixel dominant instance and its coverage fraction.
#include "labels/masks.h"

#include <stdexcept>
#include <string>

namespace dg {

namespace {

void checkFrame(const CoverageFrame& f, const char* who) {
  const Image<uint16_t>& d = f.dominant;
  const Image<float>& c = f.coverage;
  if (d.channels != 1 || c.channels != 1 || d.width != c.width || d.height != c.height ||
      d.data.size() != size_t(d.width) * d.height || c.data.size() != d.data.size()) {
    throw std::logic_error(std::string(who) + ": dominant (" + std::to_string(d.width) + "x" +
                           std::to_string(d.height) + "x" + std::to_string(d.channels) +
                           ") and coverage (" + std::to_string(c.width) + "x" +
                           std::to_string(c.height) + "x" + std::to_string(c.channels) +
                           ") must be single-channel images of the same size");
  }
}

// Instance id -> class id (1..4), or -1 for ids not in the instance list.
std::vector<int> classLookup(const std::vector<InstanceInfo>& instances) {
  std::vector<int> lut(65536, -1);
  for (const InstanceInfo& in : instances) {
    if (in.id == 0) throw std::logic_error("semanticMask: instance id 0 is reserved for background");
    int cls = int(in.cls);
    if (cls < 1 || cls > kNumDefectClasses)
      throw std::logic_error("semanticMask: instance " + std::to_string(in.id) +
                             " has invalid class " + std::to_string(cls));
    if (lut[in.id] != -1)
      throw std::logic_error("semanticMask: instance id " + std::to_string(in.id) + " listed twice");
    lut[in.id] = cls;
  }
  return lut;
}

// Per instance id: the coverage its pixels need to be labelled.
std::vector<float> thresholds(const std::vector<InstanceInfo>& inst) {
  std::vector<float> t(65536, kMaskCoverageThreshold);
  for (const InstanceInfo& in : inst) t[in.id] = maskCoverageThreshold(in.cls);
  return t;
}

}  // namespace

Image<uint16_t> instanceMask(const CoverageFrame& f) {
  checkFrame(f, "instanceMask");
  const std::vector<float> thr = thresholds(f.instances);
  Image<uint16_t> out(f.dominant.width, f.dominant.height, 1, 0);
  for (size_t i = 0; i < out.data.size(); ++i) {
    uint16_t id = f.dominant.data[i];
    // NaN coverage fails the comparison and so stays background.
    if (id != 0 && f.coverage.data[i] >= (id < thr.size() ? thr[id] : kMaskCoverageThreshold)) out.data[i] = id;
  }
  return out;
}

Image<uint8_t> semanticMask(const CoverageFrame& f) {
  checkFrame(f, "semanticMask");
  const std::vector<int> lut = classLookup(f.instances);
  const std::vector<float> thr = thresholds(f.instances);
  Image<uint8_t> out(f.dominant.width, f.dominant.height, 1, 0);
  for (size_t i = 0; i < out.data.size(); ++i) {
    uint16_t id = f.dominant.data[i];
    if (id == 0 || !(f.coverage.data[i] >= (id < thr.size() ? thr[id] : kMaskCoverageThreshold))) continue;
    if (lut[id] < 0)
      throw std::logic_error("semanticMask: pixel (" + std::to_string(i % out.width) + ", " +
                             std::to_string(i / out.width) + ") has instance id " +
                             std::to_string(id) + " that is not in the instance list");
    out.data[i] = uint8_t(lut[id]);
  }
  return out;
}

Image<uint8_t> binaryMaskOf(const Image<uint16_t>& instance, uint16_t id) {
  if (instance.channels != 1 || instance.data.size() != size_t(instance.width) * instance.height)
    throw std::logic_error("binaryMaskOf: instance mask must be a single-channel image");
  Image<uint8_t> out(instance.width, instance.height, 1, 0);
  for (size_t i = 0; i < out.data.size(); ++i) out.data[i] = instance.data[i] == id ? 1 : 0;
  return out;
}

}  // namespace dg
