// Label classes: names used in COCO categories and overlay colours for previews.
#include "labels/classes.h"

#include <stdexcept>
#include <string>

namespace dg {

const char* className(DefectClass c) {
  switch (c) {
    case DefectClass::Background: return "background";
    case DefectClass::Dent: return "dent";
    case DefectClass::Scratch: return "scratch";
    case DefectClass::Rust: return "rust";
    case DefectClass::Patina: return "patina";
  }
  // An out-of-range enum value can only come from a bad cast inside the program.
  throw std::logic_error("className: invalid DefectClass value " + std::to_string(int(c)));
}

void classColor(DefectClass c, uint8_t rgb[3]) {
  // Chosen to be far apart in hue and easy to tell from grey/metallic car-part renders:
  // dent blue, scratch red, rust orange, patina teal; background black.
  auto set = [&](uint8_t r, uint8_t g, uint8_t b) { rgb[0] = r; rgb[1] = g; rgb[2] = b; };
  switch (c) {
    case DefectClass::Background: set(0, 0, 0); return;
    case DefectClass::Dent: set(30, 90, 255); return;
    case DefectClass::Scratch: set(230, 20, 30); return;
    case DefectClass::Rust: set(255, 140, 0); return;
    case DefectClass::Patina: set(0, 170, 160); return;
  }
  throw std::logic_error("classColor: invalid DefectClass value " + std::to_string(int(c)));
}

}  // namespace dg
