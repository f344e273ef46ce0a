// From a validated config to what the renderer needs: the per-dataset parts (built once: the part's
// BVH, environment maps, a calibration file) and, per sample, the sampled scene with its metadata.
#pragma once
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "generator/config.h"
#include "labels/masks.h"
#include "render/integrator.h"

namespace dg {

struct Dataset {
  Config config;
  std::shared_ptr<const PartGeometry> part;
  std::vector<std::shared_ptr<const EnvironmentMap>> env_maps;  // per light index (null if none)
  bool has_calibration = false;
  CameraIntrinsics calibration;
};

// Loads everything the config refers to (mesh, maps, calibration). Throws InputError.
Dataset prepareDataset(Config config);

struct Sample {
  uint64_t index = 0;
  RenderScene scene;
  RenderSettings settings;
  std::unique_ptr<DefectList> defects;
  std::vector<InstanceInfo> instances;
  nlohmann::json meta;  // camera, lights, material, defects, every sampled value
};

Sample makeSample(const Dataset& ds, uint64_t seed, uint64_t index);

// The frame's buffers that the config's render block asks for (RenderSettings::want_*): RGB where a
// PNG or the EXR is written, depth and normals only into the EXR, coverage for the masks. The
// samples' settings and generate's memory estimate both take them from here.
void setFrameOutputs(const Value& render, RenderSettings& settings);

// Throws what makeSample(ds, seed, index) would throw, at less cost: a mesh of the sample's own is
// made but gets no BVH, and the explicit scratch geometry is only cut and counted, not stored.
void checkSample(const Dataset& ds, uint64_t seed, uint64_t index);

}  // namespace dg
