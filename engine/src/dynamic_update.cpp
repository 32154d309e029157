// Incremental updates: the paper's negative and positive shooting (sec. 3) with shadow zones (sec. 5).
//
// Radiosity is linear in the light sent, so a change is undone and redone by signed gathers that
// restore the solver's invariant (solver_impl.h) for the new scene; the unshot radiance those leave
// (positive or negative) is then shot as in a solve, down to a stop relative to that light
// (Settings::update_threshold). When an object moves:
//  - its own shooters (emission and what it has reflected) shoot negative from the old place and
//    positive from the new one, to every other receiving point;
//  - its own receiving points gather everything anew;
//  - every other pair of source and receiver gathers only the rays the move changed: a ray counts +
//    where the object blocked it before and not now (the exit zone), - where the reverse (the enter
//    zone), and nothing where it blocks both times or neither (the stay zone). Pairs whose rays
//    cannot pass near the object, old or new (a capsule test, the paper's cone test), cost nothing.
// Objects that move together (a frame of an animation) do so in one pass: a ray counts if what the
// moved objects block of it changed, whichever of them. An object that vanishes is a move to
// nowhere: it blocks nothing after, sends and holds nothing; one that appears, a move from nowhere.
#include "solver_impl.h"

#include "coincident_patches.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace radiosity {

namespace {

// The gathers of an update are not cancellable: half of one would break the invariant.
constexpr bool kWhole = false;

// When a change leaves less than this part of the light (the main lamp turned off), what was shot
// of the old light would have to cancel to the new scene's precision; its sampling errors, relative
// to the old light, would be that much larger in the new one (a bright cube vanishing from a dim
// room). Solving the new scene afresh is exact.
constexpr double kRestartBelow = 0.1;

// An update stops at most this many thresholds up: light left unshot after a change is signed and
// lies near it (a shadow half moved), so it costs a frame more accuracy than a solve's, spread and
// positive, at the same residual; and a change that moves much light (a lamp moved) would otherwise
// stop where the scene is visibly off.
constexpr double kStopAtMost = 3.0;

// Groups of receivers whose sources an update culls together, relative to a shooter's size.
constexpr double kGroupRadius = 0.5;

// Around the object's vertices, before (mesh) or after (PlacedObject::at) a move.
Sphere bounds_of(const std::vector<dvec3>& points, double margin) {
  dvec3 lo(INFINITY), hi(-INFINITY);
  for (const dvec3& p : points) lo = glm::min(lo, p), hi = glm::max(hi, p);
  Sphere s{0.5 * (lo + hi), 0.0};
  for (const dvec3& p : points) s.radius = std::max(s.radius, glm::length(p - s.centre));
  s.radius += margin;
  return s;
}

// Receiving points in groups of neighbours: the corners of the patches of each node of a cut of
// the cluster tree (a point shared by several, in the first).
struct ReceiverGroups {
  std::vector<int> of;          // per point
  std::vector<Sphere> bounds;   // per group, around its points
};

ReceiverGroups group_receivers(const PatchMesh& mesh, const ClusterTree& tree, double radius) {
  ReceiverGroups g;
  g.of.assign(mesh.points.size(), -1);
  std::vector<int> nodes = tree.cut(radius);
  std::vector<dvec3> lo(nodes.size(), dvec3(INFINITY)), hi(nodes.size(), dvec3(-INFINITY));
  for (size_t k = 0; k < nodes.size(); ++k) {
    const ClusterNode& n = tree.nodes[nodes[k]];
    for (int i = n.begin; i < n.end; ++i)
      for (int point : mesh.patches[tree.order[i]].point)
        if (g.of[point] < 0) {
          g.of[point] = int(k);
          lo[k] = glm::min(lo[k], mesh.points[point].position);
          hi[k] = glm::max(hi[k], mesh.points[point].position);
        }
  }
  g.bounds.resize(nodes.size());
  for (size_t k = 0; k < nodes.size(); ++k) g.bounds[k].centre = 0.5 * (lo[k] + hi[k]);
  for (size_t i = 0; i < mesh.points.size(); ++i) {
    Sphere& s = g.bounds[g.of[i]];
    s.radius = std::max(s.radius, glm::length(mesh.points[i].position - s.centre));
  }
  return g;
}

// Where the object is (its mesh) and where `placed` puts it, each within a sphere `margin` wide.
Zone zone_of(const PatchMesh& mesh, int object, const PlacedObject& placed, double margin) {
  const ObjectPatches& o = mesh.objects[object];
  return {bounds_of({mesh.vertices.begin() + o.vertex_begin, mesh.vertices.begin() + o.vertex_end}, margin),
          bounds_of(placed.at, margin)};
}

const Source& source_ref(const Source& s) { return s; }
const Source& source_ref(const Source* s) { return *s; }

}  // namespace

