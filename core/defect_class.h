// Defect label classes, shared by defects/ (which creates instances) and labels/ (which writes them).
// The id is the value in the semantic mask and the COCO category_id; 0 is background.
#pragma once
#include <cstdint>

namespace dg {

enum class DefectClass : uint8_t { Background = 0, Dent = 1, Scratch = 2, Rust = 3, Patina = 4 };
constexpr int kNumDefectClasses = 4;

}  // namespace dg
