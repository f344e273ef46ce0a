#include <CGAL/version.h>
#include <OpenEXR/OpenEXRConfig.h>
#include <OpenImageIO/oiioversion.h>
#include <assimp/version.h>
#include <embree3/rtcore_config.h>
#include <oneapi/tbb/version.h>
#include <yaml-cpp/yaml.h>

#include <CLI/Version.hpp>
#include <opencv2/core/version.hpp>

#include "core/version.h"
#include "generator/runner.h"

namespace dg {

nlohmann::json libraryVersions() {
  std::string assimp = std::to_string(aiGetVersionMajor()) + "." + std::to_string(aiGetVersionMinor()) + "." +
                       std::to_string(aiGetVersionPatch());
  return {{"defectgen", DEFECTGEN_VERSION},
          {"embree", RTC_VERSION_STRING},
          {"opencv", CV_VERSION},
          {"openimageio", OIIO_VERSION_STRING},
          {"openexr", OPENEXR_VERSION_STRING},
          {"cgal", CGAL_VERSION_STR},
          {"tbb", std::to_string(TBB_VERSION_MAJOR) + "." + std::to_string(TBB_VERSION_MINOR)},
          {"yaml-cpp", DG_YAMLCPP_VERSION},
          {"nlohmann_json", std::to_string(NLOHMANN_JSON_VERSION_MAJOR) + "." +
                                std::to_string(NLOHMANN_JSON_VERSION_MINOR) + "." +
                                std::to_string(NLOHMANN_JSON_VERSION_PATCH)},
          {"cli11", CLI11_VERSION},
          {"assimp", assimp}};
}

}  // namespace dg
