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

// The key of the patch with corners at[vertex[0..3]], and the corner it starts at.
std::pair<Key, int> patch_key(const PatchMesh& pm, const std::array<int, 4>& vertex, const dvec3* at) {
  double step = 1e-9 * pm.diagonal;
  std::array<std::array<long long, 3>, 4> c;
  for (int i = 0; i < 4; ++i) c[i] = on_grid(at[vertex[i]], step);
  int first = int(std::min_element(c.begin(), c.end()) - c.begin());
  Key key;
  for (int i = 0; i < 4; ++i)
    for (int a = 0; a < 3; ++a) key[3 * i + a] = c[(first + i) % 4][a];
  return {key, first};
}

bool stays(const MeshDesc& mesh) { return !mesh.dynamic && !mesh.deforms && mesh.visible; }

// Patches of different objects may merge only where both objects stay; an object's own always do.
bool may_merge(const std::vector<MeshDesc>& meshes, int a, int b) {
  return a == b || (stays(meshes[a]) && stays(meshes[b]));
}

}  // namespace

std::vector<std::string> merge_coincident_patches(PatchMesh& pm, const std::vector<MeshDesc>& meshes) {
  // Per key, the patches first seen with it (with their first corner): one that stays, and one a
  // patch of each object that does not (which only its own may copy).
  std::unordered_map<Key, std::vector<std::pair<int, int>>, KeyHash> first_seen;
  std::vector<int> slot_to(4 * pm.patches.size(), -1);  // a copy's slot -> the first one's
  std::map<int, std::map<int, int>> copies;             // object -> object lain on -> patches
  for (size_t o = 0; o < pm.objects.size(); ++o) {
    const ObjectPatches& obj = pm.objects[o];
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
      Patch& patch = pm.patches[q];
      if (patch.area == 0) continue;
      auto [key, first] = patch_key(pm, patch.vertex, pm.vertices.data());
      std::vector<std::pair<int, int>>& seen = first_seen[key];
      auto match = std::find_if(seen.begin(), seen.end(), [&](const std::pair<int, int>& s) {
        return may_merge(meshes, pm.patches[s.first].object, int(o));
      });
      if (match == seen.end()) {
        seen.emplace_back(q, first);
        continue;
      }
      auto [original, original_first] = *match;
      for (int i = 0; i < 4; ++i)
        slot_to[4 * q + (first + i) % 4] = 4 * original + (original_first + i) % 4;
      patch.copy_of = original;
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
    std::string what;
    for (const auto& [other, count] : on) {
      if (other != object) pm.objects[object].coincident_with_others = pm.objects[other].coincident_with_others = true;
      what += std::string(what.empty() ? "" : " and ") + "on " +
              (other == object ? "its own" : "'" + meshes[other].name + "'") + " (" + std::to_string(count) +
              " patches)";
    }
    messages.push_back("object '" + meshes[object].name + "': faces stacked exactly " + what +
                       ": each stack is lit and seen once, as a ray tracer sees the first");
  }
  return messages;
}

bool copies_hold(const PatchMesh& pm, int object, const PlacedObject& placed) {
  const ObjectPatches& obj = pm.objects[object];
  auto local = [&](const Patch& p) {
    std::array<int, 4> v;
    for (int c = 0; c < 4; ++c) v[c] = p.vertex[c] - obj.vertex_begin;
    return v;
  };
  for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
    const Patch& patch = pm.patches[q];
    if (patch.copy_of >= 0 &&
        patch_key(pm, local(patch), placed.at.data()).first !=
            patch_key(pm, local(pm.patches[patch.copy_of]), placed.at.data()).first)
      return false;
  }
  return true;
}

}  // namespace radiosity
