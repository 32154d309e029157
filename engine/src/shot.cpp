#include "shot.h"

#include "dispatch.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool is_zero(const dvec3& v) { return v.x == 0 && v.y == 0 && v.z == 0; }

// Cache keys: a patch's cells (as many per side as a shot asks for, at most 64) per side; a node per side.
constexpr long long kMaxCellsPerSide = 64;
long long cell_key(int patch, int cells_per_side, int side) {
  return (kMaxCellsPerSide * patch + cells_per_side) * 2 + side;
}
long long member_key(int node, int side) { return 2LL * node + side; }

// Radiance a patch sends from side `side` at (u, v), interpolated over the corners in `corners`
// (a bit each) alone. Inline: near cells ask it once a piece, and called it ran in the baseline ISA
// (dispatch.h).
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

// Copies a shooter's subtree into a shot. Radiance is interpolated or averaged only over what the
// sample point sees: a patch or cluster running under a wall would otherwise carry light from the
// lit room into the dark one. What a sample sees of its own shooter does not change while the
// geometry does not, so it is worked out once per side and kept in the cache.
struct ShotBuilder {
  const PatchMesh& mesh;
  const ClusterTree& tree;
  const Visibility* vis;
  ShotCache* cache;
  const std::vector<CornerUnshot>& unshot;
  double scale;
  double near_factor;
  int cells_per_side;
  Shot& shot;
  std::vector<Cell> cells;  // of the patch being added, kept to spare an allocation per patch

  bool sees(const dvec3& a, const dvec3& na, const dvec3& b, const dvec3& nb, int side, double bulge = 0.0,
            double lift_a = 0.0) const {
    return !vis || (side == 0 ? vis->connected(a, na, b, nb, bulge, lift_a)
                              : vis->connected(a, -na, b, -nb, bulge, lift_a));
  }

  // The cached entry under `key`, made by `make` (which fills one byte per item) on first use.
  template <class Make>
  const std::vector<uint8_t>& cached(std::unordered_map<long long, std::vector<uint8_t>>& map, long long key,
                                     Make&& make) {
    auto it = map.find(key);
    if (it != map.end()) return it->second;
    std::vector<uint8_t>& entry = map[key];
    make(entry);
    return entry;
  }

  int copy(int node) {
    const ClusterNode& n = tree.nodes[node];
    int id = int(shot.elements.size());
    shot.elements.emplace_back();
    ShotElement e;
    e.centroid = n.centroid;
    e.projected_area = glm::length(n.vector_area);
    e.normal = e.projected_area > 0 ? n.vector_area / e.projected_area : dvec3(0.0);
    e.radius = n.radius;
    e.planar = n.planar;
    if (n.flat) {
      e.far2 = near_factor * near_factor * n.radius * n.radius;
      e.spread = n.spread.in_plane(e.normal);
    }
    if (n.left < 0) {
      add_cells(tree.order[n.begin], e);
    } else {
      e.left = copy(n.left);
      e.right = copy(n.right);
      if (n.flat) average_visible(node, e);  // only flat clusters ever stand for their patches
    }
    shot.elements[id] = e;
    return id;
  }

  void average_visible(int node, ShotElement& e) {
    const ClusterNode& n = tree.nodes[node];
    const Patch& anchor = mesh.patches[n.anchor];
    e.anchor = n.aim;
    e.anchor_lift = n.aim_lift;
    if (vis && vis->may_lie_under(n.anchor)) e.anchor_under_patch = n.anchor;
    for (int side = 0; side < 2; ++side) {
      auto mean_unshot = [&](int patch) {
        const CornerUnshot& u = unshot[patch];
        return 0.25 * (u[side] + u[2 + side] + u[4 + side] + u[6 + side]);
      };
      bool any = false;
      for (int i = n.begin; i < n.end && !any; ++i) any = !is_zero(mean_unshot(tree.order[i]));
      if (!any) continue;
      const std::vector<uint8_t>& seen = cached(cache->member, member_key(node, side), [&](std::vector<uint8_t>& out) {
            for (int i = n.begin; i < n.end; ++i) {
              const Patch& p = mesh.patches[tree.order[i]];
              out.push_back(&p == &anchor || sees(anchor.centre, anchor.normal, p.centre, p.normal, side));
            }
          });
      dvec3 power(0.0);
      double area = 0.0;
      for (int i = n.begin; i < n.end; ++i) {
        const Patch& p = mesh.patches[tree.order[i]];
        dvec3 mean = mean_unshot(tree.order[i]);
        if (seen[i - n.begin]) {
          power += p.area * mean;
          area += p.area;
        }
      }
      e.radiance[side] = area > 0 ? scale * power / area : dvec3(0.0);
    }
  }

