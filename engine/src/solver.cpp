#include "radiosity/solver.h"

#include "cluster_tree.h"
#include "lights.h"
#include "patch_mesh.h"
#include "shot.h"
#include "visibility.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

namespace radiosity {

namespace {

double channel_sum(const dvec3& v) { return v.x + v.y + v.z; }
double abs_sum(const dvec3& v) { return std::fabs(v.x) + std::fabs(v.y) + std::fabs(v.z); }
constexpr double kProgressInterval = 0.05;  // seconds between progress callbacks
constexpr int kParallelMinimum = 256;       // receiving points worth a second thread

}  // namespace

struct Solver::Impl {
  SceneDesc scene;
  Settings settings;
  PatchMesh mesh;
  ClusterTree tree;
  std::unique_ptr<Visibility> vis;
  std::vector<int> shooters;       // cluster nodes
  std::vector<int> patch_shooter;  // patch -> index in shooters
  std::vector<char> emits;         // shooter holds emitting patches
  ShotCache shot_cache;

  std::vector<dvec3> front, back;      // accumulated H per point and side
  std::vector<CornerUnshot> unshot;    // per patch
  std::vector<dvec3> delta_front, delta_back;  // the shot in flight, discarded if cancelled
  bool injected = false;
  double injected_power = 0.0;
  double reference_power = 0.0;  // unshot power right after injection: the residual's scale
  std::atomic<bool> cancel_requested{false};
  SolveStats stats;

  Impl(SceneDesc s, const Settings& st) : scene(std::move(s)), settings(st) {
    scene.validate();
    mesh = build_patch_mesh(scene, settings);
    tree = ClusterTree::build(mesh);
    std::vector<bool> dynamic;
    for (const MeshDesc& m : scene.meshes) dynamic.push_back(m.dynamic);
    vis = std::make_unique<Visibility>(mesh, dynamic);

    shooters = tree.cut(settings.shooter_size_relative * mesh.diagonal);
    patch_shooter.assign(mesh.patches.size(), -1);
    emits.assign(shooters.size(), 0);
    for (size_t s = 0; s < shooters.size(); ++s) {
      const ClusterNode& n = tree.nodes[shooters[s]];
      for (int i = n.begin; i < n.end; ++i) {
        int p = tree.order[i];
        patch_shooter[p] = int(s);
        if (mesh.patches[p].area > 0 && channel_sum(material(p).emission) > 0) emits[s] = 1;
      }
    }
    front.assign(mesh.points.size(), dvec3(0.0));
    back.assign(mesh.points.size(), dvec3(0.0));
    CornerUnshot none;
    none.fill(dvec3(0.0));
    unshot.assign(mesh.patches.size(), none);

    stats.patches = int(mesh.patches.size());
    stats.points = int(mesh.points.size());
    stats.shooters = int(shooters.size());
    if (mesh.patches.empty()) stats.warnings.push_back("the scene has no geometry: nothing to light");
    if (mesh.degenerate_patches > 0)
      stats.warnings.push_back(std::to_string(mesh.degenerate_patches) +
                               " degenerate (zero-area) patches were left out");
  }

  const Material& material(int patch) const { return scene.materials[mesh.patches[patch].material]; }

  // Gathers into delta_* for every receiving point; false if cancelled part-way.
  template <class Gather>
  bool gather_all(Gather&& gather_one) {
    delta_front.assign(mesh.points.size(), dvec3(0.0));
    delta_back.assign(mesh.points.size(), dvec3(0.0));
    long long rays = 0;
    int count = int(mesh.points.size());
    // Small scenes stay on one thread: thousands of tiny parallel regions lose to spinning barriers,
    // badly so when Blender or another process holds the other cores.
#pragma omp parallel reduction(+ : rays) if (count > kParallelMinimum)
    {
      OcclusionBatch batch(*vis, delta_front.data(), delta_back.data());
#pragma omp for schedule(dynamic, 32)
      for (int i = 0; i < count; ++i) {
        if (cancel_requested.load(std::memory_order_relaxed)) continue;
        const ReceiverPoint& p = mesh.points[i];
        if (p.normal == dvec3(0.0)) continue;
        gather_one(i, p, batch);
      }
      batch.flush();
      rays += batch.rays_traced();
    }
    stats.rays += rays;
    return !cancel_requested.load();
  }

