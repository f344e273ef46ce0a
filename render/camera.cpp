// Pinhole camera with OpenCV's Brown-Conrady distortion (OpenCV docs, calib3d module, "Camera
// Calibration and 3D Reconstruction"): for normalized coordinates x' = X/Z, y' = Y/Z and
// r^2 = x'^2 + y'^2,
//   x'' = x' (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x' y' + p2 (r^2 + 2 x'^2)
//   y'' = y' (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y'^2) + 2 p2 x' y'
//   u = fx x'' + cx,  v = fy y'' + cy.
// The inverse of the distortion has no closed form; it is solved by damped Newton iteration.
#include "render/camera.h"

#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "core/error.h"
#include "core/fsutil.h"
#include "core/parallel.h"

namespace dg {

namespace {

// Forward distortion and its Jacobian J = d(x'', y'') / d(x', y') (row-major 2x2).
// With R(r^2) = 1 + k1 r^2 + k2 r^4 + k3 r^6 and R' = dR/d(r^2) = k1 + 2 k2 r^2 + 3 k3 r^4:
//   dx''/dx' = R + 2 x'^2 R' + 2 p1 y' + 6 p2 x'     dx''/dy' = 2 x' y' R' + 2 p1 x' + 2 p2 y'
//   dy''/dx' = 2 x' y' R' + 2 p1 x' + 2 p2 y'        dy''/dy' = R + 2 y'^2 R' + 6 p1 y' + 2 p2 x'
void distortWithJacobian(const CameraIntrinsics& k, double x, double y, double& xd, double& yd,
                         double* J) {
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  xd = x * radial + 2.0 * k.p1 * x * y + k.p2 * (r2 + 2.0 * x * x);
  yd = y * radial + k.p1 * (r2 + 2.0 * y * y) + 2.0 * k.p2 * x * y;
  if (J) {
    const double dR = k.k1 + r2 * (2.0 * k.k2 + 3.0 * k.k3 * r2);
    const double cross = 2.0 * x * y * dR + 2.0 * k.p1 * x + 2.0 * k.p2 * y;
    J[0] = radial + 2.0 * x * x * dR + 2.0 * k.p1 * y + 6.0 * k.p2 * x;
    J[1] = cross;
    J[2] = cross;
    J[3] = radial + 2.0 * y * y * dR + 6.0 * k.p1 * y + 2.0 * k.p2 * x;
  }
}

constexpr double kUndistortTol = 1e-12;  // max-norm of the residual, normalized units
constexpr int kUndistortMaxIter = 100;

// Solves distort(x) = target by Newton's method with step halving. Returns true when the residual
// fell below kUndistortTol and the solution lies on the invertible sheet of the map (Jacobian
// determinant > 0), i.e. the distortion has not folded over between the centre and this point.
bool undistortSolve(const CameraIntrinsics& k, Vec2d target, Vec2d& out) {
  double x = target.x, y = target.y;  // the distorted point is a good starting guess
  double fx, fy, J[4];
  distortWithJacobian(k, x, y, fx, fy, J);
  double rx = fx - target.x, ry = fy - target.y;
  double err = std::max(std::abs(rx), std::abs(ry));
  // Iterate to the tolerance, then take one more (undamped) step to polish to rounding level.
  bool polishing = false;
  for (int it = 0; it < kUndistortMaxIter; ++it) {
    if (err < kUndistortTol) {
      if (polishing) break;
      polishing = true;
    }
    const double det = J[0] * J[3] - J[1] * J[2];
    double sx, sy;
    if (std::abs(det) > 1e-300 && std::isfinite(det)) {
      // Newton step: J s = -r.
      sx = -(J[3] * rx - J[1] * ry) / det;
      sy = -(-J[2] * rx + J[0] * ry) / det;
    } else {
      sx = -rx;  // singular Jacobian: fall back to a plain fixed-point correction
      sy = -ry;
    }
    // Step halving keeps the iteration from jumping onto another sheet of the polynomial.
    double step = 1.0;
    bool improved = false;
    for (int h = 0; h < (polishing ? 1 : 40); ++h, step *= 0.5) {
      const double nx = x + step * sx, ny = y + step * sy;
      double gx, gy, JN[4];
      distortWithJacobian(k, nx, ny, gx, gy, JN);
      const double nrx = gx - target.x, nry = gy - target.y;
      const double nerr = std::max(std::abs(nrx), std::abs(nry));
      if (nerr < err) {
        x = nx, y = ny, rx = nrx, ry = nry, err = nerr;
        std::copy(JN, JN + 4, J);
        improved = true;
        break;
      }
    }
    if (!improved) break;  // stuck at the best attainable point (rounding or no solution)
  }
  out = {x, y};
  return err < kUndistortTol && (J[0] * J[3] - J[1] * J[2]) > 0.0;
}

// Checks that the distortion can be inverted on the outer ring of the ray grid (pixel positions
// -1.5 and W + 0.5, H + 0.5). Returns false and the first failing pixel otherwise. For the radial
// polynomial, the border is where the map folds first, so the border check covers the interior.
bool invertibleOverImage(const CameraIntrinsics& k, double& badU, double& badV) {
  auto test = [&](double u, double v) {
    Vec2d xy;
    if (undistortSolve(k, {(u - k.cx) / k.fx, (v - k.cy) / k.fy}, xy)) return true;
    badU = u, badV = v;
    return false;
  };
  const double u0 = -1.5, u1 = k.width + 0.5, v0 = -1.5, v1 = k.height + 0.5;
  for (double u = u0; u <= u1; u += 1.0)
    if (!test(u, v0) || !test(u, v1)) return false;
  for (double v = v0; v <= v1; v += 1.0)
    if (!test(u0, v) || !test(u1, v)) return false;
  return true;
}

std::string describeShape(const cv::Mat& m) {
  return std::to_string(m.rows) + "x" + std::to_string(m.cols);
}

// Reads a matrix node; throws InputError naming the node when it is missing or not a matrix.
cv::Mat readMatrixNode(const cv::FileStorage& fs, const std::string& path, const char* name,
                       const char* expected) {
  cv::FileNode node = fs[name];
  if (node.empty() || node.isNone())
    throw InputError(path, std::string("missing node '") + name + "' (expected " + expected + ")");
  cv::Mat m;
  bool ok = node.isMap();
  if (ok) {
    try {
      node >> m;
    } catch (const cv::Exception&) {
      ok = false;
    }
  }
  if (!ok || m.empty() || m.channels() != 1)
    throw InputError(path, std::string("node '") + name +
                               "' is not an OpenCV matrix (expected " + expected +
                               ", written as !!opencv-matrix with rows, cols, dt, data)");
  cv::Mat d;
  m.convertTo(d, CV_64F);
  for (int r = 0; r < d.rows; ++r)
    for (int c = 0; c < d.cols; ++c)
      if (!std::isfinite(d.at<double>(r, c)))
        throw InputError(path, std::string("node '") + name + "' entry (" + std::to_string(r) +
                                   ", " + std::to_string(c) + ") is not a finite number");
  return d;
}

int readSizeNode(const cv::FileStorage& fs, const std::string& path, const char* name) {
  cv::FileNode node = fs[name];
  if (node.empty() || node.isNone())
    throw InputError(path,
                     std::string("missing node '") + name + "' (expected a positive integer)");
  double v = std::numeric_limits<double>::quiet_NaN();
  if (node.isInt())
    v = double(int(node));
  else if (node.isReal())
    v = double(node);
  if (!(v >= 1.0 && v <= 1e6 && v == std::floor(v)))
    throw InputError(path, std::string("node '") + name +
                               "' must be a positive integer number of pixels");
  return int(v);
}

void requireValid(const CameraIntrinsics& k, const char* where) {
  if (k.width <= 0 || k.height <= 0 || !(k.fx > 0) || !(k.fy > 0) || !std::isfinite(k.fx) ||
      !std::isfinite(k.fy) || !std::isfinite(k.cx) || !std::isfinite(k.cy) ||
      !std::isfinite(k.k1) || !std::isfinite(k.k2) || !std::isfinite(k.p1) ||
      !std::isfinite(k.p2) || !std::isfinite(k.k3))
    throw std::invalid_argument(std::string(where) +
                                ": intrinsics need positive size and focal lengths, finite values");
}

}  // namespace

CameraIntrinsics intrinsicsFromFov(int width, int height, double fov_x_deg) {
  if (width <= 0 || height <= 0 || !(fov_x_deg > 0.0 && fov_x_deg < 180.0))
    throw std::invalid_argument("intrinsicsFromFov: need a positive size and 0 < fov < 180 deg");
  CameraIntrinsics k;
  k.width = width;
  k.height = height;
  // The image spans [-0.5, W - 0.5] in OpenCV pixel coordinates, W pixels wide, so the edge is at
  // W/2 pixels from the centre (W - 1)/2: tan(fov/2) = (W/2) / fx.
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * fov_x_deg * kPi / 180.0);
  k.cx = 0.5 * (width - 1);
  k.cy = 0.5 * (height - 1);
  return k;
}

