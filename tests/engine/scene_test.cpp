// Whole scenes with closed-form solutions (shared/reference/analytic.md, cases 10-14) and the hard
// cases: the solver must stay finite, sane and right.
#include "radiosity/form_factor.h"
#include "radiosity/solver.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <stdexcept>

using namespace radiosity;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct MeshBuilder {
  MeshDesc mesh;
  void quad(std::array<dvec3, 4> q, int material) {
    int base = int(mesh.positions.size());
    for (const dvec3& p : q) mesh.positions.push_back(p);
    mesh.face_sizes.push_back(4);
    for (int i = 0; i < 4; ++i) mesh.face_vertices.push_back(base + i);
    mesh.face_materials.push_back(material);
  }
  // Axis-aligned box, faces counter-clockwise seen from outside (or inside when inward).
  void box(dvec3 lo, dvec3 hi, bool inward, int material, int top_material = -1) {
    auto at = [&](int x, int y, int z) { return dvec3(x ? hi.x : lo.x, y ? hi.y : lo.y, z ? hi.z : lo.z); };
    std::array<std::array<int, 3>, 4> faces[6] = {
        {{{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}}, {{{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}},
        {{{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}}, {{{1, 1, 0}, {0, 1, 0}, {0, 1, 1}, {1, 1, 1}}},
        {{{0, 1, 0}, {0, 0, 0}, {0, 0, 1}, {0, 1, 1}}}, {{{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}}}};
    for (int f = 0; f < 6; ++f) {
      std::array<dvec3, 4> q;
      for (int i = 0; i < 4; ++i) {
        const auto& c = faces[f][inward ? 3 - i : i];
        q[i] = at(c[0], c[1], c[2]);
      }
      quad(q, f == 1 && top_material >= 0 ? top_material : material);
    }
  }
  MeshDesc done(Refinement r = Refinement::None, double patch_size = 0.0) {
    mesh.refine = r;
    mesh.patch_size = patch_size;
    return mesh;
  }
};

Settings tight(double threshold = 1e-7) {
  Settings s = Settings::preset("default");
  s.threshold = threshold;
  return s;
}

dvec3 at(const std::vector<float>& rgb, size_t i) { return dvec3(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]); }

void expect_finite_non_negative(const std::vector<float>& rgb) {
  for (float v : rgb) {
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_GE(v, 0.0f);
  }
}

}  // namespace

TEST(Scenes, FurnaceIsEOverOneMinusRho) {  // case 10
  for (double rho : {0.5, 0.9, 0.99}) {
    SceneDesc scene;
    scene.materials.push_back({dvec3(rho), dvec3(1.0)});
    MeshBuilder b;
    b.box(dvec3(-1), dvec3(1), true, 0);
    scene.meshes.push_back(b.done(Refinement::Bilinear, 1.0));
    Solver solver(scene, tight());
    const SolveStats& stats = solver.solve();
    EXPECT_TRUE(stats.converged);
    EXPECT_EQ(stats.patches, 24);
    std::vector<float> b_out = solver.corner_radiance(0);
    for (size_t i = 0; i < b_out.size() / 3; ++i)
      EXPECT_NEAR(at(b_out, i).x * (1 - rho), 1.0, 1e-3) << "rho " << rho << " corner " << i;
  }
}

TEST(Scenes, PowerBalanceHoldsDuringTheSolve) {  // case 13
  SceneDesc scene;
  scene.materials.push_back({dvec3(0.7, 0.5, 0.3), dvec3(0.0)});
  scene.materials.push_back({dvec3(0.5), dvec3(10.0)});
  MeshBuilder b;
  b.box(dvec3(-1), dvec3(1), true, 0, 1);
  scene.meshes.push_back(b.done(Refinement::Bilinear, 0.25));
  Solver solver(scene, tight(1e-5));
  int checks = 0;
  solver.solve([&](double, double) {
    PowerBalance p = solver.power_balance();
    EXPECT_NEAR((p.unshot + p.absorbed) / p.injected, 1.0, 0.01);
    ++checks;
    return true;
  });
  PowerBalance p = solver.power_balance();
  EXPECT_GT(checks, 0);
  EXPECT_LT(std::fabs(p.unshot), 1e-4 * p.injected);
  EXPECT_NEAR(p.absorbed / p.injected, 1.0, 0.01);  // a closed box: nothing escapes
}

TEST(Scenes, InsideASphere) {  // case 11: B(P) = E(P) + rho Ebar / (1 - rho) for any emission
  const int rings = 24, segments = 48;
  const double rho = 0.5;
  SceneDesc scene;
  scene.materials.push_back({dvec3(rho), dvec3(0.0)});
  scene.materials.push_back({dvec3(rho), dvec3(2.0)});
  MeshDesc m;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      double t = kPi * r / rings, p = 2 * kPi * s / segments;
      m.positions.push_back(dvec3(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)));
    }
  double emitted = 0, area = 0;
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      int a = r * segments + s, b = r * segments + (s + 1) % segments;
      // Inward: clockwise seen from outside.
      m.face_sizes.push_back(4);
      for (int v : {a, b, b + segments, a + segments}) m.face_vertices.push_back(v);
      bool cap = r < rings / 4;
      m.face_materials.push_back(cap ? 1 : 0);
      double band = 2 * kPi * (std::cos(kPi * r / rings) - std::cos(kPi * (r + 1) / rings)) / segments;
      area += band;
      emitted += cap ? 2.0 * band : 0.0;
    }
  scene.meshes.push_back(m);
  Solver solver(scene, tight(1e-5));
  solver.solve();
  double ebar = emitted / area;
  std::vector<float> v = solver.vertex_radiance(0);
  // Away from the cap edge (where corners of emitting and dark faces are averaged).
  for (int r = rings / 4 + 1; r <= rings; ++r)
    EXPECT_NEAR(at(v, r * segments).x / (rho * ebar / (1 - rho)), 1.0, 0.01) << "ring " << r;
  EXPECT_NEAR(at(v, segments * 2).x / (2.0 + rho * ebar / (1 - rho)), 1.0, 0.01);
}

