#include "render/envmap.h"

#include <gtest/gtest.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <unistd.h>
#include <vector>

#include "core/error.h"
#include "core/rng.h"

namespace dg {
namespace {

namespace fs = std::filesystem;

Vec3f dirFromAngles(double theta, double phi) {
  return Vec3f(Vec3d{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                     std::cos(theta)});
}

// Pixel (column, row) a direction falls in, for an unrotated w x h lat-long map; computed here in
// double independently of the implementation.
void pixelOf(Vec3f d, int w, int h, int& i, int& j) {
  const double theta = std::atan2(std::hypot(double(d.x), double(d.y)), double(d.z));
  double u = std::atan2(double(d.y), double(d.x)) / (2 * kPi);
  u -= std::floor(u);
  i = std::min(int(u * w), w - 1);
  j = std::min(int(theta / kPi * h), h - 1);
}

class EnvMap : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dg_envmap_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes w x h x nc floats (row-major, row 0 at the top) in the given pixel format.
  std::string writeImage(const std::string& name, int w, int h, int nc,
                         const std::vector<float>& data,
                         OIIO::TypeDesc format = OIIO::TypeDesc::FLOAT) {
    const std::string p = (dir_ / name).string();
    auto out = OIIO::ImageOutput::create(p);
    EXPECT_TRUE(out) << OIIO::geterror();
    OIIO::ImageSpec spec(w, h, nc, format);
    EXPECT_TRUE(out->open(p, spec)) << out->geterror();
    EXPECT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, data.data())) << out->geterror();
    out->close();
    return p;
  }
  std::string writeRgb(const std::string& name, int w, int h, const std::vector<Rgb>& px) {
    std::vector<float> d;
    for (const Rgb& c : px) d.insert(d.end(), {c.x, c.y, c.z});
    return writeImage(name, w, h, 3, d);
  }
  void expectInputError(const std::string& path, const std::string& text) {
    try {
      EnvironmentMap::load(path);
      ADD_FAILURE() << "no InputError for " << path;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(fs::path(path).filename().string()), std::string::npos) << msg;
      EXPECT_NE(msg.find(text), std::string::npos) << msg;
    }
  }
  fs::path dir_;
};

// 64 x 32 map: dim grey background and a bright 4 x 4 block at columns 40..43, rows 8..11.
constexpr int kW = 64, kH = 32, kI0 = 40, kI1 = 44, kJ0 = 8, kJ1 = 12;
const Rgb kBackground{0.05f, 0.05f, 0.05f}, kBlock{8.0f, 5.0f, 2.0f};
std::vector<Rgb> blockMap() {
  std::vector<Rgb> px(kW * kH, kBackground);
  for (int j = kJ0; j < kJ1; ++j)
    for (int i = kI0; i < kI1; ++i) px[j * kW + i] = kBlock;
  return px;
}
bool inBlock(int i, int j) { return i >= kI0 && i < kI1 && j >= kJ0 && j < kJ1; }

// Share of luminance-weighted solid angle held by the block: exact cell solid angles
// (2 pi / w)(cos theta_j - cos theta_{j+1}), not the sampler's own weights.
double blockMass() {
  double in = 0, all = 0;
  for (int j = 0; j < kH; ++j) {
    const double omega = 2 * kPi / kW * (std::cos(kPi * j / kH) - std::cos(kPi * (j + 1) / kH));
    for (int i = 0; i < kW; ++i) {
      const double l = luminance(inBlock(i, j) ? kBlock : kBackground) * omega;
      all += l;
      if (inBlock(i, j)) in += l;
    }
  }
  return in / all;
}

// 4 pi * mean of pdf over stratified uniform directions (z and phi strata, jittered).
double integratePdf(const EnvironmentMap& env, bool onlyBlock = false) {
  const int nz = 256, nphi = 512;
  Rng rng(7, Stream::Test);
  double sum = 0;
  for (int a = 0; a < nz; ++a) {
    for (int b = 0; b < nphi; ++b) {
      const double z = 1.0 - 2.0 * (a + rng.uniformD()) / nz;
      const double phi = 2 * kPi * (b + rng.uniformD()) / nphi;
      const Vec3f d = dirFromAngles(std::acos(z), phi);
      if (onlyBlock) {
        int i, j;
        pixelOf(d, kW, kH, i, j);
        if (!inBlock(i, j)) continue;
      }
      sum += env.pdf(d);
    }
  }
  return 4 * kPi * sum / (double(nz) * nphi);
}

