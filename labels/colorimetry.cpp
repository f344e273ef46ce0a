#include "labels/colorimetry.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace dg::color {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double deg2rad(double d) { return d * kPi / 180.0; }
constexpr double rad2deg(double r) { return r * 180.0 / kPi; }

// CIE 1976 constants: delta = 6/29; the cube-root branch is used above delta^3.
constexpr double kDelta = 6.0 / 29.0;
constexpr double kDelta3 = kDelta * kDelta * kDelta;     // 0.008856...
constexpr double kLinSlope = 1.0 / (3.0 * kDelta * kDelta);  // 7.787...

}  // namespace

double srgbDecode(double v) {
  // IEC 61966-2-1: V <= 0.04045 -> V / 12.92, else ((V + 0.055) / 1.055)^2.4. Odd extension for
  // negative values so that the curve is monotone over the whole line.
  double a = std::fabs(v);
  double r = a <= 0.04045 ? a / 12.92 : std::pow((a + 0.055) / 1.055, 2.4);
  return v < 0 ? -r : r;
}

double srgbEncode(double v) {
  double a = std::fabs(v);
  double r = a <= 0.0031308 ? a * 12.92 : 1.055 * std::pow(a, 1.0 / 2.4) - 0.055;
  return v < 0 ? -r : r;
}

const cv::Matx33d& linearSrgbToXyz() {
  // IEC 61966-2-1 (sRGB), section 5.2, times 100.
  static const cv::Matx33d m(41.24, 35.76, 18.05,  //
                             21.26, 71.52, 7.22,   //
                             1.93, 11.92, 95.05);
  return m;
}

const cv::Matx33d& xyzToLinearSrgb() {
  static const cv::Matx33d m = linearSrgbToXyz().inv();
  return m;
}

Vec3 srgbWhiteXyz() { return linearSrgbToXyz() * Vec3(1, 1, 1); }

double fastCbrt(double t) {
  if (!(t > 0)) return t == 0 ? 0.0 : (std::isnan(t) ? t : -fastCbrt(-t));
  if (std::isinf(t)) return t;
  // First guess: a third of the bit pattern plus 2/3 of the pattern of 1.0 (0x3FF0... * 2/3 =
  // 0x2AA0..., lowered slightly to centre the guess's error), about 5 correct bits. Then two steps
  // of Halley's iteration y <- y (y^3 + 2t) / (2y^3 + t), which triples the number of correct bits
  // per step (5 -> 15 -> 45+); the worst relative error measured against std::cbrt over
  // [1e-12, 1e3] is 7e-15.
  uint64_t bits;
  std::memcpy(&bits, &t, sizeof bits);
  bits = bits / 3 + 0x2A9F7893782DA1CEull;
  double y;
  std::memcpy(&y, &bits, sizeof y);
  for (int i = 0; i < 2; ++i) {
    double y3 = y * y * y;
    y = y * (y3 + 2.0 * t) / (2.0 * y3 + t);
  }
  return y;
}

double labF(double t) { return t > kDelta3 ? fastCbrt(t) : t * kLinSlope + 4.0 / 29.0; }

double labFInv(double f) { return f > kDelta ? f * f * f : (f - 4.0 / 29.0) / kLinSlope; }