TEST(Scenes, ParallelPlates) {  // case 12, plates large and close: centre values of infinite plates
  const double rho1 = 0.6, rho2 = 0.4, e1 = 1.0, e2 = 3.0, gap = 0.05, half = 5.0;
  SceneDesc scene;
  scene.materials.push_back({dvec3(rho1), dvec3(e1)});
  scene.materials.push_back({dvec3(rho2), dvec3(e2)});
  MeshBuilder b;
  b.quad({dvec3(-half, -half, 0), dvec3(half, -half, 0), dvec3(half, half, 0), dvec3(-half, half, 0)}, 0);
  b.quad({dvec3(-half, -half, gap), dvec3(-half, half, gap), dvec3(half, half, gap), dvec3(half, -half, gap)}, 1);
  scene.meshes.push_back(b.done(Refinement::Bilinear, 0.25));
  Solver solver(scene, tight(1e-6));
  solver.solve();
  // Finite plates: the centre sees the other plate with factor F a little under 1.
  std::array<dvec3, 4> other = {dvec3(-half, -half, gap), dvec3(half, -half, gap), dvec3(half, half, gap),
                                dvec3(-half, half, gap)};
  double f = polygon_form_factor(dvec3(0), dvec3(0, 0, 1), other.data(), 4);
  ASSERT_GT(f, 0.98);
  double b1 = (e1 + rho1 * f * e2) / (1 - rho1 * rho2 * f * f);
  double b2 = (e2 + rho2 * f * e1) / (1 - rho1 * rho2 * f * f);
  Solver::Refined r = solver.refined(0);
  double best1 = 1e9, best2 = 1e9, v1 = 0, v2 = 0;
  for (size_t i = 0; i < r.positions.size() / 3; ++i) {
    double d = std::hypot(r.positions[3 * i], r.positions[3 * i + 1]);
    bool top = r.positions[3 * i + 2] > gap / 2;
    if (!top && d < best1) best1 = d, v1 = r.radiance[3 * i];
    if (top && d < best2) best2 = d, v2 = r.radiance[3 * i];
  }
  EXPECT_NEAR(v1 / b1, 1.0, 5e-3);
  EXPECT_NEAR(v2 / b2, 1.0, 5e-3);
}

