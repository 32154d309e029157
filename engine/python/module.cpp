// Python module: numpy arrays in and out, long calls without the GIL.
#include "radiosity/form_factor.h"
#include "radiosity/solver.h"

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>

namespace py = pybind11;
using namespace radiosity;

namespace {

template <class T>
using Array = py::array_t<T, py::array::c_style | py::array::forcecast>;

dvec3 vec3(const std::array<double, 3>& a) { return dvec3(a[0], a[1], a[2]); }

using RGB = std::array<double, 3>;

// The keywords of a material after its reflectance, with their defaults: one list for Scene.add_material
// and Solver.set_material.
auto material_lobes() {
  return std::make_tuple(py::arg("emission") = RGB{0, 0, 0}, py::arg("transmittance") = RGB{0, 0, 0},
                         py::arg("glass") = RGB{0, 0, 0}, py::arg("ior") = 1.45, py::arg("specular") = RGB{0, 0, 0},
                         py::arg("roughness") = 0.5, py::arg("alpha") = py::none());
}

using Alpha = std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>>;

// An (H, W) array of alpha, rows from the bottom, as Material::alpha.
std::shared_ptr<const AlphaMap> alpha_map(const Alpha& a) {
  if (!a) return nullptr;
  if (a->ndim() != 2 || a->shape(0) < 1 || a->shape(1) < 1)
    throw std::invalid_argument("an alpha map must be a non-empty (H, W) array");
  return std::make_shared<const AlphaMap>(int(a->shape(1)), int(a->shape(0)),
                                          std::vector<float>(a->data(), a->data() + a->size()));
}

Material material(RGB reflectance, RGB emission, RGB transmittance, RGB glass, double ior, RGB specular,
                  double roughness, const Alpha& alpha) {
  return {vec3(reflectance), vec3(emission), vec3(transmittance), vec3(glass), ior, vec3(specular), roughness,
          alpha_map(alpha)};
}

// Runs `call` without the GIL: C++ work only, on arguments already taken out of Python objects; its
// result becomes one once the GIL is back.
template <class Call>
auto released(Call&& call) {
  py::gil_scoped_release release;
  return call();
}

template <class T>
std::vector<T> flat(const Array<T>& a) {
  return std::vector<T>(a.data(), a.data() + a.size());
}

// The rows of an (N, L) array as glm vectors of length L.
template <int L>
std::vector<glm::vec<L, double>> rows(const Array<double>& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != L)
    throw std::invalid_argument(std::string(what) + " must be an (N, " + std::to_string(L) + ") array");
  std::vector<glm::vec<L, double>> out(a.shape(0));
  std::memcpy(out.data(), a.data(), sizeof(double) * a.size());
  return out;
}

std::vector<dvec3> points(const Array<double>& a, const char* what) { return rows<3>(a, what); }

constexpr const char* kWorldMapDoc =
    "The world's radiance by direction: (H, W, 3), equirectangular in Cycles' layout, rows from the bottom";

WorldMap world_map(const Array<double>& a) {
  if (a.ndim() != 3 || a.shape(2) != 3 || a.shape(0) < 1 || a.shape(1) < 1)
    throw std::invalid_argument("a world map must be an (H, W, 3) array");
  WorldMap m;
  m.height = int(a.shape(0)), m.width = int(a.shape(1));
  m.texels.resize(size_t(m.width) * m.height);
  std::memcpy(m.texels.data(), a.data(), sizeof(double) * a.size());
  return m;
}

Refinement refinement(const std::string& name) {
  if (name == "none") return Refinement::None;
  if (name == "bilinear") return Refinement::Bilinear;
  if (name == "catmull_clark") return Refinement::CatmullClark;
  throw std::invalid_argument("refine must be 'none', 'bilinear' or 'catmull_clark', not '" + name + "'");
}