TEST_F(EnvMap, ConstantMapEvalAndIntegral) {
  const Rgb value{0.5f, 1.0f, 2.0f};
  const EnvironmentMap env =
      EnvironmentMap::load(writeRgb("const.exr", 32, 16, std::vector<Rgb>(32 * 16, value)));
  EXPECT_FALSE(env.isConstant());
  Rng rng(1, Stream::Test);
  Vec3d est{0, 0, 0};
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    Rgb L;
    float pdf;
    const Vec3f d = env.sample({rng.uniform(), rng.uniform()}, L, pdf);
    ASSERT_GT(pdf, 0.0f);
    EXPECT_NEAR(length(d), 1.0f, 1e-5f);
    EXPECT_EQ(env.eval(d), value);
    est += Vec3d(L) / double(pdf);
  }
  est = est / double(n);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(est[c], 4 * kPi * value[c], 0.01 * 4 * kPi * value[c]);
  // eval is the value everywhere, poles included.
  for (Vec3f d : {Vec3f{0, 0, 1}, Vec3f{0, 0, -1}, Vec3f{1, 0, 0}, Vec3f{-0.3f, 0.2f, -0.9f}})
    EXPECT_EQ(env.eval(d), value);
}

TEST_F(EnvMap, ConstantEnvironmentIsUniform) {
  const Rgb value{0.2f, 0.3f, 0.4f};
  const EnvironmentMap env = EnvironmentMap::constant(value);
  EXPECT_TRUE(env.isConstant());
  Rng rng(2, Stream::Test);
  double meanZ = 0, upper = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    Rgb L;
    float pdf;
    const Vec3f d = env.sample({rng.uniform(), rng.uniform()}, L, pdf);
    EXPECT_NEAR(length(d), 1.0f, 1e-5f);
    EXPECT_FLOAT_EQ(pdf, float(1 / (4 * kPi)));
    EXPECT_FLOAT_EQ(env.pdf(d), pdf);
    EXPECT_EQ(L, value);
    meanZ += d.z / n;
    upper += (d.z > 0.5f) / double(n);  // cap z > 0.5 holds a quarter of the sphere
  }
  EXPECT_NEAR(meanZ, 0.0, 4 * std::sqrt(1.0 / 3 / n));
  EXPECT_NEAR(upper, 0.25, 4 * std::sqrt(0.25 * 0.75 / n));
  EXPECT_EQ(env.eval({0.3f, -0.1f, 0.9f}), value);
}

TEST_F(EnvMap, BrightBlockGetsItsShareOfSamples) {
  const EnvironmentMap env = EnvironmentMap::load(writeRgb("block.exr", kW, kH, blockMap()));
  const double expected = blockMass();
  ASSERT_GT(expected, 0.3);  // the test is sharp only when both outcomes are common
  ASSERT_LT(expected, 0.7);
  Rng rng(3, Stream::Test);
  const int n = 40000;
  int hits = 0;
  double worstPdf = 0;
  for (int k = 0; k < n; ++k) {
    Rgb L;
    float pdf;
    const Vec3f d = env.sample({rng.uniform(), rng.uniform()}, L, pdf);
    int i, j;
    pixelOf(d, kW, kH, i, j);
    hits += inBlock(i, j);
    ASSERT_GT(pdf, 0.0f);
    EXPECT_EQ(L, env.eval(d));
    worstPdf = std::max(worstPdf, std::abs(double(env.pdf(d)) / pdf - 1.0));
  }
  EXPECT_LT(worstPdf, 1e-4);
  EXPECT_NEAR(double(hits) / n, expected, 4 * std::sqrt(expected * (1 - expected) / n));
  // The same mass by integrating the pdf over the block (no sampling involved).
  EXPECT_NEAR(integratePdf(env, true), expected, 0.005);
}

TEST_F(EnvMap, PdfIntegratesToOne) {
  EXPECT_NEAR(integratePdf(EnvironmentMap::load(writeRgb("block.exr", kW, kH, blockMap()))), 1.0,
              0.02);
  // A smooth, strongly varying map with a dark polar cap.
  std::vector<Rgb> px(48 * 24);
  for (int j = 0; j < 24; ++j)
    for (int i = 0; i < 48; ++i)
      px[j * 48 + i] = j < 2 ? Rgb(0.0f) : Rgb{1.0f + i * 0.3f, 0.1f * j, float(i % 5)};
  EXPECT_NEAR(integratePdf(EnvironmentMap::load(writeRgb("smooth.exr", 48, 24, px))), 1.0, 0.02);
  EXPECT_NEAR(integratePdf(EnvironmentMap::constant(Rgb(1.0f))), 1.0, 1e-6);
}

