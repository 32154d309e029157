// How a receiving point gathers a shot: a walk down the shooter's clusters to far samples, cells
// and, near the receiver, cells integrated exactly piece by piece, each a ray into the batch.
#pragma once

#include "bounds.h"
#include "occlusion_batch.h"
#include "shot.h"

namespace radiosity {

// Adds to the batch the rays carrying the shot's irradiance to receiving point `receiver`; with
// `zone`, only those that may pass through one of its places (whole clusters and cells are passed
// over).
void gather(const Shot& shot, int receiver, const ReceiverPoint& point, OcclusionBatch& batch,
            const Zones* zone = nullptr);

}  // namespace radiosity
