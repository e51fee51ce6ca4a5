// voxcut._voxcut.World: building a world, adding and removing its parts, stepping it (without
// the GIL), snapshots, recording and saving runs (docs/python.md, "The world").

#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include "Convert.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/CoordinateRange.h"
#include "voxcut/core/Error.h"
#include "voxcut/io/MeshReader.h"
#include "voxcut/io/SceneReader.h"
#include "voxcut/voxel/LabelVolume.h"

namespace voxcut::python {

namespace {

// The scene body of add_body's keywords; `model` is already set.
void bodyOptions(SceneBody& b, const py::kwargs& kw) {
  for (const auto& [k, v] : kw) {
    const std::string key = py::cast<std::string>(k);
    if (key == "resolution") {
      if (!v.is_none()) b.resolution = toInt(v, key);
    } else if (key == "element_level") {
      b.elementLevel = toInt(v, key);
    } else if (key == "finest_level") {
      b.finestLevel = v.is_none() ? -1 : toInt(v, key);
    } else if (key == "front_level") {
      b.frontLevel = v.is_none() ? -1 : toInt(v, key);
    } else if (key == "surface_level") {
      b.surfaceLevel = v.is_none() ? -1 : toInt(v, key);
    } else if (key == "materials") {
      if (v.is_none()) continue;
      if (!py::isinstance<py::dict>(v))
        throw InputError("materials: expected a dict of material name to its values");
      for (const auto& [name, values] : py::cast<py::dict>(v)) {
        if (!py::isinstance<py::dict>(values))
          throw InputError("materials['" + py::cast<std::string>(name) +
                           "']: expected a dict of its values");
        b.materials.push_back(
            materialFrom(py::cast<std::string>(name), py::cast<py::dict>(values)));
      }
    } else if (key == "fixed") {
      b.fixed = fixedFrom(v);
    } else if (key == "offset") {
      if (!v.is_none()) b.offset = toVec3(v, key);
      if (!isCoordinate(b.offset))
        throw InputError("offset: must be finite and within " + std::string(kCoordinateRangeText));
    } else if (key == "labels") {
      if (v.is_none()) continue;
      if (!py::isinstance<py::dict>(v))
        throw InputError("labels: expected a dict of label value to material name");
      for (const auto& [value, name] : py::cast<py::dict>(v)) {
        if (!py::isinstance<py::int_>(value))
          throw InputError("labels: keys must be integer label values");
        b.labels.push_back({py::cast<std::int64_t>(value), py::cast<std::string>(name)});
      }
    } else if (key == "label_names") {
      if (!v.is_none())
        b.labelNames = std::filesystem::absolute(py::cast<std::string>(v)).lexically_normal();
    } else if (key == "min_island") {
      b.minIsland = toInt(v, key);
      if (b.minIsland < 0) throw InputError("min_island: must be >= 0");
    } else {
      throw InputError("add_body: unknown keyword '" + key +
                       "' (known: resolution, element_level, finest_level, front_level, "
                       "surface_level, materials, fixed, offset, labels, label_names, "
                       "min_island)");
    }
  }
}

// A label volume of the application's own array: `labels` a 3-D uint8 or uint16 array in
// Fortran order (the package makes it so), voxel (i, j, k) centred at origin + spacing * ijk.
std::shared_ptr<const LabelVolume> volumeFrom(const py::array& labels, const Vec3d& spacing,
                                              const Vec3d& origin, const py::dict& names) {
  // str() of a native-order dtype is its plain name; other byte orders read '>u2' and
  // are refused with the rest.
  const std::string dt = py::str(labels.dtype());
  SampleType type;
  if (dt == "uint8") type = SampleType::UInt8;
  else if (dt == "uint16") type = SampleType::UInt16;
  else
    throw py::type_error("labels: expected a numpy array of dtype uint8 or uint16, got " +
                         dt);
  if (labels.ndim() != 3)
    throw InputError("labels: expected a 3-D array, got " + std::to_string(labels.ndim()) +
                     " dimension(s)");
  if (!(labels.flags() & py::array::f_style))
    throw InputError("labels: expected a Fortran-ordered array (numpy.asfortranarray)");
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(spacing[c]) || spacing[c] <= 0.0)
      throw InputError("voxel_size: must be finite and > 0, got " + std::to_string(spacing[c]));
    if (labels.shape(c) < 1 || labels.shape(c) > 65536)
      throw InputError("labels: each side must hold 1..65536 voxels");
  }
  if (!isCoordinate(origin))
    throw InputError("origin: must be finite and within " + std::string(kCoordinateRangeText));
  LabelVolume v;
  v.dims = Index3{static_cast<int>(labels.shape(0)), static_cast<int>(labels.shape(1)),
                  static_cast<int>(labels.shape(2))};
  v.axes = spacing.asDiagonal();
  v.origin = origin;
  v.placement = "array, voxel size and origin as given";
  setLabelsFromSamples(v, labels.data(), v.voxelCount(), type, false, "labels");
  for (const auto& [value, name] : names) {
    if (!py::isinstance<py::int_>(value))
      throw InputError("names: keys must be integer label values");
    const auto val = py::cast<std::int64_t>(value);
    bool found = false;
    for (LabelInfo& l : v.labels)
      if (l.value == val) {
        l.name = py::cast<std::string>(name);
        found = true;
      }
    if (!found)
      throw InputError("names: the array has no voxel of label " + std::to_string(val));
  }
  return std::make_shared<const LabelVolume>(std::move(v));
}

