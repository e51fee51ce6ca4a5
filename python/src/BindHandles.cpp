// voxcut._voxcut.Body, Tool and Obstacle: handle objects that name one part of one world and
// keep that world alive (docs/python.md, "Handles"). Every call checks the handle first, so a
// removed part's handle raises StaleHandleError (a KeyError) and changes nothing.

#include <pybind11/stl.h>

#include <functional>

#include "Convert.h"
#include "voxcut/collision/Obstacle.h"
#include "voxcut/core/Error.h"

namespace voxcut::python {

namespace {

template <class H>
std::size_t handleHash(const H& h) {
  return std::hash<const void*>()(h.world.get()) ^
         (static_cast<std::size_t>(h.id.slot()) * 0x9e3779b97f4a7c15ULL) ^
         (static_cast<std::size_t>(h.id.generation()) << 1);
}

py::dict infoDict(const BodyInfo& i) {
  py::dict d;
  d["elements"] = i.elements;
  d["nodes"] = i.nodes;
  d["cut_links"] = i.cutLinks;
  d["surface_vertices"] = i.surfaceVertices;
  d["surface_triangles"] = i.surfaceTriangles;
  d["voxel_size"] = i.voxelSize;
  d["material_names"] = i.materialNames;
  py::list colours;
  for (const auto& c : i.materialColours)
    colours.append(c ? py::object(py::make_tuple((*c)[0], (*c)[1], (*c)[2])) : py::none());
  d["material_colours"] = colours;
  d["solver"] = solverChoiceName(i.solver);
  d["self_candidate_queries"] = i.selfCandidateQueries;
  return d;
}

const char* kindName(ToolKind k) { return k == ToolKind::Blade ? "blade" : "probe"; }

const char* statusName(HapticAnswer::Status s) {
  switch (s) {
    case HapticAnswer::Status::Ok: return "ok";
    case HapticAnswer::Status::NonFinitePose: return "non_finite_pose";
    case HapticAnswer::Status::NotAProbe: return "not_a_probe";
  }
  return "ok";
}

std::vector<ToolKey> keysFrom(const py::handle& keys) {
  std::vector<ToolKey> out;
  if (!py::isinstance<py::sequence>(keys))
    throw InputError("trajectory: expected a list of (t, pose) or (t, pose, jump) keys");
  std::size_t i = 0;
  for (const py::handle k : keys) {
    const std::string what = "trajectory[" + std::to_string(i++) + "]";
    if (!py::isinstance<py::sequence>(k) || py::len(k) < 2 || py::len(k) > 3)
      throw InputError(what + ": expected (t, pose) or (t, pose, jump)");
    const py::sequence s = py::reinterpret_borrow<py::sequence>(k);
    ToolKey key;
    key.t = toReal(s[0], what + ".t");
    key.pose = toPose(s[1], what + ".pose");
    if (py::len(s) == 3) key.jump = py::cast<bool>(s[2]);
    out.push_back(key);
  }
  return out;
}

py::dict keysDict(const std::vector<ToolKey>& keys) {
  py::array_t<double> t(static_cast<py::ssize_t>(keys.size()));
  py::array_t<bool> jump(static_cast<py::ssize_t>(keys.size()));
  std::vector<Vec3d> a, b;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    t.mutable_at(static_cast<py::ssize_t>(i)) = keys[i].t;
    jump.mutable_at(static_cast<py::ssize_t>(i)) = keys[i].jump;
    a.push_back(keys[i].pose.a);
    b.push_back(keys[i].pose.b);
  }
  py::dict d;
  d["t"] = t;
  d["a"] = vec3Array(a);
  d["b"] = vec3Array(b);
  d["jump"] = jump;
  return d;
}

void bindBody(py::module_& m) {
  py::class_<PyBody>(m, "Body", "A deformable body of a world (a handle)")
      .def_property_readonly("alive", [](const PyBody& b) { return b.world->world.contains(b.id); })
      .def_property_readonly("slot", [](const PyBody& b) { return b.id.slot(); })
      .def("__eq__", [](const PyBody& a, const PyBody& b) { return a == b; })
      .def("__hash__", &handleHash<PyBody>)
      .def("_info",
           [](const PyBody& b) {
             PyWorld::Guard g(*b.world);
             return infoDict(b.live().world.bodyInfo(b.id));
           })
      .def("_nodes",
           [](const PyBody& b) {
             PyWorld::Guard g(*b.world);
             const NodeState n = b.live().world.nodes(b.id);
             py::dict d;
             d["positions"] = vec3Array(n.positions);
             d["rest_positions"] = vec3Array(n.restPositions);
             d["velocities"] = vec3Array(n.velocities);
             d["masses"] = py::array_t<double>(static_cast<py::ssize_t>(n.masses.size()),
                                               n.masses.data());
             return d;
           })
      .def("_voxels",
           [](const PyBody& b) {
             PyWorld::Guard g(*b.world);
             const BodyVoxels v = b.live().world.voxels(b.id);
             py::dict d;
             d["rest_positions"] = vec3Array(v.restPositions);
             d["positions"] = vec3Array(v.positions);
             d["pieces"] =
                 py::array_t<int>(static_cast<py::ssize_t>(v.pieces.size()), v.pieces.data());
             d["piece_voxels"] = v.pieceVoxels;
             return d;
           })
      .def("pieces",
           [](const PyBody& b) {
             PyWorld::Guard g(*b.world);
             return b.live().world.pieces(b.id);
           },
           "Connected voxel pieces of the body (through connected links).")
      .def("_energy",
           [](const PyBody& b) {
             PyWorld::Guard g(*b.world);
             const BodyEnergy e = b.live().world.energy(b.id);
             py::dict d;
             d["kinetic"] = e.kinetic;
             d["gravitational"] = e.gravitational;
             d["elastic"] = e.elastic;
             return d;
           })
      .def("_set_material",
           [](const PyBody& b, const std::string& name, const py::dict& values) {
             PyWorld::Guard g(*b.world);
             b.live().setMaterial(b.id, materialFrom(name, values));
           })
      .def("_material",
           [](const PyBody& b, const std::string& name) {
             PyWorld::Guard g(*b.world);
             const SceneMaterial mat = b.live().material(b.id, name);
             py::dict d;
             d["young_modulus"] = mat.youngModulus;
             d["poisson_ratio"] = mat.poissonRatio;
             d["density"] = mat.density;
             d["mass_damping"] = mat.massDamping;
             d["stiffness_damping"] = mat.stiffnessDamping;
             d["max_internal_level"] = mat.maxInternalLevel;
             d["max_boundary_level"] = mat.maxBoundaryLevel;
             return d;
           })
      .def("_set_fixed",
           [](const PyBody& b, const py::handle& boxes) {
             PyWorld::Guard g(*b.world);
             b.live().setFixed(b.id, fixedFrom(boxes));
           })
      .def("self_check",
           [](const PyBody& b) {
             PyWorld::Guard g(*b.world);
             return b.live().world.selfCheck(b.id);
           },
           "The body's invariants: '' when they hold, else what is broken (for tests).")
      .def("penetration",
           [](const PyBody& b, const PyBody& other) {
             PyWorld::Guard g(*b.world);
             if (other.world != b.world) throw InputError("penetration: other is of another world");
             b.live().check(other.id);
             return b.world->world.penetration(b.id, other.id);
           },
           py::arg("other"),
           "The deepest any surface vertex of this body lies inside `other` now (m).");
}

void bindTool(py::module_& m) {
  py::class_<PyTool>(m, "Tool", "A blade or a probe of a world (a handle)")
      .def_property_readonly("alive", [](const PyTool& t) { return t.world->world.contains(t.id); })
      .def_property_readonly("slot", [](const PyTool& t) { return t.id.slot(); })
      .def("__eq__", [](const PyTool& a, const PyTool& b) { return a == b; })
      .def("__hash__", &handleHash<PyTool>)
      .def_property_readonly("kind",
                             [](const PyTool& t) {
                               PyWorld::Guard g(*t.world);
                               return kindName(t.live().world.toolKind(t.id));
                             })
      .def_property_readonly("radius",
                             [](const PyTool& t) {
                               PyWorld::Guard g(*t.world);
                               return t.live().world.toolRadius(t.id);
                             })
      .def_property(
          "pose",
          [](const PyTool& t) {
            PyWorld::Guard g(*t.world);
            return poseArray(t.live().world.toolPose(t.id));
          },
          [](const PyTool& t, const py::handle& pose) {
            PyWorld::Guard g(*t.world);
            t.live().world.setToolPose(t.id, toPose(pose, "pose"));
          },
          "Where the tool is, (2, 3): ends a and b. Setting it moves the tool there over the "
          "next frame, in a straight line (a blade cuts on the way); stops a trajectory.")
      .def("place",
           [](const PyTool& t, const py::handle& pose) {
             PyWorld::Guard g(*t.world);
             t.live().world.placeTool(t.id, toPose(pose, "pose"));
           },
           py::arg("pose"),
           "Puts the tool at `pose` now without moving it there (cuts and pushes nothing).")
      .def("_set_trajectory",
           [](const PyTool& t, const py::handle& keys) {
             PyWorld::Guard g(*t.world);
             t.live().setToolTrajectory(t.id, keysFrom(keys));
           })
      .def_property_readonly("force",
                             [](const PyTool& t) {
                               PyWorld::Guard g(*t.world);
                               return vec3Array(t.live().world.toolReaction(t.id).force);
                             })
      .def_property_readonly("torque",
                             [](const PyTool& t) {
                               PyWorld::Guard g(*t.world);
                               return vec3Array(t.live().world.toolReaction(t.id).torque);
                             })
      .def("_haptic",
           [](const PyTool& t, const py::handle& pose) {
             // No world lock, no exception: the haptic call may run while another thread
             // steps the world. A bad pose answers zero with its status.
             BladePose p{Vec3d::Constant(std::nan("")), Vec3d::Constant(std::nan(""))};
             try {
               p = toPose(pose, "pose");
             } catch (const InputError&) {
             }
             bool busy = false;
             const HapticAnswer a = t.world->haptic(t.id, p, busy);
             return py::make_tuple(vec3Array(a.reaction.force), vec3Array(a.reaction.torque),
                                   busy ? "busy" : statusName(a.status));
           },
           py::arg("pose"))
      .def("_recording", [](const PyTool& t) {
        PyWorld::Guard g(*t.world);
        return keysDict(t.live().world.recording(t.id));
      });
}

void bindObstacle(py::module_& m) {
  py::class_<PyObstacle>(m, "Obstacle", "A static obstacle of a world (a handle)")
      .def_property_readonly("alive",
                             [](const PyObstacle& o) { return o.world->world.contains(o.id); })
      .def_property_readonly("slot", [](const PyObstacle& o) { return o.id.slot(); })
      .def("__eq__", [](const PyObstacle& a, const PyObstacle& b) { return a == b; })
      .def("__hash__", &handleHash<PyObstacle>)
      .def_property_readonly("kind", [](const PyObstacle& o) {
        PyWorld::Guard g(*o.world);
        switch (o.live().world.obstacle(o.id).type) {
          case ObstacleType::Plane: return "plane";
          case ObstacleType::Box: return "box";
          case ObstacleType::Mesh: return "mesh";
        }
        return "plane";
      });
}

}  // namespace

void bindHandles(py::module_& m) {
  bindBody(m);
  bindTool(m);
  bindObstacle(m);
}

}  // namespace voxcut::python
