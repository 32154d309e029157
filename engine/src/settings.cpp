#include "radiosity/settings.h"

#include "refine.h"

#include <cmath>
#include <stdexcept>

namespace radiosity {

void Settings::validate() const {
  auto check = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("settings: " + what);
  };
  check(samples_direct >= 1, "samples_direct must be at least 1");
  check(samples_indirect >= 1, "samples_indirect must be at least 1");
  check(patch_size_relative > 0 && patch_size_relative <= 1, "patch_size_relative must lie in (0, 1]");
  check(light_refinement >= 0 && light_refinement <= kMaxCellDepth, "light_refinement must lie in [0, 8]");
  check(light_contrast > 0 && light_contrast <= 1, "light_contrast must lie in (0, 1]");
  check(shooter_size_relative > 0 && shooter_size_relative <= 1, "shooter_size_relative must lie in (0, 1]");
  check(near_factor > 0 && std::isfinite(near_factor), "near_factor must be positive");
  check(threshold > 0 && threshold <= 1, "threshold must lie in (0, 1]");
  check(update_threshold >= 0 && update_threshold < 1, "update_threshold must lie in [0, 1)");
  check(relaxation == 0 || (relaxation >= 1 && relaxation < 2),
        "relaxation must be 0 (automatic) or lie in [1, 2) (2 and past it diverge)");
  check(max_shots >= 0, "max_shots must be 0 (direct light only) or more");
  check(max_patches >= 1, "max_patches must be at least 1");
  check(db_cache_mb >= 0 && std::isfinite(db_cache_mb), "db_cache_mb must be 0 or more");
  check(threads >= 0, "threads must be 0 (one a core) or more");
}

Settings Settings::preset(const std::string& name) {
  Settings s;
  if (name == "draft") {
    s.samples_direct = 16;
    s.samples_indirect = 4;
    s.patch_size_relative = 1.0 / 16.0;
    s.threshold = 1e-2;
    s.exact_near_direct = false;
  } else if (name == "default") {
    // The defaults above. Uniform patches: at this budget refinement driven by the light reaches
    // about the same error against Cycles with fewer patches but no less time
    // (bench/light_refinement.py), and an update's patches stay those of a fresh solve.
  } else if (name == "high") {
    s.samples_direct = 256;
    s.samples_indirect = 32;
    // Patches of the default's size, split twice where the light changes (down to 1/128): as
    // close to Cycles as uniform patches of 1/64, with a third of their patches.
    s.patch_size_relative = 1.0 / 32.0;
    s.light_refinement = 2;
    s.threshold = 5e-4;
    // A box's foot takes the floor's reflected light where it lands, which halves its corners'
    // distance from their limit value (trace_corner.py), for a read that costs up to twice a
    // solve where many corners stand beside surfaces whose light varies.
    s.exact_near_reflected = true;
  } else if (name == "reference") {
    s.samples_direct = 1024;
    s.samples_indirect = 64;
    s.patch_size_relative = 1.0 / 128.0;
    s.threshold = 1e-4;
    s.exact_near_reflected = true;
  } else {
    throw std::invalid_argument("unknown quality preset '" + name +
                                "' (draft, default, high, reference)");
  }
  return s;
}

std::vector<std::string> Settings::preset_names() {
  return {"draft", "default", "high", "reference"};
}

}  // namespace radiosity
