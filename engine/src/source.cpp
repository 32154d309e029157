#include "source.h"

#include "gather.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

// Whether some ray from x towards the sun may pass through `s`.
bool sun_may_cross(const Lamp& sun, const dvec3& x, const Sphere& s) {
  dvec3 v = s.centre - x;
  double d = glm::length(v);
  if (d <= s.radius) return true;
  double to_sun = std::acos(std::clamp(-glm::dot(v, glm::normalize(sun.direction)) / d, -1.0, 1.0));
  return to_sun <= 0.5 * sun.angle + std::asin(s.radius / d);
}

}  // namespace

void Source::gather(int receiver, const ReceiverPoint& point, OcclusionBatch& batch, const Zones* zone) const {
  if (zone && std::none_of(zone->zones, zone->zones + zone->count,
                           [&](const Zone& z) { return may_reach({point.position, 0.0}, z); }))
    return;
  switch (kind) {
    case Kind::Lamp:
      gather_lamp(lamp, samples, receiver, point, batch);
      break;
    case Kind::World:
      gather_world(world, samples, receiver, point, batch);
      break;
    case Kind::Shot:
      radiosity::gather(shot, receiver, point, batch, zone);
      break;
  }
}

// A ray from a point x' within `receivers` of its centre x is a ray from x moved by x' - x: it
// passes through a sphere only if one from x passes through that sphere grown by the group's
// radius, to a target grown as much.
bool Source::may_reach(const Sphere& receivers, const Zone& zone) const {
  if (kind == Kind::World) return true;  // rays leave every point in every direction
  const dvec3& x = receivers.centre;
  double grow = receivers.radius;
  // Asked about each receiving point (grow 0) of each pair a gather takes: the zone as it is, whose
  // enclosing sphere, worked out anew, would cost a square root and a division each time.
  Zone grown = grow == 0 ? zone
                         : Zone{{zone.before.centre, zone.before.radius + grow}, {zone.after.centre, zone.after.radius + grow}};
  if (kind == Kind::Lamp && lamp.type == Lamp::Type::Sun)
    return sun_may_cross(lamp, x, grown.before) || sun_may_cross(lamp, x, grown.after);
  return grown.may_cross(x, {bounds.centre, bounds.radius + grow});
}

Source lamp_source(const Lamp& lamp, int samples) {
  Source s;
  s.lamp = lamp;
  s.samples = samples;
  s.bounds = {lamp.position, lamp.radius};
  if (lamp.type == Lamp::Type::Rect || lamp.type == Lamp::Type::Disc) {
    s.kind = Source::Kind::Shot;
    s.shot = area_lamp_shot(lamp, samples);
    // A disc is shot as a polygon a little wider than its radius.
    s.bounds.radius = 1.5 * std::max(lamp.radius, glm::length(lamp.u_axis) + glm::length(lamp.v_axis));
  }
  return s;
}

Source world_source(WorldMap sky, int samples) {
  Source s;
  s.kind = Source::Kind::World;
  s.world = std::move(sky);
  s.samples = samples;
  return s;
}

Source shot_source(Shot shot, int shooter, const Sphere& bounds) {
  Source s;
  s.kind = Source::Kind::Shot;
  s.shot = std::move(shot);
  s.shooter = shooter;
  s.bounds = bounds;
  return s;
}

}  // namespace radiosity
