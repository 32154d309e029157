#include "radiosity/scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace radiosity {

namespace {

bool finite(const dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument(what); }

// Reflectance a surface can have: a surface that reflects all the light it gets would hold it
// forever in a closed room, and shooting would never converge.
void check_reflectance(const dvec3& rho, const std::string& who) {
  if (!finite(rho)) fail(who + ": NaN or infinite reflectance");
  for (int c = 0; c < 3; ++c)
    if (rho[c] < 0 || rho[c] >= 1)
      fail(who + ": reflectance must be in [0, 1) (a surface cannot reflect all light it gets)");
}

// An image of width x height texels (rows from the bottom) read bilinearly at (x, y) in texels,
// their centres at whole numbers: the columns repeat, the rows repeat or hold at the ends.
template <class T>
T bilinear_texel(const std::vector<T>& texels, int width, int height, double x, double y, bool rows_repeat) {
  auto wrap = [](double i, int n) {  // fmod is exact, however far from 0
    double r = std::fmod(i, double(n));
    return std::clamp(int(r < 0 ? r + n : r), 0, n - 1);
  };
  double fx = std::floor(x), fy = std::floor(y);
  double tx = x - fx, ty = y - fy;
  int c0 = wrap(fx, width), c1 = (c0 + 1) % width;
  int r0 = rows_repeat ? wrap(fy, height) : std::clamp(int(fy), 0, height - 1);
  int r1 = rows_repeat ? (r0 + 1) % height : std::clamp(int(fy) + 1, 0, height - 1);
  auto texel = [&](int c, int r) { return texels[size_t(r) * width + c]; };
  return (1 - ty) * ((1 - tx) * texel(c0, r0) + tx * texel(c1, r0)) + ty * ((1 - tx) * texel(c0, r1) + tx * texel(c1, r1));
}

std::string mesh_label(const MeshDesc& m, size_t i) {
  return "object '" + (m.name.empty() ? "#" + std::to_string(i) : m.name) + "'";
}

}  // namespace

