#include "visibility.h"

#include "dispatch.h"
#include "parallel.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace radiosity {

namespace {

constexpr double kRelativeEpsilon = 1e-5;

// The object's quads (so Embree's primitive ids count its patches); Visibility::take_panes commits them.
RTCGeometry make_quads(RTCDevice device, const PatchMesh& mesh, const ObjectPatches& obj) {
  std::vector<int> patches(obj.patch_end - obj.patch_begin);
  std::iota(patches.begin(), patches.end(), obj.patch_begin);
  return patch_quads(device, mesh, patches);
}

// What a trace's hits are filtered by: objects left out (occluded_without), and Coincident. Every
// trace passes one: the panes' filter reads it.
struct FilterContext {
  RTCIntersectContext context;  // first: Embree hands the filter a pointer to it
  const Visibility* vis = nullptr;
  const unsigned* excluded = nullptr;  // instance geometry ids in the top-level scene
  unsigned excluded_count = 0;
  int only_object = -1;                         // the object traced alone (occluded_by)
  const Coincident* coincident = nullptr;
  Crossings* crossings = nullptr;  // rays carry light on through panes (Visibility::occluded)
};

// Whether a hit is passed over: it is on an object left out, or on a surface a Coincident ray's
// target lies under or on that the ray must see through.
bool rejected(const FilterContext& f, const RTCFilterFunctionNArguments* args, unsigned i) {
  unsigned instance = RTCHitN_instID(args->hit, args->N, i, 0);
  if (instance != RTC_INVALID_GEOMETRY_ID &&
      std::find(f.excluded, f.excluded + f.excluded_count, instance) != f.excluded + f.excluded_count)
    return true;
  if (!f.coincident) return false;
  unsigned id = RTCRayN_id(args->ray, args->N, i);
  int target = f.coincident->target_object[id];
  // The ray's tfar is the hit's distance here (instances are not transformed: the same units).
  if (target < 0 || RTCRayN_tfar(args->ray, args->N, i) < f.coincident->zone_start[id]) return false;
  int object = f.only_object >= 0 ? f.only_object
               : f.vis->object_of(instance != RTC_INVALID_GEOMETRY_ID ? instance : RTCHitN_geomID(args->hit, args->N, i));
  if (object < target) return false;
  int patch = f.coincident->target_patch[id];
  return object > target || patch < 0 || f.vis->patch_begin(object) + int(RTCHitN_primID(args->hit, args->N, i)) >= patch;
}

void filter_hits(const RTCFilterFunctionNArguments* args) {
  const FilterContext& f = *reinterpret_cast<const FilterContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i)
    if (args->valid[i] == -1 && rejected(f, args, i)) args->valid[i] = 0;
}

void trace(RTCScene scene, FilterContext& ctx, RTCRay* rays, unsigned count) {
  if (ctx.crossings) ctx.crossings->clear(rays, count);
  rtcInitIntersectContext(&ctx.context);
  if (ctx.excluded_count > 0 || ctx.coincident) ctx.context.filter = filter_hits;
  rtcOccluded1M(scene, &ctx.context, rays, count, sizeof(RTCRay));
}

}  // namespace

RTCGeometry patch_quads(RTCDevice device, const PatchMesh& mesh, const std::vector<int>& patches) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_QUAD);
  auto* index = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4, 4 * sizeof(unsigned), patches.size()));
  // Vertices are referenced globally; copy the patches' span so each geometry is self-contained.
  int lo = INT32_MAX, hi = -1;
  for (int p : patches)
    for (int v : mesh.patches[p].vertex) lo = std::min(lo, v), hi = std::max(hi, v);
  auto* vert = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), patches.empty() ? 0 : hi - lo + 1));
  for (int v = lo; v <= hi; ++v)
    for (int k = 0; k < 3; ++k) vert[3 * (v - lo) + k] = float(mesh.vertices[v][k]);
  for (size_t i = 0; i < patches.size(); ++i)
    for (int c = 0; c < 4; ++c) index[4 * i + c] = unsigned(mesh.patches[patches[i]].vertex[c] - lo);
  return geom;
}

Visibility::Visibility(const PatchMesh& mesh, const std::vector<bool>& dynamic_objects,
                       const std::vector<bool>& visible)
    : epsilon_(kRelativeEpsilon * mesh.diagonal) {
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("Embree device could not be created");
  top_ = rtcNewScene(device_);
  rtcSetSceneFlags(top_, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);  // occluded_without
  for (size_t o = 0; o < mesh.objects.size(); ++o)
    attach(mesh, o < dynamic_objects.size() && dynamic_objects[o], o >= visible.size() || visible[o]);
  rtcCommitScene(top_);
  count_panes();
  find_coincident(mesh);
}

