// Light at any points of an object's surface (lightmap texels), not only at its patch corners.
//
// Interpolating a patch's corners smooths away every shadow and hot spot smaller than the patch. So
// a point gathers its own direct light (lamps, sky, emitters, with its own visibility), at the
// solve's direct sampling; the reflected light, which changes slowly across a surface, is the
// solution's, interpolated within the patch that holds the point from the corners the point sees.
#include "solver_impl.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <unordered_map>

namespace radiosity {

namespace {

// Where a point lies on a bilinear patch p0..p3 (counter-clockwise): the (u, v) in [0, 1]^2 whose
// place is nearest, by Gauss-Newton from the centre (a patch is flat or nearly so: a few steps).
struct OnPatch {
  double u = 0.5, v = 0.5, distance = std::numeric_limits<double>::infinity();
};

OnPatch locate(const dvec3 (&p)[4], const dvec3& x) {
  OnPatch at;
  auto place = [&](double u, double v) {
    return (1 - u) * (1 - v) * p[0] + u * (1 - v) * p[1] + u * v * p[2] + (1 - u) * v * p[3];
  };
  for (int step = 0; step < 6; ++step) {
    dvec3 r = place(at.u, at.v) - x;
    dvec3 du = (1 - at.v) * (p[1] - p[0]) + at.v * (p[2] - p[3]);
    dvec3 dv = (1 - at.u) * (p[3] - p[0]) + at.u * (p[2] - p[1]);
    double a = glm::dot(du, du), b = glm::dot(du, dv), c = glm::dot(dv, dv);
    double det = a * c - b * b;
    if (!(det > 0)) break;
    double gu = glm::dot(du, r), gv = glm::dot(dv, r);
    at.u = std::clamp(at.u - (c * gu - b * gv) / det, 0.0, 1.0);
    at.v = std::clamp(at.v - (a * gv - b * gu) / det, 0.0, 1.0);
  }
  at.distance = glm::length(place(at.u, at.v) - x);
  return at;
}

// An object's patches by input face, and a uniform grid over them for finding the few a point may
// lie on: a floor face refined into thousands of patches is not searched whole for each texel.
class PatchFinder {
 public:
  PatchFinder(const PatchMesh& mesh, const ObjectPatches& obj, int faces)
      : mesh_(mesh), obj_(obj), by_face_(faces) {
    int count = obj.patch_end - obj.patch_begin;
    double size = 0.0;
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) size += std::sqrt(mesh.patches[q].area);
    cell_ = count > 0 && size > 0 ? 2.0 * size / count : mesh.diagonal;
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) {
      dvec3 lo(INFINITY), hi(-INFINITY);
      for (int v : mesh.patches[q].vertex) lo = glm::min(lo, mesh.vertices[v]), hi = glm::max(hi, mesh.vertices[v]);
      // Widened a little: a flat patch lying on a cell boundary (a floor at z = 0) is found from
      // points a rounding off its plane on either side.
      dvec3 pad(1e-6 * cell_);
      glm::ivec3 a = cell(lo - pad), b = cell(hi + pad);
      for (int i = a.x; i <= b.x; ++i)
        for (int j = a.y; j <= b.y; ++j)
          for (int k = a.z; k <= b.z; ++k) grid_[key({i, j, k})].push_back(q);
    }
    for (int q = obj.patch_begin; q < obj.patch_end; ++q) by_face_[obj.patch_face[q - obj.patch_begin]].push_back(q);
  }

  // The patch of face `face` nearest x (frame of the patch mesh), and where on it; -1 if the face has none.
  std::pair<int, OnPatch> find(int face, const dvec3& x) const {
    std::pair<int, OnPatch> best{-1, {}};
    auto consider = [&](int q) {
      if (obj_.patch_face[q - obj_.patch_begin] != face) return;
      OnPatch at = on(q, x);
      if (at.distance < best.second.distance) best = {q, at};
    };
    if (auto it = grid_.find(key(cell(x))); it != grid_.end())
      for (int q : it->second) consider(q);
    // Off its face's patches (a curved face's cage, round-off at an edge): the nearest of them all.
    if (best.first < 0)
      for (int q : by_face_[face]) consider(q);
    // A coincident copy takes no part in the lighting: the point is on the patch it copies
    // (coincident_patches.h), whose corners may come in another order.
    if (best.first >= 0 && mesh_.patches[best.first].copy_of >= 0) {
      int original = mesh_.patches[best.first].copy_of;
      best = {original, on(original, x)};
    }
    return best;
  }

