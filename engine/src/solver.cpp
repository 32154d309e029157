#include "radiosity/solver.h"

#include "solver_impl.h"

#include "coincident_patches.h"
#include "dispatch.h"
#include "gather.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace radiosity {

namespace {

double abs_sum(const dvec3& v) { return std::fabs(v.x) + std::fabs(v.y) + std::fabs(v.z); }
// A patch's unshot radiance times its area, over its corners, on one side (0 front, 1 back).
double unshot_power(const CornerUnshot& unshot, double area, int side) {
  double sum = 0.0;
  for (int c = 0; c < 4; ++c) sum += abs_sum(unshot[2 * c + side]);
  return 0.25 * area * sum;
}
constexpr double kProgressInterval = 0.05;  // seconds between progress callbacks
// At the default threshold, about a shooter's even share of the light put in (150-230 shooters).
constexpr double kFullSamplesAbove = 8.0;
// Landing shares (measure_landing): a flat shooter's side sending less than kMeasuredSide of a shot
// keeps its share, and so does light whose sum is under kOneSign of its size (of both signs). The
// residual's scale does not fall below kLandingFloor of the light reflected in the direct pass.
constexpr double kMeasuredSide = 1e-3;
constexpr double kOneSign = 0.9;
constexpr double kLandingFloor = 1e-9;
constexpr double kDiverged = 10.0;  // growth of the residual past which shooting cannot be converging
// Residual, in thresholds, below which an update shoots without over-relaxation (relaxation()).
constexpr double kRelaxAbove = 2.0;
// Automatic over-relaxation (Settings::relaxation 0): the first kMeasuredShots shots landing at least
// kMeasuredLanding of their light, at 1.0, measure the share of the light that lands which comes
// back to be shot again, and the relaxation follows it: the best relaxation grows with that share,
// from 1.0 for boxes in the sun (little comes back) to about 1.2 for closed rooms, and the error
// against Cycles does not depend on it.
// Each propagate measures anew. An update's light is signed, and light landing on light of the
// other sign cancels, which the measure (of |unshot|) rightly counts as not come back: an update
// shooting on at the solve's value takes more rays.
constexpr int kMeasuredShots = 8;
constexpr double kMeasuredLanding = 0.5;
double relaxation_for(double returned) { return 1.0 + 0.3 * std::clamp(returned, 0.0, 1.0); }

// Checked before any member is built from them (the dB cache sizes itself from db_cache_mb).
const Settings& validated(const Settings& s) {
  s.validate();
  return s;
}

}  // namespace

Solver::Impl::Impl(SceneDesc s, const Settings& st, const std::vector<std::vector<QuadCell>>& cells)
    : workers(st.threads), scene(std::move(s)), settings(validated(st)), db_cache(settings.db_cache_mb) {
  scene.validate();
  std::vector<std::string> coincident;
  workers.run([&] {
    mesh = build_patch_mesh(scene, settings, cells);
    coincident = merge_coincident_patches(mesh, scene.meshes);
    tree = ClusterTree::build(mesh);
    std::vector<bool> dynamic, visible;
    for (const MeshDesc& m : scene.meshes) dynamic.push_back(m.dynamic), visible.push_back(m.visible);
    vis = std::make_unique<Visibility>(mesh, dynamic, visible);
    fit_to_mesh(0);
  });
  if (mesh.patches.empty()) stats.warnings.push_back("the scene has no geometry: nothing to light");
  if (mesh.degenerate_patches > 0)
    stats.warnings.push_back(std::to_string(mesh.degenerate_patches) +
                             " degenerate (zero-area) patches were left out");
  stats.warnings.insert(stats.warnings.end(), coincident.begin(), coincident.end());
}

void Solver::Impl::fit_to_mesh(int first_object) {
  for (auto* points : {&front, &back, &reflected_front, &reflected_back}) points->resize(mesh.points.size(), dvec3(0.0));
  CornerUnshot none;
  none.fill(dvec3(0.0));
  unshot.resize(mesh.patches.size(), none);
  shot.resize(mesh.patches.size(), none);
  landing.resize(mesh.patches.size(), {1.0, 1.0});
  reference_part.resize(mesh.patches.size(), {0.0, 0.0});
  hidden_point.resize(mesh.points.size(), 0);
  for (size_t o = first_object; o < scene.meshes.size(); ++o) mark_hidden(int(o));
  cut_shooters();
  stats.patches = int(mesh.patches.size());
  stats.points = int(mesh.points.size());
  stats.uniform_patches = 0;
  for (size_t o = 0; o < mesh.objects.size(); ++o)
    stats.uniform_patches += quad_count(scene.meshes[o], mesh.objects[o].face_levels) << (2 * settings.light_refinement);
}

