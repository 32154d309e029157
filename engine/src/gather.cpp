#include "gather.h"

#include "dispatch.h"
#include "place_offset.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

namespace radiosity {

namespace {

// Form factor of a distant flat cluster. Where the receiver's plane clears it, the kernel expanded
// to second order, right whatever the orientations: the disc approximation is right on the axis
// only, and falls 15% short at three radii beside the edge where a wall meets the floor. Where the
// plane cuts it, the disc approximation.
// Of one element (ShotElement, doubles) or four (FrontierBlock, Lanes).
template <class V, class Element>
RADIOSITY_LANES auto cluster_form_factor(const V& x, const V& n, const Element& e) {
  V d = e.centroid - x;
  auto r2 = dot(d, d);
  auto f = dot(n, d), g = dot(e.normal, d);
  return clear_of_plane(n, e.normal, f, e.radius) ? expanded_form_factor(d, r2, f, g, e.projected_area, e.spread, n)
                                                  : disc_form_factor(r2, f, g, e.projected_area);
}

// One ray to `to` carries `factor()` times the radiance of the side of an element (at `centre`,
// facing to.normal) that faces the receiver; none from side `shut`. Forced inline: a call would pass
// its arguments and recompute the dot products it shares with to_point, a tenth of the instructions
// a draft solve spends outside Embree. The factor is asked for last: a third of the far clusters a
// default shot's receivers reach show them a side that sends nothing (their backs), or lie in the
// receiver's plane.
template <class Factor>
__attribute__((always_inline)) inline void far_sample(const RayStart& from, const dvec3& centre, const RayEnd& to,
                                                     Factor&& factor, const dvec3 radiance[2], int shut,
                                                     OcclusionBatch& batch) {
  dvec3 d = centre - from.x;
  int side = glm::dot(to.normal, d) <= 0 ? 0 : 1;  // 0: the receiver in front of the element
  const dvec3& rad = radiance[side];
  double cos_r = glm::dot(from.n, d);
  if (side == shut || is_zero(rad) || cos_r == 0 || !batch.open(cos_r > 0)) return;
  double f = factor();
  if (!(f > 0)) return;
  batch.to_point(from, to, cos_r > 0, rad * f);
}

// What lights the pieces of one cell near a receiver: its patch, the side facing the receiver, and
// the patch corners that light the part of the cell in front of the receiver's plane and the part
// behind it.
struct NearLight {
  const ShotPatch& patch;
  int side;
  uint8_t corners[2];
  uint8_t other;  // the corners the cell's centre sees on its other side
  const Shot& shot;  // how far to split
  const PlaceOffset* end;  // where a ray to a whole piece ends in it (Shot::ends_by_place); null: its centre
};

// A piece of a cell: the cell itself or a quarter of a piece, with its square in the patch's (u, v).
// It refers to its cell rather than holding a copy, which would be made at every level of the split.
struct Piece {
  const Cell& cell;
  double u0, v0, size;
};

// Where a ray to the square of side `size` at (u0, v0) of its patch ends in it, in the patch's (u, v):
// at the place's offset, turned along the golden ratio by the square's column for its height and by
// its row for its width (a Kronecker lattice shifted by the offset). Over the places each end still
// falls anywhere in its square with equal chance; at one place the squares along a row or a column,
// which a window's frame cuts across alike, put their ends at heights spread over their squares
// rather than at one, so they see the cut in proportion to its place across them.
PlaceOffset end_in_square(const PlaceOffset& offset, double u0, double v0, double size) {
  constexpr double kGolden = 0.6180339887498949;  // (sqrt(5) - 1) / 2
  double a = offset.u + kGolden * std::round(v0 / size), b = offset.v + kGolden * std::round(u0 / size);
  return {u0 + size * (a - std::floor(a)), v0 + size * (b - std::floor(b))};
}

// Centroid in (u, v) of the part of the piece on side `part` (0: h > 0) of the receiver's plane,
// h being the corners' heights above it (linear across a planar piece).
void part_centroid(const Piece& p, const double h[4], int part, double& u, double& v) {
  // Relative to the square's first corner: slivers keep their precision.
  const double su[4] = {0.0, p.size, p.size, 0.0};
  const double sv[4] = {0.0, 0.0, p.size, p.size};
  double pu[8], pv[8];
  int count = 0;
  for (int i = 0; i < 4; ++i) {
    int j = (i + 1) % 4;
    double a = part == 0 ? h[i] : -h[i], b = part == 0 ? h[j] : -h[j];
    if (a >= 0) pu[count] = su[i], pv[count++] = sv[i];
    if ((a >= 0) != (b >= 0)) {
      double t = a / (a - b);
      pu[count] = su[i] + t * (su[j] - su[i]), pv[count++] = sv[i] + t * (sv[j] - sv[i]);
    }
  }
  double area = 0.0, cu = 0.0, cv = 0.0;
  for (int i = 0; i < count; ++i) {
    int j = (i + 1) % count;
    double cross = pu[i] * pv[j] - pu[j] * pv[i];
    area += cross;
    cu += (pu[i] + pu[j]) * cross;
    cv += (pv[i] + pv[j]) * cross;
  }
  bool sliver = !(std::fabs(area) > 1e-12 * p.size * p.size);
  u = p.u0 + (sliver ? 0.5 * p.size : std::clamp(cu / (3 * area), 0.0, p.size));
  v = p.v0 + (sliver ? 0.5 * p.size : std::clamp(cv / (3 * area), 0.0, p.size));
}

// Whether a piece at `depth` of its cell's splits is split again near receiver x (exact_piece).
bool splits_near(const Shot& shot, const Cell& piece, const dvec3& x, int depth) {
  double split = shot.split_radii * piece.radius;
  return depth < shot.split_depth && glm::dot(piece.centre - x, piece.centre - x) < split * split;
}

// An exactly integrated piece of a cell. Each part of it on one side of the receiver's plane is
// seen through one ray to that part's centroid and sends the patch's radiance interpolated there:
// the cell's value at its centre would be wrong where the centre lies under the receiver's own
// surface (a floor cell half under a box, seen from the box's foot: the centre's light is the
// dark floor under the box, while all that the foot sees is the lit half).
RADIOSITY_HOT void exact_piece(const RayStart& from, const Piece& p, const NearLight& light, int depth,
                               OcclusionBatch& batch) {
  const dvec3& x = from.x;
  const dvec3& n = from.n;
  // Split near the receiver: one ray to the centre of a cell that straddles an occluder's edge (a
  // floor cell half under a box, seen from the box's foot) would count the whole cell as lit or dark.
  if (splits_near(light.shot, p.cell, x, depth)) {
    Cell cells[4];
    bilinear_cells(p.cell.corners, 2, cells);
    double half = 0.5 * p.size;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        const Cell& c = cells[j * 2 + i];
        if (c.area > 0) exact_piece(from, {c, p.u0 + i * half, p.v0 + j * half, half}, light, depth + 1, batch);
      }
    return;
  }
  SideFactors f = cell_form_factor(p.cell, x, n);
  if (f.front == 0 && f.back == 0) return;
  // A piece split off near the receiver faces it from its own side, which on a twisted patch need
  // not be its cell's: by a box's fold the receiver can lie behind a cell's plane and in front of
  // the pieces beside it, and would take none of their reflected light (one-sided).
  bool flipped = depth > 0 && (glm::dot(p.cell.normal, x - p.cell.centre) >= 0) != (light.side == 0);
  int side = flipped ? 1 - light.side : light.side;
  // One ray to `target` carries the light of the part on side `part` of the receiver's plane.
  auto send = [&](int part, double u, double v, const dvec3& target) __attribute__((always_inline)) {
    dvec3 radiance = radiance_at(light.patch, side, flipped ? light.other : light.corners[part], u, v);
    if (light.patch.piece) radiance += (*light.patch.piece)(target, p.cell.normal, side);
    dvec3 e = radiance * (part == 0 ? f.front : f.back);
    if (!is_zero(e))
      batch.to_point(from, {target, p.cell.normal, bilinear_lift(light.patch.twist, u, v), light.patch.under_patch},
                     part == 0, e);
  };
  if (f.front > 0 && f.back > 0) {
    double h[4];
    for (int c = 0; c < 4; ++c) h[c] = glm::dot(n, p.cell.corners[c] - x);
    for (int part = 0; part < 2; ++part) {
      double u, v;
      part_centroid(p, h, part, u, v);
      send(part, u, v, bilinear(light.patch.corner, u, v));
    }
    return;
  }
  int part = f.front > 0 ? 0 : 1;
  if (!light.end) {
    send(part, p.u0 + 0.5 * p.size, p.v0 + 0.5 * p.size, p.cell.centre);
    return;
  }
  PlaceOffset at = end_in_square(*light.end, p.u0, p.v0, p.size);
  send(part, at.u, at.v, bilinear(light.patch.corner, at.u, at.v));
}

// Starts the exact integration of a cell. Where the receiver's surface stands on the cell's patch
// (a box on the floor) it divides the patch: the cell's centre sees only patch corners on its own
// side of the receiver's plane, and the part of the cell on the other side is lit by the corners
// there that it sees (a wall between it and them, over a patch that runs under both, would let the
// next room's light onto the strip between box and wall). Where the centre sees corners on both
// sides, something else divides the patch (a wall between two rooms) and the centre's view holds
// for the whole cell.
inline void exact_cell(const RayStart& from, const Shot& shot, const ShotCell& sc, int side, const PlaceOffset* end,
                       OcclusionBatch& batch) {
  const dvec3& x = from.x;
  const dvec3& n = from.n;
  const ShotPatch& patch = shot.patches[sc.patch];
  uint8_t seen = sc.seen[side];
  NearLight light{patch, side, {seen, seen}, sc.seen[1 - side], shot, end};
  if (seen != 15) {
    double tolerance = 1e-9 * sc.cell.radius;
    double h[4];
    bool above = false, below = false;
    for (int c = 0; c < 4; ++c) {
      h[c] = glm::dot(n, sc.cell.corners[c] - x);
      above |= h[c] > tolerance;
      below |= h[c] < -tolerance;
    }
    uint8_t front = 0;
    for (int c = 0; c < 4; ++c) front |= (glm::dot(n, patch.corner[c] - x) > 0) << c;
    uint8_t back = 15 & ~front;
    auto seen_from_part = [&](int part, uint8_t corners) {
      double u, v;
      part_centroid({sc.cell, sc.u0, sc.v0, sc.size}, h, part, u, v);
      dvec3 m = side == 0 ? sc.cell.normal : -sc.cell.normal;
      dvec3 y = bilinear(patch.corner, u, v);
      uint8_t sees = 0;
      for (int c = 0; c < 4; ++c)
        if ((corners & (1 << c)) &&
            batch.visibility().connected(y, m, patch.corner[c], m, bilinear_bulge(patch.twist), bilinear_lift(patch.twist, u, v)))
          sees |= 1 << c;
      return sees;
    };
    if (above && below && front && back && seen) {
      if ((seen & ~front) == 0) light.corners[1] = seen_from_part(1, back);
      if ((seen & ~back) == 0) light.corners[0] = seen_from_part(0, front);
    }
  }
  bool lit = patch.piece != nullptr;  // it may light a piece its corners leave dark
  // Pieces split off it may face the receiver from the other side (exact_piece).
  bool splits = splits_near(shot, sc.cell, x, 0);
  for (int c = 0; c < 4; ++c)
    lit |= (((light.corners[0] | light.corners[1]) & (1 << c)) && !is_zero(patch.radiance[c][side])) ||
           (splits && (light.other & (1 << c)) && !is_zero(patch.radiance[c][1 - side]));
  if (lit) exact_piece(from, {sc.cell, sc.u0, sc.v0, sc.size}, light, 0, batch);
}

// A point takes no cells of the patches it lies on. They are flat, or curved so that a point on
// them sees them edge-on; but the point sits a little off their corners' planes, which Lambert's
// formula would take for a view of a whole quarter of the sky, lit by the point's own light. What
// they do show it, at close range on a concave surface, it takes at its corner's radiance, with
// no ray (and so nothing that a move elsewhere changes).
int corner_at(const ShotPatch& patch, int receiver) {
  for (int c = 0; c < 4; ++c)
    if (patch.point[c] == receiver) return c;
  return -1;
}

void take_own_view(const ShotPatch& patch, int c, int receiver, OcclusionBatch& batch) {
  for (int side = 0; side < 2; ++side)
    if (patch.own_view[c][side] > 0) batch.add(receiver, side == 0, patch.own_view[c][side] * patch.radiance[c][side]);
}

// Where a far sample's one ray ends: at the anchor, moved off it by epsilon and the anchor's lift.
Sphere far_end(const ShotElement& e, double eps) { return {e.anchor, eps + e.anchor_lift}; }

}  // namespace

