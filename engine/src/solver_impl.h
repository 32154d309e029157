// The solver's state, shared by the shooting loop (solver.cpp) and incremental updates
// (dynamic_update.cpp).
//
// Invariant: front/back hold, per receiving point, everything gathered so far: the direct light of
// the current lamps, world and emitters, plus every shooter's `shot` radiance (the total it has sent)
// through the current geometry; reflected_front/back the part of it the shooters' radiance brought.
// `unshot` is what patches reflected and have not sent yet: a patch corner reflects rho times its
// point's direct light plus `onward` (PatchMesh) times its reflected light. An update restores the
// invariant for the changed scene with a few signed gathers; shooting then goes on.
#pragma once

#include "radiosity/solver.h"

#include "changed_rays.h"
#include "cluster_tree.h"
#include "db_cache.h"
#include "mirror.h"
#include "patch_mesh.h"
#include "occlusion_batch.h"
#include "parallel.h"
#include "shot.h"
#include "source.h"
#include "visibility.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

namespace radiosity {

constexpr int kParallelMinimum = 256;  // receiving points worth a second thread

inline double channel_sum(const dvec3& v) { return v.x + v.y + v.z; }

struct NearDetail;  // near_direct.cpp

struct Solver::Impl {
  Workers workers;  // first: what the others build, they build on its threads
  SceneDesc scene;
  Settings settings;
  PatchMesh mesh;
  ClusterTree tree;
  std::unique_ptr<Visibility> vis;
  std::vector<int> shooters;       // cluster nodes
  std::vector<int> patch_shooter;  // patch -> index in shooters
  void cut_shooters();             // both, from the tree as it is
  // The per-point and per-patch state grown to the mesh (new entries empty, the points of objects
  // from `first_object` on hidden as their objects are) and the shooters cut again: on construction
  // and after add().
  void fit_to_mesh(int first_object);
  mutable ShotCache shot_cache;  // filled as shots are built
  ShotScene shot_scene() const { return {mesh, tree, vis.get(), &shot_cache}; }
  DbCache db_cache;              // per moved object (dynamic_update.cpp)
  // The planar mirrors of the scene as the last injection found them (find_mirrors): each source
  // of light is also seen as its image in each (add_images).
  MirrorPlanes mirrors;
  // Appends the sources' images in `planes` (null: in every mirror).
  void add_images(std::vector<Source>& sources, const MirrorPlanes* planes = nullptr) const;
  // The mirror planes of the visible objects `only` marks (null: all); those of them that are
  // curved mirrors reflect their sharp lobe diffusely from now on (curved_mirror), with a warning.
  MirrorPlanes find_planes(const std::vector<char>* only = nullptr);
  std::vector<char> curved_mirror;  // per object, as find_planes last found it
  bool curved(int object) const { return object < int(curved_mirror.size()) && curved_mirror[object]; }
  // Sets patch p's reflectance (each corner's) to `rho`: its patches reflect the difference of what
  // their points hold (of their reflected light, `onward` times it) as more unshot light.
  void change_reflectance(int p, const dvec3& rho);

  std::vector<dvec3> front, back;      // accumulated H per point and side
  std::vector<dvec3> reflected_front, reflected_back;  // the part of it reflected light brought
  std::vector<CornerUnshot> unshot;    // per patch
  std::vector<CornerUnshot> shot;      // per patch: all it has sent so far
  std::vector<dvec3> delta_front, delta_back;  // a gather in flight, discarded if cancelled
  std::vector<dvec3> spare_front, spare_back;  // all zero by the next gather (gather_all)
  std::vector<char> hidden_point;  // per point: its object is hidden, and it gathers nothing
  void mark_hidden(int object);    // hidden_point from the object's visibility
  bool injected = false;
  double injected_power = 0.0;
  // The residual's scale: the unshot power right after injection that lands on patches when shot
  // (each patch side's part times its `landing`), kept so as the shares are measured.
  double reference_power = 0.0;
  // Per patch and side (front, back): the share of the light it sends that lands on patches, as
  // its shooter's last shot measured it (measure_landing); 1 until then. Unshot light weighs by it
  // (landing_power): light that leaves the scene brings nothing back, and left unshot it is no error.
  std::vector<std::array<double, 2>> landing;
  // Per patch and side: its part of the unshot power right after injection; `reference_landing` the
  // sum of these parts times `landing`, by which reference_power stands to that unshot power.
  std::vector<std::array<double, 2>> reference_part;
  double reference_landing = 1.0;
  void take_reference();  // reference_power and its parts from the unshot light just injected
  // Weighs shooter `s`'s patches by the share of `sent` (per side, signed; `magnitude` unsigned)
  // that landed in the gather just absorbed, and reference_power with them. Returns the share of
  // all it sent that landed (0 where its light is of both signs).
  double measure_landing(int s, const std::array<double, 2>& sent, const std::array<double, 2>& magnitude);
  double landing_power(int patch) const;  // its unshot power, each side times its landing share
  std::atomic<bool> cancel_requested{false};
  SolveStats stats;