const SolveStats& Solver::Impl::update(const ProgressCallback& progress) {
  auto start = std::chrono::steady_clock::now();
  cancel_requested = false;
  stats.cancelled = false;
  touched.assign(mesh.points.size(), 0);
  Pending changes = std::move(pending);
  pending = Pending();
  // Refuse a bad change before anything moves: the state stays as it was. Only what changes is
  // checked (the set_* calls took indices the scene has).
  for (const auto& [o, m] : changes.meshes) validate_mesh(m, o, scene.materials.size());
  for (const auto& [i, m] : changes.materials) validate_material(m, i);
  for (const auto& [i, l] : changes.lamps) validate_lamp(l, i);
  if (changes.world) validate_world(*changes.world);
  // A material whose panes pass more or less light changes what rays get through: each object with
  // a patch of it moves where it stands, its panes' light changing as a moved object's shadow does.
  for (const auto& [i, m] : changes.materials) {
    if (!optics_differ(scene.materials[i], m)) continue;
    for (const Patch& patch : mesh.patches)
      if (patch.material == i) changes.meshes.emplace(patch.object, scene.meshes[patch.object]);
  }
  std::map<int, PlacedObject> placed;
  for (const auto& [o, m] : changes.meshes) {
    const MeshDesc& was = scene.meshes[o];
    if (mesh.objects[o].coincident_with_others &&
        (m.transform != was.transform || m.positions != was.positions || m.visible != was.visible))
      throw std::invalid_argument("object '" + m.name +
                                  "': it has faces stacked on another object's (or another's on its), seen once; "
                                  "changed, it must be added anew");
    placed[o] = refine_object(mesh, o, m);
    if (!copies_hold(mesh, o, placed[o]))
      throw std::invalid_argument("object '" + m.name +
                                  "': its deformation pulls apart faces stacked on its own, seen once; it must be "
                                  "added anew");
  }
  auto done = [&]() -> const SolveStats& {
    DbCache::Counts db = db_cache.take_counts();
    stats.db_hits = db.hits, stats.db_misses = db.misses;
    stats.db_entries = db_cache.entries(), stats.db_bytes = db_cache.bytes();
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return stats;
  };

  stats.shoot_residual = stats.shoot_seconds = 0.0;
  stats.restart.clear();
  double unshot_before = 0.0;
  if (!injected) {  // nothing gathered yet (or forgotten): the next solve sees the new scene
    for (const auto& [i, m] : changes.materials) take_material(i, m);
    for (const auto& [o, m] : changes.meshes) place(o, m, placed[o]);  // with their materials' panes
    for (const auto& [i, l] : changes.lamps) scene.lamps[i] = l;
    if (changes.world) scene.world = *changes.world;
    return done();
  } else {
    double light = injected_power;
    unshot_before = total_unshot_power();
    // What the near direct light worked out stands where the direct light does (a read costs seconds
    // in a large room): only objects moved, none of them an emitter, and only near them.
    bool light_changed = changes.world || !changes.lamps.empty() || !changes.materials.empty();
    std::vector<int> objects;
    std::vector<Zone> zones;
    for (const auto& [o, m] : changes.meshes) {
      objects.push_back(o);
      for (int q = mesh.objects[o].patch_begin; q < mesh.objects[o].patch_end; ++q)
        light_changed = light_changed || mesh.emits(q);
      // A mirror that moves (or comes, or goes) moves its images' light everywhere.
      const std::vector<int>& faces = m.face_materials;
      light_changed = light_changed || std::any_of(faces.begin(), faces.end(), [&](int f) {
                        return is_mirror(scene.materials[f]);
                      }) || std::any_of(mirrors.begin(), mirrors.end(), [&](const auto& plane) {
                        return object_of(*plane, mesh) == o;
                      });
    }
    // The reflected light every point's surroundings send changes with any change.
    if (light_changed || settings.exact_near_reflected) near_direct.reset();
    if (changes.world) change_world(*changes.world);
    for (const auto& [i, l] : changes.lamps) change_lamp(i, l);
    for (const auto& [i, m] : changes.materials) change_material(i, m);
    zones = change_objects(changes.meshes, placed);
    keep_near_direct(objects, zones);
    if (light > 0 && !(injected_power > kRestartBelow * light))
      stats.restart = "the change left " + std::to_string(int(std::round(100 * injected_power / light))) +
                      "% of the light (under " + std::to_string(int(100 * kRestartBelow)) + "%)";
  }
  if (!stats.restart.empty()) {
    restart();
    touched.assign(mesh.points.size(), 1);
  }
  stats.touched_points = std::count(touched.begin(), touched.end(), 1);
  auto shooting = std::chrono::steady_clock::now();
  if (!injected) {
    solve(progress);
    stats.shoot_residual = 1.0;
  } else {
    double unshot_after = total_unshot_power();
    stats.shoot_residual = reference_power > 0 ? unshot_after / reference_power : 0.0;
    // The light the change put to shoot sets how far it is shot (Settings::update_threshold); light
    // left from before (a budgeted update's) is shot down with it.
    double moved = reference_power > 0 ? std::max(0.0, unshot_after - unshot_before) / reference_power : 0.0;
    double stop = std::min(kStopAtMost * settings.threshold, settings.update_threshold * moved);
    propagate(progress, {std::max(settings.threshold, stop), true});
  }
  stats.shoot_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - shooting).count();
  return done();
}

