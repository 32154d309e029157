#include "patch_mesh.h"

#include "corner_view.h"
#include "mirror.h"
#include "refine.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace radiosity {

namespace {

constexpr double kSameNormal = 0.999;   // corners whose normals differ by less than ~2.5 degrees
constexpr double kInwardNudge = 0.01;   // fraction of the way towards the adjacent patch centres

dvec3 transform_point(const dmat4& m, const dvec3& p) { return dvec3(m * glm::dvec4(p, 1.0)); }

void scene_bounds(const SceneDesc& scene, dvec3& lo, dvec3& hi) {
  lo = dvec3(INFINITY);
  hi = dvec3(-INFINITY);
  for (const MeshDesc& m : scene.meshes)
    for (const dvec3& p : m.positions) {
      dvec3 w = transform_point(m.transform, p);
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    }
}

// Appends one object's patches (topology only: corners, material, reflectance and emission, object);
// `set_geometry` places them.
void add_patches(PatchMesh& pm, const MeshDesc& mesh, const RefinedMesh& refined, const std::vector<Material>& materials,
                 int object, ObjectPatches& obj) {
  int base = int(pm.vertices.size());
  pm.vertices.resize(base + refined.positions.size());
  // A mirroring transform turns counter-clockwise into clockwise: swap to keep the front.
  bool mirrored = glm::determinant(glm::dmat3(mesh.transform)) < 0;
  obj.mirrored = mirrored;
  for (size_t q = 0; q < refined.quads.size(); ++q) {
    std::array<int, 4> v = refined.quads[q];
    if (mirrored) std::swap(v[1], v[3]);
    Patch patch;
    for (int c = 0; c < 4; ++c) patch.vertex[c] = base + v[c];
    patch.material = mesh.face_materials[refined.quad_face[q]];
    patch.object = object;
    pm.patches.push_back(patch);
    auto per_corner = [&](const dvec3& material, const std::vector<std::array<dvec3, 4>>& corners,
                          std::vector<dvec3>& to) {
      std::array<dvec3, 4> value;
      value.fill(material);
      if (!corners.empty()) value = corners[q];
      if (mirrored) std::swap(value[1], value[3]);
      to.insert(to.end(), value.begin(), value.end());
    };
    per_corner(diffuse_reflectance(materials[patch.material]), refined.corner_reflectance, pm.reflectance);
    per_corner(materials[patch.material].emission, refined.corner_emission, pm.emission);
    if (!refined.corner_uv.empty() || !pm.uv.empty()) {
      pm.uv.resize(4 * (pm.patches.size() - 1), dvec3(NAN));  // the slots of objects without UVs before it
      per_corner(dvec3(NAN), refined.corner_uv, pm.uv);
    }
  }
}

Facet facet(const PatchMesh& pm, const dvec3& p0, const dvec3& p1, const dvec3& p2, const dvec3& p3) {
  dvec3 va = 0.5 * glm::cross(p2 - p0, p3 - p1);
  double area = glm::length(va);
  if (!(area > 1e-14 * pm.diagonal * pm.diagonal)) return {};
  return {area, va / area};
}

// Whether patch `q` of the object takes shading normals at its corners (a smooth face, not degenerate).
bool shaded_smooth(const MeshDesc& mesh, const RefinedMesh& refined, const ObjectPatches& obj, int q, double area) {
  return !refined.normals.empty() && area > 0 && mesh.smooth(refined.quad_face[q - obj.patch_begin]);
}

// The object `obj` (its patches' vertex indices) refined to `refined` and put where `mesh`'s
// transform puts it.
PlacedObject place(const PatchMesh& pm, const MeshDesc& mesh, RefinedMesh refined, const ObjectPatches& obj) {
  PlacedObject out;
  out.at.resize(refined.positions.size());
  for (size_t i = 0; i < out.at.size(); ++i) out.at[i] = transform_point(mesh.transform, refined.positions[i]) - pm.origin;
  glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(mesh.transform)));
  out.facets.reserve(obj.patch_end - obj.patch_begin);
  out.normals.reserve(4 * (obj.patch_end - obj.patch_begin));
  for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
    int v[4];
    for (int c = 0; c < 4; ++c) v[c] = pm.patches[q].vertex[c] - obj.vertex_begin;
    Facet f = pm.patches[q].copy_of >= 0 ? Facet{} : facet(pm, out.at[v[0]], out.at[v[1]], out.at[v[2]], out.at[v[3]]);
    bool smooth = shaded_smooth(mesh, refined, obj, q, f.area);
    for (int c = 0; c < 4; ++c) {
      dvec3 n = f.normal;
      if (smooth) {
        dvec3 shading = normal_matrix * refined.normals[v[c]];
        if (glm::length(shading) > 0) n = glm::normalize(shading);
      }
      out.normals.push_back(n);
    }
    out.facets.push_back(f);
  }
  out.refined = std::move(refined);
  return out;
}