  // Changes waiting for update().
  struct Pending {
    std::map<int, MeshDesc> meshes;
    std::map<int, Material> materials;
    std::map<int, Lamp> lamps;
    std::optional<WorldMap> world;
  } pending;

  // `cells`: per mesh, the light's splits of its refined quads (light_refinement.h); empty: none.
  Impl(SceneDesc s, const Settings& st, const std::vector<std::vector<QuadCell>>& cells = {});
  // light_refinement.cpp: refinement driven by the light, which splits patches where the light
  // across them changes (a shadow's edge, a lamp or emitter seen in part), not where it is flat.
  // Per mesh of `scene`, the cells its refined quads split into (ObjectPatches::cells). Each round
  // solves on the patches so far to a loose threshold (the marks need the light's shape, not its
  // last bounce), splits in four the patches light_marks marks, and stops after
  // Settings::light_refinement rounds, when none is marked, or before passing Settings::max_patches.
  // Empty when no patch was split.
  static std::vector<std::vector<QuadCell>> cells_by_light(const SceneDesc& scene, const Settings& settings);
  // Per patch, whether the light across it changes by more than `contrast` of its brightest
  // (Settings::light_contrast), from the solution so far.
  std::vector<char> light_marks(double contrast) const;

  const Material& material(int patch) const { return scene.materials[mesh.patches[patch].material]; }

  // Gathers into delta_* for every receiving point `wanted(i)` accepts, on the workers' threads, in
  // `batch_for` batches (one per thread). False if cancelled part-way (only when `cancellable`). Once
  // all have gathered, and only if none was passed over, runs `then`.
  struct Nothing {
    void operator()() const {}
  };
  template <class Wanted, class MakeBatch, class Gather, class Then = Nothing>
  bool gather_all(Wanted&& wanted, MakeBatch&& batch_for, Gather&& gather_one, bool cancellable = true,
                  Then&& then = {});
  template <class Gather>
  bool gather_all(Gather&& gather_one) {
    return gather_all([](int) { return true; }, [this] { return delta_batch(); }, gather_one);
  }
  // A batch adding into delta_*.
  OcclusionBatch delta_batch() { return OcclusionBatch(*vis, delta_front.data(), delta_back.data()); }
  // One adding only what the last move of an object changed.
  OcclusionBatch changed_batch(const ChangedRays& changed) {
    return OcclusionBatch(*vis, delta_front.data(), delta_back.data(), changed);
  }
  // Adds the gathered delta, of one kind of light, to the solution and, reflected, to the unshot
  // radiance.
  enum class Light { direct, reflected };
  void apply_delta(Light light);
  // apply_delta(), after shooter `sent` (if any) moves `omega` times its unshot radiance to what it
  // has shot. Leaves each patch's share of shooter_power() in patch_power, and where the shooter's
  // light landed in landed_sides, read in the same pass.
  void absorb_delta(int sent, double omega, Light light);
  std::vector<double> patch_power;
  std::array<double, 2> landed_sides{0.0, 0.0};  // per side of the shooter (measure_landing)
  std::vector<double> summed_power() const;  // shooter_power() from patch_power
  double landed_power() const;  // of the gathered delta, radiance x area over both sides
  void apply_direct_delta();    // apply_delta() of direct light, for a change of it: the residual's scale follows
  void add_direct_power(double change);  // the residual's scale follows the direct light that lands