void Solver::Impl::cut_shooters() {
  shooters = tree.cut(settings.shooter_size_relative * mesh.diagonal);
  patch_shooter.assign(mesh.patches.size(), -1);
  for (size_t s = 0; s < shooters.size(); ++s) {
    const ClusterNode& n = tree.nodes[shooters[s]];
    for (int i = n.begin; i < n.end; ++i) patch_shooter[tree.order[i]] = int(s);
  }
  stats.shooters = int(shooters.size());
}

void Solver::Impl::mark_hidden(int object) {
  const ObjectPatches& o = mesh.objects[object];
  std::fill(hidden_point.begin() + o.point_begin, hidden_point.begin() + o.point_end, !scene.meshes[object].visible);
}

void Solver::Impl::apply_delta(Light light) {
  patch_power.resize(mesh.patches.size());
  absorb_delta(-1, 0.0, light);
}

RADIOSITY_HOT void Solver::Impl::absorb_delta(int sent, double omega, Light light) {
  int points = int(mesh.points.size());
  int patches = int(mesh.patches.size());
  bool reflected = light == Light::reflected;
  auto add_to_point = [&](int i) {
    front[i] += delta_front[i];
    back[i] += delta_back[i];
    if (reflected) {
      reflected_front[i] += delta_front[i];
      reflected_back[i] += delta_back[i];
    }
  };
  // A shot's light landing, per side of its shooter (measure_landing): a receiver in front of a flat
  // shooter's plane takes its front side's light only; a shooter that is not flat, all on side 0.
  const ClusterNode* from = sent >= 0 ? &tree.nodes[shooters[sent]] : nullptr;
  auto add_to_patch = [&](int p, std::array<double, 2>& landed) {
    if (sent >= 0 && patch_shooter[p] == sent)
      for (int k = 0; k < 8; ++k) {
        shot[p][k] += omega * unshot[p][k];
        unshot[p][k] *= 1.0 - omega;  // over-relaxation leaves it negative
      }
    const Patch& patch = mesh.patches[p];
    if (patch.area != 0) {
      for (int c = 0; c < 4; ++c) {
        int pt = patch.point[c];
        const dvec3& rho = mesh.reflectance[4 * p + c];
        dvec3 r = reflected ? mesh.onward[4 * p + c] * rho : rho;
        unshot[p][c * 2 + 0] += r * delta_front[pt];
        unshot[p][c * 2 + 1] += r * delta_back[pt];
        if (from) {
          int side = from->flat && glm::dot(mesh.points[pt].position - from->centroid, from->vector_area) < 0;
          landed[side] += 0.25 * patch.area * channel_sum(delta_front[pt] + delta_back[pt]);
        }
      }
    }
    patch_power[p] = landing_power(p);
  };
  landed_sides = {0.0, 0.0};
  // The patches read only the delta: points and patches are one loop, with one join. A small scene's
  // loop is over sooner than a thread would wake for it.
  if (points + patches <= 16 * kParallelMinimum) {
    for (int i = 0; i < points; ++i) add_to_point(i);
    for (int p = 0; p < patches; ++p) add_to_patch(p, landed_sides);
    return;
  }
  constexpr int kChunk = 1024;
  int point_chunks = (points + kChunk - 1) / kChunk;
  int patch_chunks = (patches + kChunk - 1) / kChunk;
  std::vector<std::array<double, 2>> landed(patch_chunks, {0.0, 0.0});  // per chunk, summed in order
  parallel_for(0, point_chunks + patch_chunks, 1, [&](int k) {
    if (k < point_chunks)
      for (int i = k * kChunk, end = std::min(points, i + kChunk); i < end; ++i) add_to_point(i);
    else
      for (int p = (k - point_chunks) * kChunk, end = std::min(patches, p + kChunk); p < end; ++p)
        add_to_patch(p, landed[k - point_chunks]);
  });
  for (const auto& part : landed) landed_sides[0] += part[0], landed_sides[1] += part[1];
}