  // Adds the gathered shot to the solution and to the unshot radiance of the receiving patches.
  void apply_delta() {
    int points = int(mesh.points.size());
#pragma omp parallel for schedule(static) if (points > 16 * kParallelMinimum)
    for (int i = 0; i < points; ++i) {
      front[i] += delta_front[i];
      back[i] += delta_back[i];
    }
    int patches = int(mesh.patches.size());
#pragma omp parallel for schedule(static) if (patches > 16 * kParallelMinimum)
    for (int p = 0; p < patches; ++p) {
      const Patch& patch = mesh.patches[p];
      if (patch.area == 0) continue;
      const dvec3& rho = material(p).reflectance;
      for (int c = 0; c < 4; ++c) {
        unshot[p][c * 2 + 0] += rho * delta_front[patch.point[c]];
        unshot[p][c * 2 + 1] += rho * delta_back[patch.point[c]];
      }
    }
  }

  // Direct light at full sample density: lamps, area lamps, the world and emitting surfaces. What
  // lands becomes unshot radiance. Emission itself is never unshot: every emitter's uniform
  // radiance goes through the same dense shot, and only reflected light is shot coarser, so a
  // furnace still has the uniform solution.
  bool inject() {
    std::vector<Lamp> lamps = scene.lamps;
    for (Lamp& l : lamps) l.position -= mesh.origin;
    std::vector<Shot> shots;
    for (const Lamp& l : lamps)
      if (l.type == Lamp::Type::Rect || l.type == Lamp::Type::Disc)
        shots.push_back(area_lamp_shot(l, settings.samples_direct, settings.near_factor));
    std::vector<CornerUnshot> emission(mesh.patches.size());
    for (size_t p = 0; p < mesh.patches.size(); ++p) emission[p].fill(material(int(p)).emission);
    for (size_t s = 0; s < shooters.size(); ++s)
      if (emits[s])
        shots.push_back(cluster_shot(mesh, tree, vis.get(), &shot_cache, shooters[s], emission, settings.samples_direct, 1.0,
                                     settings.near_factor));
    bool world = channel_sum(scene.world) > 0;
    bool complete = gather_all([&](int i, const ReceiverPoint& p, OcclusionBatch& batch) {
      for (const Lamp& l : lamps)
        if (l.type != Lamp::Type::Rect && l.type != Lamp::Type::Disc)
          gather_lamp(l, settings.samples_direct, i, p, batch);
      for (const Shot& s : shots) gather(s, i, p, batch);
      if (world) gather_world(scene.world, settings.samples_direct, i, p, batch);
    });
    if (!complete) return false;
    for (const Patch& patch : mesh.patches)
      for (int c = 0; c < 4; ++c)
        injected_power += 0.25 * patch.area * channel_sum(delta_front[patch.point[c]] + delta_back[patch.point[c]]);
    apply_delta();
    ++stats.shots;
    injected = true;
    return true;
  }

  std::vector<double> shooter_power() const {
    std::vector<double> power(shooters.size(), 0.0);
    for (size_t p = 0; p < mesh.patches.size(); ++p) {
      double sum = 0.0;
      for (const dvec3& u : unshot[p]) sum += abs_sum(u);
      power[patch_shooter[p]] += 0.25 * mesh.patches[p].area * sum;
    }
    return power;
  }

  bool shoot(int s) {
    double omega = settings.relaxation;
    Shot shot = cluster_shot(mesh, tree, vis.get(), &shot_cache, shooters[s], unshot, settings.samples_indirect, omega,
                             settings.near_factor);
    if (!gather_all([&](int i, const ReceiverPoint& p, OcclusionBatch& batch) { gather(shot, i, p, batch); }))
      return false;
    const ClusterNode& n = tree.nodes[shooters[s]];
    for (int i = n.begin; i < n.end; ++i)
      for (dvec3& u : unshot[tree.order[i]]) u *= 1.0 - omega;  // over-relaxation leaves it negative
    apply_delta();
    ++stats.shots;
    return true;
  }