// Puts an object's vertices and patches where `placed` has them.
void set_geometry(PatchMesh& pm, const MeshDesc& mesh, const PlacedObject& placed, ObjectPatches& obj) {
  std::copy(placed.at.begin(), placed.at.end(), pm.vertices.begin() + obj.vertex_begin);
  pm.degenerate_patches -= obj.degenerate;
  obj.degenerate = 0;
  for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
    Patch& patch = pm.patches[q];
    dvec3 corners[4];
    for (int c = 0; c < 4; ++c) corners[c] = pm.vertices[patch.vertex[c]];
    const Facet& f = placed.facets[q - obj.patch_begin];
    patch.area = f.area;
    patch.normal = f.normal;
    patch.centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
    if (f.area == 0 && patch.copy_of < 0) ++obj.degenerate;
    patch.interior_share = shaded_smooth(mesh, placed.refined, obj, q, f.area)
                               ? interior_share(corners, &placed.normals[4 * (q - obj.patch_begin)])
                               : 1.0;
  }
  pm.degenerate_patches += obj.degenerate;
}

// How far `x` must go along `n` to come onto triangle (a, b, c), where that line crosses it ahead; 0
// where it does not.
double rise_onto(const dvec3& x, const dvec3& n, const dvec3& a, const dvec3& b, const dvec3& c) {
  dvec3 e1 = b - a, e2 = c - a, p = glm::cross(n, e2);
  double det = glm::dot(e1, p);
  if (!(std::fabs(det) > 0)) return 0.0;
  dvec3 s = x - a, q = glm::cross(s, e1);
  double u = glm::dot(s, p) / det, v = glm::dot(n, q) / det, t = glm::dot(e2, q) / det;
  return u >= 0 && v >= 0 && u + v <= 1 && t > 0 ? t : 0.0;
}

int vertex_of_point(const PatchMesh& pm, int p) {
  int slot = pm.point_slots[pm.point_slot_begin[p]];
  return pm.patches[slot / 4].vertex[slot % 4];
}