void Solver::Impl::add(const SceneDesc& more) {
  SceneDesc next = scene;
  next.materials.insert(next.materials.end(), more.materials.begin(), more.materials.end());
  next.meshes.insert(next.meshes.end(), more.meshes.begin(), more.meshes.end());
  next.lamps.insert(next.lamps.end(), more.lamps.begin(), more.lamps.end());
  next.validate();
  for (const MeshDesc& m : more.meshes)
    for (const dvec3& p : m.positions)
      if (!(glm::length(dvec3(m.transform * glm::dvec4(p, 1.0)) - mesh.origin) <= mesh.diagonal))
        throw std::invalid_argument("object '" + m.name + "' reaches beyond the scene the solver was made " +
                                    "for; it needs a new Solver");
  check_patch_budget(mesh, more.meshes, settings);
  scene.materials = std::move(next.materials);
  // Lamps come dark, and light up as a lamp's change of strength.
  for (const Lamp& l : more.lamps) {
    if (channel_sum(l.color) > 0) pending.lamps[int(scene.lamps.size())] = l;
    scene.lamps.push_back(l);
    scene.lamps.back().color = dvec3(0.0);
  }
  // Meshes come hidden, and appear as a hidden object does: a move from nowhere.
  int degenerate = mesh.degenerate_patches;
  int first_object = int(scene.meshes.size());
  for (MeshDesc m : more.meshes) {
    int object = int(scene.meshes.size());
    m.dynamic = true;
    if (m.visible) pending.meshes[object] = m;
    m.visible = false;
    scene.meshes.push_back(m);
    add_object(mesh, m, scene.materials, settings);
    tree.add_object(mesh);
    vis->add_object(mesh);
  }
  fit_to_mesh(first_object);
  near_direct.reset();
  if (mesh.degenerate_patches > degenerate)
    stats.warnings.push_back(std::to_string(mesh.degenerate_patches - degenerate) +
                             " degenerate (zero-area) patches of added objects were left out");
}

void Solver::Impl::restart() {
  for (auto* points : {&front, &back, &reflected_front, &reflected_back})
    std::fill(points->begin(), points->end(), dvec3(0.0));
  CornerUnshot none;
  none.fill(dvec3(0.0));
  std::fill(unshot.begin(), unshot.end(), none);
  std::fill(shot.begin(), shot.end(), none);
  injected = false;
  injected_power = reference_power = 0.0;
}

// A fresh solve measures its residual against the direct light that lands; when the lamps, world
// or emission change, so does that scale (a lamp four times as strong: four times the scale).
void Solver::Impl::add_direct_power(double change) {
  double before = injected_power;
  injected_power += change;
  if (before > 0 && injected_power > 0) reference_power *= injected_power / before;
}

void Solver::Impl::apply_direct_delta() {
  add_direct_power(landed_power());
  apply_delta(Light::direct);
  if (reference_power == 0) take_reference();  // the first light: as a solve starts
}

void Solver::Impl::gather_direct_change(std::vector<Source> sources) {
  add_images(sources);
  gather_all([](int) { return true; }, [this] { return delta_batch(); },
             [&](int i, const ReceiverPoint& p, OcclusionBatch& batch) {
               for (const Source& s : sources) s.gather(i, p, batch);
             },
             kWhole);
  apply_direct_delta();
  touched.assign(mesh.points.size(), 1);
}