  const SolveStats& solve(const ProgressCallback& progress) {
    auto start = std::chrono::steady_clock::now();
    auto last_report = start;
    cancel_requested = false;
    stats.cancelled = false;
    auto elapsed = [&](auto since) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
    };
    auto finish = [&]() -> const SolveStats& {
      stats.seconds = elapsed(start);
      return stats;
    };
    if (!injected) {
      if (!inject()) {
        stats.cancelled = true;
        return finish();
      }
      for (double p : shooter_power()) reference_power += p;
      if (reference_power == 0 && !mesh.patches.empty())
        stats.warnings.push_back("no light reaches any surface: the scene is black");
    }
    for (;;) {
      std::vector<double> power = shooter_power();
      double total = 0.0;
      for (double p : power) total += p;
      stats.residual = reference_power > 0 ? total / reference_power : 0.0;
      if (stats.residual <= settings.threshold) {
        stats.converged = true;
        break;
      }
      if (stats.shots >= settings.max_shots) {
        stats.warnings.push_back("stopped at the shot limit before converging");
        break;
      }
      if (progress && elapsed(last_report) > kProgressInterval) {
        last_report = std::chrono::steady_clock::now();
        double done = std::clamp(std::log(stats.residual) / std::log(settings.threshold), 0.0, 1.0);
        if (!progress(done, stats.residual)) cancel_requested = true;
      }
      if (cancel_requested) break;
      int best = int(std::max_element(power.begin(), power.end()) - power.begin());
      if (!shoot(best)) break;
    }
    stats.cancelled = cancel_requested.load();
    if (progress && !stats.cancelled) progress(1.0, stats.residual);
    return finish();
  }

  dvec3 corner_value(int slot) const {
    if (slot < 0) return dvec3(0.0);
    const Patch& patch = mesh.patches[slot / 4];
    const Material& m = scene.materials[patch.material];
    return m.emission + m.reflectance * front[patch.point[slot % 4]];
  }
};

Solver::Solver(SceneDesc scene, const Settings& settings)
    : impl_(std::make_unique<Impl>(std::move(scene), settings)) {}
Solver::~Solver() = default;

const SolveStats& Solver::solve(const ProgressCallback& progress) { return impl_->solve(progress); }
void Solver::cancel() { impl_->cancel_requested = true; }
const SolveStats& Solver::stats() const { return impl_->stats; }

void Solver::record_rays(int stride) { impl_->vis->record(stride); }
double Solver::replay_recorded_rays() const { return impl_->vis->replay_recorded(); }

PowerBalance Solver::power_balance() const {
  const Impl& s = *impl_;
  PowerBalance b;
  b.injected = s.injected_power;
  for (size_t p = 0; p < s.mesh.patches.size(); ++p) {
    const Patch& patch = s.mesh.patches[p];
    dvec3 absorb = dvec3(1.0) - s.material(int(p)).reflectance;
    for (int c = 0; c < 4; ++c) {
      int pt = patch.point[c];
      b.unshot += 0.25 * patch.area * channel_sum(s.unshot[p][c * 2] + s.unshot[p][c * 2 + 1]);
      b.absorbed += 0.25 * patch.area * channel_sum(absorb * (s.front[pt] + s.back[pt]));
    }
  }
  return b;
}

std::vector<float> Solver::corner_radiance(int object) const {
  const ObjectPatches& obj = impl_->mesh.objects.at(object);
  std::vector<float> out(3 * obj.corner_slot.size());
  for (size_t i = 0; i < obj.corner_slot.size(); ++i) {
    dvec3 b = glm::max(impl_->corner_value(obj.corner_slot[i]), dvec3(0.0));  // round-off negatives
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
      dvec3 b = glm::max(s.corner_value(p * 4 + c), dvec3(0.0));
      for (int k = 0; k < 3; ++k) r.positions.push_back(pos[k]), r.radiance.push_back(float(b[k]));
    }
  return r;
}

}  // namespace radiosity