CameraIntrinsics scaleIntrinsics(const CameraIntrinsics& k, int width, int height) {
  requireValid(k, "scaleIntrinsics");
  if (width <= 0 || height <= 0) throw std::invalid_argument("scaleIntrinsics: size must be > 0");
  const double sx = double(width) / k.width, sy = double(height) / k.height;
  CameraIntrinsics s = k;
  s.width = width;
  s.height = height;
  s.fx = k.fx * sx;
  s.fy = k.fy * sy;
  // Pixel centres are at integers, so the continuous image edge is at -0.5: u_new + 0.5 =
  // (u_old + 0.5) * s.
  s.cx = (k.cx + 0.5) * sx - 0.5;
  s.cy = (k.cy + 0.5) * sy - 0.5;
  return s;
}

Vec3d Camera::position() const { return -world_to_camera.rotateT(world_to_camera.t); }

Vec3d Camera::forward() const { return world_to_camera.rotateT({0.0, 0.0, 1.0}); }

Vec2d Camera::distortNormalized(Vec2d xy) const {
  if (!K.hasDistortion()) return xy;
  Vec2d d;
  distortWithJacobian(K, xy.x, xy.y, d.x, d.y, nullptr);
  return d;
}

Vec2d Camera::undistortNormalized(Vec2d xy_distorted) const {
  if (!K.hasDistortion()) return xy_distorted;
  Vec2d out;
  undistortSolve(K, xy_distorted, out);  // outside the invertible region: the closest point found
  return out;
}

