// Built-in parametric car parts. Each is a tessellated surface in mm, centred at the origin, with
// its outside facing +z on average, and an arc-length UV chart in mm (u across, v along).
#pragma once
#include "render/mesh.h"

namespace dg {

struct PlateParams {  // a flat test plate
  double width_mm = 300, height_mm = 200;
};
struct DoorPanelParams {  // a door skin: curved across its height, with a character line
  double width_mm = 1000, height_mm = 600;
  double curvature_radius_mm = 1500;   // radius of the cylindrical bow across the height
  double character_line_height = 0.6;  // position of the character line as a fraction of height
  double character_line_depth_mm = 4;  // height of the crease ridge
  double character_line_width_mm = 20; // width of the ridge
};
struct HoodParams {  // a hood: doubly curved, crowned in the middle
  double width_mm = 1400, length_mm = 1100, crown_mm = 40;
};
struct FenderParams {  // a front fender: side panel with a wheel-arch cut-out, curved in plan view
  double length_mm = 900, height_mm = 600;
  double arch_radius_mm = 330;
  double curvature_radius_mm = 1200;
};

// Tessellation density: the largest edge length in mm (smaller = finer).
TriangleMesh makePlate(const PlateParams& p, double max_edge_mm = 10);
TriangleMesh makeDoorPanel(const DoorPanelParams& p, double max_edge_mm = 10);
TriangleMesh makeHood(const HoodParams& p, double max_edge_mm = 15);
TriangleMesh makeFender(const FenderParams& p, double max_edge_mm = 10);

}  // namespace dg
