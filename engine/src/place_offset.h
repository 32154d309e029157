// A fixed offset of a sample pattern within its cells per receiving place, two numbers in [0, 1).
//
// A solve stays deterministic, and over the receivers each sample falls anywhere in its cell with
// equal chance, so what they gather is right on average. A pattern fixed in its cells puts every
// receiver's samples at the same few points: for the sky the same few elevations, which weigh a
// window by the rings of samples it meets rather than by its size (a floor under a window reads its
// sky high); for an area lamp seen through a window the same few points of the lamp, so that which
// of them pass the window's frame decides the light of whole bands of the floor. Shadows band where
// they should be noise. Drawn from the place's coordinates, not the receiver's index: a place
// gathers the same samples whatever the objects around it, or their order, so one face of two
// meshes alike (an object and its modifiers applied) gets the same light, and an update's gather
// takes the samples a fresh solve's does.
#pragma once

#include "radiosity/scene.h"

#include <cstdint>
#include <cstring>

namespace radiosity {

struct PlaceOffset {
  double u, v;
};

inline PlaceOffset place_offset(const dvec3& x) {
  auto mix = [](uint32_t h) {
    h ^= h >> 16;
    h *= 0x45d9f3bu;
    h ^= h >> 16;
    return h;
  };
  uint32_t h = 0x2545f491u;  // not 0: the origin's bits would give no offset at all
  for (int k = 0; k < 3; ++k) {
    float c = float(x[k]);
    uint32_t bits;
    std::memcpy(&bits, &c, sizeof bits);
    h = mix(h * 2654435761u ^ bits);
  }
  uint32_t g = mix(h * 0x9e3779b9u + 0x7f4a7c15u);
  return {(h & 0xFFFFFF) / double(0x1000000), (g & 0xFFFFFF) / double(0x1000000)};
}

}  // namespace radiosity
