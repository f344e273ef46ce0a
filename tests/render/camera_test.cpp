#include "render/camera.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <unistd.h>

#include "core/error.h"

namespace dg {
namespace {

namespace fs = std::filesystem;

CameraIntrinsics realisticIntrinsics(bool distorted) {
  CameraIntrinsics k;
  k.width = 1280;
  k.height = 960;
  k.fx = 1004.5;
  k.fy = 998.25;
  k.cx = 643.2;
  k.cy = 477.9;
  if (distorted) {
    k.k1 = -0.28;
    k.k2 = 0.07;
    k.p1 = 1e-3;
    k.p2 = -5e-4;
    k.k3 = -0.01;
  }
  return k;
}

// A camera somewhere off the origin looking at a point obliquely, so R is a general rotation.
Camera testCamera(bool distorted) {
  return cameraLookAt(realisticIntrinsics(distorted), {350.0, -420.0, 610.0}, {10.0, 25.0, -5.0},
                      {0.1, 0.2, 1.0});
}

cv::Mat cameraMatrix(const CameraIntrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}
cv::Mat distCoeffs(const CameraIntrinsics& k) {
  return (cv::Mat_<double>(1, 5) << k.k1, k.k2, k.p1, k.p2, k.k3);
}

// World point that lies in front of the camera at normalized image position (x, y) and depth z.
Vec3d worldPointAt(const Camera& cam, double x, double y, double z) {
  const Pose& p = cam.world_to_camera;
  return p.rotateT(Vec3d{x * z, y * z, z} - p.t);
}

class ProjectVsOpenCV : public ::testing::TestWithParam<bool> {};

TEST_P(ProjectVsOpenCV, MatchesProjectPoints) {
  const Camera cam = testCamera(GetParam());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-0.7, 0.7), uy(-0.55, 0.55), uz(50.0, 3000.0);
  std::vector<cv::Point3d> obj;
  std::vector<Vec2d> ours;
  for (int i = 0; i < 2000; ++i) {
    const Vec3d w = worldPointAt(cam, ux(rng), uy(rng), uz(rng));
    obj.emplace_back(w.x, w.y, w.z);
    ours.push_back(cam.project(w));
  }
  cv::Mat R(3, 3, CV_64F, const_cast<double*>(cam.world_to_camera.R)), rvec;
  cv::Rodrigues(R, rvec);
  const Vec3d t = cam.world_to_camera.t;
  const cv::Mat tvec = (cv::Mat_<double>(3, 1) << t.x, t.y, t.z);
  std::vector<cv::Point2d> ref;
  cv::projectPoints(obj, rvec, tvec, cameraMatrix(cam.K), distCoeffs(cam.K), ref);
  double maxErr = 0;
  for (size_t i = 0; i < ref.size(); ++i)
    maxErr = std::max(maxErr, std::hypot(ours[i].x - ref[i].x, ours[i].y - ref[i].y));
  EXPECT_LT(maxErr, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Distortion, ProjectVsOpenCV, ::testing::Values(false, true));

TEST(Camera, PointBehindCameraIsNaN) {
  const Camera cam = testCamera(true);
  const Vec2d p = cam.project(worldPointAt(cam, 0.1, 0.1, -5.0));
  EXPECT_TRUE(std::isnan(p.x) && std::isnan(p.y));
  EXPECT_TRUE(std::isnan(cam.project(cam.position()).x));
}

TEST(Camera, DistortionMatchesFormula) {
  // One point by hand with the calib3d formula, to pin down the p1/p2 convention.
  Camera cam;
  cam.K = realisticIntrinsics(true);
  const double x = 0.3, y = -0.2, r2 = x * x + y * y;
  const double rad = 1 - 0.28 * r2 + 0.07 * r2 * r2 - 0.01 * r2 * r2 * r2;
  const double xd = x * rad + 2 * 1e-3 * x * y + -5e-4 * (r2 + 2 * x * x);
  const double yd = y * rad + 1e-3 * (r2 + 2 * y * y) + 2 * -5e-4 * x * y;
  const Vec2d d = cam.distortNormalized({x, y});
  EXPECT_NEAR(d.x, xd, 1e-15);
  EXPECT_NEAR(d.y, yd, 1e-15);
}

TEST(Camera, UndistortInvertsDistortOverTheImage) {
  Camera cam;
  cam.K = realisticIntrinsics(true);
  const CameraIntrinsics& k = cam.K;
  double maxRound = 0, maxResidual = 0;
  // Distorted positions of pixel corners over the whole image plus a 2-pixel margin.
  for (double v = -2.0; v <= k.height + 1.0; v += 17.0 + 0.25) {
    for (double u = -2.0; u <= k.width + 1.0; u += 23.0 + 0.5) {
      const Vec2d xd{(u - k.cx) / k.fx, (v - k.cy) / k.fy};
      const Vec2d xu = cam.undistortNormalized(xd);
      const Vec2d back = cam.distortNormalized(xu);
      maxResidual =
          std::max(maxResidual, std::max(std::abs(back.x - xd.x), std::abs(back.y - xd.y)));
      const Vec2d again = cam.undistortNormalized(cam.distortNormalized(xu));
      maxRound = std::max(maxRound, std::max(std::abs(again.x - xu.x), std::abs(again.y - xu.y)));
    }
  }
  EXPECT_LT(maxResidual, 1e-12);
  EXPECT_LT(maxRound, 1e-9);
  // The corners are strongly distorted: undistortion must move them outwards substantially.
  const Vec2d corner{(-0.5 - k.cx) / k.fx, (-0.5 - k.cy) / k.fy};
  const Vec2d cu = cam.undistortNormalized(corner);
  EXPECT_GT(std::hypot(cu.x, cu.y), 1.15 * std::hypot(corner.x, corner.y));
}

TEST(Camera, UndistortAgreesWithOpenCV) {
  Camera cam;
  cam.K = realisticIntrinsics(true);
  std::vector<cv::Point2d> px, und;
  for (double v = 0; v < cam.K.height; v += 95.0)
    for (double u = 0; u < cam.K.width; u += 127.0) px.emplace_back(u, v);
  cv::undistortPoints(px, und, cameraMatrix(cam.K), distCoeffs(cam.K), cv::noArray(),
                      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT, 200, 0));
  double maxErr = 0;
  for (size_t i = 0; i < px.size(); ++i) {
    const Vec2d ours =
        cam.undistortNormalized({(px[i].x - cam.K.cx) / cam.K.fx, (px[i].y - cam.K.cy) / cam.K.fy});
    maxErr = std::max(maxErr, std::hypot(ours.x - und[i].x, ours.y - und[i].y));
  }
  EXPECT_LT(maxErr, 1e-9);
}

class RayGen : public ::testing::TestWithParam<bool> {};

TEST_P(RayGen, RayThroughPixelProjectsBackToIt) {
  const Camera cam = testCamera(GetParam());
  const RayGenerator gen(cam);
  const Vec3d pos = cam.position();
  const int W = cam.K.width, H = cam.K.height;
  std::vector<float> us = {-1.5f, -0.5f, 0.0f, 0.37f, float(W) - 0.5f, float(W) + 0.5f};
  std::vector<float> vs = {-1.5f, -0.5f, 0.0f, 0.81f, float(H) - 0.5f, float(H) + 0.5f};
  for (float u = 3.3f; u < W; u += 61.7f) us.push_back(u);
  for (float v = 2.1f; v < H; v += 47.3f) vs.push_back(v);
  double maxErr = 0, maxOrg = 0, maxLenErr = 0;
  for (float v : vs) {
    for (float u : us) {
      Vec3f org, dir, dx, dy;
      gen.generate(u, v, org, dir, dx, dy);
      maxOrg = std::max(maxOrg, length(Vec3d(org) - pos));
      maxLenErr = std::max(maxLenErr, std::abs(double(length(dir)) - 1.0));
      const Vec2d p = cam.project(pos + Vec3d(dir) * 500.0);
      maxErr = std::max(maxErr, std::hypot(p.x - u, p.y - v));
    }
  }
  EXPECT_LT(maxErr, 1e-3);
  EXPECT_LT(maxOrg, 1e-3);  // float rounding of a centre ~800 mm from the origin
  EXPECT_LT(maxLenErr, 1e-6);
}

TEST_P(RayGen, DirectionDerivativesMatchFiniteDifferences) {
  const Camera cam = testCamera(GetParam());
  const RayGenerator gen(cam);
  // Integer positions are cell centres of the grid; a +-0.25 step stays inside the cell where the
  // bilinear map is smooth.
  const float h = 0.25f;
  double maxErr = 0, minMag = 1;
  for (float v : {0.0f, 201.0f, 480.0f, 959.0f}) {
    for (float u : {0.0f, 333.0f, 640.0f, 1279.0f}) {
      Vec3f o, d, dx, dy, dp, dm, unused;
      gen.generate(u, v, o, d, dx, dy);
      gen.generate(u + h, v, o, dp, unused, unused);
      gen.generate(u - h, v, o, dm, unused, unused);
      const Vec3f fdx = (dp - dm) / (2 * h);
      gen.generate(u, v + h, o, dp, unused, unused);
      gen.generate(u, v - h, o, dm, unused, unused);
      const Vec3f fdy = (dp - dm) / (2 * h);
      maxErr = std::max({maxErr, double(length(fdx - dx)), double(length(fdy - dy))});
      minMag = std::min({minMag, double(length(dx)), double(length(dy))});
      // A unit vector's derivative is orthogonal to it.
      EXPECT_NEAR(dot(dx, d), 0.0f, 1e-9f);
      EXPECT_NEAR(dot(dy, d), 0.0f, 1e-9f);
    }
  }
  EXPECT_GT(minMag, 0.5 / 1004.5 * 0.5);  // about one pixel's angle, not zero
  EXPECT_LT(maxErr, 2e-6);                // vs magnitudes ~1e-3: 0.2 % of a pixel step
}

INSTANTIATE_TEST_SUITE_P(Distortion, RayGen, ::testing::Values(false, true));

TEST(RayGen, CentralDerivativeWithoutDistortionIsOneOverF) {
  const Camera cam = testCamera(false);
  const RayGenerator gen(cam);
  Vec3f o, d, dx, dy;
  gen.generate(float(cam.K.cx), float(cam.K.cy), o, d, dx, dy);
  const Vec3d f = cam.forward();
  EXPECT_NEAR(dot(Vec3d(d), f), 1.0, 1e-6);
  const Vec3d right = cam.world_to_camera.rotateT({1, 0, 0});
  const Vec3d down = cam.world_to_camera.rotateT({0, 1, 0});
  EXPECT_NEAR(length(Vec3d(dx) - right / cam.K.fx), 0.0, 1e-9);
  EXPECT_NEAR(length(Vec3d(dy) - down / cam.K.fy), 0.0, 1e-9);
}

TEST(RayGen, BarrelDistortionWidensTheCornerRay) {
  // With barrel distortion (k1 < 0) the corner pixel sees further off-axis than the pinhole would.
  const Camera a = testCamera(false), b = testCamera(true);
  Vec3f o, da, db, x, y;
  RayGenerator(a).generate(-0.5f, -0.5f, o, da, x, y);
  RayGenerator(b).generate(-0.5f, -0.5f, o, db, x, y);
  EXPECT_LT(dot(Vec3d(db), b.forward()), dot(Vec3d(da), a.forward()) - 0.02);
}

TEST(CameraLookAt, TargetAtPrincipalPointAndUpIsUp) {
  const CameraIntrinsics k = realisticIntrinsics(true);
  const Vec3d eye{120, -800, 300}, target{5, 10, 40}, up{0, 0, 1};
  const Camera cam = cameraLookAt(k, eye, target, up);
  const Vec2d c = cam.project(target);
  EXPECT_NEAR(c.x, k.cx, 1e-9);
  EXPECT_NEAR(c.y, k.cy, 1e-9);
  const Vec2d above = cam.project(target + Vec3d{0, 0, 20});
  EXPECT_LT(above.y, c.y - 10.0);
  // Up lies in the plane of the optical axis and image y: without the tangential terms (which
  // shift x along the y axis) the point above stays on the principal column.
  Camera pinhole = cam;
  pinhole.K = realisticIntrinsics(false);
  EXPECT_NEAR(pinhole.project(target + Vec3d{0, 0, 20}).x, k.cx, 1e-9);
  EXPECT_NEAR(length(cam.position() - eye), 0.0, 1e-9);
  EXPECT_NEAR(length(cam.forward() - normalize(target - eye)), 0.0, 1e-12);
  // Right-handed frame: with z up and looking along +y, world +x is image right.
  const Camera c2 = cameraLookAt(k, {0, -100, 0}, {0, 0, 0}, {0, 0, 1});
  EXPECT_GT(c2.project({10, 0, 0}).x, k.cx + 10.0);
  double det = 0;
  const double* R = cam.world_to_camera.R;
  det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
        R[2] * (R[3] * R[7] - R[4] * R[6]);
  EXPECT_NEAR(det, 1.0, 1e-12);
}

TEST(CameraLookAt, RejectsDegenerateInput) {
  const CameraIntrinsics k = realisticIntrinsics(false);
  EXPECT_THROW(cameraLookAt(k, {1, 2, 3}, {1, 2, 3}, {0, 0, 1}), std::invalid_argument);
  EXPECT_THROW(cameraLookAt(k, {0, 0, 10}, {0, 0, 0}, {0, 0, 1}), std::invalid_argument);
}

TEST(Intrinsics, FromFov) {
  const CameraIntrinsics k = intrinsicsFromFov(1600, 1200, 60.0);
  EXPECT_NEAR(k.fx, 800.0 / std::tan(30.0 * kPi / 180.0), 1e-9);
  EXPECT_DOUBLE_EQ(k.fy, k.fx);
  EXPECT_DOUBLE_EQ(k.cx, 799.5);
  EXPECT_DOUBLE_EQ(k.cy, 599.5);
  // The left edge of the image (pixel position -0.5) is at half the field of view.
  const Camera cam = cameraLookAt(k, {0, 0, 0}, {0, 0, 1}, {0, -1, 0});
  Vec3f o, d, dx, dy;
  RayGenerator(cam).generate(-0.5f, float(k.cy), o, d, dx, dy);
  EXPECT_NEAR(std::acos(double(d.z)) * 180.0 / kPi, 30.0, 1e-4);
  EXPECT_THROW(intrinsicsFromFov(100, 100, 180.0), std::invalid_argument);
}

TEST(Intrinsics, ScaleKeepsTheSameRays) {
  const CameraIntrinsics k = realisticIntrinsics(true);
  const CameraIntrinsics h = scaleIntrinsics(k, 640, 480);
  const Camera a = cameraLookAt(k, {0, 0, 0}, {0, 0, 1}, {0, -1, 0});
  Camera b = a;
  b.K = h;
  for (Vec3d p : {Vec3d{0.1, 0.2, 1.0}, Vec3d{-0.5, 0.3, 1.0}, Vec3d{0, 0, 1}}) {
    const Vec2d pa = a.project(p), pb = b.project(p);
    EXPECT_NEAR((pa.x + 0.5) * 0.5 - 0.5, pb.x, 1e-9);
    EXPECT_NEAR((pa.y + 0.5) * 0.5 - 0.5, pb.y, 1e-9);
  }
}

class Calibration : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dg_camera_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = (dir_ / name).string();
    std::ofstream(p) << text;
    return p;
  }
  // Expects loadCalibration to throw InputError mentioning the file and `node`.
  void expectError(const std::string& path, const std::string& node) {
    try {
      loadCalibration(path);
      ADD_FAILURE() << "no InputError for " << path << " (" << node << ")";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(fs::path(path).filename().string()), std::string::npos) << msg;
      EXPECT_NE(msg.find(node), std::string::npos) << msg;
      EXPECT_EQ(e.file(), path);
    }
  }
  fs::path dir_;
};

