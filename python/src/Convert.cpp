#include "Convert.h"

#include <cmath>
#include <cstring>

#include <pybind11/stl.h>

#include "voxcut/core/Error.h"

namespace voxcut::python {

namespace {

// A float64 array of `value` (any sequence or array of numbers), or InputError naming `what`.
py::array_t<double> realArray(const py::handle& value, const std::string& what) {
  try {
    auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
    if (a) return a;
  } catch (const py::error_already_set&) {
  }
  throw InputError(what + ": expected numbers, got " +
                   std::string(py::str(py::type::handle_of(value).attr("__name__"))));
}

}  // namespace

Vec3d toVec3(const py::handle& value, const std::string& what) {
  const py::array_t<double> a = realArray(value, what);
  if (a.ndim() != 1 || a.shape(0) != 3)
    throw InputError(what + ": expected 3 numbers (x, y, z), got an array of shape " +
                     std::string(py::str(py::tuple(py::cast(std::vector<py::ssize_t>(
                         a.shape(), a.shape() + a.ndim()))))));
  return {a.at(0), a.at(1), a.at(2)};
}

BladePose toPose(const py::handle& value, const std::string& what) {
  const py::array_t<double> a = realArray(value, what);
  if (a.ndim() == 1 && a.shape(0) == 3) {
    const Vec3d p(a.at(0), a.at(1), a.at(2));
    return {p, p};
  }
  if (a.ndim() == 2 && a.shape(0) == 2 && a.shape(1) == 3)
    return {Vec3d(a.at(0, 0), a.at(0, 1), a.at(0, 2)), Vec3d(a.at(1, 0), a.at(1, 1), a.at(1, 2))};
  throw InputError(what + ": expected a pose: ((ax, ay, az), (bx, by, bz)) or one point "
                          "(x, y, z) for a sphere, got an array of shape " +
                   std::string(py::str(py::tuple(py::cast(
                       std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()))))));
}