void Solver::Impl::change_world(const WorldMap& world) {
  // A uniform sky's change is one uniform sky; a map's, the old one taken back and the new one sent.
  if (world.texels.size() == 1 && scene.world.texels.size() == 1)
    gather_direct_change(
        {world_source(WorldMap::uniform(world.texels[0] - scene.world.texels[0]), settings.samples_direct)});
  else
    gather_direct_change({world_source(scene.world.scaled(-1.0), settings.samples_direct),
                          world_source(world, settings.samples_direct)});
  scene.world = world;
}

namespace {

bool same_but_colour(const Lamp& a, const Lamp& b) {
  return a.type == b.type && a.position == b.position && a.direction == b.direction && a.radius == b.radius &&
         a.angle == b.angle && a.spot_size == b.spot_size && a.spot_blend == b.spot_blend &&
         a.u_axis == b.u_axis && a.v_axis == b.v_axis;
}

}  // namespace

// Radiosity is linear in the light sent: when one lamp is all the light there is (no other lamp,
// world or emission) and only its strength changes, every radiance held is that lamp's, so the
// whole state scales with it. Exact, and no rays: a key light dimming over an animation costs a
// pass over the arrays instead of a solve's worth of reflected shots. The factor must be one for
// all channels: the residual's scale is a sum over them.
bool Solver::Impl::scale_sole_lamp(int index, const Lamp& lamp) {
  const Lamp& old = scene.lamps[index];
  // Colours are validated non-negative: a zero channel sum is no light.
  if (!same_but_colour(old, lamp) || scene.world.lit() || !(channel_sum(old.color) > 0)) return false;
  for (size_t i = 0; i < scene.lamps.size(); ++i)
    if (int(i) != index && channel_sum(scene.lamps[i].color) > 0) return false;
  for (const dvec3& e : mesh.emission)
    if (channel_sum(e) > 0) return false;
  double k = glm::dot(lamp.color, old.color) / glm::dot(old.color, old.color);
  if (glm::length(lamp.color - k * old.color) > 1e-12 * glm::length(lamp.color)) return false;
  for (auto* points : {&front, &back, &reflected_front, &reflected_back})
    for (dvec3& h : *points) h *= k;
  for (auto* patches : {&unshot, &shot})
    for (CornerUnshot& c : *patches)
      for (dvec3& r : c) r *= k;
  injected_power *= k;
  reference_power *= k;
  touched.assign(mesh.points.size(), 1);
  scene.lamps[index] = lamp;
  return true;
}

void Solver::Impl::change_lamp(int index, const Lamp& lamp) {
  if (scale_sole_lamp(index, lamp)) return;
  std::vector<Source> sources;
  for (double sign : {-1.0, 1.0}) {
    Lamp l = sign < 0 ? scene.lamps[index] : lamp;
    l.position -= mesh.origin;
    l.color *= sign;
    sources.push_back(lamp_source(l, settings.samples_direct));
  }
  gather_direct_change(sources);
  scene.lamps[index] = lamp;
}

void Solver::Impl::take_material(int index, const Material& m) {
  scene.materials[index] = m;
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const Patch& patch = mesh.patches[p];
    if (patch.material != index) continue;
    // A textured object's reflectance (emission) is its own, per corner.
    if (scene.meshes[patch.object].corner_reflectance.empty())
      std::fill_n(mesh.reflectance.begin() + 4 * p, 4, diffuse_reflectance(m, curved(patch.object)));
    if (scene.meshes[patch.object].corner_emission.empty())
      std::fill_n(mesh.emission.begin() + 4 * p, 4, m.emission);
  }
}

void Solver::Impl::change_material(int index, const Material& m) {
  Material old = scene.materials[index];
  // Reflected light: B = E + rho H, so the patches reflect (rho' - rho) H more than they did. A
  // textured object's reflectance (emission) is its own.
  dvec3 emission = m.emission - old.emission;
  std::vector<CornerUnshot> emitted(mesh.patches.size());
  for (size_t p = 0; p < mesh.patches.size(); ++p) {
    const Patch& patch = mesh.patches[p];
    emitted[p].fill(dvec3(0.0));
    if (patch.material != index) continue;
    if (scene.meshes[patch.object].corner_reflectance.empty())
      change_reflectance(int(p), diffuse_reflectance(m, curved(patch.object)));
    // A hidden object emits nothing.
    if (patch.area > 0 && scene.meshes[patch.object].visible && scene.meshes[patch.object].corner_emission.empty())
      emitted[p].fill(emission);
  }
  take_material(index, m);
  // Emitted light: the difference, shot like all emission.
  std::vector<Source> sources = patch_sources(emitted, false, settings.samples_direct, 1.0, nullptr);
  if (!sources.empty()) gather_direct_change(sources);
}