Obstacle obstacleFrom(const std::string& kind, const py::kwargs& kw) {
  Obstacle o;
  auto get = [&](const char* key) -> py::handle {
    if (!kw.contains(key)) throw InputError("add_obstacle('" + kind + "'): " + key + " is required");
    return kw[key];
  };
  if (kind == "plane") {
    o.type = ObstacleType::Plane;
    o.point = toVec3(get("point"), "point");
    o.normal = toVec3(get("normal"), "normal");
    const double n = o.normal.norm();
    if (!std::isfinite(n) || n == 0.0) throw InputError("normal: must be finite and non-zero");
    o.normal /= n;
  } else if (kind == "box") {
    o.type = ObstacleType::Box;
    o.lo = toVec3(get("lo"), "lo");
    o.hi = toVec3(get("hi"), "hi");
  } else if (kind == "mesh") {
    const std::string path =
        std::filesystem::absolute(py::cast<std::string>(get("path"))).lexically_normal();
    o = meshObstacle(readMesh(path));
    if (o.mesh->triangleCount() == 0)
      throw InputError("mesh file '" + path + "' has no non-degenerate triangles");
    o.path = path;
  } else {
    throw InputError("add_obstacle: unknown kind '" + kind + "' (known: plane, box, mesh)");
  }
  if (kw.contains("friction") && !kw["friction"].is_none())
    o.friction = toReal(kw["friction"], "friction");
  return o;
}

py::dict settingsDict(const WorldSettings& s) {
  py::dict d;
  d["time_step"] = s.timeStep;
  d["gravity"] = vec3Array(s.gravity);
  d["tolerance"] = s.solver.tolerance;
  d["max_iterations"] = s.solver.maxIterations;
  d["preconditioner"] = solverChoiceName(s.solver.preconditioner);
  d["projection_history"] = s.solver.projectionHistory;
  d["contact_stiffness"] = s.contact.stiffness;
  d["friction"] = s.contact.friction;
  d["self_collision"] = s.contact.selfCollision;
  d["keep_self_candidates"] = s.contact.keepSelfCandidates;
  d["use_octree"] = s.useOctree;
  d["threaded"] = s.threaded;
  d["blade_segments"] = s.bladeSegments;
  d["min_fragment_voxels"] = s.minFragmentVoxels;
  return d;
}

// Contacts as arrays: kind codes (0 obstacle, 1 probe, 2 body, 3 self), the body's position
// in bodies(), the touched thing's position in obstacles(), tools() or bodies().
py::dict contactsDict(const PyWorld& w) {
  const std::vector<Contact>& cs = w.world.contacts();
  const std::vector<BodyId> bodies = w.world.bodies();
  const std::vector<ToolId> tools = w.world.tools();
  const std::vector<ObstacleId> obstacles = w.world.obstacles();
  auto indexOf = [](const auto& list, const auto& id) -> std::int64_t {
    for (std::size_t i = 0; i < list.size(); ++i)
      if (list[i] == id) return static_cast<std::int64_t>(i);
    return -1;
  };
  const auto n = static_cast<py::ssize_t>(cs.size());
  py::array_t<std::int8_t> kind(n);
  py::array_t<std::int64_t> body(n), target(n);
  py::array_t<double> depth(n);
  std::vector<Vec3d> point, normal, force;
  for (py::ssize_t i = 0; i < n; ++i) {
    const Contact& c = cs[static_cast<std::size_t>(i)];
    kind.mutable_at(i) = static_cast<std::int8_t>(c.with);
    body.mutable_at(i) = indexOf(bodies, c.body);
    switch (c.with) {
      case Contact::With::Obstacle: target.mutable_at(i) = indexOf(obstacles, c.obstacle); break;
      case Contact::With::Probe: target.mutable_at(i) = indexOf(tools, c.tool); break;
      default: target.mutable_at(i) = indexOf(bodies, c.other); break;
    }
    depth.mutable_at(i) = c.depth;
    point.push_back(c.point);
    normal.push_back(c.normal);
    force.push_back(c.force);
  }
  py::dict d;
  d["kind"] = kind;
  d["body"] = body;
  d["target"] = target;
  d["point"] = vec3Array(point);
  d["normal"] = vec3Array(normal);
  d["depth"] = depth;
  d["force"] = vec3Array(force);
  return d;
}

