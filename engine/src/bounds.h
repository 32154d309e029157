// Bounding spheres, and the test an update uses to tell which rays a moved object may cross.
#pragma once

#include "radiosity/scene.h"

#include <algorithm>

namespace radiosity {

struct Sphere {
  dvec3 centre{0.0};
  double radius = 0.0;
};

inline bool overlap(const Sphere& a, const Sphere& b) {
  return glm::length(a.centre - b.centre) <= a.radius + b.radius;
}

// Whether the ray origin + t dir, t in [0, t_max], passes through `s`.
inline bool ray_crosses(const dvec3& origin, const dvec3& dir, double t_max, const Sphere& s) {
  double len2 = glm::dot(dir, dir);
  double t = len2 > 0 ? std::clamp(glm::dot(s.centre - origin, dir) / len2, 0.0, t_max) : 0.0;
  return glm::length(origin + t * dir - s.centre) <= s.radius;
}

// Whether a segment from x to some point of `target` may pass through `s`: every such segment lies
// in the capsule of radius target.radius around the segment from x to target's centre.
inline bool may_cross(const dvec3& x, const Sphere& target, const Sphere& s) {
  return ray_crosses(x, target.centre - x, 1.0, {s.centre, s.radius + target.radius});
}

// Where a moved object was and is: rays that pass through neither did not change.
struct Zone {
  Sphere before, after;
  bool may_cross(const dvec3& x, const Sphere& target) const {
    return radiosity::may_cross(x, target, before) || radiosity::may_cross(x, target, after);
  }
  bool crossed_by(const dvec3& origin, const dvec3& dir, double t_max) const {
    return ray_crosses(origin, dir, t_max, before) || ray_crosses(origin, dir, t_max, after);
  }
};

}  // namespace radiosity