void Solver::Impl::place(int object, const MeshDesc& m, const PlacedObject& placed) {
  if (scene.meshes[object].visible || m.visible)  // a hidden one blocks no ray
    db_cache.moved(object, zone_of(mesh, object, placed, 2 * vis->epsilon()));
  scene.meshes[object] = m;
  place_object(mesh, object, m, placed);
  radiosity::take_optics(mesh, object, scene.materials);  // the panes it takes there
  tree.rebuild(mesh, object);  // as a fresh solve would cluster it there: a refit is off on a curved one
  cut_shooters();
  vis->move_object(object, mesh, m.visible);
  mark_hidden(object);
}

void Solver::Impl::forget_nodes(int node) {
  const ClusterNode& n = tree.nodes[node];
  std::vector<int> patches(tree.order.begin() + n.begin, tree.order.begin() + n.end);
  shot_cache.forget(patches, node, tree.subtree_end(node));
}

// What change_objects' steps share: the objects, where they were and are, and the shooters whose
// light they change.
struct Solver::Impl::ObjectsChange {
  // Per object changed, in one order: the object, as it is to be, its refined geometry there, and
  // where it was and is.
  std::vector<int> objects;
  std::vector<const MeshDesc*> desc;
  std::vector<const PlacedObject*> placed;
  std::vector<Zone> zones;
  std::vector<char> changing;  // per object of the scene: one of `objects`
  std::vector<char> on_them;   // per receiving point: on one of them
  // Their own shooters, and those near enough for one of them to come between their own parts
  // (what a shooter's samples see of itself is cached, and shapes the light it sends). Flags per
  // shooter of the cut as it is; the objects' are cut anew where they land, so they are taken again
  // then (the others keep their nodes, and their order).
  std::vector<int> near_nodes;  // sorted
  std::vector<char> own, near;
  // The cut before the move, and `own` in it: the sources made then name shooters by their index
  // in it.
  std::vector<int> shooters_before;
  std::vector<char> own_before;
  // Sources as they shoot before the move, made before it: all the direct light, the others'
  // reflected light, and the near shooters' (direct and reflected).
  std::vector<Source> others_direct, others_reflected, near_before;
  double own_direct_before = 0.0;  // the direct light landing on the objects' points (landed_power)
  // The mirrors of other objects, which stay (their images' rays change where the objects cross
  // them, as others' do), and the objects' own before and after the move (all their images change).
  MirrorPlanes still, theirs_before, theirs_after;

  bool on_object(int point) const { return on_them[point]; }
};

namespace {

// Gathers each receiver's light from all `sources` (of Source or of const Source*), into its batch.
template <class Sources>
auto gather_from(const Sources& sources) {
  return [&sources](int i, const ReceiverPoint& p, OcclusionBatch& batch) {
    for (const auto& s : sources) source_ref(s).gather(i, p, batch);
  };
}

}  // namespace

// All the objects at once: each shooter's light is taken back, sent again and walked for its
// changed rays once an update, not once a moved object, and a ray in several objects' zones is
// asked about once.
std::vector<Zone> Solver::Impl::change_objects(const std::map<int, MeshDesc>& meshes,
                                               std::map<int, PlacedObject>& placed) {
  std::vector<Zone> zones;
  ObjectsChange change;
  change.changing.assign(mesh.objects.size(), 0);
  change.on_them.assign(mesh.points.size(), 0);
  for (const auto& [o, m] : meshes) {
    if (!scene.meshes[o].visible && !m.visible) {  // hidden before and after: nothing to light
      place(o, m, placed[o]);
      Sphere nowhere{dvec3(0.0), -INFINITY};
      zones.push_back({nowhere, nowhere});
      continue;
    }
    zones.push_back(zone_of(mesh, o, placed[o], 2 * vis->epsilon()));
    change.objects.push_back(o);
    change.desc.push_back(&m);
    change.placed.push_back(&placed[o]);
    change.zones.push_back(zones.back());
    change.changing[o] = 1;
    const ObjectPatches& patches = mesh.objects[o];
    std::fill(change.on_them.begin() + patches.point_begin, change.on_them.begin() + patches.point_end, 1);
  }
  if (change.objects.empty()) return zones;
  begin_change(change);
  take_back_sent(change);
  send_by_their_mirrors(change, change.theirs_before, -1.0);
  keep_sources_before(change);
  move(change);
  send_again(change);
  send_by_their_mirrors(change, change.theirs_after, 1.0);
  gather_changed_rays(change);
  gather_on_objects(change);
  return zones;
}