  void add_cells(int p, ShotElement& e) {
    const Patch& patch = mesh.patches[p];
    e.cell_begin = int(shot.cells.size());
    if (patch.area > 0) {
      int k = cells_per_side;
      ShotPatch light;
      for (int c = 0; c < 4; ++c) {
        light.corner[c] = mesh.vertices[patch.vertex[c]];
        light.point[c] = patch.point[c];
        for (int s = 0; s < 2; ++s) {
          light.radiance[c][s] = scale * unshot[p][c * 2 + s];
          light.own_view[c][s] = mesh.own_view[4 * p + c][s];
        }
      }
      light.twist = bilinear_twist(light.corner, patch.normal);
      // A ray across the patch to its corner passes its middle: it needs the whole bulge.
      double bulge = bilinear_bulge(light.twist);
      if (vis && vis->may_lie_under(p)) light.under_patch = p;
      cells.resize(k * k);
      bilinear_cells(light.corner, k, cells.data());
      const std::vector<uint8_t>* seen[2] = {nullptr, nullptr};  // per cell, a bit per corner it sees
      for (int s = 0; s < 2; ++s) {
        bool any = false;
        for (int c = 0; c < 4; ++c) any |= !is_zero(unshot[p][c * 2 + s]);
        if (!any) continue;
        seen[s] = &cached(cache->cell, cell_key(p, k, s), [&](std::vector<uint8_t>& out) {
          for (int i = 0; i < k * k; ++i) {
            const Cell& cell = cells[i];
            double lift = bilinear_lift(light.twist, (i % k + 0.5) / k, (i / k + 0.5) / k);
            uint8_t bits = 0;
            for (int c = 0; c < 4; ++c) {
              const ReceiverPoint& corner = mesh.points[patch.point[c]];
              if (sees(cell.centre, cell.normal, corner.position, corner.normal, s, bulge, lift)) bits |= 1 << c;
            }
            out.push_back(bits);
          }
        });
      }
      add_patch(shot, light, cells, k, seen);
    }
    e.cell_end = int(shot.cells.size());
  }
};

}  // namespace

void add_patch(Shot& shot, const ShotPatch& patch, const std::vector<Cell>& cells, int k,
               const std::vector<uint8_t>* const seen[2]) {
  int index = int(shot.patches.size());
  shot.patches.push_back(patch);
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      ShotCell sc;
      sc.cell = cells[j * k + i];
      if (!(sc.cell.area > 0)) continue;
      area_moments(sc.cell);
      sc.patch = index;
      sc.u0 = double(i) / k, sc.v0 = double(j) / k, sc.size = 1.0 / k;
      for (int s = 0; s < 2; ++s) {
        sc.seen[s] = seen[s] ? (*seen[s])[j * k + i] : 0;  // by visibility alone: linear in the radiance
        sc.radiance[s] = radiance_at(patch, s, sc.seen[s], sc.u0 + 0.5 * sc.size, sc.v0 + 0.5 * sc.size);
      }
      shot.cells.push_back(sc);
    }
}

void ShotCache::forget(const std::vector<int>& patches, int node_begin, int node_end) {
  for (int p : patches)
    for (int k = 1; k < kMaxCellsPerSide; ++k)
      for (int side = 0; side < 2; ++side) cell.erase(cell_key(p, k, side));
  for (int node = node_begin; node < node_end; ++node)
    for (int side = 0; side < 2; ++side) member.erase(member_key(node, side));
}

namespace {

// The subtree's clusters where every receiver starts: the widest split until there are `samples`
// of them or only patches remain.
std::vector<int> frontier_of(const ClusterTree& tree, int node, int samples) {
  std::vector<int> frontier{node};
  for (;;) {
    if (int(frontier.size()) >= samples) break;
    int widest = -1;
    for (size_t i = 0; i < frontier.size(); ++i) {
      const ClusterNode& n = tree.nodes[frontier[i]];
      if (n.left >= 0 && (widest < 0 || n.radius > tree.nodes[frontier[widest]].radius)) widest = int(i);
    }
    if (widest < 0) break;
    const ClusterNode& n = tree.nodes[frontier[widest]];
    frontier[widest] = n.left;
    frontier.push_back(n.right);
  }
  return frontier;
}

}  // namespace

