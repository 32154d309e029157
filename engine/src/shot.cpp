#include "shot.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct ShotBuilder {
  const PatchMesh& mesh;
  const ClusterTree& tree;
  const std::vector<CornerUnshot>& unshot;
  double scale;
  int cells_per_side;
  Shot& shot;

  // Copies the subtree under `node`, returning its element index and filling power per side.
  int copy(int node, dvec3 power[2]) {
    const ClusterNode& n = tree.nodes[node];
    int id = int(shot.elements.size());
    shot.elements.emplace_back();
    ShotElement e;
    e.centroid = n.centroid;
    e.anchor = n.anchor;
    e.projected_area = glm::length(n.vector_area);
    e.normal = e.projected_area > 0 ? n.vector_area / e.projected_area : dvec3(0.0);
    e.radius = n.radius;
    e.flat = n.flat;
    power[0] = power[1] = dvec3(0.0);
    if (n.left < 0) {
      int p = tree.order[n.begin];
      add_cells(p, e);
      const Patch& patch = mesh.patches[p];
      for (int s = 0; s < 2; ++s) {
        for (int c = 0; c < 4; ++c) power[s] += 0.25 * patch.area * unshot[p][c * 2 + s];
        power[s] *= scale;
      }
    } else {
      dvec3 lp[2], rp[2];
      e.left = copy(n.left, lp);
      e.right = copy(n.right, rp);
      for (int s = 0; s < 2; ++s) power[s] = lp[s] + rp[s];
    }
    for (int s = 0; s < 2; ++s) e.radiance[s] = n.area > 0 ? power[s] / n.area : dvec3(0.0);
    shot.elements[id] = e;
    return id;
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
          for (int s = 0; s < 2; ++s) {
            dvec3 corner_values[4];
            for (int c = 0; c < 4; ++c) corner_values[c] = unshot[p][c * 2 + s];
            sc.radiance[s] = scale * bilinear(corner_values, u, v);
          }
          shot.cells.push_back(sc);
        }
    }
    e.cell_end = int(shot.cells.size());
  }
};

bool is_zero(const dvec3& v) { return v.x == 0 && v.y == 0 && v.z == 0; }

}  // namespace

Shot cluster_shot(const PatchMesh& mesh, const ClusterTree& tree, int node,
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
  ShotBuilder builder{mesh, tree, unshot, scale, cells_per_side, shot};
  dvec3 power[2];
  builder.copy(node, power);
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
        dvec3 irradiance = rad * (std::fabs(cos_s * cos_r) * e.projected_area / (kPi * r2 * r2));
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