// (N, 3) rows of `v`, which the array takes over (no copy).
template <class T>
py::array_t<T> rows3(std::vector<T> v) {
  auto* heap = new std::vector<T>(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>({py::ssize_t(heap->size() / 3), py::ssize_t(3)}, heap->data(), owner);
}

py::dict stats_dict(const SolveStats& s) {
  py::dict d;
  d["seconds"] = s.seconds;
  d["residual"] = s.residual;
  d["shots"] = s.shots;
  d["rays"] = s.rays;
  d["pane_crossings"] = s.pane_crossings;
  d["rays_through_panes"] = s.rays_through_panes;
  d["mirror_rays"] = s.mirror_rays;
  d["patches"] = s.patches;
  d["uniform_patches"] = s.uniform_patches;
  d["points"] = s.points;
  d["shooters"] = s.shooters;
  d["threads"] = s.threads;
  d["relaxation"] = s.relaxation;
  d["converged"] = s.converged;
  d["settled"] = s.settled;
  d["restart"] = s.restart;
  d["diverged"] = s.diverged;
  d["cancelled"] = s.cancelled;
  d["warnings"] = s.warnings;
  d["touched_points"] = s.touched_points;
  d["shoot_residual"] = s.shoot_residual;
  d["shoot_seconds"] = s.shoot_seconds;
  d["db_hits"] = s.db_hits;
  d["db_misses"] = s.db_misses;
  d["db_entries"] = s.db_entries;
  d["db_bytes"] = s.db_bytes;
  return d;
}

// numpy/Blender matrices are row-major; glm is column-major.
dmat4 matrix(const Array<double>& m) {
  if (m.size() != 16) throw std::invalid_argument("transform must be 4 x 4");
  dmat4 out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[c][r] = m.data()[4 * r + c];
  return out;
}

Lamp point_lamp(std::array<double, 3> position, std::array<double, 3> intensity, double radius) {
  Lamp l;
  l.type = Lamp::Type::Point;
  l.position = vec3(position);
  l.color = vec3(intensity);
  l.radius = radius;
  return l;
}

Lamp spot_lamp(std::array<double, 3> position, std::array<double, 3> direction, std::array<double, 3> intensity,
               double radius, double spot_size, double spot_blend) {
  Lamp l = point_lamp(position, intensity, radius);
  l.type = Lamp::Type::Spot;
  l.direction = vec3(direction);
  l.spot_size = spot_size;
  l.spot_blend = spot_blend;
  return l;
}

Lamp sun_lamp(std::array<double, 3> direction, std::array<double, 3> irradiance, double angle) {
  Lamp l;
  l.type = Lamp::Type::Sun;
  l.direction = vec3(direction);
  l.color = vec3(irradiance);
  l.angle = angle;
  return l;
}

Lamp area_lamp(std::array<double, 3> position, std::array<double, 3> u_axis, std::array<double, 3> v_axis,
               std::array<double, 3> radiance, const std::string& shape) {
  Lamp l;
  l.position = vec3(position);
  l.u_axis = vec3(u_axis);
  l.v_axis = vec3(v_axis);
  l.color = vec3(radiance);
  if (shape == "rect") {
    l.type = Lamp::Type::Rect;
  } else if (shape == "disc") {
    l.type = Lamp::Type::Disc;
    l.radius = glm::length(l.u_axis);
    l.direction = -glm::cross(l.u_axis, l.v_axis);
  } else {
    throw std::invalid_argument("shape must be 'rect' or 'disc'");
  }
  return l;
}

// Runs a long solver call without the GIL; progress(fraction, residual) may return False to cancel
// and its exceptions come back to the caller.
template <class Call>
py::dict run(Solver& solver, const std::optional<py::function>& progress, Call&& call) {
  std::exception_ptr error;
  ProgressCallback callback;
  if (progress) {
    callback = [&](double fraction, double residual) {
      py::gil_scoped_acquire acquire;
      try {
        py::object r = (*progress)(fraction, residual);
        return r.is_none() || r.cast<bool>();
      } catch (...) {
        error = std::current_exception();
        return false;
      }
    };
  }
  {
    py::gil_scoped_release release;
    call(callback);
  }
  if (error) std::rethrow_exception(error);
  return stats_dict(solver.stats());
}

}  // namespace

