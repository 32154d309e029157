#include "refine.h"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

namespace radiosity {

namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

namespace {

constexpr int kMaxLevel = 10;  // 4^10 patches per input quad: far past any sane request

// The primvar type OpenSubdiv interpolates.
struct Point3 {
  dvec3 p{0.0};
  void Clear(void* = nullptr) { p = dvec3(0.0); }
  void AddWithWeight(const Point3& src, double w) { p += w * src.p; }
};

// A face corner's reflectance and emission, refined as one face-varying value.
struct CornerColours {
  dvec3 reflectance{0.0}, emission{0.0};
  void Clear(void* = nullptr) { reflectance = emission = dvec3(0.0); }
  void AddWithWeight(const CornerColours& src, double w) {
    reflectance += w * src.reflectance;
    emission += w * src.emission;
  }
};

bool all_quads_or_triangles(const MeshDesc& mesh) {
  return std::all_of(mesh.face_sizes.begin(), mesh.face_sizes.end(),
                     [](int n) { return n == 3 || n == 4; });
}

dvec3 unit_or_zero(const dvec3& v) {
  double length = glm::length(v);
  return length > 0 ? v / length : dvec3(0.0);
}

bool any_smooth(const MeshDesc& mesh) {
  for (size_t f = 0; f < mesh.face_sizes.size(); ++f)
    if (mesh.smooth(int(f))) return true;
  return false;
}

// Blender's vertex normals: the normals of the faces round a vertex, each weighted by its angle
// there, flat faces included (mesh_normals.cc). Unit, or zero where every face round it is degenerate.
std::vector<dvec3> vertex_normals(const MeshDesc& mesh) {
  std::vector<dvec3> sum(mesh.positions.size(), dvec3(0.0));
  int offset = 0;
  for (int n : mesh.face_sizes) {
    const int* v = &mesh.face_vertices[offset];
    offset += n;
    // Newell's normal (any polygon), about its first corner: far from the origin, products of
    // absolute positions would cancel.
    const dvec3& origin = mesh.positions[v[0]];
    dvec3 normal(0.0);
    for (int i = 1; i + 1 < n; ++i)
      normal += glm::cross(mesh.positions[v[i]] - origin, mesh.positions[v[i + 1]] - origin);
    normal = unit_or_zero(normal);
    for (int i = 0; i < n; ++i) {
      dvec3 a = mesh.positions[v[(i + n - 1) % n]] - mesh.positions[v[i]];
      dvec3 b = mesh.positions[v[(i + 1) % n]] - mesh.positions[v[i]];
      double la = glm::length(a), lb = glm::length(b);
      if (la > 0 && lb > 0) sum[v[i]] += std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0)) * normal;
    }
  }
  for (dvec3& n : sum) n = unit_or_zero(n);
  return sum;
}

// Faces taken as they are: no OpenSubdiv needed.
RefinedMesh copy_faces(const MeshDesc& mesh) {
  RefinedMesh out;
  out.positions = mesh.positions;
  if (any_smooth(mesh)) out.normals = vertex_normals(mesh);
  out.input_vertex.resize(mesh.positions.size());
  for (size_t i = 0; i < out.input_vertex.size(); ++i) out.input_vertex[i] = int(i);
  int offset = 0;
  for (size_t f = 0; f < mesh.face_sizes.size(); ++f) {
    const int* v = &mesh.face_vertices[offset];
    int n = mesh.face_sizes[f];
    out.quads.push_back({v[0], v[1], v[2], n == 4 ? v[3] : v[2]});
    out.quad_face.push_back(int(f));
    auto corners = [&](const std::vector<dvec3>& values, std::vector<std::array<dvec3, 4>>& to) {
      if (values.empty()) return;
      const dvec3* c = &values[offset];
      to.push_back({c[0], c[1], c[2], n == 4 ? c[3] : c[2]});
    };
    corners(mesh.corner_reflectance, out.corner_reflectance);
    corners(mesh.corner_emission, out.corner_emission);
    offset += n;
  }
  return out;
}

