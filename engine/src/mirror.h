// Planar mirrors (the paper's light "via mirrors"): patches whose specular lobe reflects sharply
// (Glossy BSDF, Principled metal, at low roughness), grouped by plane. Each plane passes on what
// reaches it as the mirrored images of the shooters in front of it, seen through its outline: a ray
// from a receiver to an image point counts where it crosses the outline at p and both legs, receiver
// to p and p to the real point, are clear; it carries the mirror's colour times the image's light.
#pragma once

#include "bounds.h"
#include "patch_mesh.h"
#include "radiosity/form_factor.h"
#include "radiosity/scene.h"
#include "shot.h"

#include <embree3/rtcore.h>

#include <memory>
#include <string>
#include <vector>

namespace radiosity {

// Specular lobes at most this rough are mirrors; rougher ones scatter as a diffuse solve can take them.
constexpr double kMirrorRoughness = 0.05;
// An object whose sharp specular patches lie in more planes than this is taken as curved: no mirror
// planes, its sharp lobe spread as a rough one is.
constexpr int kMostPlanes = 6;

bool is_mirror(const Material& m);
// What a patch of the material reflects diffusely: its reflectance and, where its specular lobe is
// too rough to be a mirror or the patch's object is a curved mirror, that lobe's colour too (spread
// as a diffuse solve can), kept under one. A convex mirror spreads what it reflects every way (a
// sphere lit from one side, evenly), so a diffuse lobe of its colour keeps its light and much of
// where it goes.
dvec3 diffuse_reflectance(const Material& m, bool curved = false);

class MirrorPlane {
 public:
  // The plane of `patches` (of one object and material, in one plane), reflecting `reflectance`.
  MirrorPlane(std::shared_ptr<RTCDeviceTy> device, const PatchMesh& mesh, const std::vector<int>& patches,
              const dvec3& reflectance);
  ~MirrorPlane();
  MirrorPlane(const MirrorPlane&) = delete;
  MirrorPlane& operator=(const MirrorPlane&) = delete;

  const dvec3& normal() const { return normal_; }
  const dvec3& reflectance() const { return reflectance_; }
  const Sphere& bounds() const { return bounds_; }
  const std::vector<int>& patches() const { return patches_; }
  double height(const dvec3& p) const { return glm::dot(p - origin_, normal_); }
  dvec3 reflect(const dvec3& p) const { return p - 2.0 * height(p) * normal_; }
  dvec3 reflect_direction(const dvec3& d) const { return d - 2.0 * glm::dot(d, normal_) * normal_; }
  Symmetric3 reflect(const Symmetric3& s) const;  // a second moment, M S M with M the reflection
  // Where the ray origin + t dir, 0 < t < t_max, crosses the mirror's outline: its t, or a negative value.
  double crossing(const dvec3& origin, const dvec3& dir, double t_max) const;

 private:
  std::shared_ptr<RTCDeviceTy> device_;  // first: the outline is released before it
  RTCScene outline_ = nullptr;            // the plane's patches alone
  dvec3 normal_, origin_, reflectance_;
  std::vector<int> patches_;
  Sphere bounds_;
};

using MirrorPlanes = std::vector<std::shared_ptr<const MirrorPlane>>;

// The mirror planes of the visible objects of `scene` (those `only` marks, if given); `curved`
// lists the objects whose sharp specular patches form no few planes (no mirror planes).
MirrorPlanes find_mirrors(const PatchMesh& mesh, const SceneDesc& scene, std::vector<int>& curved,
                          const std::vector<char>* only = nullptr);
// The object whose patches make the plane.
int object_of(const MirrorPlane& plane, const PatchMesh& mesh);

// The shot as the plane shows it: positions reflected, each element and cell turned to face the way
// its image sends (the reflection reverses the corners' winding, so its sides swap), and nothing a
// receiving point would take as its own (corners, coincident targets, the shooter's enclosure).
Shot mirrored(Shot shot, const MirrorPlane& plane);
// The world as the plane shows it: the radiance the world sends along each reflected direction
// (a map resampled texel by texel).
WorldMap mirrored(const WorldMap& world, const MirrorPlane& plane);

}  // namespace radiosity