Vec2d Camera::project(Vec3d world) const {
  const Vec3d c = world_to_camera.apply(world);
  if (!(c.z > 0.0)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan};
  }
  const Vec2d d = distortNormalized({c.x / c.z, c.y / c.z});
  return {K.fx * d.x + K.cx, K.fy * d.y + K.cy};
}

Camera cameraLookAt(const CameraIntrinsics& k, Vec3d eye, Vec3d target, Vec3d up) {
  const Vec3d f = target - eye;
  const double fl = length(f);
  if (!(fl > 0.0) || !std::isfinite(fl))
    throw std::invalid_argument("cameraLookAt: eye and target must differ");
  const Vec3d z = f / fl;
  // Camera y points down in the image, so it is minus the part of `up` orthogonal to the view.
  const Vec3d upPerp = up - z * dot(up, z);
  const double ul = length(upPerp);
  if (!(ul > 1e-9 * length(up)) || !std::isfinite(ul))
    throw std::invalid_argument("cameraLookAt: up must not be parallel to the viewing direction");
  const Vec3d y = -upPerp / ul;
  const Vec3d x = cross(y, z);  // right-handed: x = y cross z
  Camera cam;
  cam.K = k;
  Pose& p = cam.world_to_camera;
  const Vec3d rows[3] = {x, y, z};  // rows of R are the camera axes in world coordinates
  for (int r = 0; r < 3; ++r) {
    p.R[3 * r + 0] = rows[r].x;
    p.R[3 * r + 1] = rows[r].y;
    p.R[3 * r + 2] = rows[r].z;
  }
  p.t = -p.rotate(eye);
  return cam;
}