// Puts points [begin, end) at their vertices, facing the way their first corner faces, nudged
// towards the centres of their patches. `corner_normal[slot - first_slot]` is a corner's normal.
void place_points(PatchMesh& pm, const dvec3* corner_normal, int first_slot, int begin, int end) {
  for (int p = begin; p < end; ++p) {
    ReceiverPoint& rp = pm.points[p];
    int first = pm.point_slots[pm.point_slot_begin[p]];
    rp.position = pm.vertices[pm.patches[first / 4].vertex[first % 4]];
    rp.normal = corner_normal[first - first_slot];
    CornerView view = corner_view(pm, p, corner_normal, first_slot);
    rp.reflected_share = view.reflected_share;
    dvec3 centre_sum(0.0), first_centre(0.0);
    double reach = 0.0;
    int count = 0;
    for (int i = pm.point_slot_begin[p]; i < pm.point_slot_begin[p + 1]; ++i) {
      int slot = pm.point_slots[i];
      pm.own_view[slot] = view.own[i - pm.point_slot_begin[p]];
      pm.onward[slot] = view.onward[i - pm.point_slot_begin[p]];
      const Patch& patch = pm.patches[slot / 4];
      if (patch.area == 0) continue;
      if (count++ == 0) first_centre = patch.centre;
      centre_sum += patch.centre;
      reach += glm::length(patch.centre - rp.position);
    }
    if (count == 0) continue;
    // Where the surface is convex the patch centres lie below the tangent plane: a point moved
    // towards them would sit inside the tessellated surface, shadowed by itself, so it moves
    // along the plane. Where it is concave, moved along the plane a point whose patches lie to
    // one side of it (a T-junction; wide faces beside narrow ones) would go behind their facets and
    // gather nothing: it moves towards them, into the open.
    dvec3 towards = centre_sum / double(count) - rp.position;
    // A point holding faces that lie opposite each other round its vertex, beside another point's
    // (a fold between flat faces: the diagonal pair of four), would go nowhere: on the other faces'
    // corners, where Lambert's formula is round-off, it would take them for its whole sky. It goes
    // into one of its own faces.
    bool shared = (p > begin && vertex_of_point(pm, p - 1) == vertex_of_point(pm, p)) ||
                  (p + 1 < end && vertex_of_point(pm, p + 1) == vertex_of_point(pm, p));
    if (shared && glm::length(towards) < 0.25 * reach / count) towards = first_centre - rp.position;
    double rise = glm::dot(towards, rp.normal);
    rp.position += kInwardNudge * (rise > 0 ? towards : towards - rise * rp.normal);
    // Embree traces a quad as the triangles (v0, v1, v3) and (v2, v3, v1). Where the quad is not
    // planar, the way to the patch centres can pass under them: a quad with one corner raised puts
    // the corners of the other diagonal under the triangle beside them, where every ray they send
    // would hit it (black corners). The point comes up onto them along its normal.
    double up = 0.0;
    for (int i = pm.point_slot_begin[p]; i < pm.point_slot_begin[p + 1]; ++i) {
      const Patch& patch = pm.patches[pm.point_slots[i] / 4];
      const dvec3* v[4];
      for (int c = 0; c < 4; ++c) v[c] = &pm.vertices[patch.vertex[c]];
      up = std::max({up, rise_onto(rp.position, rp.normal, *v[0], *v[1], *v[3]),
                     rise_onto(rp.position, rp.normal, *v[2], *v[3], *v[1])});
    }
    rp.position += up * rp.normal;
  }
}

// Groups the corners of an object's patches (slots from `first_slot` on) at each vertex into
// receiving points by normal (the first corner of a group sets its normal), appends them, then
// places them. `corner_normals` holds the object's corners' normals, `apart` a key per corner:
// corners with different keys never share a point.
void make_points(PatchMesh& pm, const std::vector<dvec3>& corner_normals, const std::vector<int>& apart,
                 int first_slot, ObjectPatches& obj) {
  int slots = int(pm.patches.size()) * 4;
  int count = slots - first_slot;
  auto vertex_of = [&](int s) { return pm.patches[s / 4].vertex[s % 4]; };
  std::vector<int> by_vertex(count);
  for (int k = 0; k < count; ++k) by_vertex[k] = first_slot + k;
  std::stable_sort(by_vertex.begin(), by_vertex.end(), [&](int a, int b) { return vertex_of(a) < vertex_of(b); });
  int first_point = int(pm.points.size());
  std::vector<int> slot_point(count, -1);
  std::vector<dvec3> point_normal;
  std::vector<int> point_key;
  for (int i = 0; i < count;) {
    int vertex = vertex_of(by_vertex[i]);
    int vertex_first = int(point_normal.size());
    int j = i;
    for (; j < count && vertex_of(by_vertex[j]) == vertex; ++j) {
      int s = by_vertex[j] - first_slot;
      const dvec3& n = corner_normals[s];
      int chosen = -1;
      for (int p = vertex_first; p < int(point_normal.size()) && chosen < 0; ++p)
        if (point_key[p] == apart[s] && (glm::length(n) == 0 || glm::dot(point_normal[p], n) > kSameNormal))
          chosen = p;
      if (chosen < 0) {
        chosen = int(point_normal.size());
        point_normal.push_back(n);
        point_key.push_back(apart[s]);
      }
      slot_point[s] = first_point + chosen;
    }
    i = j;
  }
  int points = first_point + int(point_normal.size());
  pm.points.resize(points);
  // CSR: the object's points count their slots, then their starts follow on from the last point's.
  pm.point_slot_begin.resize(points + 1, 0);
  std::fill(pm.point_slot_begin.begin() + first_point + 1, pm.point_slot_begin.end(), 0);
  for (int k = 0; k < count; ++k) {
    int s = first_slot + k;
    pm.patches[s / 4].point[s % 4] = slot_point[k];
    ++pm.point_slot_begin[slot_point[k] + 1];
  }
  for (int p = first_point; p < points; ++p) pm.point_slot_begin[p + 1] += pm.point_slot_begin[p];
  pm.point_slots.resize(slots);
  pm.own_view.resize(slots);
  pm.onward.resize(slots);
  std::vector<int> fill(pm.point_slot_begin.begin() + first_point, pm.point_slot_begin.end() - 1);
  for (int k = 0; k < count; ++k) pm.point_slots[fill[slot_point[k] - first_point]++] = first_slot + k;
  place_points(pm, corner_normals.data(), first_slot, first_point, points);
  // Points are made vertex by vertex, and an object's vertices are its own, so its points are a range.
  obj.point_begin = point_normal.empty() ? 0 : first_point;
  obj.point_end = point_normal.empty() ? 0 : points;
}