void validate_mesh(const MeshDesc& m, size_t index, size_t material_count) {
  std::string who = mesh_label(m, index);
  for (size_t i = 0; i < m.positions.size(); ++i)
    if (!finite(m.positions[i]))
      fail(who + ": vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m.transform[c][r])) fail(who + ": transform has NaN or infinite entries");
  if (m.face_materials.size() != m.face_sizes.size())
    fail(who + ": " + std::to_string(m.face_sizes.size()) + " faces but " +
         std::to_string(m.face_materials.size()) + " face materials");
  if (!m.face_smooth.empty() && m.face_smooth.size() != m.face_sizes.size())
    fail(who + ": " + std::to_string(m.face_sizes.size()) + " faces but " +
         std::to_string(m.face_smooth.size()) + " smooth flags");
  size_t corners = 0;
  for (size_t f = 0; f < m.face_sizes.size(); ++f) {
    if (m.face_sizes[f] < 3) fail(who + ": face " + std::to_string(f) + " has fewer than 3 vertices");
    corners += size_t(m.face_sizes[f]);
    int mat = m.face_materials[f];
    if (mat < 0 || size_t(mat) >= material_count)
      fail(who + ": face " + std::to_string(f) + " uses material " + std::to_string(mat) +
           " of " + std::to_string(material_count));
  }
  if (corners != m.face_vertices.size())
    fail(who + ": face sizes add up to " + std::to_string(corners) + " corners but " +
         std::to_string(m.face_vertices.size()) + " face vertex indices were given");
  for (int v : m.face_vertices)
    if (v < 0 || size_t(v) >= m.positions.size())
      fail(who + ": face vertex index " + std::to_string(v) + " is out of range");
  if (m.refine == Refinement::CatmullClark && (m.level < 0 || m.level > 10))
    fail(who + ": Catmull-Clark level must be in 0..10");
  if (!(m.patch_size >= 0) || !std::isfinite(m.patch_size))
    fail(who + ": patch size must be a finite non-negative number");
  // A per-corner array is empty or has one entry a face corner.
  auto per_corner = [&](size_t size, const char* what) {
    if (size != 0 && size != corners)
      fail(who + ": " + std::to_string(corners) + " face corners but " + std::to_string(size) + " " + what);
  };
  per_corner(m.corner_reflectance.size(), "corner reflectances");
  for (size_t k = 0; k < m.corner_reflectance.size(); ++k)
    check_reflectance(m.corner_reflectance[k], who + ", face corner " + std::to_string(k));
  per_corner(m.corner_emission.size(), "corner emissions");
  per_corner(m.corner_uv.size(), "corner UVs");
  for (size_t k = 0; k < m.corner_uv.size(); ++k)
    if (!std::isfinite(m.corner_uv[k].x) || !std::isfinite(m.corner_uv[k].y))
      fail(who + ", face corner " + std::to_string(k) + ": NaN or infinite UV");
  for (size_t k = 0; k < m.corner_emission.size(); ++k) {
    const dvec3& e = m.corner_emission[k];
    if (!finite(e) || e.x < 0 || e.y < 0 || e.z < 0)
      fail(who + ", face corner " + std::to_string(k) + ": emission must be finite and not negative");
  }
}

void validate_material(const Material& m, size_t index) {
  std::string who = "material " + std::to_string(index);
  check_reflectance(m.reflectance, who);
  if (!finite(m.emission)) fail(who + ": NaN or infinite emission");
  for (int c = 0; c < 3; ++c)
    if (m.emission[c] < 0) fail(who + ": emission must not be negative");
  for (const auto& [lobe, name] : {std::pair{m.transmittance, "transmittance"}, {m.glass, "glass colour"},
                                   {m.specular, "specular colour"}}) {
    if (!finite(lobe)) fail(who + ": NaN or infinite " + name);
    for (int c = 0; c < 3; ++c)
      if (lobe[c] < 0 || lobe[c] > 1) fail(who + ": " + name + " must be in [0, 1]");
  }
  if (m.alpha) {
    const AlphaMap& a = *m.alpha;
    if (a.width < 1 || a.height < 1 || a.texels.size() != size_t(a.width) * a.height)
      fail(who + ": alpha map: " + std::to_string(a.texels.size()) + " texels for " + std::to_string(a.width) +
           " x " + std::to_string(a.height));
    for (float t : a.texels)
      if (!(t >= 0 && t <= 1)) fail(who + ": alpha map: a texel is NaN or outside [0, 1]");
  }
  // With an alpha map, the transparent part passes where the surface is not: on average 1 - mean.
  dvec3 total = m.reflectance + (m.alpha ? 1 - m.alpha->mean() : 1.0) * m.transmittance + m.glass + m.specular;
  for (int c = 0; c < 3; ++c)
    if (total[c] > 1 + 1e-9)
      fail(who + ": reflectance, transmittance, glass and specular add up to more than 1 (it would make light)");
  if (!(m.ior >= 1 && m.ior <= 10)) fail(who + ": index of refraction must be in [1, 10]");
  if (!(m.roughness >= 0 && m.roughness <= 1)) fail(who + ": roughness must be in [0, 1]");
}

void validate_lamp(const Lamp& l, size_t index) {
  std::string who = "lamp " + std::to_string(index);
  if (!finite(l.position) || !finite(l.direction) || !finite(l.color) || !finite(l.u_axis) ||
      !finite(l.v_axis) || !std::isfinite(l.radius) || !std::isfinite(l.angle) ||
      !std::isfinite(l.spot_size) || !std::isfinite(l.spot_blend))
    fail(who + ": NaN or infinite parameter");
  if (l.color.x < 0 || l.color.y < 0 || l.color.z < 0) fail(who + ": negative strength");
  if (l.radius < 0) fail(who + ": negative radius");
  bool directional = l.type == Lamp::Type::Spot || l.type == Lamp::Type::Sun ||
                     l.type == Lamp::Type::Disc;
  if (directional && glm::length(l.direction) == 0) fail(who + ": zero direction");
  if (l.type == Lamp::Type::Rect && glm::length(glm::cross(l.u_axis, l.v_axis)) == 0)
    fail(who + ": rectangle has zero area");
}

void validate_world(const WorldMap& world) {
  if (world.width < 1 || world.height < 1 || world.texels.size() != size_t(world.width) * world.height)
    fail("world map: its texels are not its width times its height");
  for (const dvec3& t : world.texels)
    if (!finite(t) || t.x < 0 || t.y < 0 || t.z < 0) fail("world colour must be finite and non-negative");
}

void SceneDesc::validate() const {
  for (size_t i = 0; i < materials.size(); ++i) validate_material(materials[i], i);
  for (size_t i = 0; i < meshes.size(); ++i) validate_mesh(meshes[i], i, materials.size());
  for (size_t i = 0; i < lamps.size(); ++i) validate_lamp(lamps[i], i);
  validate_world(world);
}

float AlphaMap::at(double u, double v) const {
  return float(bilinear_texel(texels, width, height, u * width - 0.5, v * height - 0.5, true));
}

AlphaMap::AlphaMap(int width, int height, std::vector<float> texels)
    : width(width), height(height), texels(std::move(texels)) {
  double sum = 0.0;
  for (float t : this->texels) sum += t;
  if (!this->texels.empty()) mean_ = sum / double(this->texels.size());
}

WorldMap WorldMap::uniform(const dvec3& radiance) {
  WorldMap m;
  m.texels[0] = radiance;
  return m;
}

dvec3 WorldMap::at(const dvec3& d) const {
  if (texels.size() == 1) return texels[0];
  constexpr double kPi = 3.14159265358979323846;
  double x = (0.5 - std::atan2(d.y, d.x) / (2 * kPi)) * width - 0.5;
  double y = (0.5 + std::asin(std::clamp(d.z, -1.0, 1.0)) / kPi) * height - 0.5;
  return bilinear_texel(texels, width, height, x, y, false);  // round the columns, held at the poles
}

dvec3 WorldMap::direction(int column, int row) const {
  constexpr double kPi = 3.14159265358979323846;
  double phi = (0.5 - (column + 0.5) / width) * 2 * kPi;
  double theta = ((row + 0.5) / height - 0.5) * kPi;
  return {std::cos(theta) * std::cos(phi), std::cos(theta) * std::sin(phi), std::sin(theta)};
}

bool WorldMap::lit() const {
  for (const dvec3& t : texels)
    if (t.x + t.y + t.z > 0) return true;
  return false;
}

WorldMap WorldMap::scaled(double factor) const {
  WorldMap m = *this;
  for (dvec3& t : m.texels) t = factor * t;
  return m;
}

}  // namespace radiosity
