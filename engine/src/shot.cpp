#include "shot.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

bool is_zero(const dvec3& v) { return v.x == 0 && v.y == 0 && v.z == 0; }

// Copies a shooter's subtree into a shot. Radiance is interpolated or averaged only over what the
// sample point sees: a patch or cluster running under a wall would otherwise carry light from the
// lit room into the dark one.
struct ShotBuilder {
  const PatchMesh& mesh;
  const ClusterTree& tree;
  const Visibility* vis;
  const std::vector<CornerUnshot>& unshot;
  double scale;
  int cells_per_side;
  Shot& shot;

  dvec3 side_normal(const dvec3& n, int side) const { return side == 0 ? n : -n; }

  bool sees(const dvec3& a, const dvec3& na, const dvec3& b, const dvec3& nb, int side) const {
    return !vis || vis->connected(a, side_normal(na, side), b, side_normal(nb, side));
  }

  int copy(int node) {
    const ClusterNode& n = tree.nodes[node];
    int id = int(shot.elements.size());
    shot.elements.emplace_back();
    ShotElement e;
    e.centroid = n.centroid;
    e.projected_area = glm::length(n.vector_area);
    e.normal = e.projected_area > 0 ? n.vector_area / e.projected_area : dvec3(0.0);
    e.radius = n.radius;
    e.flat = n.flat;
    if (n.left < 0) {
      add_cells(tree.order[n.begin], e);
    } else {
      e.left = copy(n.left);
      e.right = copy(n.right);
      if (e.flat) average_visible(n, e);  // only flat clusters ever stand for their patches
    }
    shot.elements[id] = e;
    return id;
  }

  void average_visible(const ClusterNode& n, ShotElement& e) {
    const Patch& anchor = mesh.patches[n.anchor];
    e.anchor = anchor.centre;
    for (int side = 0; side < 2; ++side) {
      dvec3 power(0.0);
      double area = 0.0;
      for (int i = n.begin; i < n.end; ++i) {
        const Patch& p = mesh.patches[tree.order[i]];
        dvec3 mean = 0.25 * (unshot[tree.order[i]][side] + unshot[tree.order[i]][2 + side] +
                             unshot[tree.order[i]][4 + side] + unshot[tree.order[i]][6 + side]);
        if (p.area == 0 || is_zero(mean)) {
          area += p.area;
          continue;
        }
        if (&p == &anchor || sees(anchor.centre, anchor.normal, p.centre, p.normal, side)) {
          power += p.area * mean;
          area += p.area;
        }
      }
      e.radiance[side] = area > 0 ? scale * power / area : dvec3(0.0);
    }
  }

  void add_cells(int p, ShotElement& e) {
    const Patch& patch = mesh.patches[p];
    e.cell_begin = int(shot.cells.size());
    if (patch.area > 0) {
      int k = cells_per_side;
      dvec3 corners[4];
      for (int c = 0; c < 4; ++c) corners[c] = mesh.vertices[patch.vertex[c]];
      std::vector<Cell> cells(k * k);
      bilinear_cells(corners, k, cells.data());
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          ShotCell sc;
          sc.cell = cells[j * k + i];
          if (!(sc.cell.area > 0)) continue;
          double u = (i + 0.5) / k, v = (j + 0.5) / k;
          double weight[4] = {(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v};
          for (int s = 0; s < 2; ++s) {
            dvec3 sum(0.0);
            double total = 0.0;
            for (int c = 0; c < 4; ++c) {
              const dvec3& value = unshot[p][c * 2 + s];
              const ReceiverPoint& corner = mesh.points[patch.point[c]];
              if (!is_zero(value) &&
                  !sees(sc.cell.centre, sc.cell.normal, corner.position, corner.normal, s))
                continue;
              sum += weight[c] * value;
              total += weight[c];
            }
            sc.radiance[s] = total > 0 ? scale * sum / total : dvec3(0.0);
          }
          shot.cells.push_back(sc);
        }
    }
    e.cell_end = int(shot.cells.size());
  }
};


}  // namespace

