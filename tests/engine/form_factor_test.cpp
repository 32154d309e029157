// Form factors against the closed forms of shared/reference/analytic.md, cases 1-9.
#include "radiosity/form_factor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

using namespace radiosity;

namespace {

constexpr double kPi = 3.14159265358979323846;
const dvec3 kUp(0, 0, 1);

std::vector<dvec3> disc(const dvec3& centre, double radius, int sides) {
  std::vector<dvec3> p;
  for (int i = 0; i < sides; ++i) {
    double a = 2 * kPi * i / sides;
    p.push_back(centre + radius * dvec3(std::cos(a), std::sin(a), 0));
  }
  return p;
}

std::vector<dvec3> rect(const dvec3& corner, const dvec3& u, const dvec3& v) {
  return {corner, corner + u, corner + u + v, corner + v};
}

double lambert(const dvec3& x, const dvec3& n, const std::vector<dvec3>& poly) {
  return polygon_form_factor(x, n, poly.data(), int(poly.size()));
}

// B-3: point under the corner of an a x b rectangle at distance c.
double corner_closed_form(double a, double b, double c) {
  double X = a / c, Y = b / c;
  return (X / std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) +
          Y / std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y))) / (2 * kPi);
}

// Point at (x, y, -h) facing up under the unit square centred on the origin in the plane z = 0.
double square_closed_form(double x, double y, double h) {
  double f = 0;
  for (double a : {0.5 + x, 0.5 - x})
    for (double b : {0.5 + y, 0.5 - y}) f += corner_closed_form(a, b, h);
  return f;
}

// The solver's kernel: a patch split into k x k cells, summed without visibility.
double cells_form_factor(const std::vector<dvec3>& quad, int k, const dvec3& x, const dvec3& n) {
  std::vector<Cell> cells(k * k);
  bilinear_cells(quad.data(), k, cells.data());
  double f = 0;
  for (const Cell& c : cells) f += cell_form_factor(c, x, n).front;
  return f;
}

// Area average over the unit square [0,1]^2 mapped by `at`, by the midpoint rule on m x m points.
double average(int m, const std::function<double(double, double)>& at) {
  double sum = 0;
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < m; ++i) sum += at((i + 0.5) / m, (j + 0.5) / m);
  return sum / (m * m);
}

constexpr int kDefaultCells = 8;  // Settings' default samples_direct = 64 cells a patch

}  // namespace

TEST(PointToSurface, CoaxialDisc) {  // case 1
  EXPECT_NEAR(lambert(dvec3(0), kUp, disc(dvec3(0, 0, 1), 1, 16384)), 0.5, 1e-6);
  double w = 20 * kPi / 180;
  dvec3 tilted(std::sin(w), 0, std::cos(w));
  EXPECT_NEAR(lambert(dvec3(0), tilted, disc(dvec3(0, 0, 2), 1, 16384)), 0.18793852, 1e-6);
  // At 80 degrees the disc dips below the receiver's horizon: only the clipped polygon is right.
  w = 80 * kPi / 180;
  tilted = dvec3(std::sin(w), 0, std::cos(w));
  EXPECT_NEAR(lambert(dvec3(0), tilted, disc(dvec3(0, 0, 2), 1, 16384)), 0.041453, 1e-6);
}

TEST(PointToSurface, ParallelRectangle) {  // cases 2 and 4
  EXPECT_NEAR(lambert(dvec3(0), kUp, rect(dvec3(0, 0, 1), dvec3(1, 0, 0), dvec3(0, 1, 0))), 0.138531605995, 1e-12);
  EXPECT_NEAR(lambert(dvec3(0), kUp, rect(dvec3(-0.5, -0.5, 1), dvec3(1, 0, 0), dvec3(0, 1, 0))),
              0.239456470461, 1e-12);
  for (double a : {0.3, 1.0, 2.5})
    for (double c : {0.01, 0.5, 3.0})
      EXPECT_NEAR(lambert(dvec3(0), kUp, rect(dvec3(0, 0, c), dvec3(a, 0, 0), dvec3(0, 1.7, 0))),
                  corner_closed_form(a, 1.7, c), 1e-12);
}

TEST(PointToSurface, PerpendicularRectangle) {  // cases 3 and 4
  // Point at the origin facing +z; the rectangle stands in the plane y = c on the line y = c, z = 0,
  // b along that line from the point's foot, a up from the point's plane.
  auto b4 = [](double a, double b, double c) {
    return lambert(dvec3(0), kUp, rect(dvec3(0, c, 0), dvec3(b, 0, 0), dvec3(0, 0, a)));
  };
  EXPECT_NEAR(b4(1, 1, 1), 0.055734197003, 1e-12);
  EXPECT_NEAR(b4(0.5, 2, 1), 0.0251641155, 1e-10);
}