RADIOSITY_HOT void gather(const Shot& shot, int receiver, const ReceiverPoint& point, OcclusionBatch& batch,
                          const Zones* zone) {
  const dvec3& x = point.position;
  const dvec3& n = point.normal;
  const RayStart start{receiver, x, n};
  int stack[128];
  int top = 0;
  auto seen_edge_on = [&](const ShotElement& e) __attribute__((always_inline)) {
    return e.planar && edge_on(e.centroid, e.normal, e.radius, x, n);
  };
  if (!shot.elements.empty() && seen_edge_on(shot.elements[0])) return;  // the shooter's whole cluster
  // Closed objects (ObjectPatches::enclosed_side): the receiver's inside, when the shooter lies
  // outside its sphere, and the shooter's inside, when the receiver does, see nothing of each
  // other; their rays would all be blocked (a third to a half of what a far box sends a box).
  int shut = -1;
  if (shot.object >= 0 && shot.object != point.object) {
    if (point.enclosed_side >= 0 && !overlap(shot.bounds, point.enclosure))
      batch.set_open(point.enclosed_side == 0 ? std::array<bool, 2>{false, true} : std::array<bool, 2>{true, false});
    if (shot.enclosed_side >= 0 && glm::length(x - shot.enclosure.centre) > shot.enclosure.radius)
      shut = shot.enclosed_side;
  }
  if (shot.reflected) batch.set_share(point.reflected_share);
  // Where rays end in cells (Shot::ends_by_place): drawn for this place, or the centres.
  const PlaceOffset placed = shot.ends_by_place ? place_offset(x) : PlaceOffset{};
  const PlaceOffset* end = shot.ends_by_place ? &placed : nullptr;
  // The subtree of a frontier element, one element at a time.
  auto walk = [&](int from) __attribute__((always_inline)) {
    stack[top++] = from;
    while (top > 0) {
      const ShotElement& e = shot.elements[stack[--top]];
      if (seen_edge_on(e)) continue;
      if (e.left < 0) {
        if (e.cell_begin == e.cell_end) continue;
        // A leaf holds one patch's cells (or an area lamp's quads, which no point lies on).
        const ShotPatch& leaf = shot.patches[shot.cells[e.cell_begin].patch];
        if (int c = corner_at(leaf, receiver); c >= 0) {
          if (!zone) take_own_view(leaf, c, receiver, batch);
          continue;
        }
        for (int c = e.cell_begin; c < e.cell_end; ++c) {
          const ShotCell& sc = shot.cells[c];
          const Cell& cell = sc.cell;
          const ShotPatch& patch = shot.patches[sc.patch];
          if (zone && !zone->may_cross(x, {cell.centre, cell.radius})) continue;
          if (std::optional<double> factor = distant_cell_form_factor(cell, x, n)) {
            PlaceOffset at = end ? end_in_square(placed, sc.u0, sc.v0, sc.size)
                                 : PlaceOffset{sc.u0 + 0.5 * sc.size, sc.v0 + 0.5 * sc.size};
            far_sample(start, cell.centre,
                       {end ? bilinear(patch.corner, at.u, at.v) : cell.centre, cell.normal,
                        bilinear_lift(patch.twist, at.u, at.v), patch.under_patch},
                       [&]() __attribute__((always_inline)) { return *factor; }, sc.radiance, shut, batch);
            continue;
          }
          int side = glm::dot(cell.normal, x - cell.centre) >= 0 ? 0 : 1;
          if (side != shut) exact_cell(start, shot, sc, side, end, batch);
        }
        continue;
      }
      dvec3 d = e.centroid - x;
      bool far = glm::dot(d, d) > e.far2;
      // Asked before the form factor, which it spares for most rays an update passes over. The
      // sphere only with a zone: a solve, which has none, need not work it out.
      if (zone && !zone->may_cross(x, far ? far_end(e, batch.visibility().epsilon()) : Sphere{e.centroid, e.radius}))
        continue;
      if (far) {
        far_sample(start, e.centroid, {e.anchor, e.normal, e.anchor_lift, e.anchor_under_patch},
                   [&]() __attribute__((always_inline)) { return cluster_form_factor(x, n, e); }, e.radiance, shut,
                   batch);
        continue;
      }
      stack[top++] = e.right;
      stack[top++] = e.left;
    }
  };
  // Far samples of four frontier elements at once: all that far_sample and to_point work out for one
  // far cluster, in lanes. The lanes are then taken in the frontier's order, so the rays (and the
  // sums they add to) come in the order a walk one element at a time gives them.
  Lanes3 xs = lanes_of(x), ns = lanes_of(n);
  Lanes eps = lanes_of(batch.visibility().epsilon());
  int count = int(shot.frontier.size());
  for (int b = 0; b * kLanes < count; ++b) {
    const FrontierBlock& block = shot.frontier_blocks[b];
    int first = b * kLanes, end = std::min(count, first + kLanes);
    Lanes3 d = block.centroid - xs;
    LaneMask far = dot(d, d) > block.far2;
    if (!any(far)) {  // near all four (a draft shot's few large clusters, mostly): no sample to work out
      for (int i = first; i < end; ++i) walk(shot.frontier[i]);
      continue;
    }
    LaneMask in_front = dot(block.normal, d) <= 0;
    Lanes3 rad = select(in_front, block.radiance[0], block.radiance[1]);
    Lanes cos_r = dot(ns, d);
    Lanes factor = cluster_form_factor(xs, ns, block);
    LaneMask sends = far & ((rad.x != 0) | (rad.y != 0) | (rad.z != 0)) & (cos_r != 0) & (factor > 0);
    Lanes3 origin, dir;
    segment_ends(xs, ns, block.anchor, block.normal, eps, block.anchor_lift, origin, dir);
    Lanes3 irradiance = factor * rad;
    for (int l = 0; first + l < end; ++l) {
      if (!far[l]) {
        walk(shot.frontier[first + l]);
      } else if (sends[l]) {
        const ShotElement& e = shot.elements[shot.frontier[first + l]];
        if (zone && !zone->may_cross(x, far_end(e, batch.visibility().epsilon()))) continue;
        if ((in_front[l] ? 0 : 1) == shut || !batch.open(cos_r[l] > 0)) continue;
        if (e.anchor_under_patch >= 0)
          batch.to_point(start, {e.anchor, e.normal, e.anchor_lift, e.anchor_under_patch}, cos_r[l] > 0,
                         lane(irradiance, l));
        else
          batch.segment(receiver, lane(origin, l), lane(dir, l), cos_r[l] > 0, lane(irradiance, l));
      }
    }
  }
  batch.set_share({1.0, 1.0});
  batch.set_open({true, true});
}

}  // namespace radiosity