PYBIND11_MODULE(radiosity_engine, m) {
  m.doc() = "Dynamic Radiosity engine: progressive-refinement radiosity on bilinear patches";

  py::class_<Settings>(m, "Settings")
      .def(py::init<>())
      .def_static("preset", &Settings::preset, py::arg("name"))
      .def_static("preset_names", &Settings::preset_names)
      .def_readwrite("samples_direct", &Settings::samples_direct)
      .def_readwrite("samples_indirect", &Settings::samples_indirect)
      .def_readwrite("patch_size_relative", &Settings::patch_size_relative)
      .def_readwrite("light_refinement", &Settings::light_refinement)
      .def_readwrite("light_contrast", &Settings::light_contrast)
      .def_readwrite("shooter_size_relative", &Settings::shooter_size_relative)
      .def_readwrite("near_factor", &Settings::near_factor)
      .def_readwrite("threshold", &Settings::threshold)
      .def_readwrite("update_threshold", &Settings::update_threshold)
      .def_readwrite("relaxation", &Settings::relaxation)
      .def_readwrite("exact_near_direct", &Settings::exact_near_direct)
      .def_readwrite("exact_near_reflected", &Settings::exact_near_reflected)
      .def_readwrite("max_shots", &Settings::max_shots)
      .def_readwrite("max_patches", &Settings::max_patches)
      .def_readwrite("db_cache_mb", &Settings::db_cache_mb)
      .def_readwrite("threads", &Settings::threads);

  py::class_<SceneDesc> scene(m, "Scene");
  std::apply(
      [&](auto... lobes) {
        scene.def(
            "add_material",
            [](SceneDesc& s, RGB reflectance, RGB emission, RGB transmittance, RGB glass, double ior, RGB specular,
               double roughness, const Alpha& alpha) {
              s.materials.push_back(material(reflectance, emission, transmittance, glass, ior, specular, roughness, alpha));
              return int(s.materials.size()) - 1;
            },
            py::arg("reflectance"), lobes...,
            "Adds a material and returns its index. alpha: (H, W) where the surface is, rows from the bottom, "
            "read at the meshes' corner_uv: a ray passes (1 - alpha) transmittance there (None: everywhere)");
      },
      material_lobes());
  scene.def(py::init<>())
      .def("add_mesh",
           [](SceneDesc& s, const Array<double>& positions, const Array<int>& face_sizes,
              const Array<int>& face_vertices, const Array<int>& face_materials,
              std::optional<Array<double>> transform, const std::string& refine, int level,
              double patch_size, bool dynamic, const std::string& name, bool visible,
              std::optional<Array<bool>> smooth, std::optional<Array<double>> corner_reflectance,
              std::optional<Array<double>> corner_emission, bool deforms, std::optional<Array<double>> corner_uv) {
             MeshDesc mesh;
             mesh.name = name;
             mesh.positions = points(positions, "positions");
             mesh.face_sizes = flat(face_sizes);
             mesh.face_vertices = flat(face_vertices);
             mesh.face_materials = flat(face_materials);
             if (transform) mesh.transform = matrix(*transform);
             mesh.refine = refinement(refine);
             mesh.level = level;
             mesh.patch_size = patch_size;
             mesh.dynamic = dynamic;
             mesh.deforms = deforms;
             mesh.visible = visible;
             if (smooth)
               for (bool b : flat(*smooth)) mesh.face_smooth.push_back(b);
             if (corner_reflectance) mesh.corner_reflectance = points(*corner_reflectance, "corner_reflectance");
             if (corner_emission) mesh.corner_emission = points(*corner_emission, "corner_emission");
             if (corner_uv) mesh.corner_uv = rows<2>(*corner_uv, "corner_uv");
             s.meshes.push_back(std::move(mesh));
             return int(s.meshes.size()) - 1;
           },
           py::arg("positions"), py::arg("face_sizes"), py::arg("face_vertices"), py::arg("face_materials"),
           py::arg("transform") = py::none(), py::arg("refine") = "none", py::arg("level") = 0,
           py::arg("patch_size") = 0.0, py::arg("dynamic") = false, py::arg("name") = "",
           py::arg("visible") = true, py::arg("smooth") = py::none(), py::arg("corner_reflectance") = py::none(),
           py::arg("corner_emission") = py::none(), py::arg("deforms") = false, py::arg("corner_uv") = py::none(),
           "visible=False: kept (refined) but out of the lighting until Solver.set_visible(id, True); "
           "smooth: per face, shaded smooth (None: smooth for catmull_clark, flat otherwise); "
           "corner_reflectance: (face corners, 3) in face_vertices' order, in place of the materials' "
           "reflectance (a texture sampled at the corners; None: the materials'); corner_emission: the same "
           "for the emitted radiance; corner_uv: (face corners, 2) texture coordinates where the materials' alpha "
           "maps are read; deforms: its flat faces will be bent (Solver.set_positions), so they "
           "keep a receiving point each at every vertex (without, bending faces that met flat apart is "
           "refused)")
      .def("add_point_light",
           [](SceneDesc& s, std::array<double, 3> position, std::array<double, 3> intensity, double radius) {
             s.lamps.push_back(point_lamp(position, intensity, radius));
           },
           py::arg("position"), py::arg("intensity"), py::arg("radius") = 0.0,
           "Sphere lamp: intensity in W/sr (radiance units x area), Cycles' disc of `radius` for shadows")
      .def("add_spot_light",
           [](SceneDesc& s, std::array<double, 3> position, std::array<double, 3> direction,
              std::array<double, 3> intensity, double radius, double spot_size, double spot_blend) {
             s.lamps.push_back(spot_lamp(position, direction, intensity, radius, spot_size, spot_blend));
           },
           py::arg("position"), py::arg("direction"), py::arg("intensity"), py::arg("radius") = 0.0,
           py::arg("spot_size") = 0.785398, py::arg("spot_blend") = 0.15)
      .def("add_sun_light",
           [](SceneDesc& s, std::array<double, 3> direction, std::array<double, 3> irradiance, double angle) {
             s.lamps.push_back(sun_lamp(direction, irradiance, angle));
           },
           py::arg("direction"), py::arg("irradiance"), py::arg("angle") = 0.0)
      .def("add_area_light",
           [](SceneDesc& s, std::array<double, 3> position, std::array<double, 3> u_axis,
              std::array<double, 3> v_axis, std::array<double, 3> radiance, const std::string& shape) {
             s.lamps.push_back(area_lamp(position, u_axis, v_axis, radiance, shape));
           },
           py::arg("position"), py::arg("u_axis"), py::arg("v_axis"), py::arg("radiance"),
           py::arg("shape") = "rect",
           "One-sided emitter along -(u x v); u, v are half extents (disc: radius |u|)")
      .def("set_world", [](SceneDesc& s, std::array<double, 3> radiance) { s.world = WorldMap::uniform(vec3(radiance)); })
      .def("set_world_map", [](SceneDesc& s, const Array<double>& texels) { s.world = world_map(texels); },
           py::arg("texels"), kWorldMapDoc)
      .def_property_readonly("mesh_count", [](const SceneDesc& s) { return s.meshes.size(); });

  py::class_<Solver> solver(m, "Solver");
  std::apply(
      [&](auto... lobes) {
        solver.def(
            "set_material",
            [](Solver& s, int index, RGB reflectance, RGB emission, RGB transmittance, RGB glass, double ior,
               RGB specular, double roughness, const Alpha& alpha) {
              s.set_material(index, material(reflectance, emission, transmittance, glass, ior, specular, roughness,
                                             alpha));
            },
            py::arg("index"), py::arg("reflectance"), lobes...,
            "The material changes at the next update() (incrementally)");
      },
      material_lobes());
  solver
      .def(py::init([](const SceneDesc& scene, const Settings& settings) {
             return released([&] { return std::make_unique<Solver>(scene, settings); });
           }),
           py::arg("scene"), py::arg("settings") = Settings())
      .def("solve",
           [](Solver& solver, std::optional<py::function> progress) {
             return run(solver, progress, [&](const ProgressCallback& c) { solver.solve(c); });
           },
           py::arg("progress") = py::none(),
           "Solve to the threshold, or shoot on to it after updates (settle). progress(fraction, residual) "
           "may return False to cancel.")
      .def("update",
           [](Solver& solver, std::optional<py::function> progress) {
             return run(solver, progress, [&](const ProgressCallback& c) { solver.update(c); });
           },
           py::arg("progress") = py::none(),
           "Apply the set_* changes incrementally, then shoot down to the update's stop "
           "(Settings.update_threshold; stats as solve(), plus touched_points; settled: at the solve's threshold; "
           "restart: why it solved afresh, if it did). A bad change raises ValueError and leaves the solution as "
           "it was.")
      // The set_* calls that copy an object's description (MeshDesc) do so without the GIL.
      .def("set_transform",
           [](Solver& s, int object, const Array<double>& m) {
             dmat4 transform = matrix(m);
             released([&] { s.set_transform(object, transform); });
           },
           py::arg("object"), py::arg("transform"))
      .def("set_positions",
           [](Solver& s, int object, const Array<double>& p) {
             std::vector<dvec3> positions = points(p, "positions");
             released([&] { s.set_positions(object, std::move(positions)); });
           },
           py::arg("object"), py::arg("positions"), "object-space positions, same vertices and faces as added")
      .def("set_visible", &Solver::set_visible, py::arg("object"), py::arg("visible"),
           py::call_guard<py::gil_scoped_release>(),
           "The object appears or vanishes at the next update() (incrementally)")
      .def("add", &Solver::add, py::arg("scene"), py::call_guard<py::gil_scoped_release>(),
           "Adds the scene's materials after the solver's (its meshes' material indices count them "
           "so), its meshes as the next object ids and its lamps as the next lamp indices; they come "
           "into the light at the next update(), incrementally (ValueError, changing nothing, on bad "
           "input or a mesh reaching past the scene's size: that needs a new Solver)")
      .def("set_point_light",
           [](Solver& s, int index, std::array<double, 3> position, std::array<double, 3> intensity, double radius) {
             s.set_lamp(index, point_lamp(position, intensity, radius));
           },
           py::arg("index"), py::arg("position"), py::arg("intensity"), py::arg("radius") = 0.0)
      .def("set_spot_light",
           [](Solver& s, int index, std::array<double, 3> position, std::array<double, 3> direction,
              std::array<double, 3> intensity, double radius, double spot_size, double spot_blend) {
             s.set_lamp(index, spot_lamp(position, direction, intensity, radius, spot_size, spot_blend));
           },
           py::arg("index"), py::arg("position"), py::arg("direction"), py::arg("intensity"),
           py::arg("radius") = 0.0, py::arg("spot_size") = 0.785398, py::arg("spot_blend") = 0.15)
      .def("set_sun_light",
           [](Solver& s, int index, std::array<double, 3> direction, std::array<double, 3> irradiance, double angle) {
             s.set_lamp(index, sun_lamp(direction, irradiance, angle));
           },
           py::arg("index"), py::arg("direction"), py::arg("irradiance"), py::arg("angle") = 0.0)
      .def("set_area_light",
           [](Solver& s, int index, std::array<double, 3> position, std::array<double, 3> u_axis,
              std::array<double, 3> v_axis, std::array<double, 3> radiance, const std::string& shape) {
             s.set_lamp(index, area_lamp(position, u_axis, v_axis, radiance, shape));
           },
           py::arg("index"), py::arg("position"), py::arg("u_axis"), py::arg("v_axis"), py::arg("radiance"),
           py::arg("shape") = "rect")
      .def("set_world", [](Solver& s, std::array<double, 3> radiance) { s.set_world(vec3(radiance)); },
           py::arg("radiance"))
      .def("set_world_map", [](Solver& s, const Array<double>& texels) { s.set_world_map(world_map(texels)); },
           py::arg("texels"), kWorldMapDoc)
      .def("cancel", &Solver::cancel)
      .def("set_threads", &Solver::set_threads, py::arg("threads"),
           "Threads the calls from now on work on (0: one a core); not while a call runs")
      .def("record_rays", &Solver::record_rays, py::arg("stride") = 1,
           "Benchmark hook: keep every stride-th batch of visibility rays traced from now on")
      .def("replay_recorded_rays", &Solver::replay_recorded_rays, py::call_guard<py::gil_scoped_release>(),
           "Benchmark hook: bare Embree rays per second on the kept rays")
      .def_property_readonly("stats", [](const Solver& s) { return stats_dict(s.stats()); })
      .def("power_balance",
           [](const Solver& s) {
             PowerBalance b = released([&] { return s.power_balance(); });
             py::dict d;
             d["injected"] = b.injected;
             d["unshot"] = b.unshot;
             d["absorbed"] = b.absorbed;
             d["transmitted"] = b.transmitted;
             return d;
           })
      .def("corner_radiance",
           [](const Solver& s, int o, bool exact) {
             return rows3(released([&] { return s.corner_radiance(o, exact); }));
           },
           py::arg("object"), py::arg("exact_near_direct") = true,
           "(K, 3) float32 front-side outgoing radiance per input face corner (exact_near_direct=False: "
           "the near direct light interpolated even with Settings.exact_near_direct)")
      .def("vertex_radiance",
           [](const Solver& s, int o) { return rows3(released([&] { return s.vertex_radiance(o); })); },
           py::arg("object"), "(N, 3) float32 mean of each input vertex's corners")
      .def("surface_radiance",
           [](const Solver& s, int o, const Array<int32_t>& faces, const Array<double>& positions) {
             std::vector<int> f = flat(faces);
             std::vector<dvec3> p = points(positions, "positions");
             return rows3(released([&] { return s.surface_radiance(o, f, p); }));
           },
           py::arg("object"), py::arg("faces"), py::arg("positions"),
           "(N, 3) float32 front-side outgoing radiance at points of the object's input faces: faces "
           "(N,) int32, positions (N, 3) object space. Direct light gathered at each point, reflected "
           "light interpolated from the solution")
      .def("refined",
           [](const Solver& s, int o) {
             Solver::Refined r = released([&] { return s.refined(o); });
             return py::make_tuple(rows3(std::move(r.positions)), rows3(std::move(r.radiance)));
           },
           py::arg("object"), "(positions, radiance) per patch corner, 4 rows a patch, world space");

  m.def("polygon_form_factor",
        [](std::array<double, 3> x, std::array<double, 3> n, const Array<double>& polygon) {
          std::vector<dvec3> p = points(polygon, "polygon");
          return polygon_form_factor(vec3(x), vec3(n), p.data(), int(p.size()));
        },
        py::arg("x"), py::arg("normal"), py::arg("polygon"));
}