TEST_F(EnvMap, PolesAreSafe) {
  const EnvironmentMap env = EnvironmentMap::load(writeRgb("block.exr", kW, kH, blockMap()));
  for (Vec3f d : {Vec3f{0, 0, 1}, Vec3f{0, 0, -1}}) {
    EXPECT_EQ(env.pdf(d), 0.0f);
    EXPECT_EQ(env.eval(d), kBackground);
  }
  // Samples at the extreme corners of [0,1)^2 stay finite.
  for (Vec2f u : {Vec2f{0, 0}, Vec2f{0.99999994f, 0.99999994f}, Vec2f{0, 0.99999994f}}) {
    Rgb L;
    float pdf;
    const Vec3f d = env.sample(u, L, pdf);
    EXPECT_TRUE(isFinite(d) && std::isfinite(pdf) && pdf >= 0.0f);
  }
}

TEST_F(EnvMap, RotationTurnsFeaturesInPhi) {
  const std::string p = writeRgb("block.exr", kW, kH, blockMap());
  const EnvironmentMap a = EnvironmentMap::load(p), b = EnvironmentMap::load(p, 1.0f, 90.0f);
  const double theta = kPi * (kJ0 + 2.0) / kH, phi = 2 * kPi * (kI0 + 2.0) / kW;  // block centre
  EXPECT_EQ(a.eval(dirFromAngles(theta, phi)), kBlock);
  EXPECT_EQ(b.eval(dirFromAngles(theta, phi)), kBackground);
  EXPECT_EQ(b.eval(dirFromAngles(theta, phi + kPi / 2)), kBlock);
  EXPECT_EQ(b.eval(dirFromAngles(theta, phi + kPi / 2 + 2.5 * 2 * kPi / kW)), kBackground);
  EXPECT_NEAR(b.pdf(dirFromAngles(theta, phi + kPi / 2)) / a.pdf(dirFromAngles(theta, phi)), 1.0,
              1e-5);
  // Same random numbers give the same direction turned by 90 degrees: (x, y) -> (-y, x).
  Rng rng(5, Stream::Test);
  for (int k = 0; k < 1000; ++k) {
    const Vec2f u{rng.uniform(), rng.uniform()};
    Rgb La, Lb;
    float pa, pb;
    const Vec3f da = a.sample(u, La, pa), db = b.sample(u, Lb, pb);
    EXPECT_NEAR(db.x, -da.y, 1e-5f);
    EXPECT_NEAR(db.y, da.x, 1e-5f);
    EXPECT_NEAR(db.z, da.z, 1e-6f);
    EXPECT_EQ(La, Lb);
    EXPECT_NEAR(pb / pa, 1.0f, 1e-6f);
  }
  // A full turn is no turn.
  const EnvironmentMap c = EnvironmentMap::load(p, 1.0f, -270.0f);
  EXPECT_EQ(c.eval(dirFromAngles(theta, phi + kPi / 2)), kBlock);
}

TEST_F(EnvMap, ScaleMultipliesRadiance) {
  const EnvironmentMap env =
      EnvironmentMap::load(writeRgb("block.exr", kW, kH, blockMap()), 2.5f);
  const Rgb got = env.eval({0, 0, 1});
  EXPECT_FLOAT_EQ(got.x, 2.5f * kBackground.x);
}