CameraIntrinsics loadCalibration(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path, "calibration file not found (expected an OpenCV FileStorage YAML, XML "
                           "or JSON file with camera_matrix and distortion_coefficients)");
  // An empty file (or only blanks): OpenCV's parser only says "buf".
  const std::string head = readFileHead(path, 4096);
  if (head.size() < 4096 && head.find_first_not_of(" \t\r\n") == std::string::npos)
    throw InputError(path, "the calibration file is empty (expected an OpenCV FileStorage YAML, XML or JSON "
                           "file with camera_matrix and distortion_coefficients)");
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ))
      throw InputError(path, "cannot open calibration file");
  } catch (const cv::Exception& e) {
    // OpenCV's parsers report "<file>(<line>): <what>" in the exception's func field.
    int line = 0;
    std::string what = e.err;
    const std::string& f = e.func;
    const size_t open = f.rfind("(", f.find("): "));
    const size_t close = f.find("): ");
    if (open != std::string::npos && close != std::string::npos && open < close) {
      try {
        line = std::stoi(f.substr(open + 1, close - open - 1));
        what = f.substr(close + 3);
      } catch (const std::exception&) {
        line = 0;
      }
    }
    throw InputError(path, line, 0,
                     "cannot parse calibration file (expected OpenCV FileStorage YAML, XML or "
                     "JSON): " + what);
  } catch (const std::exception&) {
    // OpenCV's YAML parser throws std::length_error on a key left empty ("   : 3"); other
    // standard exceptions from its parsers are reported the same way, without their text.
    int line = 0;
    std::ifstream in(path);
    std::string l;
    for (int n = 1; std::getline(in, l); ++n) {
      const size_t c = l.find_first_not_of(" \t");
      if (c != std::string::npos && l[c] == ':') {
        line = n;
        break;
      }
    }
    throw InputError(path, line, 0,
                     std::string("cannot parse calibration file (expected OpenCV FileStorage YAML, XML or JSON): ") +
                         (line > 0 ? "a key is missing before ':'" : "malformed file"));
  }
  const char* kExpectK = "a 3x3 camera matrix [fx 0 cx; 0 fy cy; 0 0 1]";
  const char* kExpectD = "1x4, 1x5 (or 4x1, 5x1, ...) distortion coefficients k1 k2 p1 p2 [k3]";
  const cv::Mat K = readMatrixNode(fs, path, "camera_matrix", kExpectK);
  const cv::Mat D = readMatrixNode(fs, path, "distortion_coefficients", kExpectD);

  if (K.rows != 3 || K.cols != 3)
    throw InputError(path, "node 'camera_matrix' is " + describeShape(K) + ", expected 3x3");
  CameraIntrinsics k;
  k.fx = K.at<double>(0, 0);
  k.fy = K.at<double>(1, 1);
  k.cx = K.at<double>(0, 2);
  k.cy = K.at<double>(1, 2);
  if (!(k.fx > 0) || !(k.fy > 0))
    throw InputError(path, "node 'camera_matrix': focal lengths fx = K(0,0) and fy = K(1,1) must "
                           "be positive");
  const double tiny = 1e-9 * std::max(k.fx, k.fy);
  if (std::abs(K.at<double>(0, 1)) > tiny)
    throw InputError(path, "node 'camera_matrix': skew K(0,1) must be 0 (OpenCV's model has no "
                           "skew)");
  if (std::abs(K.at<double>(1, 0)) > tiny || std::abs(K.at<double>(2, 0)) > 1e-9 ||
      std::abs(K.at<double>(2, 1)) > 1e-9 || std::abs(K.at<double>(2, 2) - 1.0) > 1e-9)
    throw InputError(path, "node 'camera_matrix' must have the form [fx 0 cx; 0 fy cy; 0 0 1]");

  const int n = int(D.total());
  if ((D.rows != 1 && D.cols != 1) || (n != 4 && n != 5 && n != 8 && n != 12 && n != 14))
    throw InputError(path, "node 'distortion_coefficients' is " + describeShape(D) +
                               ", expected a vector of 4 or 5 coefficients (k1 k2 p1 p2 [k3]); "
                               "OpenCV's 8, 12 and 14 are read only when the extra ones are 0");
  const double* d = D.ptr<double>(0);  // contiguous after convertTo
  for (int i = 5; i < n; ++i)
    if (d[i] != 0.0)
      throw InputError(path, "node 'distortion_coefficients' entry " + std::to_string(i) +
                                 " is nonzero: only the 5-parameter model k1 k2 p1 p2 k3 is "
                                 "supported (not the rational, thin-prism or tilted models)");
  k.k1 = d[0];
  k.k2 = d[1];
  k.p1 = d[2];
  k.p2 = d[3];
  k.k3 = n >= 5 ? d[4] : 0.0;

  k.width = readSizeNode(fs, path, "image_width");
  k.height = readSizeNode(fs, path, "image_height");

  double bu = 0, bv = 0;
  if (k.hasDistortion() && !invertibleOverImage(k, bu, bv)) {
    std::ostringstream s;
    s << "node 'distortion_coefficients': the distortion cannot be inverted at pixel (" << bu
      << ", " << bv << ") of the " << k.width << "x" << k.height
      << " image (the polynomial folds over inside the image; the calibration is not valid there)";
    throw InputError(path, s.str());
  }
  return k;
}

void saveCalibration(const std::string& path, const CameraIntrinsics& k) {
  requireValid(k, "saveCalibration");
  try {
    writeAtomically(path, [&](const std::filesystem::path& tmp) {
      cv::FileStorage fs(tmp.string(), cv::FileStorage::WRITE);
      if (!fs.isOpened()) throw InputError(path, "cannot open calibration file for writing");
      const cv::Mat K = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
      const cv::Mat D = (cv::Mat_<double>(5, 1) << k.k1, k.k2, k.p1, k.p2, k.k3);
      fs << "image_width" << k.width << "image_height" << k.height;
      fs << "camera_matrix" << K << "distortion_coefficients" << D;
      fs.release();
    });
  } catch (const cv::Exception& e) {
    throw InputError(path, "cannot write calibration file: " + e.err);
  } catch (const std::filesystem::filesystem_error& e) {
    throw InputError(path, std::string("cannot write calibration file: ") + e.what());
  }
}