Shot cluster_shot(const PatchMesh& mesh, const ClusterTree& tree, const Visibility* vis, int node,
                  const std::vector<CornerUnshot>& unshot, int samples, double scale, double near_factor) {
  // Frontier: split the widest cluster until there are `samples` of them or only patches remain.
  std::vector<int> frontier{node};
  for (;;) {
    if (int(frontier.size()) >= samples) break;
    int widest = -1;
    for (size_t i = 0; i < frontier.size(); ++i) {
      const ClusterNode& n = tree.nodes[frontier[i]];
      if (n.left >= 0 && (widest < 0 || n.radius > tree.nodes[frontier[widest]].radius)) widest = int(i);
    }
    if (widest < 0) break;
    const ClusterNode& n = tree.nodes[frontier[widest]];
    frontier[widest] = n.left;
    frontier.push_back(n.right);
  }
  int cells_per_side = std::max(1, int(std::ceil(std::sqrt(double(samples) / frontier.size()))));

  Shot shot;
  shot.near_factor = near_factor;
  ShotBuilder builder{mesh, tree, vis, unshot, scale, cells_per_side, shot};
  builder.copy(node);
  // Walk the subtree and its copy together to turn the frontier's clusters into elements.
  std::sort(frontier.begin(), frontier.end());
  std::vector<std::pair<int, int>> stack{{node, 0}};
  while (!stack.empty()) {
    auto [cluster, element] = stack.back();
    stack.pop_back();
    if (std::binary_search(frontier.begin(), frontier.end(), cluster)) {
      shot.frontier.push_back(element);
      continue;
    }
    const ClusterNode& n = tree.nodes[cluster];
    if (n.left < 0) continue;
    stack.push_back({n.left, shot.elements[element].left});
    stack.push_back({n.right, shot.elements[element].right});
  }
  return shot;
}

void gather(const Shot& shot, int receiver, const ReceiverPoint& point, OcclusionBatch& batch) {
  const dvec3& x = point.position;
  const dvec3& n = point.normal;
  int stack[128];
  int top = 0;
  for (int f : shot.frontier) {
    stack[top++] = f;
    while (top > 0) {
      const ShotElement& e = shot.elements[stack[--top]];
      if (e.left < 0) {
        for (int c = e.cell_begin; c < e.cell_end; ++c) {
          const ShotCell& sc = shot.cells[c];
          const dvec3& rad = sc.radiance[glm::dot(sc.cell.normal, x - sc.cell.centre) >= 0 ? 0 : 1];
          if (is_zero(rad)) continue;
          SideFactors f = cell_form_factor(sc.cell, x, n);
          if (f.front == 0 && f.back == 0) continue;
          batch.to_point(receiver, x, n, sc.cell.centre, sc.cell.normal, rad * f.front, rad * f.back);
        }
        continue;
      }
      dvec3 d = e.centroid - x;
      double r2 = glm::dot(d, d);
      if (e.flat && r2 > shot.near_factor * shot.near_factor * e.radius * e.radius) {
        double cos_s = glm::dot(e.normal, d);  // negative: receiver in front of the shooter
        const dvec3& rad = e.radiance[cos_s <= 0 ? 0 : 1];
        double cos_r = glm::dot(n, d);
        if (is_zero(rad) || cos_r == 0) continue;
        // Disc approximation (exact on the axis of a disc): the bare point kernel A/(pi r^2)
        // overshoots by (R/r)^2, some 10% at the near limit, and that energy adds up over a solve.
        dvec3 irradiance = rad * (std::fabs(cos_s * cos_r) / r2 * e.projected_area / (kPi * r2 + e.projected_area));
        bool front = cos_r > 0;
        batch.to_point(receiver, x, n, e.anchor, e.normal, front ? irradiance : dvec3(0.0),
                       front ? dvec3(0.0) : irradiance);
        continue;
      }
      stack[top++] = e.right;
      stack[top++] = e.left;
    }
  }
}

}  // namespace radiosity
