// Refinement of an input polygon mesh into bilinear patches (quads) with OpenSubdiv.
#pragma once

#include "radiosity/scene.h"

#include <array>
#include <vector>

namespace radiosity {

struct RefinedMesh {
  std::vector<dvec3> positions;  // object space
  // Per vertex, what smooth faces shade with: limit normals (Catmull-Clark), else the input's vertex
  // normals interpolated as positions are; empty when no face is smooth.
  std::vector<dvec3> normals;
  std::vector<std::array<int, 4>> quads;  // counter-clockwise; a triangle repeats its last vertex
  std::vector<int> quad_face;             // input face each quad came from
  std::vector<int> input_vertex;          // input vertex -> refined vertex at the same place
  // Per quad corner, MeshDesc::corner_reflectance and corner_emission interpolated linearly across
  // each input face; empty when the mesh has none.
  std::vector<std::array<dvec3, 4>> corner_reflectance, corner_emission;
};

// Bilinear levels needed for the mesh's longest world-space edge to come down to patch_size.
int bilinear_level(const MeshDesc& mesh, double patch_size);

// `bilinear_levels` applies to Refinement::Bilinear; Catmull-Clark uses mesh.level.
RefinedMesh refine_mesh(const MeshDesc& mesh, int bilinear_levels);
// The levels refine_mesh applies, and the quads it makes, worked out without refining.
int refinement_level(const MeshDesc& mesh, int bilinear_levels);
long long quad_count(const MeshDesc& mesh, int bilinear_levels);

}  // namespace radiosity