namespace {

// Two rooms side by side over one floor, the left one lit by its ceiling, sealed from each other
// by a thick wall standing on the floor at 0.93 < x < 1.07; `inside` goes into the dark room.
SceneDesc sealed_rooms(MeshDesc floor, std::vector<MeshDesc> inside = {}) {
  SceneDesc scene;
  scene.materials.push_back({dvec3(0.8), dvec3(0.0)});
  scene.materials.push_back({dvec3(0.8), dvec3(20.0)});
  scene.meshes.push_back(floor);
  MeshBuilder walls;  // two rooms' walls and ceilings; the lit room's ceiling emits
  auto room = [&](double x0, double x1, int ceiling) {
    walls.quad({dvec3(x0, 0, 1), dvec3(x1, 0, 1), dvec3(x1, 1, 1), dvec3(x0, 1, 1)}, ceiling);
    walls.quad({dvec3(x0, 0, 0), dvec3(x1, 0, 0), dvec3(x1, 0, 1), dvec3(x0, 0, 1)}, 0);
    walls.quad({dvec3(x1, 1, 0), dvec3(x0, 1, 0), dvec3(x0, 1, 1), dvec3(x1, 1, 1)}, 0);
  };
  room(0, 0.93, 1);
  room(1.07, 2, 0);
  walls.quad({dvec3(0, 1, 0), dvec3(0, 0, 0), dvec3(0, 0, 1), dvec3(0, 1, 1)}, 0);
  walls.quad({dvec3(2, 0, 0), dvec3(2, 1, 0), dvec3(2, 1, 1), dvec3(2, 0, 1)}, 0);
  scene.meshes.push_back(walls.done(Refinement::Bilinear, 0.125));
  MeshBuilder wall;
  wall.box(dvec3(0.93, 0, 0), dvec3(1.07, 1, 1), false, 0);
  scene.meshes.push_back(wall.done(Refinement::Bilinear, 0.125));
  for (MeshDesc& m : inside) scene.meshes.push_back(m);
  return scene;
}

// Solves the two rooms: the floor's points in the dark room, and every point of what stands
// there, must get exactly nothing; the lit room's floor must be lit. More than `floor_points` of
// the floor's points in each room.
void expect_the_dark_room_dark(const SceneDesc& scene, int floor_points) {
  Solver solver(scene, Settings::preset("default"));
  solver.solve();
  Solver::Refined r = solver.refined(0);
  int dark = 0, lit = 0;
  for (size_t i = 0; i < r.positions.size() / 3; ++i) {
    double x = r.positions[3 * i];
    if (x > 1.07 + 1e-9) {
      EXPECT_EQ(r.radiance[3 * i], 0.0f) << "floor at x = " << x;
      ++dark;
    } else if (x < 0.93 - 1e-9) {
      EXPECT_GT(r.radiance[3 * i], 0.1f);
      ++lit;
    }
  }
  EXPECT_GT(dark, floor_points);
  EXPECT_GT(lit, floor_points);
  for (size_t object = 3; object < scene.meshes.size(); ++object) {
    Solver::Refined inside = solver.refined(int(object));
    for (size_t i = 0; i < inside.radiance.size(); ++i)
      EXPECT_EQ(inside.radiance[i], 0.0f) << "object " << object << " at point " << i / 3;
  }
}

}  // namespace

TEST(Scenes, SealedRoomsDoNotLeak) {  // case 14
  // One floor polygon under both rooms, refined so that patches run under the dividing wall.
  MeshBuilder floor;
  floor.quad({dvec3(0, 0, 0), dvec3(2, 0, 0), dvec3(2, 1, 0), dvec3(0, 1, 0)}, 0);
  expect_the_dark_room_dark(sealed_rooms(floor.done(Refinement::Bilinear, 0.125)), 50);
}