 private:
  OnPatch on(int q, const dvec3& x) const {
    dvec3 p[4];
    for (int c = 0; c < 4; ++c) p[c] = mesh_.vertices[mesh_.patches[q].vertex[c]];
    return locate(p, x);
  }
  glm::ivec3 cell(const dvec3& x) const { return glm::ivec3(glm::floor(x / cell_)); }
  static uint64_t key(const glm::ivec3& c) {
    return (uint64_t(uint32_t(c.x) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y) & 0x1fffff) << 21) |
           uint64_t(uint32_t(c.z) & 0x1fffff);
  }
  const PatchMesh& mesh_;
  const ObjectPatches& obj_;
  std::vector<std::vector<int>> by_face_;
  double cell_;
  std::unordered_map<uint64_t, std::vector<int>> grid_;
};

// A patch's corners' reflected light differs by more than this part of the brightest: a point
// interpolates it only from the corners it sees (reflected_at).
constexpr double kReflectedContrast = 0.02;

// The solution's reflected light at point y (normal n) of patch `patch`, interpolated by weights w
// from the corners y sees along the surface. A patch that crosses the foot of a box standing on it
// has corners under the box, shut off from the light, and corners outside: a point outside takes
// the light of those outside, a point under the box that of those under it, as a ray tracer's
// point under the box sees only the box's dark inside. A point that sees none of its corners lies
// in a pocket they are shut out of: it reflects none. Corners of about equal light are all taken.
dvec3 reflected_at(const PatchMesh& mesh, const std::vector<dvec3>& reflected, const Visibility* vis,
                   const Patch& patch, const double (&w)[4], const dvec3& y, const dvec3& n) {
  dvec3 corner[4];
  double lo = INFINITY, hi = 0.0;
  for (int c = 0; c < 4; ++c) {
    corner[c] = reflected[patch.point[c]];
    double sum = corner[c].x + corner[c].y + corner[c].z;
    lo = std::min(lo, sum), hi = std::max(hi, sum);
  }
  dvec3 all(0.0), seen(0.0);
  double weight = 0.0;
  for (int c = 0; c < 4; ++c) all += w[c] * corner[c];
  if (!(hi - lo > kReflectedContrast * hi) || !vis) return all;
  for (int c = 0; c < 4; ++c) {
    if (w[c] <= 0) continue;
    const ReceiverPoint& p = mesh.points[patch.point[c]];
    if (vis->connected(y, n, p.position, glm::length(p.normal) > 0 ? p.normal : n)) {
      seen += w[c] * corner[c];
      weight += w[c];
    }
  }
  return weight > 0 ? seen / weight : dvec3(0.0);
}

// How near a patch corner, in the patch's (u, v), a point takes after the corner's receiving point.
constexpr double kCornerReach = 0.01;
// Points whose direct light one batch of rays gathers: a lamp's shadow rays go to Embree together.
constexpr int kBlock = 64;

}  // namespace

