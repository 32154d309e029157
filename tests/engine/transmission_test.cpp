// Rays through panes on their own: what Visibility's filter records, left out with the object an
// update leaves out, and the same answers as a trace without panes where nothing lets light through.
#include "patch_mesh.h"
#include "transmission.h"
#include "visibility.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

namespace radiosity {
namespace {

// A horizontal square at height z, `n` x `n` patches of size 4 / n, centred on the z axis.
MeshDesc square(double z, int material, int n, bool dynamic) {
  MeshDesc m;
  m.name = "square";
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.positions.push_back(dvec3(-2.0 + 4.0 * i / n, -2.0 + 4.0 * j / n, z));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int v = j * (n + 1) + i;
      m.face_sizes.push_back(4);
      for (int k : {v, v + 1, v + n + 2, v + n + 1}) m.face_vertices.push_back(k);
      m.face_materials.push_back(material);
    }
  m.dynamic = dynamic;
  return m;
}

Material pane(const dvec3& transmittance) {
  Material m;
  m.reflectance = dvec3(0.0);
  m.transmittance = transmittance;
  return m;
}

// Two panes (objects 0 and 1, dynamic: occluded_without leaves out an instance) over an opaque
// floor; `tau` the panes' transmittance (zero: opaque).
struct Panes {
  SceneDesc scene;
  PatchMesh mesh;
  std::unique_ptr<Visibility> vis;
  explicit Panes(const dvec3& tau_a, const dvec3& tau_b) {
    scene.materials = {pane(tau_a), pane(tau_b), Material()};
    scene.meshes = {square(1.0, 0, 4, true), square(2.0, 1, 4, true), square(0.0, 2, 1, false)};
    mesh = build_patch_mesh(scene, Settings());
    vis = std::make_unique<Visibility>(mesh, std::vector<bool>{true, true, false}, std::vector<bool>{true, true, true});
  }
  // Rays from just above the floor straight up past both panes, through patch corners, edges and
  // diagonals (the panes' patches are 1 across), and inside patches.
  std::vector<RTCRay> rays() const {
    std::vector<RTCRay> r;
    for (double x : {0.0, 0.5, 0.25, -1.0})
      for (double y : {0.0, 0.5, -0.7}) {
        r.push_back(make_ray(dvec3(x, y, 0.01) - mesh.origin, dvec3(0.0, 0.0, 3.0), 1.0f));
        r.back().id = unsigned(r.size() - 1);
      }
    return r;
  }
};

void traced(const Panes& s, std::vector<RTCRay>& rays, Crossings& crossings, int without = -1) {
  if (without >= 0)
    s.vis->occluded_without(without, rays.data(), unsigned(rays.size()), nullptr, &crossings);
  else
    s.vis->occluded(rays.data(), unsigned(rays.size()), nullptr, &crossings);
}

TEST(Transmission, RaysCarryTheProductOfThePanesTheyCross) {
  const dvec3 a(0.9, 0.5, 0.25), b(0.5, 0.8, 1.0);
  Panes s(a, b);
  ASSERT_TRUE(s.vis->transmits());
  std::vector<RTCRay> rays = s.rays();
  Crossings crossings(unsigned(rays.size()));
  traced(s, rays, crossings);
  // The panes' transmittance in single precision, as the filter reads it, multiplied in double.
  dvec3 both = dvec3(glm::vec3(a)) * dvec3(glm::vec3(b));
  for (const RTCRay& r : rays) {
    ASSERT_GE(r.tfar, 0.0f) << r.id;
    // Once per pane, also where a ray passes an edge or a corner several patches share.
    EXPECT_EQ(crossings.through(r, s.vis->epsilon()), both) << r.id;
  }
}

TEST(Transmission, AnObjectLeftOutPassesItsLightWhole) {
  const dvec3 a(0.9, 0.5, 0.25), b(0.5, 0.8, 1.0);
  Panes s(a, b);
  for (int without : {0, 1}) {
    std::vector<RTCRay> rays = s.rays();
    Crossings crossings(unsigned(rays.size()));
    traced(s, rays, crossings, without);
    dvec3 other = dvec3(glm::vec3(without == 0 ? b : a));
    for (const RTCRay& r : rays) {
      ASSERT_GE(r.tfar, 0.0f) << r.id;
      EXPECT_EQ(crossings.through(r, s.vis->epsilon()), other) << "without " << without << ", ray " << r.id;
    }
  }
}

TEST(Transmission, WhetherTwoPlacesSeeEachOtherAPaneIsAWall) {
  Panes s(dvec3(0.9), dvec3(0.9));
  std::vector<RTCRay> rays = s.rays();
  s.vis->occluded(rays.data(), unsigned(rays.size()));
  for (const RTCRay& r : rays) EXPECT_LT(r.tfar, 0.0f) << r.id;
  rays = s.rays();
  s.vis->occluded_without(0, rays.data(), unsigned(rays.size()));
  for (const RTCRay& r : rays) EXPECT_LT(r.tfar, 0.0f) << r.id;
}

TEST(Transmission, WithoutPanesRaysAreTracedAsWithout) {
  // Opaque squares: no filter, and the same answers, bit for bit, whether a trace asks for
  // crossings or not; a ray that passes beside them carries its light unscaled.
  Panes s(dvec3(0.0), dvec3(0.0));
  EXPECT_FALSE(s.vis->transmits());
  std::vector<RTCRay> plain = s.rays();
  for (unsigned i = 0; i < plain.size(); i += 2) plain[i].org_x += 3.0f;  // beside the squares
  std::vector<RTCRay> asked = plain;
  Crossings crossings(unsigned(asked.size()));
  s.vis->occluded(plain.data(), unsigned(plain.size()));
  s.vis->occluded(asked.data(), unsigned(asked.size()), nullptr, &crossings);
  for (unsigned i = 0; i < plain.size(); ++i) {
    EXPECT_EQ(std::memcmp(&plain[i], &asked[i], sizeof(RTCRay)), 0) << i;
    EXPECT_EQ(plain[i].tfar >= 0, i % 2 == 0) << i;
    if (i % 2 == 0) EXPECT_EQ(crossings.through(asked[i], s.vis->epsilon()), dvec3(1.0)) << i;
  }
}

TEST(Transmission, FresnelAtNormalIncidenceAndGrazing) {
  double n = 1.5, r0 = (n - 1) * (n - 1) / ((n + 1) * (n + 1));
  EXPECT_NEAR(fresnel_reflectance(1.0, n), r0, 1e-15);
  EXPECT_EQ(fresnel_reflectance(0.0, n), 1.0);
  EXPECT_EQ(fresnel_reflectance(std::nan(""), n), 1.0);  // a degenerate triangle's normal: nothing passes
  EXPECT_EQ(fresnel_reflectance(0.3, 1.0), 0.0);
  // A pane passes (1 - R) / (1 + R) (both faces, light back and forth between them); one face 1 - R.
  Material glass;
  glass.reflectance = dvec3(0.0);
  glass.glass = dvec3(1.0, 0.5, 0.25);
  glass.ior = n;
  std::array<float, 3> sheet = Transmission(glass, true).at(1.0), face = Transmission(glass, false).at(-1.0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_FLOAT_EQ(sheet[k], float(glass.glass[k] * (1 - r0) / (1 + r0)));
    EXPECT_FLOAT_EQ(face[k], float(glass.glass[k] * (1 - r0)));
  }
}

}  // namespace
}  // namespace radiosity
