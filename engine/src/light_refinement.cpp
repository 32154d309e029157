// Refinement driven by the light: patches split where the light across them changes, so that the
// error falls where it is seen and no patches are spent where the light is flat.
#include "solver_impl.h"

#include "radiosity/form_factor.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

// The marks read the light's shape: a solve to this residual has it (the draft preset's threshold).
constexpr double kMarkingThreshold = 1e-2;
// Light dimmer than this part of the scene's mean is not split for: its differences are not seen.
constexpr double kDimmest = 0.1;

}  // namespace

// A patch is marked where its corners' light differs by more than `contrast` of the brightest
// (a shadow's edge crossing it, a bright spot at one corner), or where the direct light at its
// centre is that far from its corners' mean (a shadow or a lamp's light falling inside it, missed
// by its corners: the lamp or emitter seen partly from there). Each side of a surface on its own.
std::vector<char> Solver::Impl::light_marks(double contrast) const {
  std::vector<char> marks(mesh.patches.size(), 0);
  auto takes_part = [&](int p) {
    const Patch& patch = mesh.patches[p];
    if (patch.area == 0 || patch.copy_of >= 0 || !scene.meshes[patch.object].visible) return false;
    dvec3 rho(0.0);
    for (int c = 0; c < 4; ++c) rho += mesh.reflectance[4 * p + c];
    return channel_sum(rho) > 0;  // a black patch shows none of its light
  };
  double sum = 0.0, area = 0.0;
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    if (!takes_part(int(p))) continue;
    const Patch& patch = mesh.patches[p];
    for (int c = 0; c < 4; ++c) sum += 0.25 * patch.area * channel_sum(front[patch.point[c]] + back[patch.point[c]]);
    area += patch.area;
  }
  if (!(sum > 0)) return marks;
  double dimmest = kDimmest * sum / area;
  std::vector<Source> sources = direct_sources();
  parallel_for(0, int(mesh.patches.size()), 16, [&](int p) {
    if (!takes_part(p)) return;
    const Patch& patch = mesh.patches[p];
    // A twisted patch's centre lies off the two triangles Embree traces for it: each side's light
    // is taken from in front of them on that side.
    dvec3 corner[4];
    for (int c = 0; c < 4; ++c) corner[c] = mesh.vertices[patch.vertex[c]];
    double lift = bilinear_lift(bilinear_twist(corner, patch.normal), 0.5, 0.5);
    std::array<dvec3, 2> centre = light_at(sources, patch.centre + lift * patch.normal, patch.normal);
    if (lift > 0) centre[1] = light_at(sources, patch.centre - lift * patch.normal, patch.normal)[1];
    for (int side = 0; side < 2; ++side) {
      double lo = INFINITY, hi = -INFINITY, direct_mean = 0.0;
      for (int c = 0; c < 4; ++c) {
        int point = patch.point[c];
        double h = channel_sum(side ? back[point] : front[point]);
        lo = std::min(lo, h), hi = std::max(hi, h);
        direct_mean += 0.25 * channel_sum(direct_now(point)[side]);
      }
      double at_centre = channel_sum(centre[side]);
      double change = std::max(hi - lo, std::fabs(at_centre - direct_mean));
      if (change > contrast * std::max({hi, at_centre, dimmest})) marks[p] = 1;
    }
  });
  return marks;
}

std::vector<std::vector<QuadCell>> Solver::Impl::cells_by_light(const SceneDesc& scene, const Settings& settings) {
  settings.validate();
  Settings loose = settings;
  loose.light_refinement = 0;
  loose.threshold = std::max(settings.threshold, kMarkingThreshold);
  std::vector<std::vector<QuadCell>> cells;  // empty: the refined quads as they are
  for (int round = 0; round < settings.light_refinement; ++round) {
    Impl impl(scene, loose, cells);
    std::vector<char> marks;
    impl.workers.run([&] {
      impl.solve({});
      marks = impl.light_marks(settings.light_contrast);
    });
    long long count = (long long)impl.mesh.patches.size(), marked = 0;
    for (char m : marks) marked += m;
    if (marked == 0 || count + 3 * marked > settings.max_patches) break;
    std::vector<std::vector<QuadCell>> next(scene.meshes.size());
    for (size_t o = 0; o < scene.meshes.size(); ++o) {
      const ObjectPatches& obj = impl.mesh.objects[o];
      for (int p = obj.patch_begin; p < obj.patch_end; ++p) {
        int q = p - obj.patch_begin;
        QuadCell cell = cells.empty() || cells[o].empty() ? QuadCell{q, 0, 0, 0} : cells[o][q];
        if (!marks[p]) {
          next[o].push_back(cell);
          continue;
        }
        for (const QuadCell& child : children(cell)) next[o].push_back(child);
      }
    }
    cells = std::move(next);
  }
  return cells;
}

}  // namespace radiosity
