// Small vector and frame types used everywhere. Floats in hot loops, doubles where geometry is derived.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

namespace dg {

constexpr double kPi = 3.14159265358979323846;
constexpr float kPiF = 3.14159265358979323846f;
constexpr float kOneMinusEps = 0x1.fffffep-1f;  // the largest float below 1
constexpr float kInvPiF = 0.31830988618379067154f;

template <class T>
struct V2 {
  T x = 0, y = 0;
  constexpr V2() = default;
  constexpr V2(T a, T b) : x(a), y(b) {}
  V2 operator+(V2 o) const { return {x + o.x, y + o.y}; }
  V2 operator-(V2 o) const { return {x - o.x, y - o.y}; }
  V2 operator*(T s) const { return {x * s, y * s}; }
  V2 operator/(T s) const { return {x / s, y / s}; }
  V2& operator+=(V2 o) { x += o.x; y += o.y; return *this; }
};

template <class T>
struct V3 {
  T x = 0, y = 0, z = 0;
  constexpr V3() = default;
  constexpr V3(T a, T b, T c) : x(a), y(b), z(c) {}
  explicit constexpr V3(T s) : x(s), y(s), z(s) {}
  template <class U>
  explicit constexpr V3(V3<U> o) : x(T(o.x)), y(T(o.y)), z(T(o.z)) {}
  T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  V3 operator+(V3 o) const { return {x + o.x, y + o.y, z + o.z}; }
  V3 operator-(V3 o) const { return {x - o.x, y - o.y, z - o.z}; }
  V3 operator*(V3 o) const { return {x * o.x, y * o.y, z * o.z}; }
  V3 operator/(V3 o) const { return {x / o.x, y / o.y, z / o.z}; }
  V3 operator*(T s) const { return {x * s, y * s, z * s}; }
  V3 operator/(T s) const { return {x / s, y / s, z / s}; }
  V3 operator-() const { return {-x, -y, -z}; }
  V3& operator+=(V3 o) { x += o.x; y += o.y; z += o.z; return *this; }
  V3& operator-=(V3 o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  V3& operator*=(V3 o) { x *= o.x; y *= o.y; z *= o.z; return *this; }
  V3& operator*=(T s) { x *= s; y *= s; z *= s; return *this; }
  bool operator==(V3 o) const { return x == o.x && y == o.y && z == o.z; }
  bool operator!=(V3 o) const { return !(*this == o); }
};

template <class T> inline V3<T> operator*(T s, V3<T> v) { return v * s; }
template <class T> inline T dot(V2<T> a, V2<T> b) { return a.x * b.x + a.y * b.y; }
template <class T> inline T dot(V3<T> a, V3<T> b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
// The plane vectors' cross product: the z component of their 3-D one (twice the signed area of the
// triangle 0, a, b; positive when b lies counterclockwise of a).
template <class T> inline T cross(V2<T> a, V2<T> b) { return a.x * b.y - a.y * b.x; }
template <class T> inline V3<T> cross(V3<T> a, V3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T> inline T length(V3<T> a) { return std::sqrt(dot(a, a)); }
template <class T> inline V3<T> normalize(V3<T> a) {
  T l = length(a);
  return l > T(0) ? a / l : a;
}
// n / |n| in single precision, or +z where n is zero (the normal of a degenerate triangle, or a
// vertex whose faces cancel).
inline V3<float> unitOrUp(V3<double> n) {
  double l = length(n);
  return l > 0 ? V3<float>(n / l) : V3<float>(0, 0, 1);
}
template <class T> inline T maxComponent(V3<T> a) { return std::max(a.x, std::max(a.y, a.z)); }
template <class T> inline bool isFinite(V3<T> a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}

using Vec2f = V2<float>;
using Vec2d = V2<double>;
using Vec3f = V3<float>;
using Vec3d = V3<double>;
using Rgb = V3<float>;  // linear Rec.709

inline float luminance(Rgb c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// Orthonormal frame (tangent, bitangent, normal). Local coordinates have the normal along +z.
struct Frame {
  Vec3f t, b, n;
  static Frame fromNormal(Vec3f n) {
    // Duff et al. 2017, "Building an orthonormal basis, revisited" (branchless ONB).
    float sign = std::copysign(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    Frame f;
    f.n = n;
    f.t = {1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x};
    f.b = {bb, sign + n.y * n.y * a, -n.y};
    return f;
  }
  static Frame fromNormalTangent(Vec3f n, Vec3f tangent) {
    Vec3f t = tangent - n * dot(n, tangent);
    float l = length(t);
    if (!(l > 1e-6f)) return fromNormal(n);
    Frame f;
    f.n = n;
    f.t = t / l;
    f.b = cross(n, f.t);
    return f;
  }
  Vec3f toLocal(Vec3f v) const { return {dot(v, t), dot(v, b), dot(v, n)}; }
  Vec3f toWorld(Vec3f v) const { return t * v.x + b * v.y + n * v.z; }
};

// Rigid transform x' = R x + t (row-major R).
struct Pose {
  double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  Vec3d t{0, 0, 0};
  Vec3d apply(Vec3d p) const {
    return {R[0] * p.x + R[1] * p.y + R[2] * p.z + t.x, R[3] * p.x + R[4] * p.y + R[5] * p.z + t.y,
            R[6] * p.x + R[7] * p.y + R[8] * p.z + t.z};
  }
  Vec3d rotate(Vec3d p) const {
    return {R[0] * p.x + R[1] * p.y + R[2] * p.z, R[3] * p.x + R[4] * p.y + R[5] * p.z,
            R[6] * p.x + R[7] * p.y + R[8] * p.z};
  }
  Vec3d rotateT(Vec3d p) const {
    return {R[0] * p.x + R[3] * p.y + R[6] * p.z, R[1] * p.x + R[4] * p.y + R[7] * p.z,
            R[2] * p.x + R[5] * p.y + R[8] * p.z};
  }
};

inline float clampf(float v, float lo, float hi) { return std::min(hi, std::max(lo, v)); }
inline float sqr(float v) { return v * v; }
inline float safeSqrt(float v) { return std::sqrt(std::max(0.0f, v)); }
inline float degToRad(float d) { return d * kPiF / 180.0f; }

}  // namespace dg