// The layout written by OpenCV's calibration sample (samples/cpp/calibration.cpp), trimmed.
std::string yamlCalib(const std::string& K, const std::string& D, const std::string& size) {
  return "%YAML:1.0\n---\ncalibration_time: \"Mon Jan  1 00:00:00 2024\"\nnframes: 20\n" + size +
         "board_width: 9\nboard_height: 6\nsquare_size: 25.\nflags: 0\n" + K + D +
         "avg_reprojection_error: 0.21\n";
}
const std::string kSize = "image_width: 1280\nimage_height: 960\n";
const std::string kK =
    "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
    "   data: [ 1.0045e+03, 0., 6.432e+02, 0., 9.9825e+02, 4.779e+02, 0., 0., 1. ]\n";
const std::string kD =
    "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
    "   data: [ -2.8e-01, 7.e-02, 1.e-03, -5.e-04, -1.e-02 ]\n";

TEST_F(Calibration, ReadsOpenCVSampleLayout) {
  const CameraIntrinsics k = loadCalibration(write("sample.yml", yamlCalib(kK, kD, kSize)));
  EXPECT_EQ(k.width, 1280);
  EXPECT_EQ(k.height, 960);
  EXPECT_DOUBLE_EQ(k.fx, 1004.5);
  EXPECT_DOUBLE_EQ(k.fy, 998.25);
  EXPECT_DOUBLE_EQ(k.cx, 643.2);
  EXPECT_DOUBLE_EQ(k.cy, 477.9);
  EXPECT_DOUBLE_EQ(k.k1, -0.28);
  EXPECT_DOUBLE_EQ(k.k2, 0.07);
  EXPECT_DOUBLE_EQ(k.p1, 1e-3);
  EXPECT_DOUBLE_EQ(k.p2, -5e-4);
  EXPECT_DOUBLE_EQ(k.k3, -0.01);
}