std::vector<float> Solver::surface_radiance(int object, const std::vector<int>& faces,
                                            const std::vector<dvec3>& positions) const {
  const Impl& s = *impl_;
  const MeshDesc& desc = s.scene.meshes.at(object);
  const ObjectPatches& obj = s.mesh.objects.at(object);
  if (faces.size() != positions.size())
    throw std::invalid_argument("surface_radiance: " + std::to_string(faces.size()) + " faces for " +
                                std::to_string(positions.size()) + " positions");
  int face_count = int(desc.face_sizes.size());
  for (int f : faces)
    if (f < 0 || f >= face_count)
      throw std::invalid_argument("surface_radiance: face " + std::to_string(f) + " of object '" + desc.name +
                                  "', which has " + std::to_string(face_count));
  int count = int(faces.size());
  // A hidden object takes no part: no light, no emission.
  if (!desc.visible || count == 0) return std::vector<float>(3 * size_t(count), 0.0f);
  return impl_->workers.run([&] {
    PatchFinder finder(s.mesh, obj, face_count);
    std::vector<Source> sources = s.injected ? s.direct_sources() : std::vector<Source>{};
    // Per point: where it lies and what it reflects, then its direct light. Its light so far is
    // emission + reflectance x reflected; `at` is where it gathers (normal zero: on no patch).
    std::vector<ReceiverPoint> at(count);
    std::vector<dvec3> reflectance(count, dvec3(0.0)), light(count, dvec3(0.0));
    parallel_for(0, count, 64, [&](int i) {
      dvec3 x = dvec3(desc.transform * glm::dvec4(positions[i], 1.0)) - s.mesh.origin;
      auto [q, on] = finder.find(faces[i], x);
      if (q < 0 || s.mesh.patches[q].area == 0) return;
      const Patch& patch = s.mesh.patches[q];
      double w[4] = {(1 - on.u) * (1 - on.v), on.u * (1 - on.v), on.u * on.v, (1 - on.u) * on.v};
      dvec3 y(0.0), normal(0.0), emission(0.0);
      for (int c = 0; c < 4; ++c) {
        y += w[c] * s.mesh.vertices[patch.vertex[c]];
        normal += w[c] * s.mesh.points[patch.point[c]].normal;
        emission += w[c] * s.mesh.emission[4 * q + c];
        reflectance[i] += w[c] * s.mesh.reflectance[4 * q + c];
      }
      dvec3 n = glm::length(normal) > 0 ? glm::normalize(normal) : patch.normal;
      dvec3 reflected = reflected_at(s.mesh, s.reflected_front, s.vis.get(), patch, w, y, n);
      // Right by a patch corner the point slides onto the corner's receiving point, which is nudged
      // into its patches (patch_mesh.cpp): at a face corner a texel then reads what the corner does.
      int c = (on.u < 0.5 ? (on.v < 0.5 ? 0 : 3) : (on.v < 0.5 ? 1 : 2));
      double off = std::max(std::min(on.u, 1 - on.u), std::min(on.v, 1 - on.v));
      double onto = std::max(0.0, 1.0 - off / kCornerReach);
      // A point inside a twisted patch (a curved surface's) may lie behind the two triangles Embree
      // traces for it: lifted off it as far as it lies off them, its rays leave in front of them.
      dvec3 corners[4];
      for (int k = 0; k < 4; ++k) corners[k] = s.mesh.vertices[patch.vertex[k]];
      double lift = bilinear_lift(bilinear_twist(corners, patch.normal), on.u, on.v);
      at[i].position = y + onto * (s.mesh.points[patch.point[c]].position - y) + lift * n;
      at[i].normal = n;
      light[i] = emission + reflectance[i] * reflected;
    });
    // Direct light, a block of points to a batch of rays: each gathers under an index past every
    // receiving point's, so no patch takes it for one of its corners (as Impl::light_at).
    if (!sources.empty()) {
      int base = int(s.mesh.points.size());
      parallel_for(0, (count + kBlock - 1) / kBlock, 1, [&](int b) {
        int first = b * kBlock, last = std::min(count, first + kBlock);
        std::vector<dvec3> front(last - first, dvec3(0.0)), back(last - first, dvec3(0.0));
        {
          OcclusionBatch batch(*s.vis, front.data(), back.data(), base + first);
          for (int i = first; i < last; ++i)
            if (at[i].normal != dvec3(0.0))
              for (const Source& source : sources) source.gather(base + i, at[i], batch);
        }  // flushed
        for (int i = first; i < last; ++i) light[i] += reflectance[i] * front[i - first];
      });
    }
    std::vector<float> out(3 * size_t(count), 0.0f);
    for (int i = 0; i < count; ++i) {
      dvec3 b = glm::max(light[i], dvec3(0.0));  // round-off negatives
      for (int k = 0; k < 3; ++k) out[3 * size_t(i) + k] = float(b[k]);
    }
    return out;
  });
}

}  // namespace radiosity
