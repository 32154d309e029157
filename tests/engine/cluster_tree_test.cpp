// The cluster tree's planar flag: a point in a planar cluster's plane gathers nothing from it (a
// shot's walk passes it over), so it must never be set on a cluster that bends, however little.
#include "cluster_tree.h"
#include "patch_mesh.h"

#include <gtest/gtest.h>

#include <cmath>

namespace radiosity {
namespace {

// A floor 2 x 2 at z = 0 and beside it, from x = 1 to 3, a slope rising to `rise`, as one mesh, in
// quads 0.25 across.
ClusterTree floor_and_slope(double rise, PatchMesh& mesh) {
  MeshDesc m;
  m.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {3, -1, rise}, {3, 1, rise}};
  m.face_sizes = {4, 4};
  m.face_vertices = {0, 1, 2, 3, 1, 4, 5, 2};
  m.face_materials = {0, 0};
  m.refine = Refinement::Bilinear;
  m.patch_size = 0.25;
  SceneDesc scene;
  scene.materials = {Material{}};
  scene.meshes = {m};
  mesh = build_patch_mesh(scene, Settings::preset("default"));
  return ClusterTree::build(mesh);
}

// Whether all of a node's patches lie on the floor (`floor`) or all on the slope. Each face is split
// as far as its own edges need, the floor's first: the patch mesh is in a frame of its own, not the
// world's.
bool all_on(const PatchMesh& mesh, const ClusterTree& tree, const ClusterNode& n, bool floor) {
  int floor_patches = 1 << (2 * mesh.objects[0].face_levels[0]);
  for (int i = n.begin; i < n.end; ++i)
    if ((tree.order[i] < floor_patches) != floor) return false;
  return true;
}

TEST(ClusterTree, OnlyClustersThatLieInOnePlaneArePlanar) {
  for (double rise : {2.0, 1e-6}) {  // a bend of 45 degrees, and one too slight to leave it not flat
    PatchMesh mesh;
    ClusterTree tree = floor_and_slope(rise, mesh);
    int planar = 0, bent = 0;
    for (const ClusterNode& n : tree.nodes) {
      if (all_on(mesh, tree, n, true) || all_on(mesh, tree, n, false)) {
        EXPECT_TRUE(n.planar) << "rise " << rise << ": " << n.end - n.begin << " patches in one plane";
        ++planar;
      } else {
        EXPECT_FALSE(n.planar) << "rise " << rise << ": " << n.end - n.begin << " patches across the bend";
        if (rise < 1) EXPECT_TRUE(n.flat);  // planar is then the only guard
        ++bent;
      }
    }
    EXPECT_GT(planar, 100);
    EXPECT_GT(bent, 0);
  }
}

TEST(ClusterTree, OnlyPointsInAPlanarClustersPlaneSeeItEdgeOn) {
  PatchMesh mesh;
  ClusterTree tree = floor_and_slope(2.0, mesh);
  const ClusterNode* floor = nullptr;
  for (const ClusterNode& n : tree.nodes)
    if (all_on(mesh, tree, n, true) && (!floor || n.end - n.begin > floor->end - floor->begin)) floor = &n;
  ASSERT_NE(floor, nullptr);
  dvec3 m = glm::normalize(floor->vector_area);
  dvec3 along = glm::normalize(glm::cross(m, dvec3(0.6, 0.8, 0.0)));  // in the floor's plane
  auto edge_on_floor = [&](dvec3 x, dvec3 n) { return edge_on(floor->centroid, m, floor->radius, x, n); };
  dvec3 far_off = floor->centroid + 5.0 * along;
  EXPECT_TRUE(edge_on_floor(far_off, m));  // anywhere in the plane, either way up
  EXPECT_TRUE(edge_on_floor(far_off, -m));
  EXPECT_FALSE(edge_on_floor(floor->centroid + 1e-6 * m, m));  // a little above it: lit
  EXPECT_FALSE(edge_on_floor(floor->centroid, glm::normalize(m + 1e-6 * along)));  // tilted: lit
}

}  // namespace
}  // namespace radiosity
