// What a receiving point on a smooth-shaded (curved) surface sees of the patches it lies on.
#pragma once

#include "patch_mesh.h"

#include <array>

namespace radiosity {

// Cycles shades a corner of a smooth facet about the corner's normal and drops directions under
// the facet (bsdf_diffuse_sample); every direction above it sees something, the facets next to it
// included. A receiving point, shared by the facets round a vertex, gathers over the hemisphere
// of its normal from every patch but those it lies on, so it misses what those show it at close
// range: nothing on a convex surface, where they fall away below the hemisphere, but on a concave
// one (the inside of a curved box) a part of the view that stays as the level rises.
struct CornerView {
  // Per side (front, back): of the light reflected towards the point from beyond its own patches,
  // the part its facets' corners take (their mean).
  std::array<double, 2> reflected_share{1.0, 1.0};
  // Per slot of the point (in PatchMesh::point_slots order) and side: the part of the cosine-
  // weighted view that slot's patch fills, above the corners' facets (their mean), seen at close
  // range, where its radiance is its corner's.
  std::vector<std::array<double, 2>> own;
  // Per slot: of the point's reflected light, what that slot's patch corner sends on, relative to
  // what the point holds. Inside a face Cycles' shading normal is interpolated and tilts less from
  // the facet than at its corners, so the face reflects more of the light round it than its
  // corners show: the patch's interior share over the corner's facet share. 1 on flat patches.
  std::vector<double> onward;
};

// Of the light reflected towards a smooth-shaded bilinear patch (corners `corner`, shading normals
// `normal` at them, interpolated inside), the part Cycles' facets let in, over the patch's area.
double interior_share(const dvec3 corner[4], const dvec3 normal[4]);

// For point `p`, whose corners' normals are `corner_normal[slot - first_slot]` (the patches'
// interior_share set).
CornerView corner_view(const PatchMesh& pm, int p, const dvec3* corner_normal, int first_slot);

}  // namespace radiosity