void Solver::Impl::begin_change(ObjectsChange& change) {
  for (int node : shooters) {
    const ClusterNode& n = tree.nodes[node];
    if (!shoots_from(change, node) &&
        std::any_of(change.zones.begin(), change.zones.end(), [&](const Zone& zone) {
          return overlap({n.centroid, n.radius}, zone.before) || overlap({n.centroid, n.radius}, zone.after);
        }))
      change.near_nodes.push_back(node);
  }
  std::sort(change.near_nodes.begin(), change.near_nodes.end());
  flag_shooters(change);
  for (const auto& plane : mirrors)
    (change.changing[object_of(*plane, mesh)] ? change.theirs_before : change.still).push_back(plane);
}

bool Solver::Impl::shoots_from(const ObjectsChange& change, int node) const {
  return change.changing[mesh.patches[tree.order[tree.nodes[node].begin]].object];
}

void Solver::Impl::flag_shooters(ObjectsChange& change) const {
  change.own.assign(shooters.size(), 0), change.near.assign(shooters.size(), 0);
  for (size_t s = 0; s < shooters.size(); ++s) {
    change.own[s] = shoots_from(change, shooters[s]);
    change.near[s] = std::binary_search(change.near_nodes.begin(), change.near_nodes.end(), shooters[s]);
  }
}

// Direct light (lamps, world, emission) that lands sets the residual's scale, which must follow it
// (an emitter that vanishes or appears, a shadow that moves): direct and reflected light are
// gathered apart, direct through apply_direct_delta. (Left out: a near emitter re-sent because an
// object changed what its samples see of it, a small change.)
void Solver::Impl::emit_own(const ObjectsChange& change, double sign) {
  std::vector<Source> emitted = direct_sources(sign, &change.own);  // `own` as it is at the time
  if (emitted.empty()) return;
  gather_all([&](int i) { return !change.on_object(i); }, [this] { return delta_batch(); }, gather_from(emitted),
             kWhole);
  apply_direct_delta();
}

// The direct light landing on the objects' own points (a closed emitter lights its own inside).
double Solver::Impl::direct_on_own(const ObjectsChange& change) {
  gather_all([&](int i) { return change.on_object(i); }, [this] { return delta_batch(); },
             gather_from(direct_sources(1.0, nullptr)), kWhole);
  return landed_power();
}

void Solver::Impl::take_back_sent(ObjectsChange& change) {
  emit_own(change, -1.0);
  gather_all([&](int i) { return !change.on_object(i); }, [this] { return delta_batch(); },
             gather_from(reflected_sources(-1.0, &change.own)), kWhole);
  apply_delta(Light::reflected);
}

void Solver::Impl::keep_sources_before(ObjectsChange& change) {
  change.others_direct = direct_sources(1.0, nullptr, &change.still);
  std::vector<char> others(shooters.size());
  for (size_t s = 0; s < shooters.size(); ++s) others[s] = !change.own[s];
  change.others_reflected = reflected_sources(1.0, &others, &change.still);
  change.near_before = direct_sources(1.0, &change.near, &change.still);
  for (Source& r : reflected_sources(1.0, &change.near, &change.still)) change.near_before.push_back(std::move(r));
  change.own_direct_before = direct_on_own(change);
}

void Solver::Impl::move(ObjectsChange& change) {
  change.own_before = change.own;
  change.shooters_before = shooters;
  for (size_t k = 0; k < change.objects.size(); ++k) place(change.objects[k], *change.desc[k], *change.placed[k]);
  flag_shooters(change);
  change.theirs_after = find_planes(&change.changing);
  mirrors = change.still;
  mirrors.insert(mirrors.end(), change.theirs_after.begin(), change.theirs_after.end());
  for (int object : change.objects)
    if (tree.object_root[object] >= 0) forget_nodes(tree.object_root[object]);
  for (size_t s = 0; s < shooters.size(); ++s)
    if (change.near[s]) forget_nodes(shooters[s]);
}