// ---------------------------------------------------------------------------------------------
// RayGenerator

RayGenerator::RayGenerator(const Camera& cam) : cam_(cam) {
  requireValid(cam.K, "RayGenerator");
  const Vec3d pos = cam.position();
  org_ = Vec3f(pos);
  const double* R = cam.world_to_camera.R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R_[3 * r + c] = float(R[3 * c + r]);
  if (!cam.K.hasDistortion()) return;  // exact per ray; no grid

  double bu = 0, bv = 0;
  if (!invertibleOverImage(cam.K, bu, bv))
    throw std::invalid_argument("RayGenerator: the distortion cannot be inverted at pixel (" +
                                std::to_string(bu) + ", " + std::to_string(bv) + ")");
  // Nodes at pixel positions -1.5, -0.5, ..., W + 0.5 (the pixel corners with a one-pixel margin).
  gw_ = cam.K.width + 3;
  gh_ = cam.K.height + 3;
  grid_.assign(size_t(gw_) * gh_, Vec2f());
  const CameraIntrinsics& K = cam.K;
  parallelFor(size_t(gh_), [&](size_t j) {
    const double v = double(j) - 1.5;
    for (int i = 0; i < gw_; ++i) {
      const double u = double(i) - 1.5;
      Vec2d xy;
      undistortSolve(K, {(u - K.cx) / K.fx, (v - K.cy) / K.fy}, xy);
      grid_[j * gw_ + i] = {float(xy.x), float(xy.y)};
    }
  });
}

// Bilinear interpolation of the grid at (px, py) and its derivatives along px and py, which are
// the grid's finite differences weighted by the other coordinate's fractions. Outside the grid the
// border cell is extended linearly.
void RayGenerator::lookup(float px, float py, Vec2f& xy, Vec2f& dx, Vec2f& dy) const {
  const float gx = px + 1.5f, gy = py + 1.5f;
  const int i = std::min(std::max(int(std::floor(gx)), 0), gw_ - 2);
  const int j = std::min(std::max(int(std::floor(gy)), 0), gh_ - 2);
  const float tx = gx - float(i), ty = gy - float(j);
  const Vec2f g00 = grid_[size_t(j) * gw_ + i], g10 = grid_[size_t(j) * gw_ + i + 1];
  const Vec2f g01 = grid_[size_t(j + 1) * gw_ + i], g11 = grid_[size_t(j + 1) * gw_ + i + 1];
  const Vec2f a = g00 + (g10 - g00) * tx;  // along x at row j
  const Vec2f b = g01 + (g11 - g01) * tx;  // along x at row j + 1
  xy = a + (b - a) * ty;
  dx = (g10 - g00) * (1.0f - ty) + (g11 - g01) * ty;
  dy = b - a;
}

void RayGenerator::generate(float px, float py, Vec3f& org, Vec3f& dir, Vec3f& dDdx,
                            Vec3f& dDdy) const {
  Vec2f xy, gx, gy;
  if (grid_.empty()) {
    const CameraIntrinsics& K = cam_.K;
    xy = {float((px - K.cx) / K.fx), float((py - K.cy) / K.fy)};
    gx = {float(1.0 / K.fx), 0.0f};
    gy = {0.0f, float(1.0 / K.fy)};
  } else {
    lookup(px, py, xy, gx, gy);
  }
  auto toWorld = [this](float x, float y, float z) {
    return Vec3f{R_[0] * x + R_[1] * y + R_[2] * z, R_[3] * x + R_[4] * y + R_[5] * z,
                 R_[6] * x + R_[7] * y + R_[8] * z};
  };
  // Un-normalized direction d = R^T (x, y, 1) and its derivatives R^T (dx, dy, 0).
  const Vec3f d = toWorld(xy.x, xy.y, 1.0f);
  const Vec3f ddx = toWorld(gx.x, gx.y, 0.0f);
  const Vec3f ddy = toWorld(gy.x, gy.y, 0.0f);
  const float len2 = dot(d, d);
  const float invLen = 1.0f / std::sqrt(len2);
  // Derivative of d/|d|: (dd - d (d . dd) / |d|^2) / |d|.
  org = org_;
  dir = d * invLen;
  dDdx = (ddx - d * (dot(d, ddx) / len2)) * invLen;
  dDdy = (ddy - d * (dot(d, ddy) / len2)) * invLen;
}

}  // namespace dg
