// The radiosity solver: progressive refinement (shooting) on bilinear patches with the unknowns at
// patch vertices.
#pragma once

#include "radiosity/scene.h"
#include "radiosity/settings.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace radiosity {

struct SolveStats {
  double seconds = 0.0;      // wall time of the last solve() call
  double residual = 1.0;     // unshot power / injected power: tracks the error, the convergence measure
  long shots = 0;            // shots so far (lamps count as one)
  long long rays = 0;        // visibility rays so far
  // Of those, hits on panes they went on through (Crossings::hits) and rays that crossed a pane:
  // what light through glass costs, which a scene without panes never counts.
  long long pane_crossings = 0, rays_through_panes = 0;
  // Of those, the legs of paths by way of a mirror: what mirrors cost, never counted without one.
  long long mirror_rays = 0;
  int patches = 0, points = 0, shooters = 0;
  // The patches uniform refinement would make down to the smallest the light may split them to
  // (Settings::light_refinement): patches' counterpart.
  long long uniform_patches = 0;
  int threads = 0;           // the last solve() or update() worked on (Settings::threads)
  double relaxation = 1.0;   // the over-relaxation the last shots took (Settings::relaxation 0: chosen)
  long long touched_points = 0;  // last update(): receiving points whose light was recomputed
  // Last update(): the residual its signed gathers left for shooting on, and the seconds that
  // shooting took. However cheap the gathers, an update that shoots that light back to the same
  // threshold with the same shots takes that long: it bounds full / update (bench/dynamic_update.py).
  double shoot_residual = 0.0, shoot_seconds = 0.0;
  // Last update(): rays a move changed whose whole-scene trace the dB cache spared (hits) or that
  // were traced (misses); what it holds after it (Settings::db_cache_mb).
  long long db_hits = 0, db_misses = 0;
  long long db_entries = 0, db_bytes = 0;
  bool converged = false;    // shot down to where it stops: `threshold` (a solve), or an update's own stop
  bool settled = false;      // the residual is below `threshold`: as a fresh solve leaves it
  // Last update(): why it solved the scene afresh instead ("the change left 4% of the light (under
  // 10%)"), or empty.
  std::string restart;
  bool cancelled = false;
  bool diverged = false;     // the unshot light grew tenfold: the scene is beyond what the engine
                             // resolves (a warning says why); the solve stopped there
  std::vector<std::string> warnings;  // e.g. no light, degenerate faces dropped
};

// Injected = unshot + absorbed + transmitted + escaped, in power units of radiance x area (both
// sides and RGB summed). `injected` is the direct light (lamps, world, emitting surfaces) that
// landed on surfaces; `transmitted` the part of it that passed on through the surfaces it landed on,
// to land again behind them (counted there in `injected` too) or to escape. Surfaces absorb what
// they neither reflect nor let through.
struct PowerBalance {
  double injected = 0.0, unshot = 0.0, absorbed = 0.0, transmitted = 0.0;
};

// Called before the first shot and between shots (50 ms apart or more) with (progress in [0, 1],
// residual); returning false cancels the solve.
using ProgressCallback = std::function<bool(double, double)>;

class Solver {
 public:
  // Validates the scene (std::invalid_argument on bad input), refines it and builds the BVH.
  Solver(SceneDesc scene, const Settings& settings);
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  // Shoots until the residual is below the threshold; may be called again to continue after a
  // cancel, or to settle after updates (which stop sooner: Settings::update_threshold). A cancelled
  // solve stops at the last complete shot: the state stays consistent.
  const SolveStats& solve(const ProgressCallback& progress = {});
  void cancel();  // thread-safe: the running solve stops soon after
  void set_threads(int threads);  // Settings::threads for the calls from now on; not while one runs

  // Scene changes, applied by the next update(). Indices are the SceneDesc's. An object keeps its
  // patches: a new transform or new positions must refine to the same topology (else
  // std::invalid_argument from update()). An object appears or vanishes with set_visible (one that
  // was not in the SceneDesc comes with add()); a hidden one may move, and appears where it is.
  void set_transform(int object, const dmat4& transform);
  void set_positions(int object, std::vector<dvec3> positions);
  void set_visible(int object, bool visible);
  // Adds what `more` holds: its materials after the solver's (its meshes' face_materials index the
  // list so extended), its meshes as the next objects and its lamps as the next lamps (its world is
  // not used). They come into the light at the next update(), as hidden objects that appear and
  // lamps that light up do: incrementally. Refused whole (std::invalid_argument) on bad input, or a
  // mesh reaching farther from the scene's centre than the scene is across: ray offsets and patch
  // sizes scale with the scene the Solver was made for, and it needs a new Solver.
  void add(const SceneDesc& more);
  void set_material(int index, const Material& material);
  void set_lamp(int index, const Lamp& lamp);  // same type as before
  void set_world(const dvec3& radiance);
  void set_world_map(WorldMap sky);
  // Incremental update (the paper's negative and positive shooting): changes only what the pending
  // changes affect, then shoots until the residual is below its own stop (Settings::update_threshold),
  // what it leaves for the next update or solve() to shoot. Before
  // the first solve() it just applies the changes. Cancelling stops the shooting, not the update.
  const SolveStats& update(const ProgressCallback& progress = {});
  const SolveStats& stats() const;
  PowerBalance power_balance() const;

  // Benchmark hooks: keep every `stride`-th batch of visibility rays of later solves, and trace
  // the kept rays again through bare Embree, returning its rays per second.
  void record_rays(int stride);
  double replay_recorded_rays() const;

  // Outgoing radiance on the front side at each input face corner / vertex (mean of its corners);
  // zero on a hidden object. With Settings::exact_near_direct, the direct light of the surfaces
  // right around each corner is evaluated where it lands (near_direct.cpp), on first read after a
  // solve or update, unless `exact_near_direct` is false: then it is interpolated, as without the
  // setting (the exact read of a 10k room costs several updates: live update skips it while playing).
  std::vector<float> corner_radiance(int object, bool exact_near_direct = true) const;  // 3 floats per face corner
  std::vector<float> vertex_radiance(int object) const;  // 3 floats per input vertex
  // Outgoing radiance on the front side at points of the object's surface (lightmap texels), in
  // corner_radiance's units: each point on input face `faces[i]` at object-space `positions[i]`
  // gathers its own direct light (lamps, emitters, sky, with its own visibility) at the solve's
  // direct sampling, plus the solution's reflected light interpolated within its patch.
  // 3 floats per point; std::invalid_argument for a face the object does not have.
  std::vector<float> surface_radiance(int object, const std::vector<int>& faces,
                                      const std::vector<dvec3>& positions) const;

  // The refined patch mesh of one object, for inspection and pictures (world positions), with the
  // radiance as solved at every patch corner (near light interpolated).
  struct Refined {
    std::vector<double> positions;  // 3 per patch corner, 4 corners per patch
    std::vector<float> radiance;    // 3 per patch corner
  };
  Refined refined(int object) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace radiosity