// Sent again from where they are (emission only, from one that just appeared: it has reflected
// nothing yet; nothing, from one that vanished: what it sent was taken back, so its totals go now);
// and a near shooter whose light the move changed, sent anew.
void Solver::Impl::send_again(ObjectsChange& change) {
  for (size_t k = 0; k < change.objects.size(); ++k)
    if (!change.desc[k]->visible) {
      const ObjectPatches& o = mesh.objects[change.objects[k]];
      for (int p = o.patch_begin; p < o.patch_end; ++p) shot[p].fill(dvec3(0.0));
    }
  emit_own(change, 1.0);
  std::vector<Source> resent[2] = {{}, reflected_sources(1.0, &change.own)};  // emitted, reflected
  std::vector<Source> near_after = direct_sources(1.0, &change.near, &change.still);
  for (Source& r : reflected_sources(1.0, &change.near, &change.still)) near_after.push_back(std::move(r));
  std::vector<Source>& near_before = change.near_before;
  for (size_t k = 0; k < near_after.size(); ++k)
    if (!same_light(near_before[k].shot, near_after[k].shot)) {
      std::vector<Source>& kind = resent[near_after[k].shot.reflected];
      // Most of a near shooter's cells see what they saw (a floor beside a box): sending only the
      // difference spares sending it whole twice.
      if (std::optional<Shot> difference_shot = difference(near_after[k].shot, near_before[k].shot)) {
        near_after[k].shot = std::move(*difference_shot);
        kind.push_back(std::move(near_after[k]));
        continue;
      }
      kind.push_back(std::move(near_after[k]));
      near_before[k].shot = scaled(std::move(near_before[k].shot), -1.0);
      kind.push_back(std::move(near_before[k]));
    }
  for (Light light : {Light::direct, Light::reflected}) {
    const std::vector<Source>& kind = resent[light == Light::reflected];
    if (kind.empty()) continue;
    gather_all([&](int i) { return !change.on_object(i); }, [this] { return delta_batch(); }, gather_from(kind),
               kWhole);
    apply_delta(light);
  }
}

// Every image in the objects' own mirrors changes with them: taken back whole before the move and
// sent whole after it, to every point but theirs (which gather all anew). Their own shooters' images
// go with the rest of their light (take_back_sent, send_again).
void Solver::Impl::send_by_their_mirrors(const ObjectsChange& change, const MirrorPlanes& planes, double sign) {
  if (planes.empty()) return;
  std::vector<char> others(shooters.size());
  for (size_t s = 0; s < shooters.size(); ++s) others[s] = !change.own[s];
  for (Light light : {Light::direct, Light::reflected}) {
    std::vector<Source> images = light == Light::direct ? direct_sources(sign, nullptr, &planes)
                                                        : reflected_sources(sign, &others, &planes);
    images.erase(std::remove_if(images.begin(), images.end(),
                                [&](const Source& s) { return !s.mirror || (s.shooter >= 0 && change.own[s.shooter]); }),
                 images.end());
    if (images.empty()) continue;
    gather_all([&](int i) { return !change.on_object(i); }, [this] { return delta_batch(); }, gather_from(images),
               kWhole);
    if (light == Light::direct) apply_direct_delta();
    else apply_delta(Light::reflected);
  }
}

// Everything else: only the rays the move changed, for receivers and sources the objects may stand
// between. A source is asked about each point of a group of receivers only if it may be about one
// of them, and then only about the objects it may be about: most of a room's sources pass near no
// moved object for most receivers, and near one for most of the rest.
void Solver::Impl::gather_changed_rays(ObjectsChange& change) {
  ReceiverGroups groups = group_receivers(mesh, tree, kGroupRadius * settings.shooter_size_relative * mesh.diagonal);
  for (int object : change.objects) db_cache.prepare(object);
  ChangedRays changed(*vis, change.objects, change.zones, db_cache);
  auto gather_changed = [&](const std::vector<Source>& others) {
    // Per group, the sources that may reach it, each with the zones it may reach there (in `zones`
    // of the group, from `first`).
    struct Reach {
      int source, first, count;
    };
    std::vector<std::vector<Reach>> reaching(groups.bounds.size());
    std::vector<std::vector<Zone>> zones(groups.bounds.size());
    parallel_for(0, int(groups.bounds.size()), 16, [&](int g) {
      for (size_t k = 0; k < others.size(); ++k) {
        const Source& s = others[k];
        if (s.shooter >= 0 && change.own_before[s.shooter]) continue;
        int first = int(zones[g].size());
        for (const Zone& zone : change.zones)
          if (s.may_reach(groups.bounds[g], zone)) zones[g].push_back(zone);
        if (int(zones[g].size()) > first) reaching[g].push_back({int(k), first, int(zones[g].size()) - first});
      }
    });
    gather_all([&](int i) { return !change.on_object(i); }, [&] { return changed_batch(changed); },
               [&](int i, const ReceiverPoint& p, OcclusionBatch& batch) {
                 int g = groups.of[i];
                 long long pushed = batch.rays_pushed();
                 for (const Reach& r : reaching[g]) {
                   Zones near{zones[g].data() + r.first, r.count};
                   others[r.source].gather(i, p, batch, &near);
                 }
                 if (batch.rays_pushed() > pushed) touched[i] = 1;
               },
               kWhole);
    db_cache.commit();
  };
  gather_changed(change.others_direct);
  apply_direct_delta();
  gather_changed(change.others_reflected);
  apply_delta(Light::reflected);
}

