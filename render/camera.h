// Pinhole camera with OpenCV's model: camera frame x right, y down, z forward; intrinsics
// fx, fy, cx, cy and distortion (k1, k2, p1, p2, k3) exactly as cv::calibrateCamera writes them,
// pose as world-to-camera (x_cam = R x_world + t, as cv::solvePnP / cv::projectPoints take it).
// Continuous pixel coordinates follow OpenCV: pixel (i, j) has its centre at (i, j).
#pragma once
#include <string>
#include <vector>

#include "core/math.h"

namespace dg {

struct CameraIntrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  bool hasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
};

// Intrinsics for a horizontal field of view (degrees), principal point at the image centre.
CameraIntrinsics intrinsicsFromFov(int width, int height, double fov_x_deg);
// The same camera at another resolution (fx, fy, cx, cy scaled; distortion unchanged).
CameraIntrinsics scaleIntrinsics(const CameraIntrinsics& k, int width, int height);

struct Camera {
  CameraIntrinsics K;
  Pose world_to_camera;
  Vec3d position() const;                     // camera centre in world coordinates
  Vec3d forward() const;                      // optical axis (+z of the camera) in world coordinates
  Vec2d distortNormalized(Vec2d xy) const;    // OpenCV's forward distortion on normalized coords
  // Its inverse, by damped Newton iteration to a residual below 1e-12. Where the polynomial has no
  // inverse (far outside a calibrated image) it returns the closest point it found.
  Vec2d undistortNormalized(Vec2d xy_distorted) const;
  // World point to pixel, with distortion; same result as cv::projectPoints. Points behind the
  // camera (z <= 0) give NaN.
  Vec2d project(Vec3d world) const;
};

// Look-at pose: the camera at eye, looking at target, with `up` giving the image's up direction
// (the camera's -y). Throws std::invalid_argument when eye == target or up is parallel to the view.
Camera cameraLookAt(const CameraIntrinsics& k, Vec3d eye, Vec3d target, Vec3d up);

// A calibration written by cv::FileStorage (YAML, XML or JSON) with camera_matrix (3x3),
// distortion_coefficients (1x5, 5x1, 1x4, ...), image_width, image_height, as OpenCV's calibration
// sample writes them. Throws InputError naming the file and the missing or malformed node; also
// when the distortion has nonzero rational/thin-prism/tilt terms (entries past the fifth:
// unsupported) or folds over (cannot be inverted) inside the image.
CameraIntrinsics loadCalibration(const std::string& path);
void saveCalibration(const std::string& path, const CameraIntrinsics& k);

// Primary-ray generation. The inverse distortion is solved once per camera on the grid of pixel
// corners and interpolated bilinearly, so generating a ray costs a few multiply-adds. Without
// distortion there is no grid and rays are exact. Throws std::invalid_argument when the
// distortion cannot be inverted over the image (loadCalibration reports that as an InputError).
class RayGenerator {
 public:
  explicit RayGenerator(const Camera& cam);
  // (px, py): continuous OpenCV pixel coordinates. Outputs a world-space origin, a unit direction
  // and the direction's derivatives for a one-pixel step in x and in y (ray differentials).
  void generate(float px, float py, Vec3f& org, Vec3f& dir, Vec3f& dDdx, Vec3f& dDdy) const;

 private:
  Camera cam_;
  int gw_ = 0, gh_ = 0;           // grid size (corners): width + 3, height + 3 (one pixel margin)
  std::vector<Vec2f> grid_;       // undistorted normalized coordinates at each grid node
  Vec3f org_;
  float R_[9];                    // camera-to-world rotation (transpose of world_to_camera.R)
  // Interpolated grid value at (px, py) and its derivatives for a one-pixel step in x and in y.
  void lookup(float px, float py, Vec2f& xy, Vec2f& dx, Vec2f& dy) const;
};

}  // namespace dg