Shot cluster_shot(const PatchMesh& mesh, const ClusterTree& tree, const Visibility* vis, ShotCache* cache,
                  int node, const std::vector<CornerUnshot>& unshot, int samples, double scale,
                  double near_factor, int far_samples) {
  std::vector<int> frontier = frontier_of(tree, node, samples);
  int cells_per_side = std::max(1, int(std::ceil(std::sqrt(double(samples) / frontier.size()))));
  if (far_samples < samples) frontier = frontier_of(tree, node, std::max(1, far_samples));

  Shot shot;
  // Sized up front: growing them copied every element and cell already built, several times a shot.
  const ClusterNode& root = tree.nodes[node];
  shot.elements.reserve(2 * (root.end - root.begin) - 1);
  shot.patches.reserve(root.end - root.begin);
  shot.cells.reserve(size_t(root.end - root.begin) * cells_per_side * cells_per_side);
  ShotCache local;  // without a cache to keep, work it out for this shot alone
  ShotBuilder builder{mesh, tree, vis, cache ? cache : &local, unshot, scale, near_factor, cells_per_side, shot, {}};
  builder.copy(node);
  // Walk the subtree and its copy together to turn the frontier's clusters into elements.
  std::sort(frontier.begin(), frontier.end());
  std::vector<int> elements;
  std::vector<std::pair<int, int>> stack{{node, 0}};
  while (!stack.empty()) {
    auto [cluster, element] = stack.back();
    stack.pop_back();
    if (std::binary_search(frontier.begin(), frontier.end(), cluster)) {
      elements.push_back(element);
      continue;
    }
    const ClusterNode& n = tree.nodes[cluster];
    if (n.left < 0) continue;
    stack.push_back({n.left, shot.elements[element].left});
    stack.push_back({n.right, shot.elements[element].right});
  }
  set_frontier(shot, std::move(elements));
  shot.object = mesh.patches[tree.order[root.begin]].object;
  shot.enclosed_side = mesh.objects[shot.object].enclosed_side;
  shot.enclosure = mesh.objects[shot.object].enclosure;
  shot.bounds = {root.centroid, root.radius};
  return shot;
}

void set_frontier(Shot& shot, std::vector<int> frontier) {
  shot.frontier = std::move(frontier);
  shot.frontier_blocks.assign((shot.frontier.size() + kLanes - 1) / kLanes, FrontierBlock{});
  for (size_t b = 0; b < shot.frontier_blocks.size(); ++b) {
    FrontierBlock& block = shot.frontier_blocks[b];
    for (int l = 0; l < kLanes; ++l) {
      const ShotElement& e = shot.elements[shot.frontier[std::min(b * kLanes + l, shot.frontier.size() - 1)]];
      set_lane(block.centroid, l, e.centroid);
      set_lane(block.normal, l, e.normal);
      set_lane(block.anchor, l, e.anchor);
      for (int side = 0; side < 2; ++side) set_lane(block.radiance[side], l, e.radiance[side]);
      block.far2[l] = e.left < 0 ? INFINITY : e.far2;
      block.radius[l] = e.radius, block.projected_area[l] = e.projected_area, block.anchor_lift[l] = e.anchor_lift;
      block.spread.xx[l] = e.spread.xx, block.spread.yy[l] = e.spread.yy, block.spread.zz[l] = e.spread.zz;
      block.spread.xy[l] = e.spread.xy, block.spread.xz[l] = e.spread.xz, block.spread.yz[l] = e.spread.yz;
    }
  }
}

bool same_light(const Shot& a, const Shot& b) {
  if (a.elements.size() != b.elements.size() || a.cells.size() != b.cells.size() ||
      a.patches.size() != b.patches.size())
    return false;
  for (size_t i = 0; i < a.patches.size(); ++i)
    for (int c = 0; c < 4; ++c)
      for (int side = 0; side < 2; ++side)
        if (a.patches[i].radiance[c][side] != b.patches[i].radiance[c][side]) return false;
  for (size_t i = 0; i < a.elements.size(); ++i)
    for (int side = 0; side < 2; ++side)
      if (a.elements[i].radiance[side] != b.elements[i].radiance[side]) return false;
  // A cell's light follows from its patch's and from what its centre sees, which also decides how
  // near receivers are lit.
  for (size_t i = 0; i < a.cells.size(); ++i)
    for (int side = 0; side < 2; ++side)
      if (a.cells[i].seen[side] != b.cells[i].seen[side]) return false;
  return true;
}

