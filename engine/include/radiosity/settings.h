// Quality knobs and the named presets behind them.
#pragma once

#include <string>
#include <vector>

namespace radiosity {

struct Settings {
  // Micro-elements (one visibility ray each) per shot: emitters and lamps first, reflected light after.
  // A reflected shot carrying less than an even share of the light put in takes fewer, down to one
  // (Solver::Impl::shot_samples).
  int samples_direct = 64;
  int samples_indirect = 16;
  // Bilinear objects without their own patch size are split to this fraction of the scene diagonal.
  double patch_size_relative = 1.0 / 32.0;
  // Refinement driven by the light (light_refinement.cpp): patches start at patch_size_relative, and
  // a patch across which the light changes by more than `light_contrast` of its brightest is split
  // in four, up to this many times over, each time after a solve on the patches so far. 0: none.
  int light_refinement = 0;
  double light_contrast = 0.25;
  // Reflected light shoots from clusters of patches about this fraction of the scene diagonal across
  // (coarse shooters, fine receivers): their number does not grow with the receiver count.
  double shooter_size_relative = 1.0 / 8.0;
  // A cluster or micro-element closer than near_factor times its radius is split / integrated exactly.
  // A far cluster's form factor is good to fourth order in radius / distance: at 5 a furnace at rho
  // 0.9 comes out within 0.05%, for 2% more rays than at 3.
  double near_factor = 5.0;
  // Stop when the unshot light still to land on surfaces, over the light reflected in the direct pass
  // that lands (Solver::Impl::measure_landing: light leaving the scene brings nothing back), falls
  // below this, and the unshot light, landing or not, below this part of all that was reflected.
  double threshold = 1e-3;
  // An update stops once what it leaves unshot is below this part of the light its change put to
  // shoot, or below `threshold` if that is more: a frame is judged by its distance from a fresh
  // solve, and the light a change moves near itself is what shapes that distance. What it leaves is
  // shot by the next update, or down to `threshold` by solve() (the add-on's settle). 0: to
  // `threshold`, as a solve.
  double update_threshold = 0.05;
  // Over-relaxation of reflected shots: 1 = plain progressive refinement; 0 = automatic, from the
  // share of their light the first shots see come back (Solver::Impl::propagate).
  double relaxation = 0.0;
  // Reported points gather the direct light their near surroundings reflect once more, evaluated
  // where it lands rather than interpolated from patch corners (near_direct.cpp).
  bool exact_near_direct = true;
  // With it, the light those surroundings reflect is evaluated where it lands as a whole, the
  // reflected light too (each piece gathers every shooter's light; near_direct.cpp): interpolated,
  // a floor's light under-reads the foot of a box on it by up to 10%, a room's concave corners by
  // 1-3%. It costs tens of ms a reported point near patches whose light varies, a read many times a
  // solve's, so only `high` and `reference` have it. An update works all of it out anew.
  bool exact_near_reflected = false;
  long max_shots = 2000000;  // a guard: rho near 1 must end, the residual says how far it got
  // A guard: a scene that would refine to more patches is refused with a message. A solve holds
  // about 2.3 KB a patch; a patch size far below the faces' makes many.
  long max_patches = 2000000;
  // Memory for the dB cache (db_cache.h), in MB: what the scene without a moving object does to the
  // rays its moves change, so that a move back traces them no more. Full, it starts over, and rays
  // it does not hold are traced again: the same results. 0: no cache. About 20 bytes a ray.
  double db_cache_mb = 256.0;
  // Threads a solve, an update or a read works on; 0: one a core. Blender's Render > Performance >
  // Threads sets it, so that a bake leaves the cores the user keeps for other work.
  int threads = 0;

  // std::invalid_argument naming the first knob out of its range: a threshold of 0 would run
  // max_shots shots, a relaxation of 2.5 diverge under a message blaming the faces.
  void validate() const;

  static Settings preset(const std::string& name);  // draft, default, high, reference
  static std::vector<std::string> preset_names();
};

}  // namespace radiosity