  // Sources of a gather, `scale` times their strength: everything, or only the shooters `only`
  // marks (one flag per shooter); and their images in `planes` (null: every mirror).
  // Direct: lamps and the world (not with `only`) and emitting patches, at samples_direct.
  std::vector<Source> direct_sources(double scale = 1.0, const std::vector<char>* only = nullptr,
                                     const MirrorPlanes* planes = nullptr) const;
  // Reflected: what each shooter has sent so far (`shot`), through the geometry as it is now.
  std::vector<Source> reflected_sources(double scale = 1.0, const std::vector<char>* only = nullptr,
                                        const MirrorPlanes* planes = nullptr) const;
  // Shots of per-patch radiance `radiance` (emitted, or `reflected`) from the shooters where it is not
  // zero; a distant receiver takes `far_samples` of each (cluster_shot).
  std::vector<Source> patch_sources(const std::vector<CornerUnshot>& radiance, bool reflected, int samples,
                                    double scale, const std::vector<char>* only, int far_samples = INT32_MAX) const;

  bool inject();
  std::vector<double> shooter_power() const;  // per shooter, the landing_power() of its patches
  std::vector<double> held_power() const;     // per shooter, its patches' unshot power, landing or not
  // Their sum, in shooter order as propagate() sums it: the residual's numerator, to the last bit.
  double total_unshot_power() const;
  // Distant receivers' samples for a shot of shooter power `power`: fewer for less light.
  int far_samples(double power) const;
  // What propagate() shoots: down to which residual, and whether it is an update's signed light.
  struct Shooting {
    double stop;
    bool update;
  };
  // The omega shots send their unshot light with, when shooting starts from `residual`; 0: to be
  // measured (propagate).
  double relaxation(const Shooting& shooting, double residual) const;
  // power: shooter_power() after the shot; landed: the share of what it sent that landed
  bool shoot(int s, std::vector<double>& power, double omega, double& landed);
  void propagate(const ProgressCallback& progress, const Shooting& shooting);  // until the residual is below its stop
  std::string holders_of() const;  // the objects holding most of the unshot light
  const SolveStats& solve(const ProgressCallback& progress);

  // dynamic_update.cpp
  const SolveStats& update(const ProgressCallback& progress);
  void add(const SceneDesc& more);  // Solver::add
  void restart();  // forgets all light gathered and shot: the next solve() starts from the lamps
  void gather_direct_change(std::vector<Source> sources);  // and their images, everywhere, then applied
  void change_world(const WorldMap& world);
  void change_lamp(int index, const Lamp& lamp);
  bool scale_sole_lamp(int index, const Lamp& lamp);  // change_lamp's exact shortcut; false if it does not hold
  void change_material(int index, const Material& material);
  void take_material(int index, const Material& material);  // the scene's and its patches', no light
  // Moves, deforms, shows or hides the objects of `meshes` (as they are to be) together, each to
  // its refined geometry in `placed`. Returns where each was and is, in their order.
  std::vector<Zone> change_objects(const std::map<int, MeshDesc>& meshes, std::map<int, PlacedObject>& placed);
  // change_objects' steps, in their order, on what they share.
  struct ObjectsChange;
  void begin_change(ObjectsChange& change);         // the shooters near where the objects were and will be
  void take_back_sent(ObjectsChange& change);       // what their shooters sent, from everywhere else
  void keep_sources_before(ObjectsChange& change);  // every other source as it shoots before the move
  void move(ObjectsChange& change);                 // their geometry and mirrors, and the shots' caches near it
  void send_again(ObjectsChange& change);           // their shooters' light and the near ones' change
  // Everything but their shooters, by way of their mirrors (before the move, after it): `sign` 1 to
  // send, -1 to take back.
  void send_by_their_mirrors(const ObjectsChange& change, const MirrorPlanes& planes, double sign);
  void gather_changed_rays(ObjectsChange& change);  // the rest: only the rays the move changed
  void gather_on_objects(ObjectsChange& change);    // their own points: all their light anew
  bool shoots_from(const ObjectsChange& change, int node) const;  // the cluster node's patches are theirs
  void flag_shooters(ObjectsChange& change) const;  // `own` and `near` for the cut as it is
  void emit_own(const ObjectsChange& change, double sign);  // their emission, elsewhere
  double direct_on_own(const ObjectsChange& change);        // gathered on their points; landed_power
  std::vector<char> touched;  // per point: its light was recomputed by this update
  void place(int object, const MeshDesc& mesh, const PlacedObject& placed);  // geometry only
  void forget_nodes(int node);  // the cached views of itself of the subtree from `node`