// ObjectPatches::enclosed_side: closed if each directed edge of the input faces comes once and its
// reverse once (shared vertices: a mesh whose faces do not share theirs counts as open); the inside
// is behind the front sides where the patches enclose a positive volume.
int enclosed_side(const PatchMesh& pm, const MeshDesc& mesh, const ObjectPatches& obj) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(mesh.face_vertices.size());
  for (size_t f = 0, offset = 0; f < mesh.face_sizes.size(); offset += mesh.face_sizes[f++])
    for (int k = 0; k < mesh.face_sizes[f]; ++k) {
      int a = mesh.face_vertices[offset + k], b = mesh.face_vertices[offset + (k + 1) % mesh.face_sizes[f]];
      if (a == b) return -1;
      edges.emplace_back(a, b);
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size(); ++i) {
    if (i + 1 < edges.size() && edges[i + 1] == edges[i]) return -1;
    if (!std::binary_search(edges.begin(), edges.end(), std::make_pair(edges[i].second, edges[i].first))) return -1;
  }
  if (edges.empty()) return -1;
  // Three times the volume, about a point of the surface (round-off far from the origin).
  const dvec3& base = pm.patches[obj.patch_begin].centre;
  double volume = 0.0, area = 0.0;
  for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
    const Patch& p = pm.patches[q];
    volume += p.area * glm::dot(p.centre - base, p.normal), area += p.area;
  }
  if (!(std::fabs(volume) > 1e-9 * area * std::sqrt(area))) return -1;
  return volume > 0 ? 1 : 0;
}

// Gives the object's points its index and enclosed side, and where it is closed a sphere round it.
void enclose(PatchMesh& pm, ObjectPatches& obj, int object) {
  for (int p = obj.point_begin; p < obj.point_end; ++p)
    pm.points[p].object = object, pm.points[p].enclosed_side = obj.enclosed_side;
  if (obj.enclosed_side < 0) return;
  dvec3 lo(INFINITY), hi(-INFINITY);
  widen_to(pm, obj, lo, hi);
  obj.enclosure = {0.5 * (lo + hi), 0.0};
  for (int v = obj.vertex_begin; v < obj.vertex_end; ++v)
    obj.enclosure.radius = std::max(obj.enclosure.radius, glm::length(pm.vertices[v] - obj.enclosure.centre));
  obj.enclosure.radius *= 1 + 1e-9;
  for (int p = obj.point_begin; p < obj.point_end; ++p) pm.points[p].enclosure = obj.enclosure;
}

// For each input face corner, the patch corner at the same place.
std::vector<int> corner_slots(const MeshDesc& mesh, const RefinedMesh& refined, const ObjectPatches& obj) {
  std::vector<int> first_quad(mesh.face_sizes.size() + 1, 0);
  for (int f : refined.quad_face) ++first_quad[f + 1];
  for (size_t f = 0; f < mesh.face_sizes.size(); ++f) first_quad[f + 1] += first_quad[f];
  std::vector<int> quads_by_face(refined.quad_face.size());
  std::vector<int> fill(first_quad.begin(), first_quad.end() - 1);
  for (size_t q = 0; q < refined.quad_face.size(); ++q) quads_by_face[fill[refined.quad_face[q]]++] = int(q);

  std::vector<int> slots;
  slots.reserve(mesh.face_vertices.size());
  int offset = 0;
  for (size_t f = 0; f < mesh.face_sizes.size(); ++f) {
    for (int k = 0; k < mesh.face_sizes[f]; ++k) {
      int target = refined.input_vertex[mesh.face_vertices[offset + k]];
      int slot = -1;
      for (int i = first_quad[f]; i < first_quad[f + 1] && slot < 0; ++i) {
        int q = quads_by_face[i];
        for (int c = 0; c < 4; ++c)
          if (refined.quads[q][c] == target) {
            slot = (obj.patch_begin + q) * 4 + (obj.mirrored && c % 2 ? 4 - c : c);  // see add_patches
            break;
          }
      }
      slots.push_back(slot);  // -1 only if the refinement dropped the corner: the output reads 0
    }
    offset += mesh.face_sizes[f];
  }
  return slots;
}

}  // namespace

