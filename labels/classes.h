// Label classes. The id is the value in the semantic mask and the COCO category_id; 0 is background.
#pragma once
#include <cstdint>
#include <string>

#include "core/defect_class.h"

namespace dg {

const char* className(DefectClass c);  // "dent", ...
// Suggested display colour for overlays (sRGB 8-bit), documented in docs/output.md.
void classColor(DefectClass c, uint8_t rgb[3]);

}  // namespace dg