  // Outgoing front radiance at a patch corner; with `near`, with near_direct_correction.
  dvec3 corner_value(int slot, bool near) const;
  // near_direct.cpp: what a reported point's front side gains from the direct light its near
  // surroundings reflect, evaluated where it lands; worked out on first use after a solve or update.
  struct NearDirect;
  mutable std::shared_ptr<NearDirect> near_direct;  // shared_ptr: NearDirect is complete only there
  dvec3 near_direct_correction(int point) const;
  void prepare_near_direct(const std::vector<int>& points) const;  // for many points, on all cores
  const NearDetail* near_detail(int patch) const;  // null if it needs none
  std::array<dvec3, 2> direct_at(const dvec3& y, const dvec3& normal) const;  // H per side
  // H per side at y from `sources` (a point that is no receiving point's).
  std::array<dvec3, 2> light_at(const std::vector<Source>& sources, const dvec3& y, const dvec3& normal) const;
  std::array<dvec3, 2> direct_now(int point) const;  // the solver's direct H at a point, per side
  // After an update that moved, deformed, showed or hid `objects` (in `zones`) and changed no light:
  // keeps what near_direct worked out where it still holds, forgets the rest.
  void keep_near_direct(const std::vector<int>& objects, const std::vector<Zone>& zones);
};

template <class Wanted, class MakeBatch, class Gather, class Then>
bool Solver::Impl::gather_all(Wanted&& wanted, MakeBatch&& batch_for, Gather&& gather_one, bool cancellable,
                              Then&& then) {
  int count = int(mesh.points.size());
  // The last gather's delta is dead from here on: it becomes the spare, cleared while this one runs.
  std::swap(delta_front, spare_front);
  std::swap(delta_back, spare_back);
  if (delta_front.size() != size_t(count)) {
    delta_front.assign(count, dvec3(0.0));
    delta_back.assign(count, dvec3(0.0));
  }
  auto cancelled = [&] { return cancellable && cancel_requested.load(std::memory_order_relaxed); };
  std::atomic<int> passed_over{0};  // receivers left out on cancelling
  // A batch a thread, made when the thread first takes part.
  tbb::enumerable_thread_specific<OcclusionBatch> batches(batch_for);
  auto gather_range = [&](int begin, int end) {
    OcclusionBatch& batch = batches.local();
    for (int i = begin; i < end; ++i) {
      if (cancelled()) {
        passed_over.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      const ReceiverPoint& p = mesh.points[i];
      if (p.normal == dvec3(0.0) || hidden_point[i] || !wanted(i)) continue;
      gather_one(i, p, batch);
    }
  };
  // Small scenes stay on one thread: sharing a few hundred points costs more than it saves.
  if (count > kParallelMinimum)
    tbb::parallel_for(tbb::blocked_range<int>(0, count, 4),
                      [&](const tbb::blocked_range<int>& r) { gather_range(r.begin(), r.end()); });
  else
    gather_range(0, count);
  // Each batch adds only into the receivers it gathered for: they flush side by side, and the dead
  // spare is cleared beside them.
  int spare = int(spare_front.size());
  std::vector<OcclusionBatch*> pending;
  for (OcclusionBatch& b : batches) pending.push_back(&b);
  int flushes = int(pending.size());
  parallel_for(0, flushes + (spare + 4095) / 4096, 1, [&](int k) {
    if (k < flushes) return pending[k]->flush();
    for (int i = (k - flushes) * 4096, end = std::min(spare, i + 4096); i < end; ++i)
      spare_front[i] = spare_back[i] = dvec3(0.0);
  });
  long long rays = 0;
  for (OcclusionBatch* b : pending) {
    rays += b->rays_traced();
    stats.mirror_rays += b->mirror_rays();
    if (const Crossings* c = b->crossings())
      stats.pane_crossings += c->hits(), stats.rays_through_panes += c->rays_crossing();
  }
  if constexpr (!std::is_same_v<std::decay_t<Then>, Nothing>)
    if (passed_over.load(std::memory_order_relaxed) == 0) then();
  stats.rays += rays;
  return passed_over.load() == 0;
}

}  // namespace radiosity