// The filter of quads some of which let light through. Embree runs it before the context's
// filter (filter_hits), and what it passes over that one never sees: so it leaves out what that
// one would, itself, or occluded_without would multiply in the panes of the object it leaves out.
void Visibility::filter_panes(const RTCFilterFunctionNArguments* args) {
  const FilterContext& f = *reinterpret_cast<const FilterContext*>(args->context);
  if (!f.crossings) return;  // whether two places see each other: a pane is a wall
  const Panes& panes = *static_cast<const Panes*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    if (rejected(f, args, i)) {
      args->valid[i] = 0;
      continue;
    }
    unsigned primitive = RTCHitN_primID(args->hit, args->N, i);
    const Transmission& through = panes.patches[primitive];
    if (!through.passes()) continue;  // an opaque patch of the object: the ray stops
    dvec3 d(RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
            RTCRayN_dir_z(args->ray, args->N, i));
    dvec3 n(RTCHitN_Ng_x(args->hit, args->N, i), RTCHitN_Ng_y(args->hit, args->N, i),
            RTCHitN_Ng_z(args->hit, args->N, i));
    std::array<float, 3> rgb = through.at(glm::dot(d, n) / std::sqrt(glm::dot(d, d) * glm::dot(n, n)),
                                          RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i));
    // Too little passes in every channel to be worth tracing on for: the ray stops.
    if (std::max({rgb[0], rgb[1], rgb[2]}) < 1e-4f) continue;
    if (f.crossings->add(RTCRayN_id(args->ray, args->N, i), RTCRayN_tfar(args->ray, args->N, i), panes.object,
                         panes.patch_begin + int(primitive), rgb))
      args->valid[i] = 0;
  }
}

void Visibility::take_panes(RTCGeometry quads, const PatchMesh& mesh, int object, std::unique_ptr<Panes>& panes) {
  const ObjectPatches& obj = mesh.objects[object];
  panes.reset();
  auto begin = mesh.transmission.begin() + obj.patch_begin, end = mesh.transmission.begin() + obj.patch_end;
  if (!mesh.transmission.empty() && std::any_of(begin, end, [](const Transmission& t) { return t.passes(); })) {
    panes = std::make_unique<Panes>();
    panes->object = object, panes->patch_begin = obj.patch_begin;
    panes->patches.assign(begin, end);
  }
  // Opaque quads get no filter: their hits cost what they cost in a scene without panes.
  rtcSetGeometryUserData(quads, panes.get());
  rtcSetGeometryOccludedFilterFunction(quads, panes ? filter_panes : nullptr);
  rtcCommitGeometry(quads);
}

void Visibility::count_panes() {
  transmits_ = std::any_of(objects_.begin(), objects_.end(), [](const Object& o) { return o.panes[o.now] != nullptr; });
}

void Visibility::attach(const PatchMesh& mesh, bool dynamic, bool shown) {
  Object& o = objects_.emplace_back();
  const ObjectPatches& obj = mesh.objects.at(objects_.size() - 1);
  o.patch_begin = obj.patch_begin;  // even for none: object_of_patch searches them in order
  if (obj.patch_end == obj.patch_begin) return;
  RTCGeometry quads = make_quads(device_, mesh, obj);
  take_panes(quads, mesh, int(objects_.size()) - 1, o.panes[0]);
  if (dynamic || !shown)
    make_instance(o, quads);
  else
    o.geometry = rtcAttachGeometry(top_, quads);
  rtcReleaseGeometry(quads);
  name_geometry(o);
  widen_to(mesh, obj, o.lo, o.hi);
  if (!shown) {
    o.visible[0] = o.visible[1] = false;
    rtcDisableGeometry(o.instance);
  }
}

void Visibility::add_object(const PatchMesh& mesh) {
  attach(mesh, true, false);
  rtcCommitScene(top_);
  count_panes();
  find_coincident(mesh, dvec3(INFINITY), dvec3(-INFINITY));  // hidden: it lies on nothing, nor anything on it
}

Visibility::~Visibility() {
  for (Object& o : objects_)
    for (RTCScene s : o.own)
      if (s) rtcReleaseScene(s);
  rtcReleaseScene(top_);
  rtcReleaseDevice(device_);
}

RTCScene Visibility::new_object_scene() {
  RTCScene scene = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);  // rebuilt on every move
  // Hits inside an instance reach the context filter only if its scene allows it (occluded_without).
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
  return scene;
}

