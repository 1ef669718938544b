#pragma once
// Library-internal: atan2 in float without a libm call (glibc's atan2f goes through the double
// routine and dominated FPFH's cost). Range reduction and polynomial as in Cephes' atanf
// (S. L. Moshier): |x| <= tan(pi/8) after reduction, a degree-9 odd polynomial; the error is a
// few float ulps (< 3e-7 rad, checked in fpfh_test.cpp), far below an FPFH bin (2 pi / 11).

#include <cmath>
#include <numbers>

namespace locard::detail {

// atan(t) for t >= 0.
inline float atan_nonnegative(float t) {
  constexpr float kPi2 = std::numbers::pi_v<float> / 2;
  constexpr float kPi4 = std::numbers::pi_v<float> / 4;
  float offset = 0.f;
  if (t > 2.414213562373095f) {  // tan(3 pi / 8)
    offset = kPi2;
    t = -1.f / t;
  } else if (t > 0.4142135623730950f) {  // tan(pi / 8)
    offset = kPi4;
    t = (t - 1.f) / (t + 1.f);
  }
  const float z = t * t;
  return offset +
         ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z -
           3.33329491539e-1f) * z * t + t);
}

// Same quadrant conventions as std::atan2 for finite inputs (atan2(+-0, x >= +0) = +-0,
// atan2(+-0, x < 0) = +-pi, atan2(y, 0) = +-pi/2).
inline float fast_atan2(float y, float x) {
  constexpr float kPi = std::numbers::pi_v<float>;
  const float ax = std::abs(x), ay = std::abs(y);
  float angle;
  if (ax == 0.f && ay == 0.f) {
    angle = 0.f;
  } else if (ax == 0.f) {
    angle = kPi / 2;
  } else {
    angle = atan_nonnegative(ay / ax);
  }
  if (std::signbit(x)) angle = kPi - angle;
  return std::signbit(y) ? -angle : angle;
}

}  // namespace locard::detail