void widen_to(const PatchMesh& pm, const ObjectPatches& obj, dvec3& lo, dvec3& hi) {
  for (int v = obj.vertex_begin; v < obj.vertex_end; ++v) lo = glm::min(lo, pm.vertices[v]), hi = glm::max(hi, pm.vertices[v]);
}

PatchMesh build_patch_mesh(const SceneDesc& scene, const Settings& settings,
                           const std::vector<std::vector<QuadCell>>& cells) {
  PatchMesh pm;
  dvec3 lo, hi;
  scene_bounds(scene, lo, hi);
  if (lo.x <= hi.x) {
    pm.origin = 0.5 * (lo + hi);
    double d = glm::length(hi - lo);
    pm.diagonal = d > 0 ? d : 1.0;
  }
  check_patch_budget(pm, scene.meshes, settings);
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    add_object(pm, scene.meshes[m], scene.materials, settings, cells.empty() ? std::vector<QuadCell>() : cells[m]);
  return pm;
}

namespace {

std::vector<int> face_levels_in(const PatchMesh& pm, const MeshDesc& mesh, const Settings& settings) {
  return face_levels(mesh, mesh.patch_size > 0 ? mesh.patch_size : settings.patch_size_relative * pm.diagonal);
}

// The object's quads: `mesh` refined as the object was, then split as the light split it.
RefinedMesh refine_patches(const MeshDesc& mesh, const ObjectPatches& obj) {
  RefinedMesh refined = refine_mesh(mesh, obj.face_levels);
  return obj.cells.empty() ? refined : split_cells(refined, obj.cells);
}

}  // namespace

void check_patch_budget(const PatchMesh& pm, const std::vector<MeshDesc>& meshes, const Settings& settings) {
  long long total = (long long)pm.patches.size(), largest = -1;
  const MeshDesc* worst = nullptr;
  for (const MeshDesc& mesh : meshes) {
    long long n = quad_count(mesh, face_levels_in(pm, mesh, settings));
    total += n;
    if (n > largest) largest = n, worst = &mesh;
  }
  if (total <= settings.max_patches) return;
  std::vector<int> levels = face_levels_in(pm, *worst, settings);
  int level = levels.empty() ? 0 : *std::max_element(levels.begin(), levels.end());
  throw std::invalid_argument(
      "the scene would refine to " + std::to_string(total) + " patches, past the limit of " +
      std::to_string(settings.max_patches) + " (about 2.3 KB each, solved); object '" + worst->name + "' alone makes " +
      std::to_string(largest) + " (" + std::to_string(worst->face_sizes.size()) +
      (worst->face_sizes.size() == 1 ? " face" : " faces") +
      (worst->refine == Refinement::CatmullClark
           ? " at subdivision level " + std::to_string(level) + ": lower the level)"
           : ", each split in four up to " + std::to_string(level) +
                 " times to bring its edges down to the patch size: raise the patch size)"));
}

