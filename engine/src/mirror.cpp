#include "mirror.h"

#include "visibility.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

namespace radiosity {

namespace {

// Patches of one plane: normals within about 1e-3 radians, offsets within this part of the scene.
constexpr double kSameNormal = 1.0 - 5e-7;
constexpr double kSameOffset = 1e-5;
// A rough specular lobe added to the diffuse one stays below this: light must not go round for ever.
constexpr double kMostDiffuse = 0.99;

}  // namespace

bool is_mirror(const Material& m) {
  return m.roughness <= kMirrorRoughness && (m.specular.x > 0 || m.specular.y > 0 || m.specular.z > 0);
}

dvec3 diffuse_reflectance(const Material& m, bool curved) {
  if (m.roughness <= kMirrorRoughness && !curved) return m.reflectance;
  return glm::max(m.reflectance, glm::min(m.reflectance + m.specular, dvec3(kMostDiffuse)));
}

MirrorPlane::MirrorPlane(std::shared_ptr<RTCDeviceTy> device, const PatchMesh& mesh, const std::vector<int>& patches,
                         const dvec3& reflectance)
    : device_(std::move(device)), reflectance_(reflectance), patches_(patches) {
  // The plane through the patches' area-weighted centre, along their area-weighted normal.
  dvec3 centre(0.0), normal(0.0);
  double area = 0.0;
  for (int p : patches) {
    const Patch& patch = mesh.patches[p];
    centre += patch.area * patch.centre, normal += patch.area * patch.normal, area += patch.area;
  }
  origin_ = centre / area;
  normal_ = glm::normalize(normal);
  bounds_ = {origin_, 0.0};
  for (int p : patches)
    for (int v : mesh.patches[p].vertex) bounds_.radius = std::max(bounds_.radius, glm::length(mesh.vertices[v] - origin_));
  outline_ = rtcNewScene(device_.get());
  RTCGeometry geom = patch_quads(device_.get(), mesh, patches);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(outline_, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(outline_);
}

MirrorPlane::~MirrorPlane() {
  if (outline_) rtcReleaseScene(outline_);
}

Symmetric3 MirrorPlane::reflect(const Symmetric3& s) const {
  // M = I - 2 n n^T, so M S M = S - 2 (n w^T + w n^T) + 4 (n.w) n n^T with w = S n.
  const dvec3& n = normal_;
  dvec3 w = s * n;
  double nw = glm::dot(n, w);
  Symmetric3 r;
  r.xx = s.xx - 4 * n.x * w.x + 4 * nw * n.x * n.x;
  r.yy = s.yy - 4 * n.y * w.y + 4 * nw * n.y * n.y;
  r.zz = s.zz - 4 * n.z * w.z + 4 * nw * n.z * n.z;
  r.xy = s.xy - 2 * (n.x * w.y + w.x * n.y) + 4 * nw * n.x * n.y;
  r.xz = s.xz - 2 * (n.x * w.z + w.x * n.z) + 4 * nw * n.x * n.z;
  r.yz = s.yz - 2 * (n.y * w.z + w.y * n.z) + 4 * nw * n.y * n.z;
  return r;
}

double MirrorPlane::crossing(const dvec3& origin, const dvec3& dir, double t_max) const {
  // The plane first, in double: most rays that miss the mirror miss its sphere.
  double along = glm::dot(dir, normal_);
  if (along == 0) return -1.0;
  double t = -height(origin) / along;
  if (!(t > 0 && t < t_max)) return -1.0;
  dvec3 p = origin + t * dir - bounds_.centre;
  if (glm::dot(p, p) > bounds_.radius * bounds_.radius) return -1.0;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray = make_ray(origin, dir, std::isinf(t_max) ? INFINITY : float(t_max));
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(outline_, &context, &rh);
  return rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1.0 : t;  // the plane's t, exact in double
}

int object_of(const MirrorPlane& plane, const PatchMesh& mesh) { return mesh.patches[plane.patches()[0]].object; }

MirrorPlanes find_mirrors(const PatchMesh& mesh, const SceneDesc& scene, std::vector<int>& curved,
                          const std::vector<char>* only) {
  MirrorPlanes planes;
  std::shared_ptr<RTCDeviceTy> device;
  double same_offset = kSameOffset * mesh.diagonal;
  for (size_t o = 0; o < mesh.objects.size(); ++o) {
    if (!scene.meshes[o].visible || (only && !(*only)[o])) continue;
    const ObjectPatches& obj = mesh.objects[o];
    // Per material, its patches' planes: a normal, an offset and the patches.
    struct Group {
      int material;
      dvec3 normal;
      double offset;
      std::vector<int> patches;
    };
    std::vector<Group> groups;
    for (int p = obj.patch_begin; p < obj.patch_end; ++p) {
      const Patch& patch = mesh.patches[p];
      if (patch.area == 0 || !is_mirror(scene.materials[patch.material])) continue;
      double offset = glm::dot(patch.centre, patch.normal);
      auto g = std::find_if(groups.begin(), groups.end(), [&](const Group& g) {
        return g.material == patch.material && glm::dot(g.normal, patch.normal) >= kSameNormal &&
               std::fabs(g.offset - offset) <= same_offset;
      });
      if (g == groups.end()) groups.push_back({patch.material, patch.normal, offset, {p}});
      else g->patches.push_back(p);
    }
    if (groups.empty()) continue;
    if (int(groups.size()) > kMostPlanes) {
      curved.push_back(int(o));
      continue;
    }
    if (!device) {
      device.reset(rtcNewDevice(nullptr), rtcReleaseDevice);
      if (!device) throw std::runtime_error("Embree device could not be created");
    }
    for (const Group& g : groups)
      planes.push_back(std::make_shared<const MirrorPlane>(device, mesh, g.patches, scene.materials[g.material].specular));
  }
  return planes;
}

WorldMap mirrored(const WorldMap& world, const MirrorPlane& plane) {
  if (world.texels.size() == 1) return world;
  WorldMap image = world;
  for (int r = 0; r < world.height; ++r)
    for (int c = 0; c < world.width; ++c)
      image.texels[size_t(r) * world.width + c] = world.at(plane.reflect_direction(world.direction(c, r)));
  return image;
}

Shot mirrored(Shot shot, const MirrorPlane& plane) {
  auto place = [&](dvec3& p) { p = plane.reflect(p); };
  // The reflection reverses a quad's winding: the normal its corners give is the reflected one
  // turned round, and what faced the front now faces the back.
  auto turn = [&](dvec3& n) { n = -plane.reflect_direction(n); };
  for (ShotElement& e : shot.elements) {
    place(e.centroid), place(e.anchor), turn(e.normal);
    e.spread = plane.reflect(e.spread);
    e.anchor_under_patch = -1;
    std::swap(e.radiance[0], e.radiance[1]);
  }
  for (ShotCell& sc : shot.cells) {
    Cell& c = sc.cell;
    place(c.centroid), place(c.centre), turn(c.normal);
    for (dvec3& corner : c.corners) place(corner);
    c.spread = plane.reflect(c.spread);
    std::swap(sc.radiance[0], sc.radiance[1]);
    std::swap(sc.seen[0], sc.seen[1]);
  }
  for (ShotPatch& patch : shot.patches) {
    std::fill(std::begin(patch.point), std::end(patch.point), -1);
    patch.under_patch = -1;
    patch.piece = nullptr;
    for (int c = 0; c < 4; ++c) {
      place(patch.corner[c]);
      std::swap(patch.radiance[c][0], patch.radiance[c][1]);
      patch.own_view[c][0] = patch.own_view[c][1] = 0.0;
    }
  }
  shot.object = shot.enclosed_side = -1;
  place(shot.bounds.centre);
  set_frontier(shot, shot.frontier);
  return shot;
}

}  // namespace radiosity