Shot scaled(Shot shot, double scale) {
  for (ShotElement& e : shot.elements)
    for (dvec3& r : e.radiance) r *= scale;
  for (ShotCell& c : shot.cells)
    for (dvec3& r : c.radiance) r *= scale;
  for (ShotPatch& p : shot.patches)
    for (auto& corner : p.radiance)
      for (dvec3& r : corner) r *= scale;
  set_frontier(shot, std::move(shot.frontier));
  return shot;
}

std::optional<Shot> difference(const Shot& after, const Shot& before) {
  const Shot &a = before, &b = after;
  if (a.elements.size() != b.elements.size() || a.patches.size() != b.patches.size() ||
      a.cells.size() != b.cells.size() || a.frontier != b.frontier || a.reflected != b.reflected)
    return std::nullopt;
  Shot d;
  d.frontier = b.frontier;
  d.split_radii = b.split_radii;
  d.split_depth = b.split_depth;
  d.reflected = b.reflected;
  // The patches as after, then as before, negative. Their own views cancel: the radiance is the same.
  int count = int(b.patches.size());
  d.patches = b.patches;
  d.patches.insert(d.patches.end(), a.patches.begin(), a.patches.end());
  for (int i = 0; i < count; ++i) {
    const ShotPatch &pa = a.patches[i], &pb = b.patches[i];
    if (pa.piece || pb.piece) return std::nullopt;
    for (int c = 0; c < 4; ++c)
      for (int side = 0; side < 2; ++side)
        if (pa.corner[c] != pb.corner[c] || pa.radiance[c][side] != pb.radiance[c][side]) return std::nullopt;
  }
  for (int i = 0; i < 2 * count; ++i) {
    ShotPatch& p = d.patches[i];
    for (auto& view : p.own_view) view[0] = view[1] = 0.0;
    if (i >= count)
      for (auto& corner : p.radiance)
        for (dvec3& r : corner) r = -r;
  }
  d.elements = b.elements;
  for (size_t i = 0; i < d.elements.size(); ++i) {
    const ShotElement &ea = a.elements[i], &eb = b.elements[i];
    if (ea.left != eb.left || ea.right != eb.right || ea.cell_begin != eb.cell_begin || ea.cell_end != eb.cell_end ||
        ea.anchor != eb.anchor || ea.anchor_lift != eb.anchor_lift || ea.far2 != eb.far2)
      return std::nullopt;
    ShotElement& e = d.elements[i];
    for (int side = 0; side < 2; ++side) e.radiance[side] = eb.radiance[side] - ea.radiance[side];
    e.cell_begin = int(d.cells.size());
    for (int c = eb.cell_begin; c < eb.cell_end; ++c) {
      const ShotCell &ca = a.cells[c], &cb = b.cells[c];
      if (ca.seen[0] == cb.seen[0] && ca.seen[1] == cb.seen[1]) continue;  // the same light
      ShotCell gone = ca;
      gone.patch += count;
      for (dvec3& r : gone.radiance) r = -r;
      d.cells.push_back(gone);
      d.cells.push_back(cb);
    }
    e.cell_end = int(d.cells.size());
  }
  set_frontier(d, std::move(d.frontier));  // the lanes hold the elements' radiance: after it is set
  return d;
}

