// Coincident copies of a surface: stacked duplicates of a face, in one mesh or across meshes, which
// a ray tracer sees once (its first hit) and Cycles therefore renders as one surface.
#pragma once

#include "patch_mesh.h"

#include <string>
#include <vector>

namespace radiosity {

// Of patches with the same four corners, wound the same way, in one object or on objects that stay
// where they are (neither dynamic nor deforming), the first keeps its part in the lighting and the
// others take none (Patch::copy_of: they neither shoot, receive nor block, and their points gather
// nothing). Their input face corners read the first one's corners, as a ray tracer's first hit
// would show. Left in, each copy sends the light it receives again: k copies reflect k times the
// light, and a stack of a bright face diverges. Returns a message per object that had copies,
// naming what they lie on.
std::vector<std::string> merge_coincident_patches(PatchMesh& pm, const std::vector<MeshDesc>& meshes);

// Whether the copies within `object` still lie on what they copy where `placed` puts it (a move
// keeps them there; a deformation may pull them apart, and then the object must be added anew).
bool copies_hold(const PatchMesh& pm, int object, const PlacedObject& placed);

}  // namespace radiosity