std::vector<double> Solver::Impl::summed_power() const {
  // On one thread in patch order, as shooter_power() sums: the same to the last bit.
  std::vector<double> power(shooters.size(), 0.0);
  for (size_t p = 0; p < mesh.patches.size(); ++p) power[patch_shooter[p]] += patch_power[p];
  return power;
}

std::vector<Source> Solver::Impl::patch_sources(const std::vector<CornerUnshot>& radiance, bool reflected,
                                                 int samples, double scale, const std::vector<char>* only,
                                                 int far_samples) const {
  std::vector<Source> out;
  for (size_t s = 0; s < shooters.size(); ++s) {
    if (only && !(*only)[s]) continue;
    int node = shooters[s];
    const ClusterNode& n = tree.nodes[node];
    bool any = false;
    for (int i = n.begin; i < n.end && !any; ++i)
      for (const dvec3& v : radiance[tree.order[i]]) any |= abs_sum(v) > 0;
    if (!any) continue;
    Shot shot = cluster_shot(shot_scene(), node, radiance, scale, {samples, settings.near_factor, far_samples});
    shot.reflected = reflected;
    out.push_back(shot_source(std::move(shot), int(s), {n.centroid, n.radius}));
  }
  return out;
}

// Emission itself is never unshot: every emitter's uniform radiance goes through the same dense
// shot, and only reflected light is shot coarser, so a furnace still has the uniform solution.
std::vector<Source> Solver::Impl::direct_sources(double scale, const std::vector<char>* only,
                                                  const MirrorPlanes* planes) const {
  std::vector<Source> out;
  if (!only) {
    for (Lamp l : scene.lamps) {
      l.position -= mesh.origin;
      l.color *= scale;
      out.push_back(lamp_source(l, settings.samples_direct));
    }
    if (scene.world.lit()) out.push_back(world_source(scene.world.scaled(scale), settings.samples_direct));
  }
  std::vector<CornerUnshot> emission(mesh.patches.size());
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    bool sends = mesh.patches[p].area > 0 && scene.meshes[mesh.patches[p].object].visible;
    for (int c = 0; c < 4; ++c)  // both sides
      emission[p][2 * c] = emission[p][2 * c + 1] = sends ? mesh.emission[4 * p + c] : dvec3(0.0);
  }
  for (Source& s : patch_sources(emission, false, settings.samples_direct, scale, only)) out.push_back(std::move(s));
  add_images(out, planes);
  return out;
}

std::vector<Source> Solver::Impl::reflected_sources(double scale, const std::vector<char>* only,
                                                     const MirrorPlanes* planes) const {
  std::vector<Source> out = patch_sources(shot, true, settings.samples_indirect, scale, only);
  add_images(out, planes);
  return out;
}

// One mirror bounce a path: images are not mirrored again.
void Solver::Impl::add_images(std::vector<Source>& sources, const MirrorPlanes* planes) const {
  size_t real = sources.size();
  for (const auto& plane : planes ? *planes : mirrors)
    for (size_t k = 0; k < real; ++k)
      for (Source& image : mirror_images(sources[k], plane)) sources.push_back(std::move(image));
}

MirrorPlanes Solver::Impl::find_planes(const std::vector<char>* only) {
  std::vector<int> curved;
  MirrorPlanes planes = find_mirrors(mesh, scene, curved, only);
  curved_mirror.resize(mesh.objects.size(), 0);
  std::vector<char> now(mesh.objects.size(), 0);
  for (int o : curved) {
    now[o] = 1;
    std::string warning = "object '" + scene.meshes[o].name + "': its mirror is curved (sharp specular faces in " +
                          "more than " + std::to_string(kMostPlanes) + " planes), and reflects diffusely";
    if (std::find(stats.warnings.begin(), stats.warnings.end(), warning) == stats.warnings.end())
      stats.warnings.push_back(warning);  // once, though each solve afresh finds it again
  }
  for (size_t o = 0; o < mesh.objects.size(); ++o) {
    if ((only && !(*only)[o]) || now[o] == curved_mirror[o]) continue;
    curved_mirror[o] = now[o];
    if (!scene.meshes[o].corner_reflectance.empty()) continue;  // a texture's, per corner
    for (int p = mesh.objects[o].patch_begin; p < mesh.objects[o].patch_end; ++p)
      change_reflectance(p, diffuse_reflectance(material(p), now[o]));
  }
  return planes;
}