TEST(Scenes, SealedRoomsDoNotLeakOntoABoxByTheWall) {
  // A floor patch runs from the lit room under the wall and on under a box that stands 3 cm from
  // the wall in the dark room: the patch's only corner the box's foot faces is in the lit room.
  MeshBuilder floor;
  floor.quad({dvec3(0, 0, 0), dvec3(0.9, 0, 0), dvec3(0.9, 1, 0), dvec3(0, 1, 0)}, 0);
  floor.quad({dvec3(0.9, 0, 0), dvec3(1.15, 0, 0), dvec3(1.15, 1, 0), dvec3(0.9, 1, 0)}, 0);
  floor.quad({dvec3(1.15, 0, 0), dvec3(2, 0, 0), dvec3(2, 1, 0), dvec3(1.15, 1, 0)}, 0);
  MeshBuilder box;
  box.box(dvec3(1.1, 0.3, 0), dvec3(1.4, 0.7, 0.3), false, 0);
  expect_the_dark_room_dark(sealed_rooms(floor.done(), {box.done(Refinement::Bilinear, 0.1)}), 1);
}

namespace {

// A closed room with a ceiling light and a block, for the hard cases.
SceneDesc lit_room(dvec3 offset = dvec3(0.0)) {
  SceneDesc scene;
  scene.materials.push_back({dvec3(0.7), dvec3(0.0)});
  scene.materials.push_back({dvec3(0.7), dvec3(5.0)});
  MeshBuilder room;
  room.box(dvec3(0) + offset, dvec3(2) + offset, true, 0, 1);
  scene.meshes.push_back(room.done(Refinement::Bilinear, 0.25));
  MeshBuilder block;
  block.box(dvec3(0.5, 0.5, 0) + offset, dvec3(1.2, 1.2, 0.7) + offset, false, 0);
  scene.meshes.push_back(block.done(Refinement::Bilinear, 0.25));
  return scene;
}

}  // namespace

TEST(HardCases, JunctionVerticesAreNotDark) {
  Solver solver(lit_room(), Settings::preset("default"));
  solver.solve();
  std::vector<float> c = solver.corner_radiance(0);
  // Floor corners (face 0) against the floor's mean: a corner sees less, but never nothing.
  for (int k = 0; k < 4; ++k) EXPECT_GT(at(c, k).x, 0.1) << k;
}

TEST(HardCases, FarFromTheOriginGivesTheSameLight) {
  Solver near(lit_room(), Settings::preset("default"));
  near.solve();
  Solver far(lit_room(dvec3(1e4, -2e4, 1e4)), Settings::preset("default"));
  far.solve();
  std::vector<float> a = near.corner_radiance(0), b = far.corner_radiance(0);
  ASSERT_EQ(a.size(), b.size());
  double diff = 0, norm = 0;
  for (size_t i = 0; i < a.size(); ++i) diff += (a[i] - b[i]) * (a[i] - b[i]), norm += a[i] * a[i];
  EXPECT_LT(std::sqrt(diff / norm), 1e-3);
}

TEST(HardCases, DegenerateAndOverlappingGeometryStaysFinite) {
  SceneDesc scene = lit_room();
  MeshBuilder junk;
  junk.quad({dvec3(0.3, 0.3, 1), dvec3(0.3, 0.3, 1), dvec3(0.3, 0.3, 1), dvec3(0.3, 0.3, 1)}, 0);  // zero area
  junk.quad({dvec3(0.2, 1.5, 0.5), dvec3(1.8, 1.5, 0.5), dvec3(1.8, 1.5 + 1e-7, 0.5), dvec3(0.2, 1.5, 0.5 + 1e-9)}, 0);
  junk.quad({dvec3(0, 0, 0), dvec3(2, 0, 0), dvec3(2, 2, 0), dvec3(0, 2, 0)}, 0);  // coincides with the floor
  junk.quad({dvec3(0.2, 0.2, 0.2), dvec3(1.8, 1.8, 0.2), dvec3(1.8, 1.8, 1.5), dvec3(0.2, 0.2, 1.5)}, 0);  // cuts the block
  junk.mesh.positions.push_back(dvec3(0.5));
  junk.mesh.face_sizes.push_back(3);  // a triangle with a repeated vertex
  for (int v : {16, 16, 1}) junk.mesh.face_vertices.push_back(v);
  junk.mesh.face_materials.push_back(0);
  scene.meshes.push_back(junk.done());
  Solver solver(scene, Settings::preset("default"));
  const SolveStats& stats = solver.solve();
  EXPECT_TRUE(stats.converged);
  EXPECT_GE(stats.warnings.size(), 1u);  // the degenerate patches are reported
  for (int o = 0; o < 3; ++o) expect_finite_non_negative(solver.corner_radiance(o));
}

