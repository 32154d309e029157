// A hierarchy of patch clusters per object. Reflected light shoots from clusters about a fixed world
// size (coarse shooters, fine receivers), sampled at a few sub-clusters far away and refined down to
// exact patch cells near the receiver, so a shot costs about the same whatever the mesh density.
#pragma once

#include "patch_mesh.h"
#include "radiosity/form_factor.h"

#include <cmath>
#include <vector>

namespace radiosity {

struct ClusterNode {
  int begin = 0, end = 0;    // range in ClusterTree::order
  int left = -1, right = -1; // children; -1 for a single-patch leaf
  dvec3 centroid{0.0};       // area-weighted
  int anchor = -1;           // the patch nearest the centroid: what it sees lights the cluster
  // Where a far sample's ray aims: the anchor's point nearest the centroid. Its centre lies a
  // quarter of the cluster off the centroid where four patches tile it, which would move the
  // samples of a partly hidden emitter off their grid (the floor beside the Cornell box's short
  // block would take 0.023 of direct light where Cycles gives 0.032).
  dvec3 aim{0.0};
  // How far the anchor's surface may lie off its triangles (bilinear_bulge): the ray ends that far
  // short of the aim. On a curved object's twisted patches a ray ending on the surface itself would
  // end behind the triangles, and its whole cluster count as hidden.
  double aim_lift = 0.0;
  dvec3 vector_area{0.0};    // sum of normal * area: the cluster's projected area in any direction
  double area = 0.0;
  double radius = 0.0;       // bounding sphere around the centroid
  Symmetric3 spread;         // second moment of its area about the centroid, per unit area
  bool flat = false;         // normals agree well enough for the cluster to act as one sample
  // Its patches lie in its plane (through the centroid, across vector_area) to a kPlanar part of
  // its radius.
  bool planar = false;
};

constexpr double kPlanar = 1e-9;

// Whether a point at x facing n (either way) lies in the plane of a planar cluster (centroid c, unit
// normal m, radius r): it sees every patch of it edge-on, and gets nothing from it.
__attribute__((always_inline)) inline bool edge_on(const dvec3& c, const dvec3& m, double r, const dvec3& x, const dvec3& n) {
  return std::fabs(glm::dot(m, x - c)) <= kPlanar * r && glm::length(glm::cross(m, n)) <= kPlanar;
}

struct ClusterTree {
  std::vector<int> order;  // patch indices; a node's patches are contiguous
  std::vector<ClusterNode> nodes;
  std::vector<int> roots;        // one per object that has patches
  std::vector<int> object_root;  // per object, -1 if it has no patches

  static ClusterTree build(const PatchMesh& mesh);
  // The hierarchy of the mesh's next object (patches past those it holds), after the others'.
  void add_object(const PatchMesh& mesh);
  // The coarsest nodes no larger than `radius`: a partition of all patches into shooters.
  std::vector<int> cut(double radius) const;
  // After an object moved or deformed: its hierarchy built anew, in the same nodes (a full binary
  // tree over its patches), as build() would make it there.
  void rebuild(const PatchMesh& mesh, int object);
  // The nodes of the subtree from `node`: ids [node, end).
  int subtree_end(int node) const;
};

}  // namespace radiosity
