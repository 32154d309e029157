#include "cluster_tree.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

// |vector area| / area above which a cluster acts as one sample: a spherical cap 11 degrees from
// its middle to its rim. Flatter clusters only: the members a receiver sees edge-on count against
// the rest (at 0.95 a Catmull-Clark cube's far clusters send its surroundings 3% too little).
constexpr double kFlat = 0.99;

// How far inside its patch, in (u, v), an aim point stays. On a patch's edge it can lie on a
// junction: aimed at the foot of a wall from the far side, a ray would run along the next surface
// through the wall's edge and light a box in a sealed dark room (SealedRoomsDoNotLeakOntoABoxByTheWall).
constexpr double kInset = 0.01;

// The point of a bilinear patch nearest `target`: Gauss-Newton in (u, v), kept kInset inside
// the patch (exact in one step on a parallelogram).
dvec3 nearest_point(const dvec3 c[4], const dvec3& target) {
  double u = 0.5, v = 0.5;
  for (int step = 0; step < 4; ++step) {
    dvec3 du = (1 - v) * (c[1] - c[0]) + v * (c[2] - c[3]);
    dvec3 dv = (1 - u) * (c[3] - c[0]) + u * (c[2] - c[1]);
    dvec3 r = target - bilinear(c, u, v);
    double a = glm::dot(du, du), b = glm::dot(du, dv), d = glm::dot(dv, dv);
    double det = a * d - b * b;
    if (!(det > 0)) break;
    double e = glm::dot(du, r), f = glm::dot(dv, r);
    u = std::clamp(u + (d * e - b * f) / det, kInset, 1.0 - kInset);
    v = std::clamp(v + (a * f - b * e) / det, kInset, 1.0 - kInset);
  }
  return bilinear(c, u, v);
}

struct Builder {
  const PatchMesh& mesh;
  ClusterTree& tree;
  int next;  // the next node id: nodes are made depth first

  int build(int begin, int end) {
    int id = next++;
    tree.nodes[id] = ClusterNode();
    if (end - begin > 1) {
      int mid = split(begin, end);
      int left = build(begin, mid);
      int right = build(mid, end);
      tree.nodes[id].left = left;
      tree.nodes[id].right = right;
    }
    summarise(id, begin, end);
    return id;
  }

  // Sets the node's bounds and summary from its patches, after its children's: its second moment
  // is theirs, moved to its centroid.
  void summarise(int id, int begin, int end) {
    ClusterNode& node = tree.nodes[id];
    int left = node.left, right = node.right;
    node = ClusterNode();
    node.begin = begin, node.end = end, node.left = left, node.right = right;
    dvec3 weighted(0.0), plain(0.0);
    for (int i = begin; i < end; ++i) {
      const Patch& p = mesh.patches[tree.order[i]];
      node.area += p.area;
      node.vector_area += p.area * p.normal;
      weighted += p.area * p.centre;
      plain += p.centre;
    }
    node.centroid = node.area > 0 ? weighted / node.area : plain / double(end - begin);
    double nearest = INFINITY;
    for (int i = begin; i < end; ++i) {
      const Patch& p = mesh.patches[tree.order[i]];
      double d = glm::length(p.centre - node.centroid);
      if (d < nearest) nearest = d, node.anchor = tree.order[i];
      for (int v : p.vertex) node.radius = std::max(node.radius, glm::length(mesh.vertices[v] - node.centroid));
    }
    const Patch& anchor = mesh.patches[node.anchor];
    dvec3 corners[4];
    for (int c = 0; c < 4; ++c) corners[c] = mesh.vertices[anchor.vertex[c]];
    node.aim = nearest_point(corners, node.centroid);
    node.aim_lift = bilinear_bulge(corners, anchor.normal);
    node.flat = glm::length(node.vector_area) >= kFlat * node.area;
    if (node.flat) {
      dvec3 normal = glm::normalize(node.vector_area);
      node.planar = true;
      for (int i = begin; i < end && node.planar; ++i)
        for (int v : mesh.patches[tree.order[i]].vertex)
          node.planar &= std::fabs(glm::dot(normal, mesh.vertices[v] - node.centroid)) <= kPlanar * node.radius;
    }
    if (node.area > 0) node.spread = node.left < 0 ? patch_spread(tree.order[begin], node.centroid) : merged_spread(node);
  }