TEST(PointToSurface, SampledPatchWithinHalfPercent) {
  // Vertex under a unit-square emitter at several heights, with the default cell density.
  std::vector<dvec3> square = rect(dvec3(-0.5, -0.5, 0), dvec3(1, 0, 0), dvec3(0, 1, 0));
  for (double h : {1.0, 0.3, 0.1}) {
    EXPECT_NEAR(cells_form_factor(square, kDefaultCells, dvec3(0.1, 0.2, -h), kUp) /
                    square_closed_form(0.1, 0.2, h), 1.0, 5e-3) << h;
  }
}

TEST(PointToSurface, NearFieldWithinOnePercent) {
  // A vertex 0.01 above a unit emitter, where point sampling is 15-33% off with 4096 samples.
  std::vector<dvec3> square = rect(dvec3(-0.5, -0.5, 0), dvec3(1, 0, 0), dvec3(0, 1, 0));
  for (double x : {0.0, 0.37})
    EXPECT_NEAR(cells_form_factor(square, kDefaultCells, dvec3(x, -0.21, -0.01), kUp) /
                    square_closed_form(x, -0.21, 0.01), 1.0, 1e-2) << x;
}

TEST(PointToSurface, JunctionVertexIsNotDark) {
  // 1e-3 from the line where a floor meets a unit wall, at its middle, the wall fills almost half
  // the view: 0.4992 of the half-plane's 0.5. Exactly on the line it would vanish.
  std::vector<dvec3> wall = rect(dvec3(-0.5, 0, 0), dvec3(1, 0, 0), dvec3(0, 0, 1));
  EXPECT_NEAR(lambert(dvec3(0, -1e-3, 0), kUp, wall), 0.49921579759626, 1e-9);
  EXPECT_EQ(lambert(dvec3(0), kUp, wall), 0.0);
}

namespace {

// F from surface 1 (unit square [0,1]^2 mapped by `at`, normal n1) to polygon 2, by averaging
// the point-to-polygon factor over surface 1.
double surface_to_polygon(const std::function<dvec3(double, double)>& at, const dvec3& n1,
                          const std::vector<dvec3>& second, int m, int cells) {
  return average(m, [&](double u, double v) {
    return cells ? cells_form_factor(second, cells, at(u, v), n1) : lambert(at(u, v), n1, second);
  });
}

double parallel_squares(double a, double b, double c, int cells) {
  auto at = [&](double u, double v) { return dvec3(a * u, b * v, 0); };
  return surface_to_polygon(at, kUp, rect(dvec3(0, 0, c), dvec3(a, 0, 0), dvec3(0, b, 0)), 200, cells);
}

// Unit squares hinged on the x axis: the first in the plane z = 0, the second rotated by phi.
double hinged(double phi_degrees, int cells) {
  double phi = phi_degrees * kPi / 180;
  dvec3 up(0, std::cos(phi), std::sin(phi));
  dvec3 n1 = kUp;
  auto at = [&](double u, double v) { return dvec3(u, v, 0); };
  return surface_to_polygon(at, n1, rect(dvec3(0), dvec3(1, 0, 0), up), 160, cells);
}

}  // namespace

TEST(SurfaceToSurface, ParallelRectangles) {  // case 5
  EXPECT_NEAR(parallel_squares(1, 1, 1, 0), 0.199824895698, 2e-5);
  EXPECT_NEAR(parallel_squares(2, 1, 1, 0), 0.285875384851, 2e-5);
  EXPECT_NEAR(parallel_squares(1, 1, 0.1, 0), 0.826994522397, 2e-4);
  for (double c : {1.0, 0.1, 0.01}) {
    double exact = c == 1.0 ? 0.199824895698 : c == 0.1 ? 0.826994522397 : 0.980416602926;
    EXPECT_NEAR(parallel_squares(1, 1, c, kDefaultCells) / exact, 1.0, 5e-3) << c;
  }
}

TEST(SurfaceToSurface, PerpendicularAndHinged) {  // cases 6 and 8
  const double expected[][2] = {{30, 0.61902832}, {45, 0.48334770}, {60, 0.37090532},
                                {90, 0.20004378}, {120, 0.08661500}, {150, 0.02134533}};
  for (const auto& e : expected) {
    EXPECT_NEAR(hinged(e[0], 0) / e[1], 1.0, 2e-3) << e[0];
    EXPECT_NEAR(hinged(e[0], kDefaultCells) / e[1], 1.0, 5e-3) << e[0];
  }
  // w = 1 (shared edge length 1), h = 2 and the reverse: reciprocity 1 x F12 = 2 x F21.
  auto at = [](double u, double v) { return dvec3(u, v, 0); };
  double f12 = surface_to_polygon(at, kUp, rect(dvec3(0), dvec3(1, 0, 0), dvec3(0, 0, 2)), 160, 0);
  auto at2 = [](double u, double v) { return dvec3(u, 0, 2 * v); };
  double f21 = surface_to_polygon(at2, dvec3(0, 1, 0), rect(dvec3(0), dvec3(1, 0, 0), dvec3(0, 1, 0)), 160, 0);
  EXPECT_NEAR(f12, 0.232852602795, 5e-4);
  EXPECT_NEAR(f21, 0.116426301398, 5e-4);
  EXPECT_NEAR(f12, 2 * f21, 5e-4);
}