TEST_F(Calibration, FourAndEightCoefficients) {
  const std::string d4 = "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 4\n"
                         "   dt: d\n   data: [ -0.1, 0.01, 0., 0. ]\n";
  CameraIntrinsics k = loadCalibration(write("d4.yml", yamlCalib(kK, d4, kSize)));
  EXPECT_DOUBLE_EQ(k.k1, -0.1);
  EXPECT_DOUBLE_EQ(k.k2, 0.01);
  EXPECT_EQ(k.k3, 0.0);
  const std::string d8zero = "distortion_coefficients: !!opencv-matrix\n   rows: 8\n   cols: 1\n"
                             "   dt: d\n   data: [ -0.1, 0.01, 0., 0., 0.002, 0., 0., 0. ]\n";
  k = loadCalibration(write("d8.yml", yamlCalib(kK, d8zero, kSize)));
  EXPECT_DOUBLE_EQ(k.k3, 0.002);
  const std::string d8 = "distortion_coefficients: !!opencv-matrix\n   rows: 8\n   cols: 1\n"
                         "   dt: d\n   data: [ -0.1, 0.01, 0., 0., 0.002, 0.3, 0., 0. ]\n";
  expectError(write("d8bad.yml", yamlCalib(kK, d8, kSize)), "distortion_coefficients");
}

