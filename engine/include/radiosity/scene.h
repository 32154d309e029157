// Scene description: what the caller hands the engine, in flat arrays.
//
// Units follow Blender/Cycles in "radiance units": emission and results are outgoing radiance, and
// a diffuse surface's radiance is B = E + rho * H with H = irradiance / pi.
#pragma once

#include <glm/glm.hpp>

#include <memory>
#include <string>
#include <vector>

namespace radiosity {

using glm::dmat4;
using glm::dvec2;
using glm::dvec3;

// How much of a surface is there, by place: an image texture's alpha (a leaf card, a lace curtain).
// Texels row by row from the bottom (Blender's pixel order), u across and v up, each in [0, 1];
// read bilinearly between texel centres, repeating both ways (the Image Texture's default Repeat).
struct AlphaMap {
  AlphaMap(int width, int height, std::vector<float> texels);
  int width = 0, height = 0;
  std::vector<float> texels;

  float at(double u, double v) const;
  double mean() const { return mean_; }  // over the image: what the surface covers on average
  bool operator==(const AlphaMap& o) const {
    return width == o.width && height == o.height && texels == o.texels;
  }

 private:
  double mean_ = 1.0;
};

struct Material {
  dvec3 reflectance{0.8};  // diffuse albedo per channel, each in [0, 1)
  dvec3 emission{0.0};     // emitted radiance, two-sided as Cycles does for meshes
  // The lobes that pass light on without diffusing it; per channel, reflectance + transmittance +
  // glass + specular is at most 1.
  dvec3 transmittance{0.0};  // passes straight through at any angle (Transparent BSDF, alpha)
  dvec3 glass{0.0};          // refracting interface's colour; Fresnel at `ior` takes its share
  double ior = 1.45;
  dvec3 specular{0.0};       // mirror colour (Glossy BSDF, Principled metal)
  double roughness = 0.5;    // of the specular lobe, as Blender's Roughness input
  // Where the surface is and where it is not, on a mesh with corner_uv: a ray crossing it at a place
  // of alpha a passes (1 - a) transmittance there. The other lobes hold for the whole surface, as
  // the caller scaled them (by the mean alpha). Null: transmittance everywhere.
  std::shared_ptr<const AlphaMap> alpha;
};

enum class Refinement {
  None,          // faces as given: quads stay, triangles become degenerate quads, n-gons are split
  Bilinear,      // bilinear splitting, each face until its patches are about `patch_size` across
  CatmullClark,  // `level` Catmull-Clark steps, vertices and normals on the limit surface
};

struct MeshDesc {
  std::string name;
  std::vector<dvec3> positions;    // object space
  std::vector<int> face_sizes;     // vertices per face (>= 3)
  std::vector<int> face_vertices;  // concatenated, counter-clockwise seen from the front
  std::vector<int> face_materials; // index into SceneDesc::materials, one per face
  dmat4 transform{1.0};            // object to world
  Refinement refine = Refinement::None;
  int level = 0;           // Catmull-Clark steps
  double patch_size = 0.0; // Bilinear target size in world units; 0 = Settings decides
  bool dynamic = false;    // will move or deform later: kept as an instance in the ray-tracing scene
  // Will deform later (modifiers, shape keys): at each vertex its flat faces keep a receiving point
  // each, which a deformation that bends them apart cannot pull into two normals (make_points).
  bool deforms = false;
  bool visible = true;     // takes part in the lighting; a hidden object is kept (refined, out of
                           // the ray-tracing scene) so it can appear later without a new Solver
  // Per face: shaded smooth (Blender's Shade Smooth), with normals interpolated from the vertices'
  // (a Catmull-Clark object's limit normals), where Cycles bakes with them; else flat. Empty: smooth
  // for Catmull-Clark, flat otherwise.
  std::vector<char> face_smooth;
  // Per face corner (face_vertices' order): the reflectance there, in place of the faces'
  // materials' (a colour texture sampled at the corners), interpolated across each face. Empty: the
  // materials'.
  std::vector<dvec3> corner_reflectance;
  // The same for the emitted radiance (an emission texture). Empty: the materials'.
  std::vector<dvec3> corner_emission;
  // Per face corner: texture coordinates, where its materials' alpha maps are read (Material::alpha).
  // Empty: such materials pass their mean.
  std::vector<dvec2> corner_uv;
  bool smooth(int face) const {
    return face_smooth.empty() ? refine == Refinement::CatmullClark && level > 0 : face_smooth[face] != 0;
  }
};

// Point and spot lamps are Cycles' sphere lamps: a disc of `radius` facing the receiver whose total
// radiant intensity is `intensity` (so irradiance = I cos / (d^2 + radius^2)).
struct Lamp {
  enum class Type { Point, Spot, Sun, Rect, Disc } type = Type::Point;
  dvec3 position{0.0};
  dvec3 direction{0.0, 0.0, -1.0}; // where the light travels (spot axis, sun rays, area normal)
  dvec3 color{1.0};  // Point/Spot: radiant intensity (W/sr); Sun: irradiance; Rect/Disc: radiance
  double radius = 0.0;             // Point/Spot/Disc radius
  double angle = 0.0;              // Sun: angular diameter (radians)
  double spot_size = 0.0;          // Spot: full cone angle (radians)
  double spot_blend = 0.0;         // Spot: Cycles' smooth edge fraction
  dvec3 u_axis{1.0, 0.0, 0.0};     // Rect: half extent vectors; the lamp emits along -(u x v)
  dvec3 v_axis{0.0, 1.0, 0.0};
};

// The world's radiance by direction: an equirectangular image in Cycles' layout (along a row
// u = 0.5 - atan2(y, x) / 2 pi, up the rows from the bottom v = 0.5 + asin(z) / pi), read
// bilinearly, the columns wrapping round. One texel: a uniform sky.
struct WorldMap {
  int width = 1, height = 1;
  std::vector<dvec3> texels{dvec3(0.0)};

  static WorldMap uniform(const dvec3& radiance);
  dvec3 at(const dvec3& direction) const;  // `direction` of unit length
  dvec3 direction(int column, int row) const;  // of the texel's centre, of unit length
  bool lit() const;                         // some texel sends light
  WorldMap scaled(double factor) const;
};

struct SceneDesc {
  std::vector<Material> materials;
  std::vector<MeshDesc> meshes;
  std::vector<Lamp> lamps;
  WorldMap world;

  // Throws std::invalid_argument naming the object and the fault for input the engine cannot take
  // (NaN/inf, bad indices, reflectance outside [0, 1), negative emission, alpha outside [0, 1]).
  void validate() const;
};

// SceneDesc::validate's parts, one item each (`index`: its place in the SceneDesc, for the message):
// an update checks only what it changes, at a cost that follows the change and not the scene.
void validate_material(const Material& m, size_t index);
void validate_mesh(const MeshDesc& m, size_t index, size_t material_count);
void validate_lamp(const Lamp& l, size_t index);
void validate_world(const WorldMap& world);

}  // namespace radiosity