void Solver::Impl::change_reflectance(int p, const dvec3& rho) {
  dvec3 more = rho - mesh.reflectance[4 * p];
  std::fill_n(mesh.reflectance.begin() + 4 * p, 4, rho);
  // A hidden object gathers nothing to reflect; before the first light, nothing is held.
  if (!injected || more == dvec3(0.0) || mesh.patches[p].area == 0 || !scene.meshes[mesh.patches[p].object].visible)
    return;
  for (int c = 0; c < 4; ++c) {
    int i = mesh.patches[p].point[c];
    double onward = mesh.onward[4 * p + c];
    unshot[p][2 * c] += more * (front[i] + (onward - 1) * reflected_front[i]);
    unshot[p][2 * c + 1] += more * (back[i] + (onward - 1) * reflected_back[i]);
    touched[i] = 1;
  }
}

double Solver::Impl::landed_power() const {
  double power = 0.0;
  for (const Patch& patch : mesh.patches)
    for (int c = 0; c < 4; ++c)
      power += 0.25 * patch.area * channel_sum(delta_front[patch.point[c]] + delta_back[patch.point[c]]);
  return power;
}

// Direct light at full sample density; what lands becomes unshot radiance.
bool Solver::Impl::inject() {
  mirrors = find_planes();
  std::vector<Source> sources = direct_sources();
  bool complete = gather_all([&](int i, const ReceiverPoint& p, OcclusionBatch& batch) {
    for (const Source& s : sources) s.gather(i, p, batch);
  });
  if (!complete) return false;
  injected_power += landed_power();
  apply_delta(Light::direct);
  ++stats.shots;
  injected = true;
  return true;
}

double Solver::Impl::landing_power(int patch) const {
  double area = mesh.patches[patch].area;
  return landing[patch][0] * unshot_power(unshot[patch], area, 0) +
         landing[patch][1] * unshot_power(unshot[patch], area, 1);
}

std::vector<double> Solver::Impl::shooter_power() const {
  std::vector<double> power(shooters.size(), 0.0);
  for (size_t p = 0; p < mesh.patches.size(); ++p) power[patch_shooter[p]] += landing_power(int(p));
  return power;
}

// Every share is unmeasured (1) again: where light lands is measured anew by each solve's shots, on
// the geometry as it now is.
void Solver::Impl::take_reference() {
  std::fill(landing.begin(), landing.end(), std::array<double, 2>{1.0, 1.0});
  reference_power = total_unshot_power();
  reference_landing = 1.0;
  for (size_t p = 0; p < mesh.patches.size(); ++p)
    for (int side = 0; side < 2; ++side)
      reference_part[p][side] =
          reference_power > 0 ? unshot_power(unshot[p], mesh.patches[p].area, side) / reference_power : 0.0;
}

// A receiver in front of a flat shooter's plane takes its front side's light only, one behind it its
// back side's, so one shot measures both sides' shares. A shooter whose normals part (a room's edge,
// a closed box) has no such plane: a shot measures the side that sends nearly all its light, and
// the other keeps its share.
double Solver::Impl::measure_landing(int s, const std::array<double, 2>& sent, const std::array<double, 2>& magnitude) {
  const ClusterNode& n = tree.nodes[shooters[s]];
  const std::array<double, 2>& landed = landed_sides;
  double total = magnitude[0] + magnitude[1];
  double signed_total = sent[0] + sent[1];
  // Light of both signs (an update's, over-relaxation's overshoot) cancels where it lands: the ratio
  // of two sums near nought says nothing of where it goes. A side that sends next to nothing would
  // measure the other side's stray light.
  auto one_sign = [&](double sum, double size) { return size > 0 && std::fabs(sum) >= kOneSign * size; };
  std::array<double, 2> share = landing[tree.order[n.begin]];
  for (int side = 0; side < 2; ++side) {
    if (n.flat && magnitude[side] > kMeasuredSide * total && one_sign(sent[side], magnitude[side]))
      share[side] = std::clamp(landed[side] / sent[side], 0.0, 1.0);
    if (!n.flat && magnitude[side] >= kOneSign * total && one_sign(signed_total, total))
      share[side] = std::clamp((landed[0] + landed[1]) / signed_total, 0.0, 1.0);
  }
  double change = 0.0;
  for (int i = n.begin; i < n.end; ++i) {
    int p = tree.order[i];
    for (int side = 0; side < 2; ++side) {
      change += (share[side] - landing[p][side]) * reference_part[p][side];
      landing[p][side] = share[side];
    }
    patch_power[p] = landing_power(p);
  }
  // Floored: where nothing lands the scale stays defined, and the residual is nought over it.
  double next = std::max(reference_landing + change, kLandingFloor);
  reference_power *= next / reference_landing;
  reference_landing = next;
  return one_sign(signed_total, total) ? std::clamp((landed[0] + landed[1]) / signed_total, 0.0, 1.0) : 0.0;
}