// A handle of another world names nothing here, whatever its slot.
void sameWorld(const PyWorld& w, const std::shared_ptr<PyWorld>& owner) {
  if (owner.get() != &w) throw StaleHandleError("the handle belongs to another world");
}

}  // namespace

void bindWorld(py::module_& m) {
  py::class_<PySnapshot, std::shared_ptr<PySnapshot>>(m, "Snapshot",
                                                      "A world's complete state (World.snapshot)")
      .def_property_readonly("frame", [](const PySnapshot& s) { return s.snapshot.frame(); })
      .def_property_readonly("time", [](const PySnapshot& s) { return s.snapshot.time(); });

  py::class_<PyWorld, std::shared_ptr<PyWorld>>(m, "World")
      .def(py::init([](const py::object& scene, const py::kwargs& kw) {
             const WorldSettings s = worldSettingsFrom(kw);
             if (scene.is_none()) return std::make_shared<PyWorld>(s);
             // A scene holds these: a keyword would be silently overridden by the file.
             for (const char* key :
                  {"time_step", "gravity", "tolerance", "max_iterations", "preconditioner",
                   "projection_history", "contact_stiffness", "friction", "self_collision",
                   "keep_self_candidates"})
               if (kw.contains(key))
                 throw InputError(std::string("from_scene: ") + key +
                                  " comes from the scene file; set it there (only use_octree, "
                                  "threaded, blade_segments and min_fragment_voxels are "
                                  "keywords of a scene's world)");
             const std::string path = py::cast<std::string>(py::str(scene));
             return PyWorld::fromScene(path, s);
           }),
           py::arg("scene") = py::none())
      .def_property_readonly("settings",
                             [](PyWorld& w) { return settingsDict(w.world.settings()); })
      .def_property_readonly("frame",
                             [](PyWorld& w) {
                               PyWorld::Guard guard(w);
                               return w.world.frame();
                             })
      .def_property_readonly("time",
                             [](PyWorld& w) {
                               PyWorld::Guard guard(w);
                               return w.world.time();
                             })
      .def("bodies",
           [](const std::shared_ptr<PyWorld>& w) {
             PyWorld::Guard guard(*w);
             std::vector<PyBody> out;
             for (const BodyId id : w->world.bodies()) out.push_back({w, id});
             return out;
           })
      .def("tools",
           [](const std::shared_ptr<PyWorld>& w) {
             PyWorld::Guard guard(*w);
             std::vector<PyTool> out;
             for (const ToolId id : w->world.tools()) out.push_back({w, id});
             return out;
           })
      .def("obstacles",
           [](const std::shared_ptr<PyWorld>& w) {
             PyWorld::Guard guard(*w);
             std::vector<PyObstacle> out;
             for (const ObstacleId id : w->world.obstacles()) out.push_back({w, id});
             return out;
           })
      .def("_add_body",
           [](const std::shared_ptr<PyWorld>& w, const std::string& model, const py::kwargs& kw) {
             PyWorld::Guard guard(*w);
             SceneBody b;
             b.model = isBuiltinModelSpec(model)
                           ? model
                           : std::filesystem::absolute(model).lexically_normal().string();
             bodyOptions(b, kw);
             return PyBody{w, w->addBody(std::move(b))};
           },
           py::arg("model"))
      .def("_add_label_array",
           [](const std::shared_ptr<PyWorld>& w, const py::array& labels, const py::handle& size,
              const py::handle& origin, const py::dict& names, const py::kwargs& kw) {
             PyWorld::Guard guard(*w);
             SceneBody b;
             b.model = "label array";
             b.volume = volumeFrom(labels, toVec3(size, "voxel_size"), toVec3(origin, "origin"),
                                   names);
             bodyOptions(b, kw);
             return PyBody{w, w->addBody(std::move(b))};
           },
           py::arg("labels"), py::arg("voxel_size"), py::arg("origin"), py::arg("names"))
      .def("add_blade",
           [](const std::shared_ptr<PyWorld>& w, const py::handle& pose) {
             PyWorld::ToolEdit edit(*w);
             return PyTool{w, w->addBlade(toPose(pose, "pose"))};
           },
           py::arg("pose"))
      .def("add_probe",
           [](const std::shared_ptr<PyWorld>& w, const py::handle& radius, const py::handle& pose,
              const py::handle& friction) {
             PyWorld::ToolEdit edit(*w);
             const double f = friction.is_none() ? -1.0 : toReal(friction, "friction");
             if (f < 0.0 && !friction.is_none()) throw InputError("friction: must be >= 0");
             return PyTool{w, w->addProbe(toReal(radius, "radius"), toPose(pose, "pose"), f)};
           },
           py::arg("radius"), py::arg("pose"), py::arg("friction") = py::none())
      .def("add_obstacle",
           [](const std::shared_ptr<PyWorld>& w, const std::string& kind, const py::kwargs& kw) {
             PyWorld::Guard guard(*w);
             return PyObstacle{w, w->addObstacle(obstacleFrom(kind, kw))};
           },
           py::arg("kind"))
      .def("remove",
           [](PyWorld& w, const PyBody& b) {
             PyWorld::Guard guard(w);
             sameWorld(w, b.world);
             w.removeBody(b.id);
           })
      .def("remove",
           [](PyWorld& w, const PyTool& t) {
             PyWorld::ToolEdit edit(w);
             sameWorld(w, t.world);
             w.removeTool(t.id);
           })
      .def("remove",
           [](PyWorld& w, const PyObstacle& o) {
             PyWorld::Guard guard(w);
             sameWorld(w, o.world);
             w.removeObstacle(o.id);
           })
      .def("_step",
           [](PyWorld& w, int n) {
             PyWorld::Guard guard(w);
             FrameReport r;
             {
               // The frame runs without the GIL: other Python threads (a ticker, a haptic
               // loop) go on meanwhile; this world's lock keeps their calls on it out.
               py::gil_scoped_release release;
               r = w.step(n);
             }
             return reportDict(r);
           },
           py::arg("n") = 1)
      .def("_step_timed",
           [](PyWorld& w, int n) {
             // The C++ baseline of bench/bench_python.py: each frame's wall time around
             // World::step, taken in C++, with its report's total_ms.
             PyWorld::Guard guard(w);
             w.refuseWhileViewed("step");
             std::vector<std::pair<double, double>> times;
             {
               py::gil_scoped_release release;
               for (int f = 0; f < n; ++f) {
                 const auto t0 = std::chrono::steady_clock::now();
                 const FrameReport r = w.world.step();
                 const std::chrono::duration<double, std::milli> dt =
                     std::chrono::steady_clock::now() - t0;
                 times.emplace_back(dt.count(), r.totalMs);
               }
             }
             return times;
           },
           py::arg("n"))
      .def("snapshot",
           [](PyWorld& w) {
             PyWorld::Guard guard(w);
             return std::make_shared<PySnapshot>(w.snapshot());
           })
      .def("restore",
           [](PyWorld& w, const PySnapshot& s) {
             PyWorld::ToolEdit edit(w);
             w.restore(s);
           },
           py::arg("snapshot"))
      .def("start_recording",
           [](PyWorld& w) {
             PyWorld::Guard guard(w);
             w.setRecording(true);
           })
      .def("stop_recording",
           [](PyWorld& w) {
             PyWorld::Guard guard(w);
             w.setRecording(false);
           })
      .def_property_readonly("recording", [](const PyWorld& w) { return w.recording(); })
      .def("save_scene",
           [](PyWorld& w, const std::string& path, const py::object& frames) {
             PyWorld::Guard guard(w);
             w.saveScene(path, frames.is_none() ? 0 : toInt(frames, "frames"));
           },
           py::arg("path"), py::arg("frames") = py::none())
      .def("cut_set_hash",
           [](PyWorld& w) {
             PyWorld::Guard guard(w);
             return w.world.cutSetHash();
           })
      .def("max_displacement",
           [](PyWorld& w) {
             PyWorld::Guard guard(w);
             return w.world.maxDisplacement();
           })
      .def("_contacts",
           [](PyWorld& w) {
             PyWorld::Guard guard(w);
             return contactsDict(w);
           })
      .def("set_use_octree",
           [](PyWorld& w, bool on) {
             PyWorld::Guard guard(w);
             w.refuseWhileViewed("set_use_octree");
             w.world.setUseOctree(on);
           })
      .def_property_readonly("_views", &PyWorld::views);
}

}  // namespace voxcut::python