Vec3 xyzToLab(const Vec3& xyz, const Vec3& w) {
  double fx = labF(xyz[0] / w[0]), fy = labF(xyz[1] / w[1]), fz = labF(xyz[2] / w[2]);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

Vec3 labToXyz(const Vec3& lab, const Vec3& w) {
  double fy = (lab[0] + 16.0) / 116.0;
  double fx = fy + lab[1] / 500.0;
  double fz = fy - lab[2] / 200.0;
  return {w[0] * labFInv(fx), w[1] * labFInv(fy), w[2] * labFInv(fz)};
}

double deltaE76(const Vec3& a, const Vec3& b) {
  double dl = a[0] - b[0], da = a[1] - b[1], db = a[2] - b[2];
  return std::sqrt(dl * dl + da * da + db * db);
}

double deltaE94(const Vec3& ref, const Vec3& test) {
  // CIE 116-1995: dE = sqrt((dL/kL SL)^2 + (dC/kC SC)^2 + (dH/kH SH)^2), SL = 1,
  // SC = 1 + K1 C1, SH = 1 + K2 C1 with C1 the reference chroma; graphic arts K1 = .045, K2 = .015.
  double c1 = std::hypot(ref[1], ref[2]), c2 = std::hypot(test[1], test[2]);
  double dl = ref[0] - test[0], dc = c1 - c2;
  double da = ref[1] - test[1], db = ref[2] - test[2];
  double dh2 = da * da + db * db - dc * dc;  // dH^2, may round slightly below 0
  if (dh2 < 0) dh2 = 0;
  double sc = 1.0 + 0.045 * c1, sh = 1.0 + 0.015 * c1;
  double tc = dc / sc;
  return std::sqrt(dl * dl + tc * tc + dh2 / (sh * sh));
}

double deltaE2000(const Vec3& lab1, const Vec3& lab2) {
  // Sharma, Wu, Dalal (2005), equations (2)-(22), kL = kC = kH = 1.
  const double L1 = lab1[0], a1 = lab1[1], b1 = lab1[2];
  const double L2 = lab2[0], a2 = lab2[1], b2 = lab2[2];
  const double pow25_7 = 6103515625.0;  // 25^7
  double C1 = std::hypot(a1, b1), C2 = std::hypot(a2, b2);
  double Cbar = 0.5 * (C1 + C2);
  double Cbar7 = std::pow(Cbar, 7.0);
  double G = 0.5 * (1.0 - std::sqrt(Cbar7 / (Cbar7 + pow25_7)));  // (4)
  double a1p = (1.0 + G) * a1, a2p = (1.0 + G) * a2;               // (5)
  double C1p = std::hypot(a1p, b1), C2p = std::hypot(a2p, b2);     // (6)
  // (7): hue angle in [0, 360), 0 when a' = b = 0.
  auto hue = [](double ap, double b) {
    if (ap == 0 && b == 0) return 0.0;
    double h = rad2deg(std::atan2(b, ap));
    return h < 0 ? h + 360.0 : h;
  };
  double h1p = hue(a1p, b1), h2p = hue(a2p, b2);
  double dLp = L2 - L1;  // (8)
  double dCp = C2p - C1p;  // (9)
  double dhp = 0;          // (10)
  if (C1p * C2p != 0) {
    dhp = h2p - h1p;
    if (dhp > 180) dhp -= 360;
    else if (dhp < -180) dhp += 360;
  }
  double dHp = 2.0 * std::sqrt(C1p * C2p) * std::sin(deg2rad(dhp / 2.0));  // (11)
  double Lbarp = 0.5 * (L1 + L2);                                          // (12)
  double Cbarp = 0.5 * (C1p + C2p);                                        // (13)
  double hbarp;                                                            // (14)
  if (C1p * C2p == 0) {
    hbarp = h1p + h2p;
  } else if (std::fabs(h1p - h2p) <= 180) {
    hbarp = 0.5 * (h1p + h2p);
  } else if (h1p + h2p < 360) {
    hbarp = 0.5 * (h1p + h2p + 360);
  } else {
    hbarp = 0.5 * (h1p + h2p - 360);
  }
  double T = 1.0 - 0.17 * std::cos(deg2rad(hbarp - 30)) + 0.24 * std::cos(deg2rad(2 * hbarp)) +
             0.32 * std::cos(deg2rad(3 * hbarp + 6)) - 0.20 * std::cos(deg2rad(4 * hbarp - 63));  // (15)
  double dTheta = 30.0 * std::exp(-((hbarp - 275) / 25) * ((hbarp - 275) / 25));                     // (16)
  double Cbarp7 = std::pow(Cbarp, 7.0);
  double RC = 2.0 * std::sqrt(Cbarp7 / (Cbarp7 + pow25_7));  // (17)
  double l50 = (Lbarp - 50) * (Lbarp - 50);
  double SL = 1.0 + 0.015 * l50 / std::sqrt(20 + l50);  // (18)
  double SC = 1.0 + 0.045 * Cbarp;                      // (19)
  double SH = 1.0 + 0.015 * Cbarp * T;                  // (20)
  double RT = -std::sin(deg2rad(2 * dTheta)) * RC;      // (21)
  double tl = dLp / SL, tc = dCp / SC, th = dHp / SH;
  return std::sqrt(tl * tl + tc * tc + th * th + RT * tc * th);  // (22)
}

double deltaE(DeltaE f, const Vec3& a, const Vec3& b) {
  switch (f) {
    case DeltaE::CIE76: return deltaE76(a, b);
    case DeltaE::CIE94: return deltaE94(a, b);
    case DeltaE::CIEDE2000: return deltaE2000(a, b);
  }
  return deltaE76(a, b);
}

const cv::Matx33d& xyzToOpponent(Observer obs) {
  // Zhang and Wandell, S-CIELAB distribution (cmatrix 'xyz2opp'), values / 1000.
  static const cv::Matx33d m2(278.7336, 721.8031, -106.5520,  //
                              -448.7736, 289.8056, 77.1569,   //
                              85.9513, -589.9859, 501.1089);
  static const cv::Matx33d m10(288.5613, 659.7617, -130.5654,  //
                               -464.8864, 326.2702, 62.4200,   //
                               79.8787, -554.7976, 481.4746);
  static const cv::Matx33d s2 = m2 * (1.0 / 1000.0), s10 = m10 * (1.0 / 1000.0);
  return obs == Observer::Deg10 ? s10 : s2;
}

cv::Matx33d opponentToXyz(Observer obs) { return xyzToOpponent(obs).inv(); }

cv::Matx33d xyzToYcxczLinear(const Vec3& w) {
  return cv::Matx33d(0, 116.0 / w[1], 0,               //
                     500.0 / w[0], -500.0 / w[1], 0,   //
                     0, 200.0 / w[1], -200.0 / w[2]);
}

Vec3 xyzToYcxcz(const Vec3& xyz, const Vec3& w) {
  Vec3 v = xyzToYcxczLinear(w) * xyz;
  v[0] -= 16.0;
  return v;
}

Vec3 ycxczToXyz(const Vec3& ycc, const Vec3& w) {
  Vec3 v = ycc;
  v[0] += 16.0;
  return xyzToYcxczLinear(w).inv() * v;
}

}  // namespace dg::color
