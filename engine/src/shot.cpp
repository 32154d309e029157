#include "shot.h"

#include "dispatch.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace radiosity {

namespace {

// Cache keys: a patch's cells (as many per side as a shot asks for, at most 64) per side; a node per side.
constexpr long long kMaxCellsPerSide = 64;
long long cell_key(int patch, int cells_per_side, int side) {
  return (kMaxCellsPerSide * patch + cells_per_side) * 2 + side;
}
long long member_key(int node, int side) { return 2LL * node + side; }

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

Shot cluster_shot(const ShotScene& scene, int node, const std::vector<CornerUnshot>& unshot, double scale,
                  const ShotSampling& sampling) {
  const PatchMesh& mesh = scene.mesh;
  const ClusterTree& tree = scene.tree;
  int samples = sampling.samples, far_samples = sampling.far_samples;
  std::vector<int> frontier = frontier_of(tree, node, samples);
  int cells_per_side = std::max(1, int(std::ceil(std::sqrt(double(samples) / frontier.size()))));
  if (far_samples < samples) frontier = frontier_of(tree, node, std::max(1, far_samples));

  Shot shot;
  // Sized up front: growing them would copy every element and cell already built, several times a shot.
  const ClusterNode& root = tree.nodes[node];
  shot.elements.reserve(2 * (root.end - root.begin) - 1);
  shot.patches.reserve(root.end - root.begin);
  shot.cells.reserve(size_t(root.end - root.begin) * cells_per_side * cells_per_side);
  ShotCache local;  // without a cache to keep, work it out for this shot alone
  ShotBuilder builder{mesh, tree, scene.vis, scene.cache ? scene.cache : &local, unshot, scale, sampling.near_factor,
                      cells_per_side, shot, {}};
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
      a.cells.size() != b.cells.size() || a.frontier != b.frontier || a.reflected != b.reflected ||
      a.ends_by_place != b.ends_by_place)
    return std::nullopt;
  Shot d;
  d.frontier = b.frontier;
  d.split_radii = b.split_radii;
  d.split_depth = b.split_depth;
  d.reflected = b.reflected;
  d.ends_by_place = b.ends_by_place;
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

}  // namespace radiosity