// Whether refine_mesh takes the mesh to its Catmull-Clark limit surface (else splits it bilinearly).
bool to_limit_surface(const MeshDesc& mesh) { return mesh.refine == Refinement::CatmullClark && mesh.level > 0; }

}  // namespace

int bilinear_level(const MeshDesc& mesh, double patch_size) {
  if (!(patch_size > 0)) return 0;
  double longest = 0.0;
  int offset = 0;
  for (int n : mesh.face_sizes) {
    for (int i = 0; i < n; ++i) {
      dvec3 a = dvec3(mesh.transform * glm::dvec4(mesh.positions[mesh.face_vertices[offset + i]], 1));
      dvec3 b = dvec3(mesh.transform *
                      glm::dvec4(mesh.positions[mesh.face_vertices[offset + (i + 1) % n]], 1));
      longest = std::max(longest, glm::length(b - a));
    }
    offset += n;
  }
  if (longest <= patch_size) return 0;
  return std::min(kMaxLevel, int(std::ceil(std::log2(longest / patch_size))));
}

int refinement_level(const MeshDesc& mesh, int bilinear_levels) {
  int level = to_limit_surface(mesh) ? std::min(mesh.level, kMaxLevel)
              : mesh.refine == Refinement::Bilinear ? bilinear_levels
                                                    : 0;
  // n-gons need one bilinear step to become quads.
  if (level == 0 && !all_quads_or_triangles(mesh)) level = 1;
  return level;
}

long long quad_count(const MeshDesc& mesh, int bilinear_levels) {
  int level = refinement_level(mesh, bilinear_levels);
  if (level == 0) return (long long)mesh.face_sizes.size();
  // The first level splits an n-gon into n quads (a quad into 4); every later one splits each in 4.
  long long after_first = 1LL << (2 * (level - 1));
  long long count = 0;
  for (int n : mesh.face_sizes) count += n * after_first;
  return count;
}