TEST_F(Calibration, SaveLoadRoundTrip) {
  CameraIntrinsics k = realisticIntrinsics(true);
  k.fx = 1004.123456789012345;
  k.cy = 477.3333333333333;
  k.k2 = 0.0712345678901234;
  for (const char* ext : {".yml", ".xml", ".json"}) {
    const std::string p = (dir_ / (std::string("calib") + ext)).string();
    saveCalibration(p, k);
    const CameraIntrinsics r = loadCalibration(p);
    EXPECT_EQ(r.width, k.width) << ext;
    EXPECT_EQ(r.height, k.height) << ext;
    for (auto [a, b] : {std::pair{r.fx, k.fx}, {r.fy, k.fy}, {r.cx, k.cx}, {r.cy, k.cy},
                        {r.k1, k.k1}, {r.k2, k.k2}, {r.p1, k.p1}, {r.p2, k.p2}, {r.k3, k.k3}})
      EXPECT_EQ(a, b) << ext;  // 17 significant digits: exact
  }
  // Nothing but the three files (no temporaries left behind).
  int n = 0;
  for (auto& e : fs::directory_iterator(dir_)) n += e.is_regular_file();
  EXPECT_EQ(n, 3);
}

TEST_F(Calibration, Errors) {
  expectError((dir_ / "nothere.yml").string(), "not found");
  expectError(write("empty.yml", ""), "the calibration file is empty");  // OpenCV's own word: "buf"
  expectError(write("blank.yml", "\n  \n"), "the calibration file is empty");
  const std::string garbage =
      write("garbage.yml", "%YAML:1.0\n---\nimage_width: 3\ncamera_matrix: [ 1, 2\n  oops: {{{\n");
  expectError(garbage, "parse");
  try {
    loadCalibration(garbage);
  } catch (const InputError& e) {
    EXPECT_GE(e.line(), 4);  // the parser's line number is passed on
    EXPECT_LE(e.line(), 6);
  }
  // A key left empty: OpenCV's parser threw std::length_error, which was an internal error (found
  // by fuzzing calibration files).
  const std::string nokey = write("nokey.yml", "%YAML:1.0\n---\nimage_width: 1280\ncamera_matrix: !!opencv-matrix\n"
                                               "   rows: 3\n   : 3\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n");
  expectError(nokey, "a key is missing before ':'");
  try {
    loadCalibration(nokey);
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 6);
  }
  expectError(write("noK.yml", yamlCalib("", kD, kSize)), "camera_matrix");
  expectError(write("noD.yml", yamlCalib(kK, "", kSize)), "distortion_coefficients");
  expectError(write("noW.yml", yamlCalib(kK, kD, "image_height: 960\n")), "image_width");
  expectError(write("negH.yml", yamlCalib(kK, kD, "image_width: 1280\nimage_height: -4\n")),
              "image_height");
  expectError(write("strH.yml", yamlCalib(kK, kD, "image_width: 1280\nimage_height: big\n")),
              "image_height");
  expectError(write("scalarK.yml", yamlCalib("camera_matrix: 1000.\n", kD, kSize)),
              "camera_matrix");
  const std::string k23 = "camera_matrix: !!opencv-matrix\n   rows: 2\n   cols: 3\n   dt: d\n"
                          "   data: [ 1000., 0., 640., 0., 1000., 480. ]\n";
  expectError(write("k23.yml", yamlCalib(k23, kD, kSize)), "camera_matrix");
  const std::string kNeg = "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                           "   data: [ -1000., 0., 640., 0., 1000., 480., 0., 0., 1. ]\n";
  expectError(write("kneg.yml", yamlCalib(kNeg, kD, kSize)), "camera_matrix");
  const std::string kSkew = "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                            "   data: [ 1000., 3., 640., 0., 1000., 480., 0., 0., 1. ]\n";
  expectError(write("kskew.yml", yamlCalib(kSkew, kD, kSize)), "camera_matrix");
  const std::string d3 = "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 3\n"
                         "   dt: d\n   data: [ -0.1, 0.01, 0. ]\n";
  expectError(write("d3.yml", yamlCalib(kK, d3, kSize)), "distortion_coefficients");
  // A barrel term so strong that the polynomial folds over inside the image.
  const std::string dFold = "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n"
                            "   dt: d\n   data: [ -0.6, 0., 0., 0., 0. ]\n";
  expectError(write("fold.yml", yamlCalib(kK, dFold, kSize)), "distortion_coefficients");
  // XML with a missing node names it too.
  expectError(write("noK.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>1280"
                               "</image_width>\n<image_height>960</image_height>\n"
                               "</opencv_storage>\n"),
              "camera_matrix");
}

}  // namespace
}  // namespace dg