namespace {

// Form factor of a distant flat cluster. Where the receiver's plane clears it, the kernel expanded
// to second order, right whatever the orientations: the disc approximation is right on the axis
// only, and beside the edge where a wall meets the floor it fell 15% short at three radii, which
// lost 0.6% of a furnace's light near its edges. Where the plane cuts it, the disc approximation.
// Of one element (ShotElement, doubles) or four (FrontierBlock, Lanes).
template <class V, class Element>
RADIOSITY_LANES auto cluster_form_factor(const V& x, const V& n, const Element& e) {
  V d = e.centroid - x;
  auto r2 = dot(d, d);
  auto f = dot(n, d), g = dot(e.normal, d);
  return clear_of_plane(n, e.normal, f, e.radius) ? expanded_form_factor(d, r2, f, g, e.projected_area, e.spread, n)
                                                  : disc_form_factor(r2, f, g, e.projected_area);
}

// One ray to `target` carries `factor()` times the radiance of the side of an element (at `centre`,
// facing `normal`) that faces x. Forced inline: called, its ten arguments and the dot products it
// could not share with to_point were a tenth of the instructions a draft solve spends outside Embree.
// The factor is asked for last: a third of the far clusters a default shot's receivers reach show
// them a side that sends nothing (their backs), or lie in the receiver's plane.
template <class Factor>
__attribute__((always_inline)) inline void far_sample(int receiver, const dvec3& x, const dvec3& n, const dvec3& centre,
                                                     const dvec3& target, const dvec3& normal, Factor&& factor,
                                                     const dvec3 radiance[2], double lift, int under_patch,
                                                     int shut, OcclusionBatch& batch) {
  dvec3 d = centre - x;
  int side = glm::dot(normal, d) <= 0 ? 0 : 1;  // 0: x in front of the element
  const dvec3& rad = radiance[side];
  double cos_r = glm::dot(n, d);
  if (side == shut || is_zero(rad) || cos_r == 0 || !batch.open(cos_r > 0)) return;
  double f = factor();
  if (!(f > 0)) return;
  batch.to_point(receiver, x, n, target, normal, cos_r > 0, rad * f, lift, under_patch);
}

// What lights the pieces of one cell near a receiver: its patch, the side facing the receiver, and
// the patch corners that light the part of the cell in front of the receiver's plane and the part
// behind it.
struct NearLight {
  const ShotPatch& patch;
  int side;
  uint8_t corners[2];
  uint8_t other;  // the corners the cell's centre sees on its other side
  const Shot& shot;  // how far to split
};

// A piece of a cell: the cell itself or a quarter of a piece, with its square in the patch's (u, v).
// It refers to its cell rather than holding a copy, which was made at every level of the split.
struct Piece {
  const Cell& cell;
  double u0, v0, size;
};

// Centroid in (u, v) of the part of the piece on side `part` (0: h > 0) of the receiver's plane,
// h being the corners' heights above it (linear across a planar piece).
void part_centroid(const Piece& p, const double h[4], int part, double& u, double& v) {
  // Relative to the square's first corner: slivers keep their precision.
  const double su[4] = {0.0, p.size, p.size, 0.0};
  const double sv[4] = {0.0, 0.0, p.size, p.size};
  double pu[8], pv[8];
  int count = 0;
  for (int i = 0; i < 4; ++i) {
    int j = (i + 1) % 4;
    double a = part == 0 ? h[i] : -h[i], b = part == 0 ? h[j] : -h[j];
    if (a >= 0) pu[count] = su[i], pv[count++] = sv[i];
    if ((a >= 0) != (b >= 0)) {
      double t = a / (a - b);
      pu[count] = su[i] + t * (su[j] - su[i]), pv[count++] = sv[i] + t * (sv[j] - sv[i]);
    }
  }
  double area = 0.0, cu = 0.0, cv = 0.0;
  for (int i = 0; i < count; ++i) {
    int j = (i + 1) % count;
    double cross = pu[i] * pv[j] - pu[j] * pv[i];
    area += cross;
    cu += (pu[i] + pu[j]) * cross;
    cv += (pv[i] + pv[j]) * cross;
  }
  bool sliver = !(std::fabs(area) > 1e-12 * p.size * p.size);
  u = p.u0 + (sliver ? 0.5 * p.size : std::clamp(cu / (3 * area), 0.0, p.size));
  v = p.v0 + (sliver ? 0.5 * p.size : std::clamp(cv / (3 * area), 0.0, p.size));
}

// Whether a piece at `depth` of its cell's splits is split again near receiver x (exact_piece).
bool splits_near(const Shot& shot, const Cell& piece, const dvec3& x, int depth) {
  double split = shot.split_radii * piece.radius;
  return depth < shot.split_depth && glm::dot(piece.centre - x, piece.centre - x) < split * split;
}

// An exactly integrated piece of a cell. Each part of it on one side of the receiver's plane is
// seen through one ray to that part's centroid and sends the patch's radiance interpolated there:
// the cell's value at its centre would be wrong where the centre lies under the receiver's own
// surface (a floor cell half under a box, seen from the box's foot: the centre's light is the
// dark floor under the box, while all that the foot sees is the lit half).
RADIOSITY_HOT void exact_piece(int receiver, const dvec3& x, const dvec3& n, const Piece& p, const NearLight& light,
                               int depth, OcclusionBatch& batch) {
  // Split near the receiver: one ray to the centre of a cell that straddles an occluder's edge (a
  // floor cell half under a box, seen from the box's foot) would count the whole cell as lit or dark.
  if (splits_near(light.shot, p.cell, x, depth)) {
    Cell cells[4];
    bilinear_cells(p.cell.corners, 2, cells);
    double half = 0.5 * p.size;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const Cell& c = cells[j * 2 + i];
        if (c.area > 0) exact_piece(receiver, x, n, {c, p.u0 + i * half, p.v0 + j * half, half}, light, depth + 1, batch);
      }
    return;
  }
  SideFactors f = cell_form_factor(p.cell, x, n);
  if (f.front == 0 && f.back == 0) return;
  // A piece split off near the receiver faces it from its own side, which on a twisted patch need
  // not be its cell's: by a box's fold the receiver can lie behind a cell's plane and in front of
  // the pieces beside it, and took none of their reflected light (one-sided) at 4 x 4 cells a patch.
  bool flipped = depth > 0 && (glm::dot(p.cell.normal, x - p.cell.centre) >= 0) != (light.side == 0);
  int side = flipped ? 1 - light.side : light.side;
  // One ray to `target` carries the light of the part on side `part` of the receiver's plane.
  auto send = [&](int part, double u, double v, const dvec3& target) __attribute__((always_inline)) {
    dvec3 radiance = radiance_at(light.patch, side, flipped ? light.other : light.corners[part], u, v);
    if (light.patch.piece) radiance += (*light.patch.piece)(target, p.cell.normal, side);
    dvec3 e = radiance * (part == 0 ? f.front : f.back);
    if (!is_zero(e))
      batch.to_point(receiver, x, n, target, p.cell.normal, part == 0, e, bilinear_lift(light.patch.twist, u, v),
                     light.patch.under_patch);
  };
  if (f.front > 0 && f.back > 0) {
    double h[4];
    for (int c = 0; c < 4; ++c) h[c] = glm::dot(n, p.cell.corners[c] - x);
    for (int part = 0; part < 2; ++part) {
      double u, v;
      part_centroid(p, h, part, u, v);
      send(part, u, v, bilinear(light.patch.corner, u, v));
    }
    return;
  }
  send(f.front > 0 ? 0 : 1, p.u0 + 0.5 * p.size, p.v0 + 0.5 * p.size, p.cell.centre);
}