// The objects' own receiving points: everything, anew (nothing, on one that vanished), each kind of
// light in place of what it held of it.
void Solver::Impl::gather_on_objects(ObjectsChange& change) {
  double own_direct_after = direct_on_own(change);
  for (int object : change.objects) {
    const ObjectPatches& o = mesh.objects[object];
    for (int i = o.point_begin; i < o.point_end; ++i) {
      delta_front[i] -= front[i] - reflected_front[i];
      delta_back[i] -= back[i] - reflected_back[i];
      touched[i] = 1;
    }
  }
  apply_delta(Light::direct);
  // Reflected light as reflected_sources() would send it now, in its order (each sum takes its
  // terms as it would): a shooter neither on the objects nor near them sends what it sent before
  // the move (its shot is made of what did not move, and of what its samples saw of themselves,
  // which the move left standing), so its shot made then serves, and its images in the mirrors
  // that stayed; its images in the objects' mirrors are made from it.
  std::vector<char> changed(shooters.size());
  for (size_t s = 0; s < shooters.size(); ++s) changed[s] = change.own[s] || change.near[s];
  std::vector<Source> remade = reflected_sources(1.0, &changed);
  auto unchanged = [&](const Source& b) {
    return !std::binary_search(change.near_nodes.begin(), change.near_nodes.end(), change.shooters_before[b.shooter]);
  };
  std::vector<Source> kept_images;
  for (const Source& b : change.others_reflected)
    if (!b.mirror && unchanged(b))
      for (const auto& plane : change.theirs_after)
        for (Source& image : mirror_images(b, plane)) kept_images.push_back(std::move(image));
  // Each by its shooter's node and its mirror (null: the shooter itself).
  std::map<std::pair<int, const MirrorPlane*>, const Source*> now;
  for (const std::vector<Source>* before : {&change.others_reflected, &kept_images})
    for (const Source& b : *before)
      if (unchanged(b)) now[{change.shooters_before[b.shooter], b.mirror.get()}] = &b;
  for (const Source& r : remade) now[{shooters[r.shooter], r.mirror.get()}] = &r;
  std::vector<const Source*> reflected_now;
  auto take = [&](const MirrorPlane* mirror) {
    for (int node : shooters)
      if (auto it = now.find({node, mirror}); it != now.end()) reflected_now.push_back(it->second);
  };
  take(nullptr);
  for (const auto& plane : mirrors) take(plane.get());
  gather_all([&](int i) { return change.on_object(i); }, [this] { return delta_batch(); },
             gather_from(reflected_now), kWhole);
  for (int object : change.objects) {
    const ObjectPatches& o = mesh.objects[object];
    for (int i = o.point_begin; i < o.point_end; ++i) {
      delta_front[i] -= reflected_front[i];
      delta_back[i] -= reflected_back[i];
    }
  }
  apply_delta(Light::reflected);
  add_direct_power(own_direct_after - change.own_direct_before);
  // What one that vanished had not sent yet goes with it (after apply_delta, which reflects into it).
  for (size_t k = 0; k < change.objects.size(); ++k)
    if (!change.desc[k]->visible) {
      const ObjectPatches& o = mesh.objects[change.objects[k]];
      for (int p = o.patch_begin; p < o.patch_end; ++p) unshot[p].fill(dvec3(0.0));
    }
}

}  // namespace radiosity