  Symmetric3 patch_spread(int patch, const dvec3& about) const {
    const Patch& p = mesh.patches[patch];
    dvec3 corners[4];
    for (int c = 0; c < 4; ++c) corners[c] = mesh.vertices[p.vertex[c]];
    Cell cell;
    bilinear_cells(corners, 1, &cell);
    area_moments(cell);
    return cell.spread.add(Symmetric3::outer(cell.centroid - about), 1.0);
  }

  Symmetric3 merged_spread(const ClusterNode& node) const {
    Symmetric3 spread;
    for (int child : {node.left, node.right}) {
      const ClusterNode& c = tree.nodes[child];
      double w = c.area / node.area;
      spread.add(c.spread, w).add(Symmetric3::outer(c.centroid - node.centroid), w);
    }
    return spread;
  }

  // Median split along the widest of position and (scaled) normal: clusters come out compact and
  // with coherent normals, so the corner of a box separates its faces early.
  int split(int begin, int end) {
    dvec3 lo(INFINITY), hi(-INFINITY), nlo(INFINITY), nhi(-INFINITY);
    for (int i = begin; i < end; ++i) {
      const Patch& p = mesh.patches[tree.order[i]];
      lo = glm::min(lo, p.centre), hi = glm::max(hi, p.centre);
      nlo = glm::min(nlo, p.normal), nhi = glm::max(nhi, p.normal);
    }
    dvec3 extent = hi - lo;
    double size = std::max(extent.x, std::max(extent.y, extent.z));
    dvec3 nextent = (nhi - nlo) * size;
    int axis = 0;
    double best = -1;
    for (int k = 0; k < 6; ++k) {
      double e = k < 3 ? extent[k] : nextent[k - 3];
      if (e > best) best = e, axis = k;
    }
    int mid = (begin + end) / 2;
    auto key = [&](int patch) {
      const Patch& p = mesh.patches[patch];
      return axis < 3 ? p.centre[axis] : p.normal[axis - 3];
    };
    std::nth_element(tree.order.begin() + begin, tree.order.begin() + mid, tree.order.begin() + end,
                     [&](int a, int b) { return key(a) < key(b); });
    return mid;
  }
};

}  // namespace

ClusterTree ClusterTree::build(const PatchMesh& mesh) {
  ClusterTree tree;
  for (size_t o = 0; o < mesh.objects.size(); ++o) tree.add_object(mesh);
  return tree;
}

void ClusterTree::add_object(const PatchMesh& mesh) {
  const ObjectPatches& obj = mesh.objects.at(object_root.size());
  order.resize(obj.patch_end);
  for (int p = obj.patch_begin; p < obj.patch_end; ++p) order[p] = p;
  object_root.push_back(-1);
  if (obj.patch_end == obj.patch_begin) return;
  int first = int(nodes.size());
  nodes.resize(first + 2 * (obj.patch_end - obj.patch_begin) - 1);  // k patches take 2k - 1
  Builder builder{mesh, *this, first};
  object_root.back() = builder.build(obj.patch_begin, obj.patch_end);
  roots.push_back(object_root.back());
}

void ClusterTree::rebuild(const PatchMesh& mesh, int object) {
  int root = object_root.at(object);
  if (root < 0) return;
  const ObjectPatches& obj = mesh.objects[object];
  for (int p = obj.patch_begin; p < obj.patch_end; ++p) order[p] = p;  // as build() starts
  Builder builder{mesh, *this, root};
  builder.build(obj.patch_begin, obj.patch_end);
}

int ClusterTree::subtree_end(int node) const {
  // Nodes are made depth first, so a subtree of k patches is the 2k - 1 nodes from its root.
  return node + 2 * (nodes[node].end - nodes[node].begin) - 1;
}

std::vector<int> ClusterTree::cut(double radius) const {
  std::vector<int> out, stack(roots.rbegin(), roots.rend());
  while (!stack.empty()) {
    int id = stack.back();
    stack.pop_back();
    const ClusterNode& n = nodes[id];
    if (n.left < 0 || n.radius <= radius) {
      out.push_back(id);
    } else {
      stack.push_back(n.right);
      stack.push_back(n.left);
    }
  }
  return out;
}

}  // namespace radiosity