double toReal(const py::handle& value, const std::string& what) {
  if (!py::isinstance<py::float_>(value) && !py::isinstance<py::int_>(value) &&
      !py::hasattr(value, "__float__"))
    throw InputError(what + ": expected a number, got " +
                     std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  if (py::isinstance<py::bool_>(value))
    throw InputError(what + ": expected a number, got a bool");
  const double v = py::cast<double>(value);
  if (!std::isfinite(v)) throw InputError(what + ": must be finite, got " + std::to_string(v));
  return v;
}

int toInt(const py::handle& value, const std::string& what) {
  if (!py::isinstance<py::int_>(value) || py::isinstance<py::bool_>(value))
    throw InputError(what + ": expected an integer, got " +
                     std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  const long long v = py::cast<long long>(value);
  if (v < -(1LL << 30) || v > (1LL << 30))
    throw InputError(what + ": out of range, got " + std::to_string(v));
  return static_cast<int>(v);
}

py::array_t<double> vec3Array(const std::vector<Vec3d>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(Vec3d));
  return a;
}

py::array_t<double> vec3Array(const Vec3d& v) {
  py::array_t<double> a(3);
  for (int c = 0; c < 3; ++c) a.mutable_at(c) = v[c];
  return a;
}

py::array_t<double> poseArray(const BladePose& pose) {
  py::array_t<double> a({py::ssize_t{2}, py::ssize_t{3}});
  for (int c = 0; c < 3; ++c) {
    a.mutable_at(0, c) = pose.a[c];
    a.mutable_at(1, c) = pose.b[c];
  }
  return a;
}

namespace {

SolverChoice solverFrom(const std::string& name) {
  for (const SolverChoice c : kSolverChoices)
    if (name == solverChoiceName(c)) return c;
  std::string known;
  for (const SolverChoice c : kSolverChoices)
    known += std::string(known.empty() ? "" : ", ") + solverChoiceName(c);
  throw InputError("preconditioner: unknown choice '" + name + "' (known: " + known + ")");
}


bool toBool(const py::handle& value, const std::string& what) {
  if (!py::isinstance<py::bool_>(value))
    throw InputError(what + ": expected True or False, got " +
                     std::string(py::str(py::type::handle_of(value).attr("__name__"))));
  return py::cast<bool>(value);
}

}  // namespace

WorldSettings worldSettingsFrom(const py::kwargs& kwargs) {
  WorldSettings s;
  for (const auto& [k, v] : kwargs) {
    const std::string key = py::cast<std::string>(k);
    if (key == "time_step") s.timeStep = toReal(v, key);
    else if (key == "gravity") s.gravity = toVec3(v, key);
    else if (key == "tolerance") s.solver.tolerance = toReal(v, key);
    else if (key == "max_iterations") s.solver.maxIterations = toInt(v, key);
    else if (key == "preconditioner") s.solver.preconditioner = solverFrom(py::cast<std::string>(v));
    else if (key == "projection_history") s.solver.projectionHistory = toInt(v, key);
    else if (key == "contact_stiffness") s.contact.stiffness = toReal(v, key);
    else if (key == "friction") s.contact.friction = toReal(v, key);
    else if (key == "self_collision") s.contact.selfCollision = toBool(v, key);
    else if (key == "keep_self_candidates") s.contact.keepSelfCandidates = toBool(v, key);
    else if (key == "use_octree") s.useOctree = toBool(v, key);
    else if (key == "threaded") s.threaded = toBool(v, key);
    else if (key == "blade_segments") s.bladeSegments = toInt(v, key);
    else if (key == "min_fragment_voxels") {
      const int n = toInt(v, key);
      if (n < 0) throw InputError(key + ": must be >= 0, got " + std::to_string(n));
      s.minFragmentVoxels = static_cast<std::size_t>(n);
    } else {
      throw InputError("World: unknown setting '" + key +
                       "' (known: time_step, gravity, tolerance, max_iterations, "
                       "preconditioner, projection_history, contact_stiffness, friction, "
                       "self_collision, keep_self_candidates, use_octree, threaded, "
                       "blade_segments, min_fragment_voxels)");
    }
  }
  return s;
}

SceneMaterial materialFrom(const std::string& name, const py::dict& values) {
  SceneMaterial m;
  m.name = name;
  for (const auto& [k, v] : values) {
    const std::string key = py::cast<std::string>(k);
    const std::string what = "materials['" + name + "']." + key;
    if (key == "young_modulus") m.youngModulus = toReal(v, what);
    else if (key == "poisson_ratio") m.poissonRatio = toReal(v, what);
    else if (key == "density") m.density = toReal(v, what);
    else if (key == "mass_damping") m.massDamping = toReal(v, what);
    else if (key == "stiffness_damping") m.stiffnessDamping = toReal(v, what);
    else if (key == "max_internal_level") m.maxInternalLevel = toInt(v, what);
    else if (key == "max_boundary_level") m.maxBoundaryLevel = toInt(v, what);
    else if (key == "name") continue;
    else
      throw InputError(what + ": unknown key (known: young_modulus, poisson_ratio, density, "
                              "mass_damping, stiffness_damping, max_internal_level, "
                              "max_boundary_level)");
  }
  return m;
}

std::vector<FixedBox> fixedFrom(const py::handle& boxes) {
  std::vector<FixedBox> out;
  if (boxes.is_none()) return out;
  if (!py::isinstance<py::sequence>(boxes) && !py::isinstance<py::array>(boxes))
    throw InputError("fixed: expected a list of boxes ((x0, y0, z0), (x1, y1, z1))");
  std::size_t i = 0;
  for (const py::handle b : boxes) {
    const BladePose p = toPose(b, "fixed[" + std::to_string(i) + "]");
    out.push_back({p.a, p.b});
    ++i;
  }
  return out;
}

py::dict reportDict(const FrameReport& r) {
  py::dict d;
  d["frame"] = r.frame;
  d["time"] = r.time;
  py::dict stages;
  const std::vector<std::string>& names = frameStageNames();
  for (std::size_t i = 0; i < names.size() && i < r.stageMs.size(); ++i)
    stages[py::str(names[i])] = r.stageMs[i];
  d["stage_ms"] = stages;
  d["total_ms"] = r.totalMs;
  d["cut_links"] = r.cutLinks;
  d["positioned_voxels"] = r.positionedVoxels;
  d["tested_links"] = r.testedLinks;
  d["solver_iterations"] = r.solverIterations;
  d["solver_solves"] = r.solverSolves;
  d["solver_factorisations"] = r.solverFactorisations;
  d["converged"] = r.converged;
  d["contacts"] = r.contacts;
  d["max_penetration"] = r.maxPenetration;
  d["obstacle_forces"] = vec3Array(r.obstacleForces);
  std::vector<Vec3d> forces, torques;
  for (const ToolReaction& t : r.toolReactions) {
    forces.push_back(t.force);
    torques.push_back(t.torque);
  }
  d["tool_forces"] = vec3Array(forces);
  d["tool_torques"] = vec3Array(torques);
  return d;
}

}  // namespace voxcut::python
