#include "refine.h"

#include "radiosity/form_factor.h"

#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <unordered_map>
#include <utility>

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

// A face corner's reflectance, emission and texture coordinates, refined as one face-varying value.
struct CornerColours {
  dvec3 reflectance{0.0}, emission{0.0}, uv{0.0};
  void Clear(void* = nullptr) { reflectance = emission = uv = dvec3(0.0); }
  void AddWithWeight(const CornerColours& src, double w) {
    reflectance += w * src.reflectance;
    emission += w * src.emission;
    uv += w * src.uv;
  }
};

// Face corner k's MeshDesc values, those the mesh has.
CornerColours corner_colours(const MeshDesc& mesh, size_t k) {
  CornerColours c;
  if (!mesh.corner_reflectance.empty()) c.reflectance = mesh.corner_reflectance[k];
  if (!mesh.corner_emission.empty()) c.emission = mesh.corner_emission[k];
  if (!mesh.corner_uv.empty()) c.uv = dvec3(mesh.corner_uv[k], 0.0);
  return c;
}

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

// Where a point lies along a segment: `at` parts in kWhole of the way.
constexpr long long kWhole = 1LL << kMaxLevel;

// The points made along the segments between a mesh's vertices, shared by the faces on both sides of
// each: found by the segment and where on it they lie.
class SegmentPoints {
 public:
  // The vertex `at` along the segment from vertex a to b, made the first time by `make(a, b, t)`, t
  // along a to b (which may come swapped). A segment from a vertex to itself (a triangle's repeated
  // corner) is that vertex.
  template <class Make>
  int at(int a, int b, long long at, Make&& make) {
    if (a == b) return a;
    if (a > b) std::swap(a, b), at = kWhole - at;
    if (at == 0) return a;
    if (at == kWhole) return b;
    auto [it, fresh] = points_.try_emplace({(long long)a << 32 | b, at}, -1);
    if (fresh) it->second = make(a, b, double(at) / double(kWhole));
    return it->second;
  }

 private:
  struct Hash {
    size_t operator()(const std::pair<long long, long long>& k) const { return std::hash<long long>()(k.first * 1031 + k.second); }
  };
  std::unordered_map<std::pair<long long, long long>, int, Hash> points_;  // ((a, b), at), a < b
};

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
    if (!mesh.corner_uv.empty()) {
      auto uv = [&](int k) { return corner_colours(mesh, offset + k).uv; };
      out.corner_uv.push_back({uv(0), uv(1), uv(2), uv(n == 4 ? 3 : 2)});
    }
    offset += n;
  }
  return out;
}

// Whether refine_mesh takes the mesh to its Catmull-Clark limit surface (else splits it bilinearly).
bool to_limit_surface(const MeshDesc& mesh) { return mesh.refine == Refinement::CatmullClark && mesh.level > 0; }