void add_object(PatchMesh& pm, const MeshDesc& mesh, const std::vector<Material>& materials,
                const Settings& settings, std::vector<QuadCell> cells) {
  ObjectPatches obj;
  obj.face_levels = face_levels_in(pm, mesh, settings);
  obj.cells = std::move(cells);
  RefinedMesh refined = refine_patches(mesh, obj);
  obj.patch_begin = int(pm.patches.size());
  obj.vertex_begin = int(pm.vertices.size());
  add_patches(pm, mesh, refined, materials, int(pm.objects.size()), obj);
  obj.patch_end = int(pm.patches.size());
  obj.vertex_end = int(pm.vertices.size());
  PlacedObject placed = place(pm, mesh, std::move(refined), obj);
  set_geometry(pm, mesh, placed, obj);
  obj.corner_slot = corner_slots(mesh, placed.refined, obj);
  obj.patch_face = placed.refined.quad_face;
  // A deforming object's flat faces keep their corners apart: faces that meet flat at a vertex now
  // may be bent apart later, and a point has one normal (refine_object refuses that).
  std::vector<int> apart(placed.normals.size(), -1);
  if (mesh.deforms)
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
      int face = placed.refined.quad_face[q - obj.patch_begin];
      if (!shaded_smooth(mesh, placed.refined, obj, q, pm.patches[q].area))
        std::fill_n(apart.begin() + 4 * (q - obj.patch_begin), 4, face);
    }
  make_points(pm, placed.normals, apart, 4 * obj.patch_begin, obj);
  if (obj.patch_end > obj.patch_begin) obj.closed_side = enclosed_side(pm, mesh, obj);
  pm.objects.push_back(std::move(obj));
  take_optics(pm, int(pm.objects.size()) - 1, materials);
}

void take_optics(PatchMesh& pm, int object, const std::vector<Material>& materials) {
  ObjectPatches& obj = pm.objects[object];
  auto of = [&](int q) {
    bool uv = !pm.uv.empty() && !std::isnan(pm.uv[4 * q].x);
    return Transmission(materials[pm.patches[q].material], obj.closed_side < 0, uv ? &pm.uv[4 * q] : nullptr);
  };
  bool passes = false;
  for (int q = obj.patch_begin; q < obj.patch_end && !passes; ++q) passes = of(q).passes();
  if (passes || !pm.transmission.empty()) {
    pm.transmission.resize(pm.patches.size());
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) pm.transmission[q] = of(q);
  }
  // Light passes into a closed glass object: its inside is lit from outside.
  obj.enclosed_side = passes ? -1 : obj.closed_side;
  enclose(pm, obj, object);
}

}  // namespace radiosity

namespace radiosity {

PlacedObject refine_object(const PatchMesh& pm, int object, const MeshDesc& mesh) {
  const ObjectPatches& obj = pm.objects.at(object);
  RefinedMesh refined = refine_patches(mesh, obj);
  bool mirrored = glm::determinant(glm::dmat3(mesh.transform)) < 0;
  if (int(refined.positions.size()) != obj.vertex_end - obj.vertex_begin ||
      int(refined.quads.size()) != obj.patch_end - obj.patch_begin || mirrored != obj.mirrored)
    throw std::invalid_argument("object '" + mesh.name +
                                "': its topology or handedness changed; it must be added anew");
  // A receiving point holds the corners that met at its vertex facing one way (make_points), and
  // keeps them: a deformation that turns one of them away (a flat floor bent into a crease) would
  // leave it gathering for the wrong normal.
  PlacedObject placed = place(pm, mesh, std::move(refined), obj);
  const std::vector<dvec3>& normals = placed.normals;
  int first_slot = 4 * obj.patch_begin;
  for (int p = obj.point_begin; p < obj.point_end; ++p) {
    const dvec3& facing = normals[pm.point_slots[pm.point_slot_begin[p]] - first_slot];
    for (int i = pm.point_slot_begin[p] + 1; i < pm.point_slot_begin[p + 1]; ++i) {
      const dvec3& n = normals[pm.point_slots[i] - first_slot];
      if (glm::length(n) > 0 && !(glm::dot(facing, n) > kSameNormal))
        throw std::invalid_argument("object '" + mesh.name +
                                    "': its deformation turns faces that met smoothly at a vertex apart (a "
                                    "crease opened); it must be added anew");
    }
  }
  return placed;
}

void place_object(PatchMesh& pm, int object, const MeshDesc& mesh, const PlacedObject& placed) {
  ObjectPatches& obj = pm.objects.at(object);
  set_geometry(pm, mesh, placed, obj);
  place_points(pm, placed.normals.data(), 4 * obj.patch_begin, obj.point_begin, obj.point_end);
  enclose(pm, obj, object);
}

}  // namespace radiosity
