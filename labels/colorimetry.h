// Colorimetry for image comparison: the sRGB transfer curve, linear sRGB <-> CIE XYZ, CIELAB,
// colour differences (CIE 1976, CIE94, CIEDE2000), the opponent space of S-CIELAB and the
// linearised CIELAB space YCxCz. Everything per colour and in double precision; the image-level
// loops live in scielab.cpp.
//
// Conventions: XYZ is scaled so that the sRGB white (linear RGB = 1, 1, 1) has Y = 100; CIELAB is
// taken relative to that white unless another white is passed. Lab triples are (L*, a*, b*).
#pragma once
#include <opencv2/core.hpp>

namespace dg::color {

using Vec3 = cv::Vec3d;

// IEC 61966-2-1:1999 sRGB transfer curve, piecewise: linear segment of slope 1/12.92 below the
// encoded value 0.04045 (linear 0.0031308), power 2.4 with offset 0.055 above. No clamping.
double srgbDecode(double encoded);
double srgbEncode(double linear);

// Linear sRGB (Rec. 709 primaries, D65) -> XYZ, the 4-digit IEC 61966-2-1 matrix times 100, so that
// white has Y = 100. srgbWhiteXyz() is its row sums, (95.05, 100.00, 108.90): the white of the images,
// used as the CIELAB white so that RGB white is exactly neutral (the tabulated D65 2-degree white,
// (95.047, 100, 108.883), differs by under 0.02 Delta E).
const cv::Matx33d& linearSrgbToXyz();
const cv::Matx33d& xyzToLinearSrgb();
Vec3 srgbWhiteXyz();

// CIE 1976 L*a*b* (CIE 15:2004, section 8.2.1), with the linear segment below (6/29)^3.
double labF(double t);     // f(t) = t^(1/3) for t > (6/29)^3, t / (3 (6/29)^2) + 4/29 below
double labFInv(double f);  // inverse of labF
Vec3 xyzToLab(const Vec3& xyz, const Vec3& white);
Vec3 labToXyz(const Vec3& lab, const Vec3& white);

// Cube root to a relative error below 1e-14, without libm's cbrt (a bit-level first guess and two
// Halley steps); about twice as fast as std::cbrt, which dominates a per-pixel Lab conversion.
double fastCbrt(double t);

enum class DeltaE { CIE76, CIE94, CIEDE2000 };

// Euclidean distance in L*a*b* (CIE 1976).
double deltaE76(const Vec3& lab1, const Vec3& lab2);
// CIE94 (CIE 116-1995) with the graphic-arts constants kL = kC = kH = 1, K1 = 0.045, K2 = 0.015.
// Not symmetric: lab1 is the reference, whose chroma sets S_C and S_H.
double deltaE94(const Vec3& lab1, const Vec3& lab2);
// CIEDE2000 (CIE 142-2001), kL = kC = kH = 1, following the implementation notes of Sharma, Wu and
// Dalal (Color Res. Appl. 30(1), 2005): hue angle 0 for zero chroma, mean hue and hue difference
// per their equations (7)-(14).
double deltaE2000(const Vec3& lab1, const Vec3& lab2);
double deltaE(DeltaE formula, const Vec3& lab1, const Vec3& lab2);

// Observer of the colour-matching functions the S-CIELAB opponent transform was fitted for.
enum class Observer { Deg2 = 2, Deg10 = 10 };

// XYZ -> opponent (O1 luminance, O2 red-green, O3 blue-yellow) of Zhang and Wandell's S-CIELAB
// (pattern-colour separable space of Poirson and Wandell 1993), o = M x. The matrices are the ones
// of the S-CIELAB distribution for the CIE 1931 2-degree and CIE 1964 10-degree XYZ.
const cv::Matx33d& xyzToOpponent(Observer obs);
cv::Matx33d opponentToXyz(Observer obs);

// YCxCz, the linearised CIELAB of Flohr, Kolpatzik, Balasubramanian, Carrara, Bouman and
// Allebach (SPIE 1913, 1993) and Kolpatzik and Bouman (J. Electronic Imaging 1(3), 1992):
//   Yy = 116 Y/Yn - 16,  Cx = 500 (X/Xn - Y/Yn),  Cz = 200 (Y/Yn - Z/Zn).
// It is CIELAB with f(t) replaced by its tangent at the white point (up to the scale 3).
Vec3 xyzToYcxcz(const Vec3& xyz, const Vec3& white);
Vec3 ycxczToXyz(const Vec3& ycc, const Vec3& white);
// The linear part of xyzToYcxcz (without the -16 offset of Yy): ycc + (16, 0, 0) = A xyz.
cv::Matx33d xyzToYcxczLinear(const Vec3& white);

}  // namespace dg::color
