// Direct light on the surfaces right around a reported point, worked out where it lands.
//
// A patch's radiance is interpolated from its corners. Across a shadow edge that is off by the
// whole step, and a point beside the patch sees the wrong part at a solid angle that does not
// shrink with the patches: the foot of a box on a lit floor, where the box's shadow edge starts,
// sees the floor beside it through patches lit on one side of that edge and dark on the other.
// So a reported point gathers once more from the patches near it whose corners' direct light
// differs a lot: the direct light they reflect, evaluated at each exactly integrated piece, minus
// what interpolation gave it. One bounce of the difference, which the rest of the scene does not
// see again, worked out only for the points asked for.
//
// test_module.py checks that a box's foot where its shadow edge starts gets the floor's light through
// the lit wedge's form factor at several floor patch sizes, where interpolation gives up to twice it.
//
// With Settings::exact_near_reflected every lit patch near a reported point does so with all it
// sends: what its shooter's shots sent is taken back, and each piece sends its reflectance times
// all the light that lands there, every shooter's too. Interpolated, a floor's reflected light
// under-reads the foot of a box on it and a room's concave corners (test_cycles_agreement.py
// measures how near Cycles the samples' corners come).
#include "solver_impl.h"

#include "gather.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <unordered_map>

namespace radiosity {

namespace {

// A patch's direct light counts as well interpolated when its corners' differ by less than this
// part of the brightest: a shadow edge across it is a step; falloff away from a lamp is smooth.
constexpr double kContrast = 0.25;
// With exact_near_reflected, the same for all their light: at 5% the samples' corners come as near
// Cycles as with every lit patch, at 15% measurably farther.
constexpr double kContrastReflected = 0.05;

// Pieces of a cell near the point are split while nearer than this many of their radii, down to
// pieces a little smaller than the point's height over them: the light changes within a cell (a
// shadow edge starting at the point's foot), and a point a millimetre off the floor sees the
// piece under it through half its view.
constexpr double kSplitRadii = 4.0;
constexpr int kSplitDepth = 16;

}  // namespace

// The difference one patch sends, as two shots of its cells cut as its shooter's shots cut them:
// the interpolated direct light taken back, split as the solver split it (so it cancels what was
// gathered), and the exact direct light at each piece, split finely. Far cells send nothing: from
// afar interpolation holds.
struct NearDetail {
  Shot interpolated, exact;
  // Per side: whether its corners' direct light differs enough (with exact_near_reflected: or their
  // light does, kContrastReflected).
  bool step[2] = {false, false};
  dvec3 reflectance{0.0};
  PieceRadiance at_piece;
  // What at_piece worked out, by the bits of its arguments, for the points asked for together:
  // neighbouring points split a patch into the same pieces away from their own feet (many of them
  // asked again, each a gather from every shooter), and the piece's light is a function of them
  // alone. Emptied after each batch of points.
  using Key = std::array<uint64_t, 7>;
  struct KeyHash {
    size_t operator()(const Key& k) const {
      uint64_t h = 0;
      for (uint64_t v : k) h = (h ^ v) * 0x100000001b3ull;
      return size_t(h ^ (h >> 29));
    }
  };
  mutable std::mutex memo_mutex;
  mutable std::unordered_map<Key, dvec3, KeyHash> memo;
};

// A point asked for: what it gains, and what that was worked out from.
struct NearPoint {
  dvec3 gained{0.0};         // on its front side
  std::vector<int> patches;  // near it, whether they need a NearDetail or not
  double reach = 0.0;        // how far from it they reach
};

struct Solver::Impl::NearDirect {
  std::vector<Source> sources;        // the direct light of the scene as it is
  std::vector<Source> reflected;      // with exact_near_reflected: what every shooter has sent
  std::vector<CornerUnshot> scratch;  // zero but for the patch being cut into cells
  std::unordered_map<int, NearDetail> detail;  // per patch near some point asked for
  std::unordered_map<int, NearPoint> points;   // per point asked for
  // Per corner point of a patch near some point asked for: the solver's direct light there (per
  // side) then. Where it still holds, so does what the patch's corners' direct light decided.
  std::unordered_map<int, std::array<dvec3, 2>> direct;
};

std::array<dvec3, 2> Solver::Impl::direct_now(int point) const {
  return {front[point] - reflected_front[point], back[point] - reflected_back[point]};
}

std::array<dvec3, 2> Solver::Impl::light_at(const std::vector<Source>& sources, const dvec3& y,
                                            const dvec3& normal) const {
  // Gathered under an index past every receiving point: no patch takes it for one of its corners.
  int slot = int(mesh.points.size());
  std::array<dvec3, 2> h{dvec3(0.0), dvec3(0.0)};
  OcclusionBatch batch(*vis, &h[0], &h[1], slot);
  ReceiverPoint point;  // of no object: no shot skips it
  point.position = y, point.normal = normal;
  for (const Source& s : sources) s.gather(slot, point, batch);
  batch.flush();
  return h;
}

std::array<dvec3, 2> Solver::Impl::direct_at(const dvec3& y, const dvec3& normal) const {
  return light_at(near_direct->sources, y, normal);
}

const NearDetail* Solver::Impl::near_detail(int q) const {
  NearDirect& nd = *near_direct;
  auto [it, fresh] = nd.detail.try_emplace(q);
  NearDetail& d = it->second;
  if (!fresh) return d.interpolated.patches.empty() ? nullptr : &d;
  const Patch& patch = mesh.patches[q];
  const dvec3* rho = &mesh.reflectance[4 * q];
  // Pieces reflect the corners' mean: a texture's colour changes little across one patch, unlike
  // the light across a shadow edge.
  dvec3 mean_rho = 0.25 * (rho[0] + rho[1] + rho[2] + rho[3]);
  if (patch.area == 0 || !scene.meshes[patch.object].visible || mean_rho == dvec3(0.0) || mesh.emits(q))
    return nullptr;
  CornerUnshot& corners = nd.scratch[q];
  for (int c = 0; c < 4; ++c) {
    const ReceiverPoint& at = mesh.points[patch.point[c]];
    std::array<dvec3, 2> h = direct_at(at.position, at.normal);
    for (int s = 0; s < 2; ++s) corners[2 * c + s] = h[s];
  }
  bool all = settings.exact_near_reflected;
  auto contrast = [](const std::array<double, 4>& h) {
    double hi = *std::max_element(h.begin(), h.end()), lo = *std::min_element(h.begin(), h.end());
    return hi > 0 ? (hi - lo) / hi : 0.0;
  };
  for (int s = 0; s < 2; ++s) {
    std::array<double, 4> direct, light;
    for (int c = 0; c < 4; ++c) {
      direct[c] = channel_sum(corners[2 * c + s]);
      light[c] = channel_sum((s == 0 ? front : back)[patch.point[c]]);
    }
    d.step[s] = contrast(direct) > kContrast || (all && contrast(light) > kContrastReflected);
  }
  if (!d.step[0] && !d.step[1]) {
    corners.fill(dvec3(0.0));
    return nullptr;
  }
  // Taken back: what the patch's shots sent (all of it, or the direct light it reflected).
  for (int k = 0; k < 8; ++k)
    corners[k] = !d.step[k % 2] ? dvec3(0.0) : all ? -shot[q][k] : -rho[k / 2] * corners[k];
  Shot whole = cluster_shot(shot_scene(), shooters[patch_shooter[q]], nd.scratch, 1.0,
                            {settings.samples_indirect, settings.near_factor});
  corners.fill(dvec3(0.0));
  // The patch's own cells, as one leaf whose far cells send nothing.
  Shot& leaf = d.interpolated;
  leaf.reflected = true;
  for (size_t i = 0; i < whole.patches.size(); ++i) {
    if (!std::equal(patch.point.begin(), patch.point.end(), whole.patches[i].point)) continue;
    leaf.patches.push_back(whole.patches[i]);
    // Its close view of itself is the solver's, with no finer evaluation to put in its place.
    for (auto& corner : leaf.patches.back().own_view) corner[0] = corner[1] = 0.0;
    for (const ShotCell& cell : whole.cells)
      if (cell.patch == int(i)) {
        leaf.cells.push_back(cell);
        leaf.cells.back().patch = 0;
        leaf.cells.back().radiance[0] = leaf.cells.back().radiance[1] = dvec3(0.0);
      }
  }
  ShotElement element;
  element.cell_end = int(leaf.cells.size());
  leaf.elements.push_back(element);
  set_frontier(leaf, {0});
  d.exact = leaf;
  d.exact.split_radii = kSplitRadii;
  d.exact.split_depth = kSplitDepth;
  for (auto& corner : d.exact.patches[0].radiance) corner[0] = corner[1] = dvec3(0.0);
  d.reflectance = mean_rho;
  // The reflected light too is split finely: near a box's foot it changes within millimetres as
  // the direct light does (split only as the solver splits, it is farther from Cycles).
  d.at_piece = [this, &d](const dvec3& y, const dvec3& normal, int side) {
    if (!d.step[side]) return dvec3(0.0);
    NearDetail::Key key;
    double args[7] = {y.x, y.y, y.z, normal.x, normal.y, normal.z, double(side)};
    std::memcpy(key.data(), args, sizeof args);
    {
      std::lock_guard<std::mutex> lock(d.memo_mutex);
      if (auto known = d.memo.find(key); known != d.memo.end()) return known->second;
    }
    dvec3 h = direct_at(y, normal)[side];
    if (!near_direct->reflected.empty()) h += light_at(near_direct->reflected, y, normal)[side];
    std::lock_guard<std::mutex> lock(d.memo_mutex);
    return d.memo.try_emplace(key, d.reflectance * h).first->second;
  };
  d.exact.patches[0].piece = &d.at_piece;
  return &d;
}

void Solver::Impl::prepare_near_direct(const std::vector<int>& points) const {
  if (!settings.exact_near_direct || !injected) return;
  if (!near_direct) {
    near_direct = std::make_shared<NearDirect>();
    near_direct->sources = direct_sources();
    if (settings.exact_near_reflected)
      // At the solve's full sampling. A piece by a box's foot sees the box fill much of its view,
      // and fewer, larger far samples (each one ray, wholly blocked or not) swing its light by
      // tens of percent.
      near_direct->reflected = reflected_sources();
    CornerUnshot none;
    none.fill(dvec3(0.0));
    near_direct->scratch.assign(mesh.patches.size(), none);
  }
  NearDirect& nd = *near_direct;
  std::vector<int> wanted;
  for (int i : points)
    if (!hidden_point[i] && mesh.points[i].normal != dvec3(0.0) && nd.points.try_emplace(i).second)
      wanted.push_back(i);
  int count = int(wanted.size());

  // Per point, the patches whose sphere comes within near_factor of their radius of it. A node
  // holds patches no wider than its diameter, so one farther than (3 + 2 near_factor) radii holds none.
  double near = settings.near_factor;
  std::vector<std::vector<int>> patches(count);
  std::vector<double> reach(count, 0.0);
  parallel_for(0, count, 16, [&](int k) {
    const dvec3& x = mesh.points[wanted[k]].position;
    std::vector<int> stack(tree.roots.begin(), tree.roots.end());
    while (!stack.empty()) {
      const ClusterNode& n = tree.nodes[stack.back()];
      stack.pop_back();
      double d = glm::length(n.centroid - x);
      if (n.left >= 0) {
        if (d <= (3 + 2 * near) * n.radius) stack.push_back(n.left), stack.push_back(n.right);
      } else if (d <= (1 + near) * n.radius) {
        patches[k].push_back(tree.order[n.begin]);
        reach[k] = std::max(reach[k], d + n.radius);
      }
    }
  });
  for (const std::vector<int>& near_patches : patches)
    for (int q : near_patches)
      for (int c : mesh.patches[q].point) nd.direct.try_emplace(c, direct_now(c));
  // Cutting patches into cells fills the shot cache: one thread. Gathering only reads.
  std::vector<std::vector<const NearDetail*>> details(count);
  for (int k = 0; k < count; ++k)
    for (int q : patches[k])
      if (const NearDetail* d = near_detail(q)) details[k].push_back(d);
  std::vector<dvec3> gained(count, dvec3(0.0));
  parallel_for(0, count, 4, [&](int k) {
    int i = wanted[k];
    for (const NearDetail* d : details[k]) {
      dvec3 h[2] = {dvec3(0.0), dvec3(0.0)};
      OcclusionBatch batch(*vis, &h[0], &h[1], i);
      gather(d->interpolated, i, mesh.points[i], batch);
      gather(d->exact, i, mesh.points[i], batch);
      batch.flush();
      gained[k] += h[0];
    }
  });
  for (int k = 0; k < count; ++k) nd.points[wanted[k]] = {gained[k], std::move(patches[k]), reach[k]};
  for (const std::vector<const NearDetail*>& near_details : details)
    for (const NearDetail* d : near_details)
      if (!d->memo.empty()) decltype(d->memo)().swap(d->memo);
}

dvec3 Solver::Impl::near_direct_correction(int i) const {
  prepare_near_direct({i});
  if (!near_direct) return dvec3(0.0);
  auto found = near_direct->points.find(i);
  return found == near_direct->points.end() ? dvec3(0.0) : found->second.gained;
}

void Solver::Impl::keep_near_direct(const std::vector<int>& objects, const std::vector<Zone>& zones) {
  if (!near_direct) return;
  NearDirect& nd = *near_direct;
  nd.sources = direct_sources();
  auto sphere_of = [&](int q) {  // a patch's, as its cluster tree leaf's
    Sphere s{mesh.patches[q].centre, 0.0};
    for (int v : mesh.patches[q].vertex) s.radius = std::max(s.radius, glm::length(mesh.vertices[v] - s.centre));
    return s;
  };
  std::vector<char> moved(scene.meshes.size(), 0);
  // A moved object's patch becomes near a point within (1 + near_factor) of its radius.
  double approach = 0.0;
  for (int o : objects) {
    moved[o] = 1;
    for (int q = mesh.objects[o].patch_begin; q < mesh.objects[o].patch_end; ++q)
      approach = std::max(approach, (1 + settings.near_factor) * sphere_of(q).radius);
  }
  auto in_zone = [&](const Sphere& s) {
    for (const Zone& z : zones)
      if (overlap(s, z.before) || overlap(s, z.after)) return true;
    return false;
  };
  // A patch's detail stands while its object stayed, its shooter's view of itself did too (no
  // moved object near it), no lamp's or emitter's ray to it may cross a moved object (a shadow
  // edge can cross a patch and miss its corners), and its corners' direct light is the same but
  // for round-off (the solver's direct light is the difference of two sums that reflected light
  // adds to alike). The world's light is let pass: every sky ray may cross the object, and past
  // the points near it (below) what it takes is a smooth part of the sky, which interpolation
  // between corners holds (test_dynamic.py compares it kept against worked out anew).
  std::unordered_map<int, bool> stale;
  auto patch_stale = [&](int q) {
    auto [it, fresh] = stale.try_emplace(q, false);
    if (!fresh) return it->second;
    const Patch& patch = mesh.patches[q];
    const ClusterNode& shooter = tree.nodes[shooters[patch_shooter[q]]];
    Sphere around = sphere_of(q);
    bool gone = moved[patch.object] || in_zone({shooter.centroid, shooter.radius});
    for (size_t k = 0; k < nd.sources.size() && !gone; ++k)
      if (nd.sources[k].kind != Source::Kind::World)
        for (const Zone& z : zones) gone = gone || nd.sources[k].may_reach(around, z);
    for (int c : patch.point) {
      auto then = nd.direct.find(c);
      std::array<dvec3, 2> now = direct_now(c);
      double scale = 1e-9 * (channel_sum(front[c]) + channel_sum(back[c]));
      gone = gone || then == nd.direct.end() || glm::length(then->second[0] - now[0]) > scale ||
             glm::length(then->second[1] - now[1]) > scale;
    }
    return it->second = gone;
  };
  for (const auto& entry : nd.detail) patch_stale(entry.first);  // every point's patches have one
  auto object_of = [&](int i) { return mesh.patches[mesh.point_slots[mesh.point_slot_begin[i]] / 4].object; };
  for (auto it = nd.points.begin(); it != nd.points.end();) {
    const NearPoint& p = it->second;
    bool gone = moved[object_of(it->first)] ||
                in_zone({mesh.points[it->first].position, std::max(p.reach, approach)});
    for (size_t k = 0; k < p.patches.size() && !gone; ++k) gone = patch_stale(p.patches[k]);
    it = gone ? nd.points.erase(it) : std::next(it);
  }
  for (const auto& [q, gone] : stale)
    if (gone) {
      nd.detail.erase(q);
      for (int c : mesh.patches[q].point) nd.direct.erase(c);
    }
  for (int o : objects)  // its patches, near no point asked for before, may be now
    for (int q = mesh.objects[o].patch_begin; q < mesh.objects[o].patch_end; ++q) nd.detail.erase(q);
}

}  // namespace radiosity