TEST_F(EnvMap, FormatsAndChannels) {
  // 8-bit PNG is sRGB-encoded: code 128 is linear ((128/255 + 0.055)/1.055)^2.4 = 0.2158605.
  std::vector<float> rgb8(4 * 2 * 3, 128.0f / 255.0f);
  EnvironmentMap png = EnvironmentMap::load(writeImage("grey.png", 4, 2, 3, rgb8,
                                                       OIIO::TypeDesc::UINT8));
  EXPECT_NEAR(png.eval({1, 0, 0.1f}).y, 0.2158605f, 1e-5f);
  // One channel is replicated to RGB.
  std::vector<float> g(4 * 2);
  for (int k = 0; k < 8; ++k) g[k] = 0.1f * (k + 1);
  EnvironmentMap grey = EnvironmentMap::load(writeImage("grey.exr", 4, 2, 1, g));
  // theta = pi/4 is row 0 of 2, theta = 3pi/4 row 1; phi = 3pi/4 is column 1 of 4.
  EXPECT_EQ(grey.eval(dirFromAngles(0.25 * kPi, 0.75 * kPi)), Rgb(g[1]));
  EXPECT_EQ(grey.eval(dirFromAngles(0.75 * kPi, 0.75 * kPi)), Rgb(g[5]));
  // Four channels: alpha is dropped.
  std::vector<float> rgba;
  for (int k = 0; k < 8; ++k) rgba.insert(rgba.end(), {1.0f, 2.0f, 3.0f, 0.0f});
  EnvironmentMap a = EnvironmentMap::load(writeImage("rgba.exr", 4, 2, 4, rgba));
  EXPECT_EQ(a.eval({0, 1, 0.2f}), (Rgb{1.0f, 2.0f, 3.0f}));
}

TEST_F(EnvMap, BadFilesThrowInputError) {
  expectInputError((dir_ / "missing.exr").string(), "not found");
  const std::string junk = (dir_ / "junk.exr").string();
  std::ofstream(junk) << "this is not an image";
  expectInputError(junk, "cannot read");
  std::vector<Rgb> px(8 * 4, Rgb(1.0f));
  px[13].y = std::nanf("");
  expectInputError(writeRgb("nan.exr", 8, 4, px), "(5, 1) is not finite");
  px[13].y = INFINITY;
  expectInputError(writeRgb("inf.exr", 8, 4, px), "not finite");
  px[13].y = -0.5f;
  expectInputError(writeRgb("neg.exr", 8, 4, px), "negative");
  expectInputError(writeRgb("narrow.exr", 1, 4, std::vector<Rgb>(4, Rgb(1.0f))), "2 pixels wide");
  // A PNG whose header declares 60000 x 60000 pixels (and holds a few): allocating 43 GB of floats
  // for it was an internal error, std::bad_alloc.
  auto crc = [](const std::string& bytes) {
    uint32_t c = 0xFFFFFFFFu;
    for (unsigned char b : bytes) {
      c ^= b;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c ^ 0xFFFFFFFFu;
  };
  auto be32 = [](uint32_t v) {
    return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
  };
  auto chunk = [&](const std::string& type, const std::string& data) {
    return be32(uint32_t(data.size())) + type + data + be32(crc(type + data));
  };
  const std::string ihdr = be32(60000) + be32(60000) + std::string("\x08\x02\x00\x00\x00", 5);
  const std::string idat("\x78\x9c\x63\x00\x00\x00\x01\x00\x01", 9);  // zlib of one 0 byte
  const std::string huge = (dir_ / "huge.png").string();
  std::ofstream(huge, std::ios::binary) << std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) +
                                               chunk("IDAT", idat) + chunk("IEND", "");
  expectInputError(huge, "60000x60000; the largest taken is 32768x16384 pixels");
  // A JPEG cut short decodes with a warning only (its lower part grey): refused; whole, it loads.
  std::vector<float> sky(64 * 32 * 3);
  for (size_t i = 0; i < sky.size(); ++i) sky[i] = float((i * 37) % 101) / 100.0f;
  const std::string whole = writeImage("sky.jpg", 64, 32, 3, sky, OIIO::TypeDesc::UINT8);
  EXPECT_NO_THROW(EnvironmentMap::load(whole));
  std::ifstream in(whole, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string half = (dir_ / "half.jpg").string();
  std::ofstream(half, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  expectInputError(half, "the environment map's JPEG is damaged (JPEG error: Premature end of JPEG file");
}

TEST_F(EnvMap, BlackMapCannotBeSampled) {
  const EnvironmentMap env =
      EnvironmentMap::load(writeRgb("black.exr", 8, 4, std::vector<Rgb>(32, Rgb(0.0f))));
  Rgb L;
  float pdf = -1;
  env.sample({0.3f, 0.6f}, L, pdf);
  EXPECT_EQ(pdf, 0.0f);
  EXPECT_EQ(L, Rgb(0.0f));
  EXPECT_EQ(env.pdf({1, 0, 0}), 0.0f);
}

}  // namespace
}  // namespace dg