RefinedMesh refine_mesh(const MeshDesc& mesh, int bilinear_levels) {
  int level = refinement_level(mesh, bilinear_levels);
  bool smooth = to_limit_surface(mesh);
  if (level == 0) return copy_faces(mesh);

  Far::TopologyDescriptor desc;
  desc.numVertices = int(mesh.positions.size());
  desc.numFaces = int(mesh.face_sizes.size());
  desc.numVertsPerFace = mesh.face_sizes.data();
  desc.vertIndicesPerFace = mesh.face_vertices.data();

  // Corner reflectance and emission are face-varying: each face corner a value of its own,
  // interpolated linearly inside its face (as Cycles interpolates a texture's colours between
  // samples). One channel carries both.
  std::vector<int> corner_index;
  Far::TopologyDescriptor::FVarChannel corners;
  bool with_rho = !mesh.corner_reflectance.empty(), with_emission = !mesh.corner_emission.empty();
  bool textured = with_rho || with_emission;
  if (textured) {
    corner_index.resize(mesh.face_vertices.size());
    for (size_t k = 0; k < corner_index.size(); ++k) corner_index[k] = int(k);
    corners.numValues = int(corner_index.size());
    corners.valueIndices = corner_index.data();
    desc.numFVarChannels = 1;
    desc.fvarChannels = &corners;
  }

  Sdc::Options sdc;
  // Blender's Subdivision Surface default ("Keep Corners").
  sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  sdc.SetFVarLinearInterpolation(Sdc::Options::FVAR_LINEAR_ALL);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> refiner(Factory::Create(
      desc, Factory::Options(smooth ? Sdc::SCHEME_CATMARK : Sdc::SCHEME_BILINEAR, sdc)));
  if (!refiner) throw std::invalid_argument("OpenSubdiv rejected the topology of '" + mesh.name + "'");
  Far::TopologyRefiner::UniformOptions uniform(level);
  uniform.fullTopologyInLastLevel = true;  // limit positions and normals need it
  refiner->RefineUniform(uniform);

  // Interpolate positions level by level, following vertices and faces back to the input. Smooth
  // faces of a bilinear refinement shade with the input's vertex normals interpolated as Cycles
  // interpolates them across a face.
  std::vector<Point3> current(mesh.positions.size());
  for (size_t i = 0; i < current.size(); ++i) current[i].p = mesh.positions[i];
  std::vector<Point3> normals;
  if (!smooth && any_smooth(mesh)) {
    std::vector<dvec3> input = vertex_normals(mesh);
    normals.resize(input.size());
    for (size_t i = 0; i < input.size(); ++i) normals[i].p = input[i];
  }
  std::vector<CornerColours> colours;
  if (textured)
    for (size_t k = 0; k < mesh.face_vertices.size(); ++k)
      colours.push_back({with_rho ? mesh.corner_reflectance[k] : dvec3(0.0),
                         with_emission ? mesh.corner_emission[k] : dvec3(0.0)});
  std::vector<int> vertex_map(mesh.positions.size());
  for (size_t i = 0; i < vertex_map.size(); ++i) vertex_map[i] = int(i);
  Far::PrimvarRefinerReal<double> primvar(*refiner);
  for (int l = 1; l <= level; ++l) {
    std::vector<Point3> next(refiner->GetLevel(l).GetNumVertices());
    primvar.Interpolate(l, current, next);
    current.swap(next);
    if (!normals.empty()) {
      std::vector<Point3> next_normals(current.size());
      primvar.Interpolate(l, normals, next_normals);
      normals.swap(next_normals);
    }
    if (textured) {
      std::vector<CornerColours> next_colours(refiner->GetLevel(l).GetNumFVarValues(0));
      primvar.InterpolateFaceVarying(l, colours, next_colours);
      colours.swap(next_colours);
    }
    const Far::TopologyLevel& parent = refiner->GetLevel(l - 1);
    for (int& v : vertex_map) v = parent.GetVertexChildVertex(v);
  }

  RefinedMesh out;
  out.input_vertex = vertex_map;
  const Far::TopologyLevel& last = refiner->GetLevel(level);
  out.quads.resize(last.GetNumFaces());
  out.quad_face.resize(last.GetNumFaces());
  for (int f = 0; f < last.GetNumFaces(); ++f) {
    Far::ConstIndexArray fv = last.GetFaceVertices(f);
    out.quads[f] = {fv[0], fv[1], fv[2], fv[3]};
    if (textured) {
      Far::ConstIndexArray fvar = last.GetFaceFVarValues(f, 0);
      auto at = [&](dvec3 CornerColours::*which) {
        return std::array<dvec3, 4>{colours[fvar[0]].*which, colours[fvar[1]].*which, colours[fvar[2]].*which,
                                    colours[fvar[3]].*which};
      };
      if (with_rho) out.corner_reflectance.push_back(at(&CornerColours::reflectance));
      if (with_emission) out.corner_emission.push_back(at(&CornerColours::emission));
    }
    int parent = f;
    for (int l = level; l > 0; --l) parent = refiner->GetLevel(l).GetFaceParentFace(parent);
    out.quad_face[f] = parent;
  }

  out.positions.resize(current.size());
  if (smooth) {
    std::vector<Point3> limit(current.size()), du(current.size()), dv(current.size());
    primvar.Limit(current, limit, du, dv);
    // The tangents' handedness at a vertex is OpenSubdiv's choice: orient each normal by the
    // winding of the refined faces around it, which is what says where the front is.
    std::vector<dvec3> winding(current.size(), dvec3(0.0));
    for (const auto& q : out.quads) {
      dvec3 n = glm::cross(limit[q[2]].p - limit[q[0]].p, limit[q[3]].p - limit[q[1]].p);
      for (int v : q) winding[v] += n;
    }
    out.normals.resize(current.size());
    for (size_t i = 0; i < current.size(); ++i) {
      out.positions[i] = limit[i].p;
      dvec3 n = unit_or_zero(glm::cross(du[i].p, dv[i].p));
      out.normals[i] = glm::dot(n, winding[i]) < 0 ? -n : n;
    }
  } else {
    for (size_t i = 0; i < current.size(); ++i) out.positions[i] = current[i].p;
    for (const Point3& n : normals) out.normals.push_back(unit_or_zero(n.p));
  }
  return out;
}

}  // namespace radiosity
