// One shot of progressive refinement: what a shooter sends (gather.h: how a receiving point takes it).
//
// A shot is a small hierarchy: the shooter's clusters, each with its mean unshot radiance per side,
// and at the bottom the m x n micro-elements (cells) of its patches. Far from the receiver a flat
// cluster acts as one sample; near it the receiver descends to cells, which are integrated exactly
// when closer still. The first `frontier` elements are where every receiver starts, so even a
// distant receiver sees the shooter through about `samples` rays.
#pragma once

#include "bounds.h"
#include "cluster_tree.h"
#include "radiosity/form_factor.h"
#include "radiosity/lanes.h"
#include "visibility.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <unordered_map>
#include <vector>

namespace radiosity {

// Unshot radiance of a patch, per corner and side: [corner * 2 + side], side 0 = front.
using CornerUnshot = std::array<dvec3, 8>;

// Radiance a patch sends from side `side` of its point y (normal m), worked out there.
using PieceRadiance = std::function<dvec3(const dvec3& y, const dvec3& m, int side)>;

// A shooting patch (or area lamp quad): its corners and the radiance it sends from each, per side.
// Near a receiver its cells are integrated piece by piece, each piece lit by interpolation there,
// plus `piece` at the piece where given. First what every visit to one of its cells reads, near or far.
struct ShotPatch {
  int point[4] = {-1, -1, -1, -1};   // receiving points at the corners (none for lamps)
  double twist = 0.0;  // of its bilinear surface off the two triangles Embree traces (bilinear_twist)
  int under_patch = -1;  // its patch, where it may lie under another surface (Coincident)
  dvec3 corner[4];
  dvec3 radiance[4][2];              // [corner][side], side 0 = front
  const PieceRadiance* piece = nullptr;
  // [corner][side]: the part of the corner's point's view the patch fills at close range (the
  // point's own patch: PatchMesh::own_view).
  double own_view[4][2] = {};
};

inline bool is_zero(const dvec3& v) { return v.x == 0 && v.y == 0 && v.z == 0; }

// Radiance a patch sends from side `side` at (u, v), interpolated over the corners in `corners`
// (a bit each) alone. Inline: near cells ask it once a piece, and a call
// would run in the baseline ISA (dispatch.h).
inline dvec3 radiance_at(const ShotPatch& patch, int side, uint8_t corners, double u, double v) {
  double weight[4] = {(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v};
  dvec3 sum(0.0);
  double total = 0.0;
  for (int c = 0; c < 4; ++c) {
    if (!(corners & (1 << c))) continue;
    sum += weight[c] * patch.radiance[c][side];
    total += weight[c];
  }
  return total > 0 ? sum / total : dvec3(0.0);
}

struct ShotCell {
  dvec3 radiance[2] = {dvec3(0.0), dvec3(0.0)};  // at the centre, from the corners it sees; front, back
  int patch = 0;                                 // in Shot::patches
  Cell cell;
  double u0 = 0.0, v0 = 0.0, size = 1.0;         // the cell's square in its patch's (u, v)
  uint8_t seen[2] = {15, 15};                    // a bit per patch corner its centre sees, per side
};

// In the order a receiver's walk reads it: whether to descend, then what a far sample sends.
struct ShotElement {
  int left = -1, right = -1;    // children (elements) for clusters
  int cell_begin = 0, cell_end = 0;  // cells for patches (leaves)
  // Squared distance beyond which it is one sample (near_factor radii; never unless flat). Worked
  // out once a shot, not at each of the thousands of receivers that ask.
  double far2 = INFINITY;
  double radius = 0.0;
  dvec3 centroid{0.0}, normal{0.0};
  double projected_area = 0.0;  // |vector area|: cos-weighted area is projected_area * |cos|
  Symmetric3 spread;            // second moment of its area in its plane (flat clusters)
  dvec3 anchor{0.0};  // where its far sample's ray aims (ClusterNode::aim)
  double anchor_lift = 0.0;  // ClusterNode::aim_lift
  int anchor_under_patch = -1;  // as ShotPatch::under_patch, for the anchor's patch
  dvec3 radiance[2] = {dvec3(0.0), dvec3(0.0)};  // mean unshot per side, over what the anchor sees
  // ClusterNode::planar: a receiver's walk passes it over when it sees it edge-on, as a point on a
  // wall or floor sees the patches round it in its own plane, which would send it nothing.
  bool planar = false;
};

// Four elements of a shot's frontier side by side, what decides whether and how each is one far
// sample: every receiver starts at all of the frontier and tests them four at a time. Lanes past
// the frontier's end repeat its last element; a leaf's far2 is infinite (the walk takes it to its
// cells).
struct alignas(kLanesAlignment) FrontierBlock {
  Lanes3 centroid, normal, anchor;
  Lanes far2, radius, projected_area, anchor_lift;
  SymmetricOf<Lanes> spread;
  Lanes3 radiance[2];
};

struct Shot {
  std::vector<ShotElement> elements;
  std::vector<ShotCell> cells;
  std::vector<ShotPatch> patches;
  std::vector<int> frontier;  // set with set_frontier, which also makes frontier_blocks from the elements
  std::vector<FrontierBlock> frontier_blocks;
  // A cell nearer a receiver than split_radii of its radii is split 2 x 2 (each piece one ray), at
  // most split_depth times: more where the light varies within a cell, as the exact direct light
  // of near_direct.cpp does.
  double split_radii = 2.0;
  int split_depth = 3;
  // Where the ray to a cell (or to a piece of a near cell that the receiver's plane does not cut)
  // ends: at its centre, or, with ends_by_place, at the point of it that place_offset draws for the
  // receiving place. Through a window the fraction of a source a receiver sees then comes out right
  // on average over the receivers round it, rather than banded by which of the few fixed centres
  // pass the window's frame; the form factor stays the cell's own.
  bool ends_by_place = false;
  // Light that surfaces reflected (not emitted): a receiver takes its reflected_share of what
  // comes from beyond the patches it lies on.
  bool reflected = false;
  // The shooter's object, and where that is closed the side facing its inside and its sphere
  // (ObjectPatches::enclosed_side); a sphere round the shooter. Object -1: a lamp, or a piece of a
  // shot that skips nothing.
  int object = -1;
  int enclosed_side = -1;
  Sphere enclosure;
  Sphere bounds;
};

// What shot samples see of their own shooter, per side: cell centre to patch corners (a bit each),
// cluster anchor to member patches. Valid while the geometry stays as it is.
struct ShotCache {
  std::unordered_map<long long, std::vector<uint8_t>> cell;    // (patch, cells per side, side)
  std::unordered_map<long long, std::vector<uint8_t>> member;  // (cluster node, side)
  // Drops what was worked out for the patches in `patches` and the nodes [node_begin, node_end).
  void forget(const std::vector<int>& patches, int node_begin, int node_end);
};

// What shots are made of: the patches, their clusters and, with `vis`, what a shot's samples see of
// their own shooter (kept in `cache`, if given).
struct ShotScene {
  const PatchMesh& mesh;
  const ClusterTree& tree;
  const Visibility* vis = nullptr;
  ShotCache* cache = nullptr;
};

// How finely a shot samples its shooter. `far_samples` (fewer than `samples`) starts receivers at
// fewer, larger clusters: a distant receiver takes that many samples, a near one descends to the
// same cells as at `samples`. A flat cluster farther than `near_factor` radii is one sample.
struct ShotSampling {
  int samples;
  double near_factor;
  int far_samples = INT32_MAX;
};

// The shot of cluster `node`, sending `scale` times its patches' `unshot` radiance. With a
// Visibility, a sample's radiance comes only from the corners / patches it sees (no light leaks
// under walls).
Shot cluster_shot(const ShotScene& scene, int node, const std::vector<CornerUnshot>& unshot, double scale,
                  const ShotSampling& sampling);

// Appends `patch` and its k x k `cells` (in bilinear_cells' order) to the shot. A cell is lit, per
// side, by the patch corners its centre sees: `seen[side]` holds a bit per corner for each cell, or
// is null for a side that sends nothing.
void add_patch(Shot& shot, const ShotPatch& patch, const std::vector<Cell>& cells, int k,
               const std::vector<uint8_t>* const seen[2]);

// Makes `frontier` (indices into shot.elements) the shot's frontier, once its elements are all in.
void set_frontier(Shot& shot, std::vector<int> frontier);

// Whether two shots of one shooter send the same light (same samples, same radiance).
bool same_light(const Shot& a, const Shot& b);
// The same shot sending `scale` times its light.
Shot scaled(Shot shot, double scale);
// One shot sending what `after` sends less what `before` does, where the two differ only in what
// their cells' centres see (a shooter beside a moved object): only the cells whose view changed,
// each twice (as before, negative, and as after), and the clusters' change of radiance. None if
// they differ otherwise.
std::optional<Shot> difference(const Shot& after, const Shot& before);

}  // namespace radiosity
