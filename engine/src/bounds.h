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

// Whether the ray origin + t dir, t in [0, t_max], passes through `s`. In squares, with no square
// root or division: an update asks it millions of times, and their latency would be most of its cost.
inline bool ray_crosses(const dvec3& origin, const dvec3& dir, double t_max, const Sphere& s) {
  dvec3 c = s.centre - origin;
  double r2 = s.radius * s.radius;
  double c2 = glm::dot(c, c);
  if (c2 <= r2) return true;
  double along = glm::dot(c, dir);  // t of the nearest point times |dir|^2
  if (along <= 0) return false;     // the sphere is behind the start, which is outside it
  double len2 = glm::dot(dir, dir);
  if (along < t_max * len2) return c2 * len2 - along * along <= r2 * len2;
  dvec3 e = c - t_max * dir;  // nearest at the end
  return glm::dot(e, e) <= r2;
}

// Whether a segment from x to some point of `target` may pass through `s`: every such segment lies
// in the capsule of radius target.radius around the segment from x to target's centre, and in the
// cone from x around `target`, which must then meet the cone around `s`. The cone is the tighter
// near x, where the capsule is as wide as at `target`.
inline bool may_cross(const dvec3& x, const Sphere& target, const Sphere& s) {
  if (!ray_crosses(x, target.centre - x, 1.0, {s.centre, s.radius + target.radius})) return false;
  dvec3 a = target.centre - x, b = s.centre - x;
  double a2 = glm::dot(a, a), b2 = glm::dot(b, b);
  double ra2 = target.radius * target.radius, rb2 = s.radius * s.radius;
  if (a2 <= ra2 || b2 <= rb2) return true;
  // The angle between the axes at most the sum of the half-angles, asin(r / d) each, in cosines.
  return glm::dot(a, b) >= std::sqrt((a2 - ra2) * (b2 - rb2)) - target.radius * s.radius;
}

// The smallest sphere around both.
inline Sphere enclosing(const Sphere& a, const Sphere& b) {
  double d = glm::length(b.centre - a.centre);
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  double r = 0.5 * (d + a.radius + b.radius);
  return {a.centre + (r - a.radius) / d * (b.centre - a.centre), r};
}

// Where a moved object was and is: rays that pass through neither did not change.
struct Zone {
  Sphere before, after;
  // Around both: most of what is asked misses it, for one test rather than two.
  Sphere around = enclosing(before, after);
  bool may_cross(const dvec3& x, const Sphere& target) const {
    return radiosity::may_cross(x, target, around) &&
           (radiosity::may_cross(x, target, before) || radiosity::may_cross(x, target, after));
  }
  bool crossed_by(const dvec3& origin, const dvec3& dir, double t_max) const {
    return ray_crosses(origin, dir, t_max, around) &&
           (ray_crosses(origin, dir, t_max, before) || ray_crosses(origin, dir, t_max, after));
  }
};

// Where several objects moved together were and are: a ray may have changed if it passes through
// any one's Zone.
struct Zones {
  const Zone* zones = nullptr;
  int count = 0;
  bool may_cross(const dvec3& x, const Sphere& target) const {
    for (int k = 0; k < count; ++k)
      if (zones[k].may_cross(x, target)) return true;
    return false;
  }
  bool crossed_by(const dvec3& origin, const dvec3& dir, double t_max) const {
    for (int k = 0; k < count; ++k)
      if (zones[k].crossed_by(origin, dir, t_max)) return true;
    return false;
  }
};

}  // namespace radiosity