std::vector<double> Solver::Impl::held_power() const {
  std::vector<double> power(shooters.size(), 0.0);
  for (size_t p = 0; p < mesh.patches.size(); ++p)
    for (int side = 0; side < 2; ++side) power[patch_shooter[p]] += unshot_power(unshot[p], mesh.patches[p].area, side);
  return power;
}

double Solver::Impl::total_unshot_power() const {
  double total = 0.0;
  for (double p : shooter_power()) total += p;
  return total;
}

// A shot's far-field sampling errors are a part of what it sends, so a shot carrying little light
// needs few distant samples: their count falls with the square root of its power (which spends a
// given cost where it cuts the summed error most), full for a shot of kFullSamplesAbove times the
// light the threshold leaves unshot: a tighter threshold keeps more shots at full samples. An
// update's shots sample so too: a move and its undo then differ by their sampling errors, which a
// frame's distance from a fresh solve bounds, as it bounds a solve's.
int Solver::Impl::far_samples(double power) const {
  double full = kFullSamplesAbove * settings.threshold * reference_power;
  if (!(full > 0) || !(power < full)) return settings.samples_indirect;
  return std::max(1, int(std::ceil(settings.samples_indirect * std::sqrt(power / full))));
}

// Over-relaxation pays where much light has many bounces to go: a solve, or an update that lit or
// darkened the scene at large (a lamp, an emitter appearing: without, up to twice the shots). An
// update that leaves the residual just past its stop (a small object moved) has a little signed
// light near the change to clear; shooting 1.3 times it would leave 0.3 of it behind, negative, in
// each shooter, for more shots and no closer to a fresh solve.
double Solver::Impl::relaxation(const Shooting& shooting, double residual) const {
  return shooting.update && residual < kRelaxAbove * shooting.stop ? 1.0 : settings.relaxation;
}

bool Solver::Impl::shoot(int s, std::vector<double>& power, double omega, double& landed) {
  Shot sent = cluster_shot(shot_scene(), shooters[s], unshot, omega,
                           {settings.samples_indirect, settings.near_factor, far_samples(power[s])});
  sent.reflected = true;
  // What it sends per side, signed as the light it carries and unsigned: absorb_delta moves it to
  // `shot`.
  std::array<double, 2> sending{0.0, 0.0}, magnitude{0.0, 0.0};
  const ClusterNode& n = tree.nodes[shooters[s]];
  for (int i = n.begin; i < n.end; ++i) {
    int p = tree.order[i];
    for (int c = 0; c < 4; ++c)
      for (int side = 0; side < 2; ++side) {
        double w = omega * 0.25 * mesh.patches[p].area;
        sending[side] += w * channel_sum(unshot[p][2 * c + side]);
        magnitude[side] += w * abs_sum(unshot[p][2 * c + side]);
      }
  }
  patch_power.resize(mesh.patches.size());
  // The shot and its images, sampled as it is: a fresh solve then sends by way of a mirror what an
  // update of that mirror takes back and sends again.
  std::vector<Source> sources{shot_source(std::move(sent), s, {n.centroid, n.radius})};
  add_images(sources);
  if (!gather_all([](int) { return true; }, [this] { return delta_batch(); },
                  [&](int i, const ReceiverPoint& p, OcclusionBatch& batch) {
                    for (const Source& source : sources) source.gather(i, p, batch);
                  },
                  true, [&] { absorb_delta(s, omega, Light::reflected); }))
    return false;
  landed = measure_landing(s, sending, magnitude);
  power = summed_power();
  ++stats.shots;
  return true;
}

