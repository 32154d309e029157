// Visibility with Embree: one BVH for the static geometry, one instance per dynamic object (so a
// move is a transform update), and occlusion rays traced in batches.
#pragma once

#include "bounds.h"
#include "patch_mesh.h"
#include "radiosity/form_factor.h"
#include "radiosity/lanes.h"
#include "transmission.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <memory>
#include <mutex>
#include <vector>

namespace radiosity {

// Points a ray from origin along dir, up to tfar times dir; its other fields stay as they are.
inline void aim(RTCRay& r, const dvec3& origin, const dvec3& dir, float tfar) {
  r.org_x = float(origin.x), r.org_y = float(origin.y), r.org_z = float(origin.z);
  r.dir_x = float(dir.x), r.dir_y = float(dir.y), r.dir_z = float(dir.z);
  r.tfar = tfar;
}

// An occlusion ray from origin along dir, up to tfar times dir.
inline RTCRay make_ray(const dvec3& origin, const dvec3& dir, float tfar) {
  RTCRay r;
  r.tnear = 0.0f;
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  aim(r, origin, dir, tfar);
  return r;
}

// The quads of `patches` (of `mesh`), primitive i being patches[i], in its corner order; not committed.
RTCGeometry patch_quads(RTCDevice device, const PatchMesh& mesh, const std::vector<int>& patches);

// Where a segment from receiver point x (normal n) to target y (normal m) starts, and its direction
// to where it ends: its ends lifted off their surfaces, on the sides that face each other, by
// epsilon, plus `lift` at y. On doubles, or on Lanes for four segments at once (lanes.h).
template <class V, class R>
RADIOSITY_LANES void segment_ends(const V& x, const V& n, const V& y, const V& m, R eps, R lift, V& origin, V& dir) {
  V d = y - x;
  origin = x + (dot(n, d) >= 0 ? eps : -eps) * n;
  V end = y + (dot(m, d) <= 0 ? eps + lift : -eps - lift) * m;
  dir = end - origin;
}

// Rays that end on a surface another one may lie on (a box's bottom on the floor, the tops of two
// boxes standing in each other, faces doubled in one mesh). Such a ray is traced on through its
// end's plane, and a hit near its end blocks it only on an object of lower index than its target's,
// or, where the target lies on its own object's patches, on a patch of lower index there: of
// coincident surfaces one is seen, as a ray tracer's first hit sees one. Ending short of the
// plane, as other rays do, they would see all of them: a box's inside the floor and its own
// bottom, two boxes standing in each other the floor three times and their tops twice, reflecting
// more than they take in (the solve diverges). Same-object patches block only where the target needs it:
// a ray to a patch corner would be stopped by the patches that share it. Per ray id: the target's
// object (-1: an ordinary ray), its patch (-1: its own object's patches do not block), and the ray
// parameter where its end's zone starts.
struct Coincident {
  const int* target_object;
  const int* target_patch;
  const float* zone_start;
};

class Visibility {
 public:
  // Hidden objects are instances switched off: they block nothing until they appear.
  Visibility(const PatchMesh& mesh, const std::vector<bool>& dynamic_objects, const std::vector<bool>& visible);
  ~Visibility();
  Visibility(const Visibility&) = delete;
  Visibility& operator=(const Visibility&) = delete;

  // Traces a stream of occlusion rays; an occluded ray comes back with tfar = -inf. Rays to
  // surfaces that may lie under another's carry their ids into `coincident`. With `crossings`, rays
  // that carry light go on through patches that let light through, which it records per ray id;
  // without, such a patch blocks as a wall does (whether two places see each other).
  void occluded(RTCRay* rays, unsigned count, const Coincident* coincident = nullptr,
                Crossings* crossings = nullptr) const;
  // Some patch lets light through (PatchMesh::transmission): only then do rays that carry light
  // need Crossings. Else no geometry has a filter, and rays cost what they cost without panes.
  bool transmits() const { return transmits_; }

  // An object moved, deformed, appeared or vanished: its new geometry (from `mesh`) and visibility
  // replace the old ones, which are kept until the next move so an update can ask what the old one
  // blocked. A static object becomes an instance on its first move (one rebuild of the top level).
  void move_object(int object, const PatchMesh& mesh, bool visible);
  // The mesh's next object, hidden (as an instance, to appear with move_object).
  void add_object(const PatchMesh& mesh);
  // Rays against one moved object alone, as it is now or as it was before its last move (a hidden
  // object blocks nothing); with `crossings`, on through its panes as `occluded` goes.
  void occluded_by(int object, bool before_move, RTCRay* rays, unsigned count,
                   const Coincident* coincident = nullptr, Crossings* crossings = nullptr) const;
  // Some patch of the object let light through as it was before its last move (or as it is).
  bool has_panes(int object, bool before_move) const {
    const Object& o = objects_.at(object);
    return o.panes[before_move ? 1 - o.now : o.now] != nullptr;
  }
  // Rays against the whole scene except one moved object, or several.
  void occluded_without(int object, RTCRay* rays, unsigned count, const Coincident* coincident = nullptr,
                        Crossings* crossings = nullptr) const;
  void occluded_without(const std::vector<int>& objects, RTCRay* rays, unsigned count,
                        const Coincident* coincident = nullptr, Crossings* crossings = nullptr) const;

