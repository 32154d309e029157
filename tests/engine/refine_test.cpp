// Bilinear refinement with a level per face (refine.cpp: split_faces): faces of different levels
// meet without gaps or doubled points, and what is interpolated across a face (corner colours,
// smooth normals, UVs) is interpolated as the uniform refinement does.
#include "refine.h"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <tuple>

namespace radiosity {
namespace {

// A 2 x 0.5 strip (corners 0 1 2 3) and a 0.5 tile (1 4 5 2) sharing the edge 1-2, and a pentagon
// (4 6 7 8 5) beyond the tile sharing 4-5: split at 0.25, the strip takes 3 levels, the tile 1, the
// pentagon 2 (its longest edge 0.7).
MeshDesc strip_tile_pentagon() {
  MeshDesc m;
  m.positions = {{0, 0, 0}, {2, 0, 0}, {2, 0.5, 0}, {0, 0.5, 0}, {2.5, 0, 0}, {2.5, 0.5, 0},
                 {3.1, -0.1, 0.1}, {3.3, 0.3, 0.2}, {2.9, 0.8, 0.1}};
  m.face_sizes = {4, 4, 5};
  m.face_vertices = {0, 1, 2, 3, 1, 4, 5, 2, 4, 6, 7, 8, 5};
  m.face_materials = {0, 0, 0};
  m.refine = Refinement::Bilinear;
  for (int k = 0; k < 13; ++k) m.corner_reflectance.push_back(dvec3(0.05 * k, 1.0 - 0.05 * k, 0.3));
  return m;
}

using Key = std::tuple<double, double, double>;
Key key(const dvec3& p) { return {p.x, p.y, p.z}; }

TEST(Refine, FacesOfDifferentLevelsMeetOnTheirEdgesWithoutDoubledPoints) {
  MeshDesc m = strip_tile_pentagon();
  std::vector<int> levels = face_levels(m, 0.25);
  ASSERT_EQ(levels, (std::vector<int>{3, 1, 2}));
  RefinedMesh r = refine_mesh(m, levels);
  EXPECT_EQ((long long)r.quads.size(), quad_count(m, levels));
  EXPECT_EQ(r.quads.size(), 64u + 4u + 5u * 4u);
  std::map<Key, int> at;
  for (size_t v = 0; v < r.positions.size(); ++v) EXPECT_TRUE(at.emplace(key(r.positions[v]), int(v)).second);
  for (int v = 0; v < 9; ++v) EXPECT_EQ(r.positions[r.input_vertex[v]], m.positions[v]);
  // On the strip's and the tile's common edge (x = 2): the strip's 9 points, the tile's 3 among them.
  std::set<int> strip, tile;
  for (size_t q = 0; q < r.quads.size(); ++q)
    for (int v : r.quads[q])
      if (r.positions[v].x == 2.0 && r.positions[v].z == 0.0) (r.quad_face[q] == 0 ? strip : tile).insert(v);
  EXPECT_EQ(strip.size(), 9u);
  EXPECT_EQ(tile.size(), 3u);
  for (int v : tile) EXPECT_TRUE(strip.count(v));
}

TEST(Refine, CornerColoursAndSmoothNormalsAreInterpolatedInEachFace) {
  MeshDesc m = strip_tile_pentagon();
  m.face_smooth = {1, 1, 1};
  m.positions[2].z = 0.3;  // a fold along the strip and tile's common edge: normals vary
  std::vector<int> levels = face_levels(m, 0.25);
  RefinedMesh r = refine_mesh(m, levels);
  // The same faces at one level (the tile's as the strip's) go through OpenSubdiv: on the tile,
  // where both split the same, every point and colour must agree.
  MeshDesc alone = m;
  RefinedMesh u = refine_mesh(alone, std::vector<int>(3, 3));
  std::map<Key, std::pair<dvec3, int>> uniform_normal;
  for (size_t v = 0; v < u.positions.size(); ++v) uniform_normal[key(u.positions[v])] = {u.normals[v], int(v)};
  int compared = 0;
  for (size_t q = 0; q < r.quads.size(); ++q) {
    if (r.quad_face[q] != 1) continue;
    for (int c = 0; c < 4; ++c) {
      const dvec3& p = r.positions[r.quads[q][c]];
      auto it = uniform_normal.find(key(p));
      if (it == uniform_normal.end()) continue;
      EXPECT_NEAR(glm::length(r.normals[r.quads[q][c]] - it->second.first), 0.0, 1e-12);
      // the uniform refinement's colour at the same corner of a quad of the same face
      for (size_t k = 0; k < u.quads.size(); ++k)
        for (int d = 0; d < 4; ++d)
          if (u.quad_face[k] == 1 && u.quads[k][d] == it->second.second) {
            EXPECT_NEAR(glm::length(r.corner_reflectance[q][c] - u.corner_reflectance[k][d]), 0.0, 1e-12);
            ++compared;
          }
    }
  }
  EXPECT_GT(compared, 9);  // the tile's 9 points, each seen from its quads
  for (const dvec3& n : r.normals) EXPECT_NEAR(glm::length(n), 1.0, 1e-12);
}

TEST(Refine, CornerUvsFollowTheCornersEveryWayAMeshIsSplit) {
  // UVs an affine function of the position at every input corner stay that function of the
  // position at every refined corner: they are interpolated with the positions' own weights.
  MeshDesc m = strip_tile_pentagon();
  auto uv_of = [](const dvec3& p) { return dvec2(0.5 * p.x + 0.1 - 0.2 * p.z, 0.3 * p.y - 0.2 + p.z); };
  for (int v : m.face_vertices) m.corner_uv.push_back(uv_of(m.positions[v]));
  auto expect_uvs = [&](const RefinedMesh& r, const char* how) {
    ASSERT_EQ(r.corner_uv.size(), r.quads.size()) << how;
    for (size_t q = 0; q < r.quads.size(); ++q)
      for (int c = 0; c < 4; ++c) {
        dvec2 want = uv_of(r.positions[r.quads[q][c]]);
        EXPECT_NEAR(r.corner_uv[q][c].x, want.x, 1e-12) << how;
        EXPECT_NEAR(r.corner_uv[q][c].y, want.y, 1e-12) << how;
        EXPECT_EQ(r.corner_uv[q][c].z, 0.0) << how;
      }
  };
  RefinedMesh split = refine_mesh(m, face_levels(m, 0.25));
  expect_uvs(split, "faces split to levels of their own");
  expect_uvs(refine_mesh(m, std::vector<int>(3, 2)), "OpenSubdiv's uniform steps");
  std::vector<QuadCell> cells;
  for (int q = 0; q < int(split.quads.size()); ++q) {
    QuadCell whole{q, 0, 0, 0};
    if (q % 3) cells.push_back(whole);
    else for (const QuadCell& c : children(whole)) cells.push_back(c);
  }
  expect_uvs(split_cells(split, cells), "the light's cells");
  MeshDesc quads = m;  // the strip and the tile as given
  quads.face_sizes = {4, 4}, quads.face_vertices.resize(8), quads.face_materials = {0, 0};
  quads.corner_reflectance.resize(8), quads.corner_uv.resize(8);
  expect_uvs(refine_mesh(quads, {0, 0}), "faces as given");
}

}  // namespace
}  // namespace radiosity