// Where unshot light runs away, it gathers in the faces that feed it: the objects holding the most.
// Two boxes standing in each other on a floor do so: inside them, the floor and both boxes' bottoms
// lie in one plane facing up, and a point there sees all three (rays end short of the plane they
// aim at), where Cycles' rays stop at the first; light that leaks in where a patch runs through the
// other box's wall then grows as it goes round.
std::string Solver::Impl::holders_of() const {
  std::vector<double> held(scene.meshes.size(), 0.0);
  for (size_t p = 0; p < mesh.patches.size(); ++p) held[mesh.patches[p].object] += patch_power[p];
  std::vector<int> order(held.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return held[a] > held[b]; });
  double total = std::accumulate(held.begin(), held.end(), 0.0);
  std::string names;
  double named = 0.0;
  for (size_t i = 0; i < order.size() && i < 4 && named < 0.9 * total; ++i) {
    names += (i ? ", '" : "'") + scene.meshes[order[i]].name + "'";
    named += held[order[i]];
  }
  return names;
}

void Solver::Impl::propagate(const ProgressCallback& progress, const Shooting& shooting) {
  // Reported before the first shot too: a caller that budgets the shooting (live update during
  // playback) starts its clock there and may stop before any shot.
  auto last_report = std::chrono::steady_clock::time_point();
  long first_shot = stats.shots;
  std::vector<double> power = shooter_power();  // then kept up to date by each shot
  double limit = 0.0;  // the residual past which this cannot be converging
  double omega = 0.0;  // relaxation(), for the residual this starts from
  double sent = 0.0, returned = 0.0;  // by the shots measuring the automatic relaxation
  int measuring = 0;
  stats.diverged = false;
  for (;;) {
    double total = 0.0;
    for (double p : power) total += p;
    stats.residual = reference_power > 0 ? total / reference_power : 0.0;
    // Past the threshold, what is left must also be spread: light held in a few shooters (around a
    // moved object) is missing from their surroundings whole, an error far above its share of the
    // residual; spread over the scene it is a solve's own. So no shooter may hold more than the
    // threshold's worth, which a solve's stop implies.
    double most = power.empty() ? 0.0 : *std::max_element(power.begin(), power.end());
    // Light that leaves the scene is no error, but the power balance holds it as unshot: once what
    // lands is down to the stop, the light left, landing or not, is shot down to the same part of
    // all that was reflected after injection (in a scene that keeps its light, nothing more).
    std::vector<double> held;
    if (stats.residual <= shooting.stop && !(most > settings.threshold * reference_power)) {
      held = held_power();
      if (!(std::accumulate(held.begin(), held.end(), 0.0) > shooting.stop * reference_power / reference_landing)) {
        stats.converged = true;
        break;
      }
    }
    stats.converged = false;
    // Reflectance below one lets shooting only shrink the unshot light, but for what over-relaxation
    // overshoots. It grows where the rays' offset (a 1e-5 part of the scene's size) is not small
    // against the patches: points of a tiny crumpled object far from the rest then see each other
    // with no ray between, and without this stop the solve runs to inf and NaN.
    if (limit == 0) limit = kDiverged * std::max(1.0, stats.residual);
    if (omega == 0) {
      omega = relaxation(shooting, stats.residual);
      if (omega == 0) {
        omega = 1.0;
        measuring = kMeasuredShots;
      }
      stats.relaxation = omega;
    }
    if (!(stats.residual <= limit)) {
      stats.diverged = true;
      stats.warnings.push_back("the solve diverged (unshot light grew to " + std::to_string(stats.residual) +
                               " times the light put in, most of it in " + holders_of() +
                               "): faces that overlap others of the same object in one plane (doubled faces: a point "
                               "in front of them sees both), or objects too small for the scene's size to be ray "
                               "traced apart (the ray offset is 1e-5 of its diagonal)");
      break;
    }
    if (stats.shots - first_shot >= settings.max_shots) {
      stats.warnings.push_back("stopped at the shot limit before converging");
      break;
    }
    if (progress &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last_report).count() > kProgressInterval) {
      last_report = std::chrono::steady_clock::now();
      double done = std::clamp(std::log(stats.residual) / std::log(shooting.stop), 0.0, 1.0);
      if (!progress(done, stats.residual)) cancel_requested = true;
    }
    if (cancel_requested) break;
    // Light that leaves gains nothing from over-relaxation, which sends ahead the light to come back.
    const std::vector<double>& most_first = held.empty() ? power : held;
    int best = int(std::max_element(most_first.begin(), most_first.end()) - most_first.begin());
    double shooting = power[best];
    double landed = 1.0;
    if (!shoot(best, power, held.empty() ? omega : 1.0, landed)) break;
    if (measuring > 0) {
      // Of the light that landed: light leaving the scene says nothing of how much comes back.
      sent += landed * shooting;
      returned += std::accumulate(power.begin(), power.end(), 0.0) - (total - shooting);
      if (landed >= kMeasuredLanding && --measuring == 0)
        omega = stats.relaxation = relaxation_for(returned / sent);
    }
  }
  stats.cancelled = cancel_requested.load();
  stats.settled = stats.residual <= settings.threshold;
  if (progress && !stats.cancelled) progress(1.0, stats.residual);
}