void Visibility::make_instance(Object& o, RTCGeometry quads) {
  o.own[0] = new_object_scene();
  rtcAttachGeometry(o.own[0], quads);
  rtcCommitScene(o.own[0]);
  o.now = 0;
  o.instance = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
  rtcSetGeometryInstancedScene(o.instance, o.own[0]);
  const float identity[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  rtcSetGeometryTransform(o.instance, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, identity);
  rtcCommitGeometry(o.instance);
  o.geometry = rtcAttachGeometry(top_, o.instance);
  rtcReleaseGeometry(o.instance);
}

void Visibility::move_object(int object, const PatchMesh& mesh, bool visible) {
  Object& o = objects_.at(object);
  if (o.geometry == RTC_INVALID_GEOMETRY_ID) return;
  if (!o.instance) {
    RTCGeometry quads = rtcGetGeometry(top_, o.geometry);
    rtcRetainGeometry(quads);
    rtcDetachGeometry(top_, o.geometry);
    object_of_geometry_[o.geometry] = -1;
    make_instance(o, quads);
    rtcReleaseGeometry(quads);
    name_geometry(o);
  }
  // Patches that lay on it, or lie on it now, are near where it was or is.
  dvec3 lo = o.lo, hi = o.hi;
  widen_to(mesh, mesh.objects[object], lo, hi);
  int next = 1 - o.now;
  if (o.own[next]) rtcReleaseScene(o.own[next]);
  o.own[next] = new_object_scene();
  RTCGeometry quads = make_quads(device_, mesh, mesh.objects[object]);
  take_panes(quads, mesh, object, o.panes[next]);
  rtcAttachGeometry(o.own[next], quads);
  rtcReleaseGeometry(quads);
  rtcCommitScene(o.own[next]);
  o.now = next;
  o.visible[next] = visible;
  rtcSetGeometryInstancedScene(o.instance, o.own[next]);
  if (visible)
    rtcEnableGeometry(o.instance);
  else
    rtcDisableGeometry(o.instance);
  rtcCommitGeometry(o.instance);
  rtcCommitScene(top_);
  count_panes();
  find_coincident(mesh, lo, hi);
  o.lo = dvec3(INFINITY), o.hi = dvec3(-INFINITY);
  widen_to(mesh, mesh.objects[object], o.lo, o.hi);
}

void Visibility::name_geometry(const Object& o) {
  if (object_of_geometry_.size() <= o.geometry) object_of_geometry_.resize(o.geometry + 1, -1);
  object_of_geometry_[o.geometry] = int(&o - objects_.data());
}

int Visibility::object_of_patch(int patch) const {
  auto after = std::upper_bound(objects_.begin(), objects_.end(), patch,
                                [](int p, const Object& o) { return p < o.patch_begin; });
  return int(after - objects_.begin()) - 1;
}

void Visibility::occluded_by(int object, bool before_move, RTCRay* rays, unsigned count,
                             const Coincident* coincident, Crossings* crossings) const {
  const Object& o = objects_.at(object);
  int state = before_move ? 1 - o.now : o.now;
  RTCScene scene = o.own[state];
  if (!scene || !o.visible[state]) {  // nothing blocked, nothing crossed
    if (crossings) crossings->clear(rays, count);
    return;
  }
  FilterContext ctx;
  ctx.vis = this, ctx.only_object = object, ctx.coincident = coincident, ctx.crossings = crossings;
  trace(scene, ctx, rays, count);
}

void Visibility::occluded_without(int object, RTCRay* rays, unsigned count, const Coincident* coincident,
                                  Crossings* crossings) const {
  FilterContext ctx;
  ctx.vis = this, ctx.excluded = &objects_.at(object).geometry, ctx.excluded_count = 1, ctx.coincident = coincident;
  ctx.crossings = crossings;
  trace(top_, ctx, rays, count);
}

void Visibility::occluded_without(const std::vector<int>& objects, RTCRay* rays, unsigned count,
                                  const Coincident* coincident, Crossings* crossings) const {
  std::vector<unsigned> geometry;
  for (int object : objects) geometry.push_back(objects_.at(object).geometry);
  FilterContext ctx;
  ctx.vis = this, ctx.excluded = geometry.data(), ctx.excluded_count = unsigned(geometry.size());
  ctx.coincident = coincident, ctx.crossings = crossings;
  trace(top_, ctx, rays, count);
}

void Visibility::occluded(RTCRay* rays, unsigned count, const Coincident* coincident, Crossings* crossings) const {
  if (recording_) {
    std::lock_guard<std::mutex> lock(recording_->mutex);
    if (recording_->batches++ % recording_->stride == 0)
      recording_->batches_kept.emplace_back(rays, rays + count);
  }
  FilterContext ctx;
  ctx.vis = this, ctx.coincident = coincident, ctx.crossings = crossings;
  trace(top_, ctx, rays, count);
}

void Visibility::find_coincident(const PatchMesh& mesh, dvec3 lo, dvec3 hi) {
  under_.resize(mesh.patches.size(), 0);
  // Each patch is probed at 3 x 3 points by a short ray through its plane, four epsilon either
  // way (as far as Coincident's zones reach): against objects of lower index, then also against
  // its own object's patches of lower index. A point only the second finds lies on its own.
  constexpr int kProbes = 9;
  double reach = 4 * epsilon_;
  lo -= reach, hi += reach;
  int count = int(mesh.patches.size());
  parallel_for(0, count, 256, [&](int q) {
    const Patch& patch = mesh.patches[q];
    dvec3 corner[4];
    for (int c = 0; c < 4; ++c) corner[c] = mesh.vertices[patch.vertex[c]];
    dvec3 plo = glm::min(glm::min(corner[0], corner[1]), glm::min(corner[2], corner[3]));
    dvec3 phi = glm::max(glm::max(corner[0], corner[1]), glm::max(corner[2], corner[3]));
    if (glm::any(glm::lessThan(phi, lo)) || glm::any(glm::greaterThan(plo, hi))) return;
    under_[q] = 0;
    if (patch.area == 0) return;
    RTCRay rays[2][kProbes];
    int target[kProbes], own[2][kProbes];
    float zone[kProbes];
    for (int k = 0; k < kProbes; ++k) {
      double u = (1 + 2 * (k % 3)) / 6.0, v = (1 + 2 * (k / 3)) / 6.0;
      dvec3 y = bilinear(corner, u, v);
      rays[0][k] = make_ray(y + reach * patch.normal, -2 * reach * patch.normal, 1.0f);
      rays[0][k].id = unsigned(k);
      rays[1][k] = rays[0][k];
      target[k] = patch.object, own[0][k] = -1, own[1][k] = q, zone[k] = 0.0f;
    }
    for (int pass = 0; pass < 2; ++pass) {
      Coincident probe{target, own[pass], zone};
      occluded(rays[pass], kProbes, &probe);
    }
    for (int k = 0; k < kProbes; ++k) {
      if (rays[0][k].tfar < 0) under_[q] |= kOnOther;
      else if (rays[1][k].tfar < 0) under_[q] |= kOnOwn;
    }
  });
}

void Visibility::record(int stride) {
  recording_ = std::make_unique<Recording>();
  recording_->stride = std::max(1, stride);
}

double Visibility::replay_recorded() const {
  if (!recording_ || recording_->batches_kept.empty()) return 0.0;
  std::vector<std::vector<RTCRay>> batches = recording_->batches_kept;  // tracing overwrites tfar
  long long rays = 0;
  unsigned ids = 0;
  for (const auto& b : batches) {
    rays += b.size();
    for (const RTCRay& r : b) ids = std::max(ids, r.id + 1);
  }
  int count = int(batches.size());
  // As the solver traced them: on through panes where some let light through.
  tbb::enumerable_thread_specific<Crossings> crossings([&] { return Crossings(ids); });
  auto start = std::chrono::steady_clock::now();
  parallel_for(0, count, 16, [&](int i) {
    FilterContext ctx;
    ctx.vis = this, ctx.crossings = transmits_ ? &crossings.local() : nullptr;
    trace(top_, ctx, batches[i].data(), unsigned(batches[i].size()));
  });
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return rays / seconds;
}

bool Visibility::connected(const dvec3& a, const dvec3& na, const dvec3& b, const dvec3& nb, double bulge,
                           double lift_a) const {
  double chord = glm::length(b - a);
  double bend = std::acos(std::clamp(glm::dot(na, nb), -1.0, 1.0));
  double arc = epsilon_ + 0.25 * chord * bend;  // a circular arc bulges chord * bend / 8
  auto clear = [&](double at_a, double at_b) {
    dvec3 origin = a + (arc + at_a) * na;
    dvec3 dir = b + (arc + at_b) * nb - origin;
    double len = glm::length(dir);
    if (len <= 2 * epsilon_) return true;
    RTCRay ray = make_ray(origin, dir, float(1.0 - epsilon_ / len));
    occluded(&ray, 1);
    return ray.tfar >= 0;
  };
  return clear(bulge, bulge) || (bulge > lift_a && clear(lift_a, 0.0));
}

}  // namespace radiosity
