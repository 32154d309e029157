#include "patch_mesh.h"

#include "refine.h"

#include <algorithm>
#include <cmath>

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

// Adds one object's refined patches; points are made afterwards from the corners.
void add_patches(PatchMesh& pm, const MeshDesc& mesh, const RefinedMesh& refined, int object,
                 std::vector<dvec3>& corner_normals) {
  int base = int(pm.vertices.size());
  for (const dvec3& p : refined.positions) pm.vertices.push_back(transform_point(mesh.transform, p) - pm.origin);
  glm::dmat3 linear(mesh.transform);
  bool mirrored = glm::determinant(linear) < 0;
  glm::dmat3 normal_matrix = glm::transpose(glm::inverse(linear));

  for (size_t q = 0; q < refined.quads.size(); ++q) {
    std::array<int, 4> v = refined.quads[q];
    if (mirrored) std::swap(v[1], v[3]);  // keep counter-clockwise = front after a mirroring transform
    Patch patch;
    for (int c = 0; c < 4; ++c) patch.vertex[c] = base + v[c];
    const dvec3* p[4];
    for (int c = 0; c < 4; ++c) p[c] = &pm.vertices[patch.vertex[c]];
    dvec3 va = 0.5 * glm::cross(*p[2] - *p[0], *p[3] - *p[1]);
    patch.area = glm::length(va);
    patch.centre = 0.25 * (*p[0] + *p[1] + *p[2] + *p[3]);
    patch.material = mesh.face_materials[refined.quad_face[q]];
    patch.object = object;
    if (!(patch.area > 1e-14 * pm.diagonal * pm.diagonal)) {
      patch.area = 0.0;
      ++pm.degenerate_patches;
    } else {
      patch.normal = va / patch.area;
    }
    for (int c = 0; c < 4; ++c) {
      dvec3 n = patch.normal;
      if (!refined.normals.empty() && patch.area > 0) {
        dvec3 smooth = normal_matrix * refined.normals[v[c]];
        if (glm::length(smooth) > 0) n = glm::normalize(smooth);
      }
      corner_normals.push_back(n);
    }
    pm.patches.push_back(patch);
  }
}

// Groups the corners at each vertex into receiving points by normal.
void make_points(PatchMesh& pm, const std::vector<dvec3>& corner_normals) {
  int slots = int(pm.patches.size()) * 4;
  std::vector<int> by_vertex(slots);
  for (int s = 0; s < slots; ++s) by_vertex[s] = s;
  std::stable_sort(by_vertex.begin(), by_vertex.end(), [&](int a, int b) {
    return pm.patches[a / 4].vertex[a % 4] < pm.patches[b / 4].vertex[b % 4];
  });
  std::vector<int> slot_point(slots, -1);
  std::vector<dvec3> centre_sum;
  std::vector<int> centre_count;
  for (int i = 0; i < slots;) {
    int vertex = pm.patches[by_vertex[i] / 4].vertex[by_vertex[i] % 4];
    int first_point = int(pm.points.size());
    int j = i;
    for (; j < slots && pm.patches[by_vertex[j] / 4].vertex[by_vertex[j] % 4] == vertex; ++j) {
      int s = by_vertex[j];
      const dvec3& n = corner_normals[s];
      int chosen = -1;
      for (int p = first_point; p < int(pm.points.size()) && chosen < 0; ++p)
        if (glm::length(n) == 0 || glm::dot(pm.points[p].normal, n) > kSameNormal) chosen = p;
      if (chosen < 0) {
        chosen = int(pm.points.size());
        pm.points.push_back({pm.vertices[vertex], n});
        centre_sum.push_back(dvec3(0.0));
        centre_count.push_back(0);
      }
      slot_point[s] = chosen;
      const Patch& patch = pm.patches[s / 4];
      if (patch.area > 0) {
        centre_sum[chosen] += patch.centre;
        ++centre_count[chosen];
      }
    }
    i = j;
  }
  for (size_t p = 0; p < pm.points.size(); ++p)
    if (centre_count[p] > 0) {
      ReceiverPoint& rp = pm.points[p];
      // Along the tangent plane only: on a curved surface the patch centres lie below it, and a
      // point moved towards them would sit inside the tessellated surface, shadowed by itself.
      dvec3 towards = centre_sum[p] / double(centre_count[p]) - rp.position;
      rp.position += kInwardNudge * (towards - glm::dot(towards, rp.normal) * rp.normal);
    }

  pm.point_slot_begin.assign(pm.points.size() + 1, 0);
  for (int s = 0; s < slots; ++s) {
    pm.patches[s / 4].point[s % 4] = slot_point[s];
    ++pm.point_slot_begin[slot_point[s] + 1];
  }
  for (size_t p = 0; p < pm.points.size(); ++p) pm.point_slot_begin[p + 1] += pm.point_slot_begin[p];
  pm.point_slots.resize(slots);
  std::vector<int> fill(pm.point_slot_begin.begin(), pm.point_slot_begin.end() - 1);
  for (int s = 0; s < slots; ++s) pm.point_slots[fill[slot_point[s]]++] = s;
}

// For each input face corner, the patch corner at the same place.
std::vector<int> corner_slots(const MeshDesc& mesh, const RefinedMesh& refined, int patch_begin) {
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
            slot = (patch_begin + q) * 4 + c;
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

PatchMesh build_patch_mesh(const SceneDesc& scene, const Settings& settings) {
  PatchMesh pm;
  dvec3 lo, hi;
  scene_bounds(scene, lo, hi);
  if (lo.x <= hi.x) {
    pm.origin = 0.5 * (lo + hi);
    double d = glm::length(hi - lo);
    pm.diagonal = d > 0 ? d : 1.0;
  }
  std::vector<dvec3> corner_normals;
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const MeshDesc& mesh = scene.meshes[i];
    double patch_size = mesh.patch_size > 0 ? mesh.patch_size
                                            : settings.patch_size_relative * pm.diagonal;
    RefinedMesh refined = refine_mesh(mesh, bilinear_level(mesh, patch_size));
    ObjectPatches obj;
    obj.patch_begin = int(pm.patches.size());
    add_patches(pm, mesh, refined, int(i), corner_normals);
    obj.patch_end = int(pm.patches.size());
    obj.corner_slot = corner_slots(mesh, refined, obj.patch_begin);
    pm.objects.push_back(std::move(obj));
  }
  make_points(pm, corner_normals);
  // Points are made vertex by vertex and vertices object by object, so each object's points are a range.
  for (ObjectPatches& obj : pm.objects) {
    obj.point_begin = int(pm.points.size());
    obj.point_end = 0;
    for (int p = obj.patch_begin; p < obj.patch_end; ++p)
      for (int c = 0; c < 4; ++c) {
        obj.point_begin = std::min(obj.point_begin, pm.patches[p].point[c]);
        obj.point_end = std::max(obj.point_end, pm.patches[p].point[c] + 1);
      }
    if (obj.point_end == 0) obj.point_begin = 0;
  }
  return pm;
}

}  // namespace radiosity
