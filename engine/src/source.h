// What one gather pass collects light from: a lamp, the world, or a shot (an area lamp, or patches
// emitting or reflecting), with the bounds of where its rays go. An update uses the bounds to find
// the receiving points a moved object could stand between: the paper's shadow zones (sec. 5).
#pragma once

#include "bounds.h"
#include "lights.h"
#include "mirror.h"
#include "occlusion_batch.h"
#include "shot.h"

#include <memory>
#include <vector>

namespace radiosity {

struct Source {
  enum class Kind { Lamp, World, Shot } kind = Kind::Lamp;
  Lamp lamp;           // point, spot or sun (area lamps are shots); in the patch mesh's frame
  WorldMap world;      // Kind::World: the sky's radiance by direction
  Shot shot;
  int samples = 0;     // lamps and world
  int shooter = -1;    // the shooter (cluster) whose patches shoot; -1 for lamps and the world
  Sphere bounds;       // holds every finite ray end (not used by suns and the world)
  // An image in a mirror: the mirror, and the side of it (+1 the normal's, -1 the other) its real
  // shooter and its receivers lie on. Its rays go by way of the mirror (OcclusionBatch::set_mirror).
  std::shared_ptr<const MirrorPlane> mirror;
  double side = 1.0;

  // With `zone`, only the rays that may pass through it.
  void gather(int receiver, const ReceiverPoint& point, OcclusionBatch& batch, const Zones* zone = nullptr) const;
  // Whether some of its rays to a point within `receivers` may pass through `zone`.
  bool may_reach(const Sphere& receivers, const Zone& zone) const;

 private:
  // The same for its rays as straight lines (an image's, unfolded: the mirror left out).
  bool unfolded_may_reach(const Sphere& receivers, const Zone& zone) const;
};

// `lamp` in the patch mesh's frame; rectangle and disc lamps become shots.
Source lamp_source(const Lamp& lamp, int samples);
Source world_source(WorldMap sky, int samples);
Source shot_source(Shot shot, int shooter, const Sphere& bounds);
// The source's images in `plane`: one on the side of the plane the source lies on (none if it lies
// in it), the world's on both.
std::vector<Source> mirror_images(const Source& source, const std::shared_ptr<const MirrorPlane>& plane);

}  // namespace radiosity