// Starts the exact integration of a cell. Where the receiver's surface stands on the cell's patch
// (a box on the floor) it divides the patch: the cell's centre sees only patch corners on its own
// side of the receiver's plane, and the part of the cell on the other side is lit by the corners
// there that it sees (a wall between it and them, over a patch that runs under both, would let the
// next room's light onto the strip between box and wall). Where the centre sees corners on both
// sides, something else divides the patch (a wall between two rooms) and the centre's view holds
// for the whole cell.
inline void exact_cell(int receiver, const dvec3& x, const dvec3& n, const Shot& shot, const ShotCell& sc, int side,
                       OcclusionBatch& batch) {
  const ShotPatch& patch = shot.patches[sc.patch];
  uint8_t seen = sc.seen[side];
  NearLight light{patch, side, {seen, seen}, sc.seen[1 - side], shot};
  if (seen != 15) {
    double tolerance = 1e-9 * sc.cell.radius;
    double h[4];
    bool above = false, below = false;
    for (int c = 0; c < 4; ++c) {
      h[c] = glm::dot(n, sc.cell.corners[c] - x);
      above |= h[c] > tolerance;
      below |= h[c] < -tolerance;
    }
    uint8_t front = 0;
    for (int c = 0; c < 4; ++c) front |= (glm::dot(n, patch.corner[c] - x) > 0) << c;
    uint8_t back = 15 & ~front;
    auto seen_from_part = [&](int part, uint8_t corners) {
      double u, v;
      part_centroid({sc.cell, sc.u0, sc.v0, sc.size}, h, part, u, v);
      dvec3 m = side == 0 ? sc.cell.normal : -sc.cell.normal;
      dvec3 y = bilinear(patch.corner, u, v);
      uint8_t sees = 0;
      for (int c = 0; c < 4; ++c)
        if ((corners & (1 << c)) &&
            batch.visibility().connected(y, m, patch.corner[c], m, bilinear_bulge(patch.twist), bilinear_lift(patch.twist, u, v)))
          sees |= 1 << c;
      return sees;
    };
    if (above && below && front && back && seen) {
      if ((seen & ~front) == 0) light.corners[1] = seen_from_part(1, back);
      if ((seen & ~back) == 0) light.corners[0] = seen_from_part(0, front);
    }
  }
  bool lit = patch.piece != nullptr;  // it may light a piece its corners leave dark
  // Pieces split off it may face the receiver from the other side (exact_piece).
  bool splits = splits_near(shot, sc.cell, x, 0);
  for (int c = 0; c < 4; ++c)
    lit |= (((light.corners[0] | light.corners[1]) & (1 << c)) && !is_zero(patch.radiance[c][side])) ||
           (splits && (light.other & (1 << c)) && !is_zero(patch.radiance[c][1 - side]));
  if (lit) exact_piece(receiver, x, n, {sc.cell, sc.u0, sc.v0, sc.size}, light, 0, batch);
}