const SolveStats& Solver::Impl::solve(const ProgressCallback& progress) {
  auto start = std::chrono::steady_clock::now();
  // Shooting on leaves the direct light where it is: what the near direct light worked out stands
  // (a settle after updates keeps the read of the last), unless it holds the reflected light too.
  if (!injected || settings.exact_near_reflected) near_direct.reset();
  cancel_requested = false;
  stats.cancelled = false;
  if (!injected) {
    if (!inject()) {
      stats.cancelled = true;
      stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      return stats;
    }
    take_reference();
    if (reference_power == 0 && !mesh.patches.empty())
      stats.warnings.push_back("no light reaches any surface: the scene is black");
  }
  propagate(progress, {settings.threshold, false});
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

dvec3 Solver::Impl::corner_value(int slot, bool near) const {
  if (slot < 0) return dvec3(0.0);
  const Patch& patch = mesh.patches[slot / 4];
  if (!scene.meshes[patch.object].visible) return dvec3(0.0);  // it takes no part: no light, no emission
  int point = patch.point[slot % 4];
  return mesh.emission[slot] +
         mesh.reflectance[slot] * (front[point] + (near ? near_direct_correction(point) : dvec3(0.0)));
}

Solver::Solver(SceneDesc scene, const Settings& settings) {
  std::vector<std::vector<QuadCell>> cells;
  if (settings.light_refinement > 0) cells = Impl::cells_by_light(scene, settings);
  impl_ = std::make_unique<Impl>(std::move(scene), settings, cells);
}
Solver::~Solver() = default;

// Every call that works does so on the Solver's own threads (parallel.h).
const SolveStats& Solver::solve(const ProgressCallback& progress) {
  return *impl_->workers.run([&] {
    impl_->stats.threads = tbb::this_task_arena::max_concurrency();
    return &impl_->solve(progress);
  });
}
void Solver::cancel() { impl_->cancel_requested = true; }
const SolveStats& Solver::update(const ProgressCallback& progress) {
  return *impl_->workers.run([&] {
    impl_->stats.threads = tbb::this_task_arena::max_concurrency();
    return &impl_->update(progress);
  });
}
void Solver::set_threads(int threads) {
  Settings next = impl_->settings;
  next.threads = threads;
  next.validate();
  impl_->settings = next;
  impl_->workers.resize(threads);
}

void Solver::set_transform(int object, const dmat4& transform) {
  Impl& s = *impl_;
  auto [it, added] = s.pending.meshes.try_emplace(object, s.scene.meshes.at(object));
  it->second.transform = transform;
}

void Solver::set_positions(int object, std::vector<dvec3> positions) {
  Impl& s = *impl_;
  const MeshDesc& now = s.scene.meshes.at(object);
  if (positions.size() != now.positions.size())
    throw std::invalid_argument("object '" + now.name + "': " + std::to_string(positions.size()) +
                                " positions for " + std::to_string(now.positions.size()) +
                                " vertices; a change of topology needs a new Solver");
  auto [it, added] = s.pending.meshes.try_emplace(object, s.scene.meshes.at(object));
  it->second.positions = std::move(positions);
}

void Solver::set_visible(int object, bool visible) {
  Impl& s = *impl_;
  auto [it, added] = s.pending.meshes.try_emplace(object, s.scene.meshes.at(object));
  it->second.visible = visible;
}

void Solver::add(const SceneDesc& more) {
  impl_->workers.run([&] { impl_->add(more); });
}

void Solver::set_material(int index, const Material& material) {
  impl_->scene.materials.at(index);
  impl_->pending.materials[index] = material;
}

void Solver::set_lamp(int index, const Lamp& lamp) {
  if (impl_->scene.lamps.at(index).type != lamp.type)
    throw std::invalid_argument("lamp " + std::to_string(index) + " cannot change its type");
  impl_->pending.lamps[index] = lamp;
}

void Solver::set_world(const dvec3& radiance) { impl_->pending.world = WorldMap::uniform(radiance); }
void Solver::set_world_map(WorldMap sky) { impl_->pending.world = std::move(sky); }
const SolveStats& Solver::stats() const { return impl_->stats; }

void Solver::record_rays(int stride) { impl_->vis->record(stride); }
double Solver::replay_recorded_rays() const {
  return impl_->workers.run([&] { return impl_->vis->replay_recorded(); });
}

PowerBalance Solver::power_balance() const {
  const Impl& s = *impl_;
  PowerBalance b;
  b.injected = s.injected_power;
  // A mirror passes on its colour of what lands on it, to land again where its images light.
  std::vector<dvec3> mirrored(s.mesh.patches.size(), dvec3(0.0));
  for (const auto& plane : s.mirrors)
    for (int p : plane->patches()) mirrored[p] = plane->reflectance();
  for (size_t p = 0; p < s.mesh.patches.size(); ++p) {
    const Patch& patch = s.mesh.patches[p];
    // What passes through the patch. Glass passes less at grazing angles than head on, which is
    // what it is counted at here: for glass, the balance is approximate.
    dvec3 passes(0.0);
    if (!s.mesh.transmission.empty()) {
      std::array<float, 3> t = s.mesh.transmission[p].at(1.0);
      passes = dvec3(t[0], t[1], t[2]);
    }
    passes += mirrored[p];
    for (int c = 0; c < 4; ++c) {
      int pt = patch.point[c];
      dvec3 absorb = dvec3(1.0) - s.mesh.reflectance[4 * p + c] - passes;
      b.unshot += 0.25 * patch.area * channel_sum(s.unshot[p][c * 2] + s.unshot[p][c * 2 + 1]);
      b.absorbed += 0.25 * patch.area * channel_sum(absorb * (s.front[pt] + s.back[pt]));
      dvec3 direct = s.front[pt] - s.reflected_front[pt] + s.back[pt] - s.reflected_back[pt];
      b.transmitted += 0.25 * patch.area * channel_sum(passes * direct);
    }
  }
  return b;
}

std::vector<float> Solver::corner_radiance(int object, bool exact_near_direct) const {
  const ObjectPatches& obj = impl_->mesh.objects.at(object);
  if (exact_near_direct) {
    std::vector<int> points;
    for (int slot : obj.corner_slot)
      if (slot >= 0) points.push_back(impl_->mesh.patches[slot / 4].point[slot % 4]);
    impl_->workers.run([&] { impl_->prepare_near_direct(points); });
  }
  std::vector<float> out(3 * obj.corner_slot.size());
  for (size_t i = 0; i < obj.corner_slot.size(); ++i) {
    dvec3 b = glm::max(impl_->corner_value(obj.corner_slot[i], exact_near_direct), dvec3(0.0));  // round-off negatives
    for (int k = 0; k < 3; ++k) out[3 * i + k] = float(b[k]);
  }
  return out;
}

std::vector<float> Solver::vertex_radiance(int object) const {
  const MeshDesc& mesh = impl_->scene.meshes.at(object);
  std::vector<float> corners = corner_radiance(object);
  std::vector<double> sum(3 * mesh.positions.size(), 0.0);
  std::vector<int> count(mesh.positions.size(), 0);
  for (size_t i = 0; i < mesh.face_vertices.size(); ++i) {
    int v = mesh.face_vertices[i];
    for (int k = 0; k < 3; ++k) sum[3 * v + k] += corners[3 * i + k];
    ++count[v];
  }
  std::vector<float> out(sum.size(), 0.0f);
  for (size_t v = 0; v < count.size(); ++v)
    if (count[v] > 0)
      for (int k = 0; k < 3; ++k) out[3 * v + k] = float(sum[3 * v + k] / count[v]);
  return out;
}

Solver::Refined Solver::refined(int object) const {
  const Impl& s = *impl_;
  const ObjectPatches& obj = s.mesh.objects.at(object);
  Refined r;
  for (int p = obj.patch_begin; p < obj.patch_end; ++p)
    for (int c = 0; c < 4; ++c) {
      dvec3 pos = s.mesh.vertices[s.mesh.patches[p].vertex[c]] + s.mesh.origin;
      dvec3 b = glm::max(s.corner_value(p * 4 + c, false), dvec3(0.0));
      for (int k = 0; k < 3; ++k) r.positions.push_back(pos[k]), r.radiance.push_back(float(b[k]));
    }
  return r;
}

}  // namespace radiosity
