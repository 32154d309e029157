// Four doubles side by side (GCC's vector extension), for arithmetic written once and run on one
// element or on four. Each lane takes the very operations of the scalar code in the same order,
// so a lane's bits are the scalar's. In the AVX2 clones (dispatch.h) a Lanes is one register; in
// the baseline build, two.
#pragma once

#include <glm/glm.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace radiosity {

constexpr int kLanes = 4;
using Lanes = double __attribute__((vector_size(kLanes * sizeof(double))));
// What comparing two Lanes gives: all ones in the lanes where it holds.
using LaneMask = std::int64_t __attribute__((vector_size(kLanes * sizeof(double))));
// Structs of Lanes kept in memory are aligned to a Lanes' size by hand: outside AVX code GCC
// aligns a Lanes to 16 bytes only, and memory the baseline code allocates for them would break the
// AVX2 clones' aligned loads. (On the type itself the alignment would be dropped where it is a
// template argument.)
constexpr std::size_t kLanesAlignment = sizeof(Lanes);

struct alignas(kLanesAlignment) Lanes3 {
  Lanes x, y, z;
};

// Everything taking or giving Lanes is inlined: a call between an AVX2 clone and baseline code
// would pass them in different registers (GCC's -Wpsabi note).
#define RADIOSITY_LANES inline __attribute__((always_inline))

RADIOSITY_LANES Lanes lanes_of(double v) { return Lanes{v, v, v, v}; }
RADIOSITY_LANES Lanes3 lanes_of(const glm::dvec3& v) { return {lanes_of(v.x), lanes_of(v.y), lanes_of(v.z)}; }
RADIOSITY_LANES glm::dvec3 lane(const Lanes3& v, int i) { return glm::dvec3(v.x[i], v.y[i], v.z[i]); }
RADIOSITY_LANES void set_lane(Lanes3& v, int i, const glm::dvec3& value) { v.x[i] = value.x, v.y[i] = value.y, v.z[i] = value.z; }

RADIOSITY_LANES Lanes3 operator+(const Lanes3& a, const Lanes3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
RADIOSITY_LANES Lanes3 operator-(const Lanes3& a, const Lanes3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
RADIOSITY_LANES Lanes3 operator*(const Lanes& s, const Lanes3& v) { return {s * v.x, s * v.y, s * v.z}; }
// In glm::dot's order.
RADIOSITY_LANES Lanes dot(const Lanes3& a, const Lanes3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// a where m holds, else b.
RADIOSITY_LANES Lanes3 select(const LaneMask& m, const Lanes3& a, const Lanes3& b) {
  return {m ? a.x : b.x, m ? a.y : b.y, m ? a.z : b.z};
}
RADIOSITY_LANES bool any(const LaneMask& m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }

// std::fabs, for the number types that generic arithmetic runs on.
RADIOSITY_LANES double magnitude(double v) { return std::fabs(v); }
RADIOSITY_LANES Lanes magnitude(const Lanes& v) {
  constexpr std::int64_t kSign = INT64_MIN;
  return Lanes(LaneMask(v) & ~LaneMask{kSign, kSign, kSign, kSign});
}
static_assert(kLanes == 4, "lanes_of, any and magnitude spell out four lanes");

}  // namespace radiosity