// A point takes no cells of the patches it lies on. They are flat, or curved so that a point on
// them sees them edge-on; but the point sits a little off their corners' planes, which Lambert's
// formula would take for a view of a whole quarter of the sky, lit by the point's own light. What
// they do show it, at close range on a concave surface, it takes at its corner's radiance, with
// no ray (and so nothing that a move elsewhere changes).
int corner_at(const ShotPatch& patch, int receiver) {
  for (int c = 0; c < 4; ++c)
    if (patch.point[c] == receiver) return c;
  return -1;
}

void take_own_view(const ShotPatch& patch, int c, int receiver, OcclusionBatch& batch) {
  for (int side = 0; side < 2; ++side)
    if (patch.own_view[c][side] > 0) batch.add(receiver, side == 0, patch.own_view[c][side] * patch.radiance[c][side]);
}

// Where a far sample's one ray ends: at the anchor, moved off it by epsilon and the anchor's lift.
Sphere far_end(const ShotElement& e, double eps) { return {e.anchor, eps + e.anchor_lift}; }

}  // namespace

RADIOSITY_HOT void gather(const Shot& shot, int receiver, const ReceiverPoint& point, OcclusionBatch& batch,
                          const Zone* zone) {
  const dvec3& x = point.position;
  const dvec3& n = point.normal;
  int stack[128];
  int top = 0;
  auto seen_edge_on = [&](const ShotElement& e) __attribute__((always_inline)) {
    return e.planar && edge_on(e.centroid, e.normal, e.radius, x, n);
  };
  if (!shot.elements.empty() && seen_edge_on(shot.elements[0])) return;  // the shooter's whole cluster
  // Closed objects (ObjectPatches::enclosed_side): the receiver's inside, when the shooter lies
  // outside its sphere, and the shooter's inside, when the receiver does, see nothing of each
  // other; their rays would all be blocked (2-3 of the 6 a far box's shot sent a box's point).
  int shut = -1;
  if (shot.object >= 0 && shot.object != point.object) {
    if (point.enclosed_side >= 0 && !overlap(shot.bounds, point.enclosure))
      batch.set_open(point.enclosed_side == 0 ? std::array<bool, 2>{false, true} : std::array<bool, 2>{true, false});
    if (shot.enclosed_side >= 0 && glm::length(x - shot.enclosure.centre) > shot.enclosure.radius)
      shut = shot.enclosed_side;
  }
  if (shot.reflected) batch.set_share(point.reflected_share);
  // The subtree of a frontier element, one element at a time.
  auto walk = [&](int from) __attribute__((always_inline)) {
    stack[top++] = from;
    while (top > 0) {
      const ShotElement& e = shot.elements[stack[--top]];
      if (seen_edge_on(e)) continue;
      if (e.left < 0) {
        if (e.cell_begin == e.cell_end) continue;
        // A leaf holds one patch's cells (or an area lamp's quads, which no point lies on).
        const ShotPatch& leaf = shot.patches[shot.cells[e.cell_begin].patch];
        if (int c = corner_at(leaf, receiver); c >= 0) {
          if (!zone) take_own_view(leaf, c, receiver, batch);
          continue;
        }
        for (int c = e.cell_begin; c < e.cell_end; ++c) {
          const ShotCell& sc = shot.cells[c];
          const Cell& cell = sc.cell;
          const ShotPatch& patch = shot.patches[sc.patch];
          if (zone && !zone->may_cross(x, {cell.centre, cell.radius})) continue;
          if (std::optional<double> factor = distant_cell_form_factor(cell, x, n)) {
            far_sample(receiver, x, n, cell.centre, cell.centre, cell.normal,
                       [&]() __attribute__((always_inline)) { return *factor; }, sc.radiance,
                       bilinear_lift(patch.twist, sc.u0 + 0.5 * sc.size, sc.v0 + 0.5 * sc.size),
                       patch.under_patch, shut, batch);
            continue;
          }
          int side = glm::dot(cell.normal, x - cell.centre) >= 0 ? 0 : 1;
          if (side != shut) exact_cell(receiver, x, n, shot, sc, side, batch);
        }
        continue;
      }
      dvec3 d = e.centroid - x;
      bool far = glm::dot(d, d) > e.far2;
      // Asked before the form factor, which it spares for most rays an update passes over. The
      // sphere only with a zone: worked out ahead of the test, it cost 0.35% of a solve's instructions.
      if (zone && !zone->may_cross(x, far ? far_end(e, batch.visibility().epsilon()) : Sphere{e.centroid, e.radius}))
        continue;
      if (far) {
        far_sample(receiver, x, n, e.centroid, e.anchor, e.normal,
                   [&]() __attribute__((always_inline)) { return cluster_form_factor(x, n, e); }, e.radiance,
                   e.anchor_lift, e.anchor_under_patch, shut, batch);
        continue;
      }
      stack[top++] = e.right;
      stack[top++] = e.left;
    }
  };
  // Far samples of four frontier elements at once: all that far_sample and to_point work out for one
  // far cluster, in lanes. The lanes are then taken in the frontier's order, so the rays (and the
  // sums they add to) come in the order a walk one element at a time gave them.
  Lanes3 xs = lanes_of(x), ns = lanes_of(n);
  Lanes eps = lanes_of(batch.visibility().epsilon());
  int count = int(shot.frontier.size());
  for (int b = 0; b * kLanes < count; ++b) {
    const FrontierBlock& block = shot.frontier_blocks[b];
    int first = b * kLanes, end = std::min(count, first + kLanes);
    Lanes3 d = block.centroid - xs;
    LaneMask far = dot(d, d) > block.far2;
    if (!any(far)) {  // near all four (a draft shot's few large clusters, mostly): no sample to work out
      for (int i = first; i < end; ++i) walk(shot.frontier[i]);
      continue;
    }
    LaneMask in_front = dot(block.normal, d) <= 0;
    Lanes3 rad = select(in_front, block.radiance[0], block.radiance[1]);
    Lanes cos_r = dot(ns, d);
    Lanes factor = cluster_form_factor(xs, ns, block);
    LaneMask sends = far & ((rad.x != 0) | (rad.y != 0) | (rad.z != 0)) & (cos_r != 0) & (factor > 0);
    Lanes3 origin, dir;
    segment_ends(xs, ns, block.anchor, block.normal, eps, block.anchor_lift, origin, dir);
    Lanes3 irradiance = factor * rad;
    for (int l = 0; first + l < end; ++l) {
      if (!far[l]) {
        walk(shot.frontier[first + l]);
      } else if (sends[l]) {
        const ShotElement& e = shot.elements[shot.frontier[first + l]];
        if (zone && !zone->may_cross(x, far_end(e, batch.visibility().epsilon()))) continue;
        if ((in_front[l] ? 0 : 1) == shut || !batch.open(cos_r[l] > 0)) continue;
        if (e.anchor_under_patch >= 0)
          batch.to_point(receiver, x, n, e.anchor, e.normal, cos_r[l] > 0, lane(irradiance, l), e.anchor_lift,
                         e.anchor_under_patch);
        else
          batch.segment(receiver, lane(origin, l), lane(dir, l), cos_r[l] > 0, lane(irradiance, l));
      }
    }
  }
  batch.set_share({1.0, 1.0});
  batch.set_open({true, true});
}

}  // namespace radiosity