// Every face through `level` steps, by OpenSubdiv.
RefinedMesh refine_uniformly(const MeshDesc& mesh, int level) {
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
  bool with_uv = !mesh.corner_uv.empty();
  bool textured = with_rho || with_emission || with_uv;
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
    for (size_t k = 0; k < mesh.face_vertices.size(); ++k) colours.push_back(corner_colours(mesh, k));
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
      if (with_uv) out.corner_uv.push_back(at(&CornerColours::uv));
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

// Bilinear refinement with a level of its own per face: each face split alone into 2^level x 2^level
// quads (an n-gon, or a triangle, first into quads about its centre, as a bilinear step makes). Where
// faces of different levels meet, the finer one's points on the edge lie on the coarser one's edge
// (T-junctions). The edge is straight, so rays find no gap along it; a receiving point there simply
// is not a corner of the coarser patch, which it sees edge-on or along its own junction.
RefinedMesh split_faces(const MeshDesc& mesh, const std::vector<int>& levels) {
  RefinedMesh out;
  out.positions = mesh.positions;
  std::vector<dvec3> normals;  // unnormalised, as OpenSubdiv's averages are
  if (any_smooth(mesh)) normals = vertex_normals(mesh);
  out.input_vertex.resize(mesh.positions.size());
  for (size_t i = 0; i < out.input_vertex.size(); ++i) out.input_vertex[i] = int(i);
  auto add_vertex = [&](const dvec3& p, const dvec3& n) {
    out.positions.push_back(p);
    if (!normals.empty()) normals.push_back(n);
    return int(out.positions.size()) - 1;
  };
  SegmentPoints on_edge;
  auto point_on = [&](int a, int b, long long at) {
    return on_edge.at(a, b, at, [&](int from, int to, double t) {
      return add_vertex((1 - t) * out.positions[from] + t * out.positions[to],
                        normals.empty() ? dvec3(0.0) : (1 - t) * normals[from] + t * normals[to]);
    });
  };
  // A quad of the face's first step: its corners, its colours there, and its sides as parts of the
  // segments they lie on (a side from corner c to c + 1 runs `from` to `to` along a to b).
  struct Side {
    int a, b;
    long long from, to;
  };
  struct Piece {
    int corner[4];
    CornerColours colour[4];
    Side side[4];
  };
  auto split = [&](const Piece& piece, int steps, int face) {
    std::vector<int> grid((steps + 1) * (steps + 1));
    auto along = [&](const Side& s, int i) { return point_on(s.a, s.b, s.from + (s.to - s.from) * i / steps); };
    dvec3 corner[4], corner_normal[4], rho[4], emission[4], uv[4];
    for (int c = 0; c < 4; ++c) {
      corner[c] = out.positions[piece.corner[c]];
      corner_normal[c] = normals.empty() ? dvec3(0.0) : normals[piece.corner[c]];
      rho[c] = piece.colour[c].reflectance, emission[c] = piece.colour[c].emission, uv[c] = piece.colour[c].uv;
    }
    for (int j = 0; j <= steps; ++j)
      for (int i = 0; i <= steps; ++i) {
        int& v = grid[j * (steps + 1) + i];
        if (j == 0) v = along(piece.side[0], i);
        else if (i == steps) v = along(piece.side[1], j);
        else if (j == steps) v = along(piece.side[2], steps - i);
        else if (i == 0) v = along(piece.side[3], steps - j);
        else {
          double u = double(i) / steps, w = double(j) / steps;
          v = add_vertex(bilinear(corner, u, w), bilinear(corner_normal, u, w));
        }
      }
    bool with_rho = !mesh.corner_reflectance.empty(), with_emission = !mesh.corner_emission.empty();
    for (int j = 0; j < steps; ++j)
      for (int i = 0; i < steps; ++i) {
        const int g[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
        std::array<int, 4> quad;
        std::array<dvec3, 4> quad_rho, quad_emission, quad_uv;
        for (int c = 0; c < 4; ++c) {
          quad[c] = grid[g[c][1] * (steps + 1) + g[c][0]];
          double u = double(g[c][0]) / steps, w = double(g[c][1]) / steps;
          quad_rho[c] = bilinear(rho, u, w), quad_emission[c] = bilinear(emission, u, w);
          quad_uv[c] = bilinear(uv, u, w);
        }
        out.quads.push_back(quad);
        out.quad_face.push_back(face);
        if (with_rho) out.corner_reflectance.push_back(quad_rho);
        if (with_emission) out.corner_emission.push_back(quad_emission);
        if (!mesh.corner_uv.empty()) out.corner_uv.push_back(quad_uv);
      }
  };

  int offset = 0;
  for (size_t f = 0; f < mesh.face_sizes.size(); ++f) {
    int n = mesh.face_sizes[f];
    const int* v = &mesh.face_vertices[offset];
    std::vector<CornerColours> colour(n);
    for (int k = 0; k < n; ++k) colour[k] = corner_colours(mesh, offset + k);
    offset += n;
    int level = levels[f];
    if (n == 4) {
      Piece face{{v[0], v[1], v[2], v[3]}, {colour[0], colour[1], colour[2], colour[3]}, {}};
      for (int c = 0; c < 4; ++c) face.side[c] = {v[c], v[(c + 1) % 4], 0, kWhole};
      split(face, 1 << level, int(f));
      continue;
    }
    if (level == 0) {  // a triangle, as copy_faces takes it
      Piece face{{v[0], v[1], v[2], v[2]}, {colour[0], colour[1], colour[2], colour[2]}, {}};
      face.side[0] = {v[0], v[1], 0, kWhole}, face.side[1] = {v[1], v[2], 0, kWhole};
      face.side[2] = {v[2], v[0], 0, 0}, face.side[3] = {v[2], v[0], 0, kWhole};
      split(face, 1, int(f));
      continue;
    }
    dvec3 centre(0.0), centre_normal(0.0);
    CornerColours mean;
    for (int k = 0; k < n; ++k) {
      centre += out.positions[v[k]] / double(n);
      if (!normals.empty()) centre_normal += normals[v[k]] / double(n);
      mean.AddWithWeight(colour[k], 1.0 / n);
    }
    int middle = add_vertex(centre, centre_normal);
    for (int k = 0; k < n; ++k) {
      int prev = v[(k + n - 1) % n], next = v[(k + 1) % n];
      int to_next = point_on(v[k], next, kWhole / 2), from_prev = point_on(prev, v[k], kWhole / 2);
      CornerColours half_next, half_prev;
      half_next.AddWithWeight(colour[k], 0.5), half_next.AddWithWeight(colour[(k + 1) % n], 0.5);
      half_prev.AddWithWeight(colour[(k + n - 1) % n], 0.5), half_prev.AddWithWeight(colour[k], 0.5);
      Piece quad{{v[k], to_next, middle, from_prev}, {colour[k], half_next, mean, half_prev}, {}};
      quad.side[0] = {v[k], next, 0, kWhole / 2};
      quad.side[1] = {to_next, middle, 0, kWhole};
      quad.side[2] = {middle, from_prev, 0, kWhole};
      quad.side[3] = {prev, v[k], kWhole / 2, kWhole};
      split(quad, 1 << (level - 1), int(f));
    }
  }
  for (const dvec3& n : normals) out.normals.push_back(unit_or_zero(n));
  return out;
}

}  // namespace

std::vector<int> face_levels(const MeshDesc& mesh, double patch_size) {
  size_t faces = mesh.face_sizes.size();
  if (mesh.refine != Refinement::Bilinear) {
    int level = to_limit_surface(mesh) ? std::min(mesh.level, kMaxLevel) : 0;
    if (level == 0 && !all_quads_or_triangles(mesh)) level = 1;
    return std::vector<int>(faces, level);
  }
  std::vector<int> levels(faces, 0);
  int offset = 0;
  for (size_t f = 0; f < faces; ++f) {
    int n = mesh.face_sizes[f];
    double longest = 0.0;
    for (int i = 0; i < n; ++i) {
      dvec3 a = dvec3(mesh.transform * glm::dvec4(mesh.positions[mesh.face_vertices[offset + i]], 1));
      dvec3 b = dvec3(mesh.transform * glm::dvec4(mesh.positions[mesh.face_vertices[offset + (i + 1) % n]], 1));
      longest = std::max(longest, glm::length(b - a));
    }
    offset += n;
    int level = patch_size > 0 && longest > patch_size
                    ? std::min(kMaxLevel, int(std::ceil(std::log2(longest / patch_size))))
                    : 0;
    levels[f] = std::max(level, n > 4 ? 1 : 0);
  }
  return levels;
}

long long quad_count(const MeshDesc& mesh, const std::vector<int>& levels) {
  // The first step splits an n-gon into n quads (a quad into 4); every later one splits each in 4.
  long long count = 0;
  for (size_t f = 0; f < mesh.face_sizes.size(); ++f)
    count += levels[f] == 0 ? 1 : mesh.face_sizes[f] * (1LL << (2 * (levels[f] - 1)));
  return count;
}

RefinedMesh refine_mesh(const MeshDesc& mesh, const std::vector<int>& levels) {
  if (levels.empty() || std::all_of(levels.begin(), levels.end(), [&](int l) { return l == levels[0]; }))
    return refine_uniformly(mesh, levels.empty() ? 0 : levels[0]);
  return split_faces(mesh, levels);
}

std::array<QuadCell, 4> children(const QuadCell& cell) {
  int d = cell.depth + 1, i = 2 * cell.i, j = 2 * cell.j;
  return {QuadCell{cell.quad, d, i, j}, QuadCell{cell.quad, d, i + 1, j}, QuadCell{cell.quad, d, i + 1, j + 1},
          QuadCell{cell.quad, d, i, j + 1}};
}

RefinedMesh split_cells(const RefinedMesh& base, const std::vector<QuadCell>& cells) {
  RefinedMesh out;
  out.positions = base.positions;
  out.normals = base.normals;
  out.input_vertex = base.input_vertex;
  bool with_rho = !base.corner_reflectance.empty(), with_emission = !base.corner_emission.empty();
  bool with_uv = !base.corner_uv.empty();
  auto add_vertex = [&](const dvec3& p, const dvec3& n) {
    out.positions.push_back(p);
    if (!out.normals.empty()) out.normals.push_back(unit_or_zero(n));
    return int(out.positions.size()) - 1;
  };
  SegmentPoints on_sides;
  struct InsideHash {
    size_t operator()(const std::array<long long, 3>& k) const {
      return std::hash<long long>()((k[0] * 1031 + k[1]) * 1031 + k[2]);
    }
  };
  std::unordered_map<std::array<long long, 3>, int, InsideHash> inside;  // (quad, u, v) in kWhole parts
  // The vertex at (u, v) of quad q, in kWhole parts: on a side, shared with the quad across it.
  auto vertex_at = [&](int q, long long u, long long v) {
    const std::array<int, 4>& c = base.quads[q];
    auto make = [&](int from, int to, double t) {
      return add_vertex((1 - t) * out.positions[from] + t * out.positions[to],
                        out.normals.empty() ? dvec3(0.0) : (1 - t) * out.normals[from] + t * out.normals[to]);
    };
    if (v == 0) return on_sides.at(c[0], c[1], u, make);
    if (u == kWhole) return on_sides.at(c[1], c[2], v, make);
    if (v == kWhole) return on_sides.at(c[2], c[3], kWhole - u, make);
    if (u == 0) return on_sides.at(c[3], c[0], kWhole - v, make);
    auto [it, fresh] = inside.try_emplace({q, u, v}, -1);
    if (fresh) {
      dvec3 corner[4], normal[4];
      for (int k = 0; k < 4; ++k) {
        corner[k] = base.positions[c[k]];
        normal[k] = out.normals.empty() ? dvec3(0.0) : base.normals[c[k]];
      }
      double s = double(u) / kWhole, t = double(v) / kWhole;
      it->second = add_vertex(bilinear(corner, s, t), bilinear(normal, s, t));
    }
    return it->second;
  };
  for (const QuadCell& cell : cells) {
    if (cell.depth < 0 || cell.depth > kMaxCellDepth || cell.quad < 0 || cell.quad >= int(base.quads.size()))
      throw std::invalid_argument("split_cells: a cell outside its quad's quadtree");
    long long step = kWhole >> cell.depth;
    const long long corner_uv[4][2] = {{cell.i * step, cell.j * step},
                                       {(cell.i + 1) * step, cell.j * step},
                                       {(cell.i + 1) * step, (cell.j + 1) * step},
                                       {cell.i * step, (cell.j + 1) * step}};
    std::array<int, 4> quad;
    std::array<dvec3, 4> rho, emission, uv;
    for (int k = 0; k < 4; ++k) {
      long long u = corner_uv[k][0], v = corner_uv[k][1];
      quad[k] = vertex_at(cell.quad, u, v);
      double s = double(u) / kWhole, t = double(v) / kWhole;
      if (with_rho) rho[k] = bilinear(base.corner_reflectance[cell.quad].data(), s, t);
      if (with_emission) emission[k] = bilinear(base.corner_emission[cell.quad].data(), s, t);
      if (with_uv) uv[k] = bilinear(base.corner_uv[cell.quad].data(), s, t);
    }
    out.quads.push_back(quad);
    out.quad_face.push_back(base.quad_face[cell.quad]);
    if (with_rho) out.corner_reflectance.push_back(rho);
    if (with_emission) out.corner_emission.push_back(emission);
    if (with_uv) out.corner_uv.push_back(uv);
  }
  return out;
}

}  // namespace radiosity
