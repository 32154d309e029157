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

// A receiver this close to a mirror's plane (in ray offsets) lies on it.
constexpr double kOffMirror = 4.0;

// A path by way of a mirror, unfolded, is the straight ray from the receiver to the image: its
// first leg is the ray's part up to the mirror, its second the reflection of the rest. So the path
// passes through a zone only where the ray passes through the zone or its reflection.
Zone reflected(const Zone& zone, const MirrorPlane& mirror) {
  return {{mirror.reflect(zone.before.centre), zone.before.radius}, {mirror.reflect(zone.after.centre), zone.after.radius}};
}

}  // namespace

void Source::gather(int receiver, const ReceiverPoint& point, OcclusionBatch& batch, const Zones* zone) const {
  if (zone && std::none_of(zone->zones, zone->zones + zone->count,
                           [&](const Zone& z) { return may_reach({point.position, 0.0}, z); }))
    return;
  const Zones* cells_zone = zone;  // what a shot's cells are asked about
  auto take = [&](const ReceiverPoint& at) {
    switch (kind) {
      case Kind::Lamp:
        gather_lamp(lamp, samples, receiver, at, batch);
        break;
      case Kind::World:
        gather_world(world, samples, receiver, at, batch);
        break;
      case Kind::Shot:
        radiosity::gather(shot, receiver, at, batch, cells_zone);
        break;
    }
  };
  if (!mirror) return take(point);
  // An image lights the receivers on its real shooter's side of the mirror that see it through the
  // mirror's sphere; the mirror's own points and those in its plane take nothing from it.
  const dvec3& x = point.position;
  if (!(side * mirror->height(x) > kOffMirror * batch.visibility().epsilon())) return;
  bool sun = kind == Kind::Lamp && lamp.type == Lamp::Type::Sun;
  if (kind != Kind::World && (sun ? !sun_may_cross(lamp, x, mirror->bounds()) : !may_cross(x, bounds, mirror->bounds())))
    return;
  // The image lies beyond the walls round the receiver: a closed object's inside sees it too.
  ReceiverPoint open = point;
  open.enclosed_side = -1;
  // The cells are images: their unfolded rays pass through the zones or the zones' reflections.
  thread_local std::vector<Zone> unfolded;
  Zones unfolded_zones;
  if (zone) {
    unfolded.assign(zone->zones, zone->zones + zone->count);
    for (int k = 0; k < zone->count; ++k) unfolded.push_back(reflected(zone->zones[k], *mirror));
    unfolded_zones = {unfolded.data(), int(unfolded.size())};
    cells_zone = &unfolded_zones;
  }
  batch.set_mirror(mirror.get(), side);
  take(open);
  batch.set_mirror(nullptr, 1.0);
}

// A ray from a point x' within `receivers` of its centre x is a ray from x moved by x' - x: it
// passes through a sphere only if one from x passes through that sphere grown by the group's
// radius, to a target grown as much.
bool Source::may_reach(const Sphere& receivers, const Zone& zone) const {
  if (kind == Kind::World) return true;  // rays leave every point in every direction
  if (mirror) return unfolded_may_reach(receivers, zone) || unfolded_may_reach(receivers, reflected(zone, *mirror));
  return unfolded_may_reach(receivers, zone);
}

bool Source::unfolded_may_reach(const Sphere& receivers, const Zone& zone) const {
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

std::vector<Source> mirror_images(const Source& source, const std::shared_ptr<const MirrorPlane>& plane) {
  if (source.kind == Source::Kind::World) {
    Source image = world_source(mirrored(source.world, *plane), source.samples);
    image.mirror = plane;
    Source back = image;
    back.side = -1.0;
    return {std::move(image), std::move(back)};
  }
  bool sun = source.kind == Source::Kind::Lamp && source.lamp.type == Lamp::Type::Sun;
  // The side the light comes from: the sun's, or the shooter's centre's.
  double h = sun ? -glm::dot(source.lamp.direction, plane->normal()) : plane->height(source.bounds.centre);
  if (h == 0) return {};
  Source image;
  image.kind = source.kind;
  image.samples = source.samples;
  image.shooter = source.shooter;
  image.mirror = plane;
  image.side = h > 0 ? 1.0 : -1.0;
  image.bounds = {plane->reflect(source.bounds.centre), source.bounds.radius};
  if (source.kind == Source::Kind::Lamp) {
    image.lamp = source.lamp;
    image.lamp.position = plane->reflect(source.lamp.position);
    image.lamp.direction = plane->reflect_direction(source.lamp.direction);
  } else {
    image.shot = mirrored(source.shot, *plane);
  }
  return {std::move(image)};
}

}  // namespace radiosity
