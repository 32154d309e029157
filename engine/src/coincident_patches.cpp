#include "coincident_patches.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <unordered_map>

namespace radiosity {

namespace {

// A patch's corners on a grid of 1e-9 of the scene's size, started at the least corner so that the
// same corners in the same cyclic order give the same key whichever corner comes first.
using Key = std::array<long long, 12>;

struct KeyHash {
  size_t operator()(const Key& k) const {
    size_t h = 1469598103934665603ull;
    for (long long v : k) h = (h ^ size_t(v)) * 1099511628211ull;
    return h;
  }
};

std::array<long long, 3> on_grid(const dvec3& p, double step) {
  return {std::llround(p.x / step), std::llround(p.y / step), std::llround(p.z / step)};
}

// The key and the corner it starts at.
std::pair<Key, int> patch_key(const PatchMesh& pm, const Patch& patch) {
  double step = 1e-9 * pm.diagonal;
  std::array<std::array<long long, 3>, 4> c;
  for (int i = 0; i < 4; ++i) c[i] = on_grid(pm.vertices[patch.vertex[i]], step);
  int first = int(std::min_element(c.begin(), c.end()) - c.begin());
  Key key;
  for (int i = 0; i < 4; ++i)
    for (int a = 0; a < 3; ++a) key[3 * i + a] = c[(first + i) % 4][a];
  return {key, first};
}

bool stays(const MeshDesc& mesh) { return !mesh.dynamic && !mesh.deforms && mesh.visible; }

}  // namespace

std::vector<std::string> merge_coincident_patches(PatchMesh& pm, const std::vector<MeshDesc>& meshes) {
  std::unordered_map<Key, std::pair<int, int>, KeyHash> first_seen;  // key -> (patch, its first corner)
  std::vector<int> slot_to(4 * pm.patches.size(), -1);                // a copy's slot -> the first one's
  std::map<int, std::map<int, int>> copies;                           // object -> object lain on -> patches
  for (size_t o = 0; o < pm.objects.size(); ++o) {
    if (!stays(meshes[o])) continue;
    const ObjectPatches& obj = pm.objects[o];
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
      Patch& patch = pm.patches[q];
      if (patch.area == 0) continue;
      auto [key, first] = patch_key(pm, patch);
      auto [it, fresh] = first_seen.try_emplace(key, q, first);
      if (fresh) continue;
      auto [original, original_first] = it->second;
      for (int i = 0; i < 4; ++i)
        slot_to[4 * q + (first + i) % 4] = 4 * original + (original_first + i) % 4;
      patch.area = 0.0;
      patch.normal = dvec3(0.0);
      ++copies[int(o)][pm.patches[original].object];
    }
  }
  if (copies.empty()) return {};
  for (auto& obj : pm.objects)
    for (int& slot : obj.corner_slot)
      if (slot >= 0 && slot_to[slot] >= 0) slot = slot_to[slot];
  // A point whose every patch is a copy gathers nothing (the solve skips points without a normal).
  for (size_t p = 0; p < pm.points.size(); ++p) {
    bool live = false;
    for (int i = pm.point_slot_begin[p]; i < pm.point_slot_begin[p + 1] && !live; ++i)
      live = pm.patches[pm.point_slots[i] / 4].area > 0;
    if (!live) pm.points[p].normal = dvec3(0.0);
  }
  std::vector<std::string> messages;
  for (const auto& [object, on] : copies) {
    pm.objects[object].coincident = true;
    std::string what;
    for (const auto& [other, count] : on) {
      pm.objects[other].coincident = true;
      what += std::string(what.empty() ? "" : " and ") + "on " +
              (other == object ? "its own" : "'" + meshes[other].name + "'") + " (" + std::to_string(count) +
              " patches)";
    }
    messages.push_back("object '" + meshes[object].name + "': faces stacked exactly " + what +
                       ": each stack is lit and seen once, as a ray tracer sees the first");
  }
  return messages;
}

}  // namespace radiosity