TEST(SurfaceToSurface, CubeSumsToOne) {  // case 7
  double adjacent = hinged(90, 0);
  double opposite = parallel_squares(1, 1, 1, 0);
  EXPECT_NEAR(4 * adjacent + opposite, 1.0, 1e-3);
}

TEST(SurfaceToSurface, CoaxialDiscs) {  // case 9
  std::vector<dvec3> top = disc(dvec3(0, 0, 1), 1, 4096);
  // Average over the lower disc in polar rings (area-weighted midpoint rule).
  const int rings = 200, spokes = 64;
  double sum = 0, area = 0;
  for (int i = 0; i < rings; ++i) {
    double r = (i + 0.5) / rings;
    for (int j = 0; j < spokes; ++j) {
      double a = 2 * kPi * (j + 0.5) / spokes;
      sum += r * lambert(dvec3(r * std::cos(a), r * std::sin(a), 0), kUp, top);
      area += r;
    }
  }
  EXPECT_NEAR(sum / area, 0.3819660113, 1e-4);
}

TEST(PointToSurface, CoplanarCellGivesNothing) {
  // A receiver inside a cell of its own (tilted, so round-off is not exactly zero) plane.
  dvec3 u = glm::normalize(dvec3(1, 0.3, 0.1)), v = glm::normalize(glm::cross(dvec3(0.2, 0.1, 1), u));
  dvec3 p[4] = {dvec3(0.1), dvec3(0.1) + u, dvec3(0.1) + u + v, dvec3(0.1) + v};
  Cell cell;
  bilinear_cells(p, 1, &cell);
  SideFactors f = cell_form_factor(cell, dvec3(0.1) + 0.37 * u + 0.61 * v, glm::normalize(glm::cross(u, v)));
  EXPECT_EQ(f.front, 0.0);
  EXPECT_EQ(f.back, 0.0);
}

// Largest error of the distant-cell expansion against Lambert's formula over receivers at `radii`
// cell radii in many directions, facing many ways, in units of the cell's A / (pi r^2).
double distant_cell_error(const std::vector<dvec3>& quad, double radii) {
  Cell cell;
  bilinear_cells(quad.data(), 1, &cell);
  area_moments(cell);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  auto direction = [&] {
    dvec3 d;
    do d = dvec3(uniform(random), uniform(random), uniform(random));
    while (glm::dot(d, d) > 1 || glm::dot(d, d) < 1e-3);
    return glm::normalize(d);
  };
  double worst = 0;
  int used = 0;
  for (int i = 0; i < 4000; ++i) {
    dvec3 x = cell.centroid + (radii + 1e-6) * cell.radius * direction();
    dvec3 n = direction();
    std::optional<double> f = distant_cell_form_factor(cell, x, n);
    if (!f) continue;
    ++used;
    SideFactors exact = cell_form_factor(cell, x, n);
    double scale = cell.area / (kPi * glm::dot(x - cell.centroid, x - cell.centroid));
    worst = std::fmax(worst, std::fabs(*f - exact.front - exact.back) / scale);
  }
  EXPECT_GT(used, 3000);  // the plane cuts only cells seen nearly edge-on
  return worst;
}

TEST(PointToSurface, DistantCellToFourthOrder) {
  const std::vector<std::vector<dvec3>> symmetric = {
      rect(dvec3(0), dvec3(1, 0, 0), dvec3(0, 1, 0)),               // square
      rect(dvec3(0.3, 0, 0), dvec3(0, 3, 0), dvec3(0, 0.2, 1)),     // long rectangle, tilted
      {dvec3(0), dvec3(1, 0, 0), dvec3(1.6, 0.8, 0), dvec3(0.6, 0.8, 0)},  // parallelogram
  };
  for (const auto& quad : symmetric) {
    double at8 = distant_cell_error(quad, 8), at16 = distant_cell_error(quad, 16);
    EXPECT_LT(at8, 2e-4);       // it is 0.5-1.1e-4 on these cells
    EXPECT_LT(at16, at8 / 12);  // fourth order: 16x smaller
  }
  // A trapezoid has a third moment about its centroid: third order, still small at 8 radii.
  std::vector<dvec3> trapezoid = {dvec3(0), dvec3(1, 0, 0), dvec3(0.8, 0.7, 0), dvec3(0.2, 0.7, 0)};
  EXPECT_LT(distant_cell_error(trapezoid, 8), 3e-4);  // it is 1.7e-4
  EXPECT_LT(distant_cell_error(trapezoid, 16), distant_cell_error(trapezoid, 8) / 6);
}
