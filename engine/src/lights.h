// Blender's lamps and world as seen by a receiving point: direct light, with sampled visibility.
#pragma once

#include "radiosity/scene.h"
#include "shot.h"
#include "occlusion_batch.h"

namespace radiosity {

// Rays from `point` to a point, spot or sun lamp, or to the sky (world), carrying the irradiance/pi
// each delivers. `lamp` is in the patch mesh's frame (origin subtracted). `samples` is the number of
// rays used for lamps with a size (soft shadows) and for the sky per side.
void gather_lamp(const Lamp& lamp, int samples, int receiver, const ReceiverPoint& point,
                 OcclusionBatch& batch);
void gather_world(const WorldMap& sky, int samples, int receiver, const ReceiverPoint& point,
                  OcclusionBatch& batch);

// Rectangle and disc lamps are one-sided emitting polygons: they shoot like a patch would.
Shot area_lamp_shot(const Lamp& lamp, int samples);

// Cycles' spot cone: the cosine to the axis, faded by smoothstep over the blend region.
double spot_attenuation(const Lamp& lamp, const dvec3& to_receiver_unit);

}  // namespace radiosity
