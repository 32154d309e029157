#include "radiosity/settings.h"

#include <stdexcept>

namespace radiosity {

Settings Settings::preset(const std::string& name) {
  Settings s;
  if (name == "draft") {
    s.samples_direct = 16;
    s.samples_indirect = 4;
    s.patch_size_relative = 1.0 / 16.0;
    s.threshold = 1e-2;
    s.exact_near_direct = false;
  } else if (name == "default") {
    // the defaults above
  } else if (name == "high") {
    s.samples_direct = 256;
    s.samples_indirect = 32;
    s.patch_size_relative = 1.0 / 64.0;
    s.threshold = 5e-4;
  } else if (name == "reference") {
    s.samples_direct = 1024;
    s.samples_indirect = 64;
    s.patch_size_relative = 1.0 / 128.0;
    s.threshold = 1e-4;
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