  // Whether part of a patch may lie on a surface of an object of lower index, or on a patch of
  // lower index of its own object (within a few epsilon, facing either way): rays to it must then
  // be traced as Coincident says. Kept for the geometry as it is: worked out for every patch, and
  // after a move for those near the object.
  bool may_lie_under(int patch) const { return under_[patch] != 0; }
  bool lies_on_own(int patch) const { return under_[patch] & kOnOwn; }
  int object_of_patch(int patch) const;
  // The first patch of the object whose quads are geometry `geometry` of the top-level scene (or
  // its instance), and that object.
  int object_of(unsigned geometry) const { return object_of_geometry_[geometry]; }
  int patch_begin(int object) const { return objects_[object].patch_begin; }

  // Whether points a and b of surfaces with normals na, nb see each other on the side the normals
  // point to. The ends are lifted off their surfaces by more than the surface can bulge between
  // them, so two points of one curved patch do not occlude each other. Where that lift takes an
  // end past a neighbouring surface (a point by a box's fold, lifted through the other wall), the
  // ray is tried again with a lifted by `lift_a` alone, what its own place needs, and b (a corner
  // of a's patch) by nothing more.
  bool connected(const dvec3& a, const dvec3& na, const dvec3& b, const dvec3& nb, double bulge = 0.0,
                 double lift_a = 0.0) const;

  // Benchmark hooks: keep a copy of every `stride`-th traced batch, then trace the copies again with
  // nothing else going on (same scene, same batch size, all cores) and return rays per second.
  void record(int stride);
  double replay_recorded() const;

  // Offset that separates a ray's ends from the surfaces they lie on, relative to the scene size.
  double epsilon() const { return epsilon_; }

 private:
  // What the filter of an object's quads reads where some of them let light through.
  struct Panes {
    int object = 0, patch_begin = 0;
    std::vector<Transmission> patches;  // its patches', from patch_begin
  };
  struct Object {
    unsigned geometry = RTC_INVALID_GEOMETRY_ID;  // in top_: its quads, or its instance
    RTCGeometry instance = nullptr;
    RTCScene own[2] = {nullptr, nullptr};          // instanced geometry: now and before the last move
    std::unique_ptr<Panes> panes[2];               // the same states; null where nothing passes light
    bool visible[2] = {true, true};
    int now = 0;
    dvec3 lo{INFINITY}, hi{-INFINITY};  // its vertices' bounds as it is
    int patch_begin = 0;  // its quads' primitive ids count from here in the patch mesh
  };
  void attach(const PatchMesh& mesh, bool dynamic, bool shown);  // the mesh's next object
  RTCScene new_object_scene();
  // Embree's occlusion filter of quads with panes among them.
  static void filter_panes(const RTCFilterFunctionNArguments* args);
  // Gives the object's quads (made by make_quads, not yet committed) its panes as `mesh` has them,
  // and a filter that reads them if some of its patches let light through; commits them.
  static void take_panes(RTCGeometry quads, const PatchMesh& mesh, int object, std::unique_ptr<Panes>& panes);
  void count_panes();  // transmits_
  void make_instance(Object& o, RTCGeometry quads);
  void name_geometry(const Object& o);  // object_of(o.geometry) is o's index
  // may_lie_under for the patches whose bounds meet [lo, hi] (all, by default).
  void find_coincident(const PatchMesh& mesh, dvec3 lo = dvec3(-INFINITY), dvec3 hi = dvec3(INFINITY));

  RTCDevice device_ = nullptr;
  RTCScene top_ = nullptr;
  std::vector<Object> objects_;
  std::vector<int> object_of_geometry_;
  static constexpr char kOnOther = 1, kOnOwn = 2;
  std::vector<char> under_;        // per patch: may_lie_under, as kOnOther | kOnOwn
  bool transmits_ = false;
  double epsilon_;
  struct Recording {
    std::mutex mutex;
    int stride = 1;
    long long batches = 0;
    std::vector<std::vector<RTCRay>> batches_kept;
  };
  std::unique_ptr<Recording> recording_;
};

}  // namespace radiosity
