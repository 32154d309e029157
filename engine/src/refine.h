// Refinement of an input polygon mesh into bilinear patches (quads): with OpenSubdiv, or face by
// face where a bilinear mesh's faces need different levels.
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
  // Per quad corner, MeshDesc::corner_reflectance, corner_emission and corner_uv (as (u, v, 0))
  // interpolated linearly across each input face; empty when the mesh has none.
  std::vector<std::array<dvec3, 4>> corner_reflectance, corner_emission, corner_uv;
};

// Per input face, the bilinear steps refine_mesh takes it through. Catmull-Clark takes the mesh's
// level everywhere. A bilinear mesh splits each face as far as its own longest world-space edge
// needs to come down to patch_size: a floor and the small faces of the furniture joined to it are
// not split alike. An n-gon takes at least one step (into quads); in a mesh not split bilinearly,
// one n-gon makes every face take it.
std::vector<int> face_levels(const MeshDesc& mesh, double patch_size);

RefinedMesh refine_mesh(const MeshDesc& mesh, const std::vector<int>& levels);
// The quads refine_mesh makes, worked out without refining.
long long quad_count(const MeshDesc& mesh, const std::vector<int>& levels);

// A cell of a quadtree over one quad of a refined mesh, in the quad's bilinear (u, v) domain:
// [i, i + 1] x [j, j + 1] / 2^depth.
struct QuadCell {
  int quad = 0;
  int depth = 0;
  int i = 0, j = 0;
};
constexpr int kMaxCellDepth = 8;  // a cell's depth within its quad

// The four cells a cell splits into, in split_cells' order.
std::array<QuadCell, 4> children(const QuadCell& cell);

// `base` with each of its quads split into the cells `cells` lists for it (which tile every quad;
// quads in the order of `cells`). Each cell is bilinear in its quad: positions, shading normals,
// corner reflectance and emission interpolated there, so a Catmull-Clark quad is split flat, within
// its limit-surface corners. Where cells of different depths meet, the finer one's corner lies on
// the coarser one's edge (a T-junction), which is straight: no gap opens for rays.
RefinedMesh split_cells(const RefinedMesh& base, const std::vector<QuadCell>& cells);

}  // namespace radiosity