TEST(HardCases, ReflectanceNearOneAndTinyBrightEmitter) {
  SceneDesc scene;
  scene.materials.push_back({dvec3(0.999), dvec3(0.0)});
  scene.materials.push_back({dvec3(0.5), dvec3(1e6)});
  MeshBuilder room;
  room.box(dvec3(0), dvec3(1), true, 0);
  scene.meshes.push_back(room.done(Refinement::Bilinear, 0.5));
  MeshBuilder spark;
  spark.box(dvec3(0.5 - 5e-4), dvec3(0.5 + 5e-4), false, 1);
  scene.meshes.push_back(spark.done());
  Settings s = Settings::preset("default");
  s.max_shots = 20000;
  Solver solver(scene, s);
  const SolveStats& stats = solver.solve();
  std::vector<float> c = solver.corner_radiance(0);
  expect_finite_non_negative(c);
  // Emitted power 6 faces x 2 sides x 1e-6 m^2 x 1e6 = 12 reaches the walls (area 6) as
  // irradiance/pi ~ 12 / 2 / 6 per side... the walls are lit, converging slowly towards
  // rho/(1-rho) times that: the residual says how far it got.
  EXPECT_GT(at(c, 0).x, 0.5);
  EXPECT_TRUE(stats.converged || stats.shots >= s.max_shots);
  EXPECT_LT(stats.residual, 1.0);
}

TEST(HardCases, BadInputIsRejectedWithAMessage) {
  auto message = [](SceneDesc scene) {
    try {
      Solver solver(scene, Settings());
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  SceneDesc nan = lit_room();
  nan.meshes[1].positions[3].y = NAN;
  EXPECT_NE(message(nan).find("NaN"), std::string::npos);
  SceneDesc inf = lit_room();
  inf.meshes[0].positions[0].x = INFINITY;
  EXPECT_NE(message(inf).find("infinite"), std::string::npos);
  SceneDesc white = lit_room();
  white.materials[0].reflectance = dvec3(1.0);
  EXPECT_NE(message(white).find("reflectance"), std::string::npos);
  SceneDesc index = lit_room();
  index.meshes[0].face_vertices[2] = 1000;
  EXPECT_NE(message(index).find("out of range"), std::string::npos);
}

TEST(HardCases, EmptySceneAndNoLight) {
  Solver empty(SceneDesc{}, Settings());
  const SolveStats& s = empty.solve();
  EXPECT_TRUE(s.converged);
  EXPECT_FALSE(s.warnings.empty());
  SceneDesc dark = lit_room();
  dark.materials[1].emission = dvec3(0.0);
  Solver solver(dark, Settings());
  const SolveStats& d = solver.solve();
  EXPECT_FALSE(d.warnings.empty());
  for (float v : solver.corner_radiance(0)) EXPECT_EQ(v, 0.0f);
}

TEST(Solver, CancelKeepsAConsistentStateAndResumes) {
  Solver solver(lit_room(), tight(1e-5));
  int calls = 0;
  const SolveStats& first = solver.solve([&](double, double) { return ++calls < 2; });
  EXPECT_TRUE(first.cancelled);
  EXPECT_FALSE(first.converged);
  PowerBalance p = solver.power_balance();
  EXPECT_NEAR((p.unshot + p.absorbed) / p.injected, 1.0, 0.02);
  const SolveStats& second = solver.solve();
  EXPECT_TRUE(second.converged);
  Solver fresh(lit_room(), tight(1e-5));
  fresh.solve();
  std::vector<float> a = solver.corner_radiance(0), b = fresh.corner_radiance(0);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-3 * (b[i] + 0.01));
}
