#pragma once
/// @file Convert.h
/// Conversions between Python values and the world API's value types, shared by the binding
/// files: vectors and poses from array-likes (with the argument's name in every error),
/// numpy arrays from vectors of Vec3d (copies), and the handle objects.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <string>
#include <vector>

#include "PyWorld.h"

namespace voxcut::python {

namespace py = pybind11;

/// A body, tool or obstacle of a world, as Python holds it: the world (kept alive) and the
/// typed handle. Equal when both name the same object of the same world.
template <class Id>
struct PyHandle {
  std::shared_ptr<PyWorld> world;
  Id id;
  /// The world, after checking that the handle still names something alive in it.
  PyWorld& live() const {
    world->check(id);
    return *world;
  }
  bool operator==(const PyHandle& o) const { return world == o.world && id == o.id; }
};
using PyBody = PyHandle<BodyId>;
using PyTool = PyHandle<ToolId>;
using PyObstacle = PyHandle<ObstacleId>;

/// A 3-vector from any sequence or array of three numbers. Throws InputError naming `what`
/// when it has another shape or an element is not a number. Non-finite values pass: the
/// world refuses them with its own message.
Vec3d toVec3(const py::handle& value, const std::string& what);
/// A tool pose from a (2, 3) array-like (ends a and b), or a (3,) one (a sphere: a == b).
BladePose toPose(const py::handle& value, const std::string& what);
/// A finite real number (InputError otherwise, naming `what`).
double toReal(const py::handle& value, const std::string& what);
/// An integer (not a bool) within +-2^30 (InputError otherwise, naming `what`).
int toInt(const py::handle& value, const std::string& what);

/// (n, 3) float64 array copied from `v`.
py::array_t<double> vec3Array(const std::vector<Vec3d>& v);
py::array_t<double> vec3Array(const Vec3d& v);
/// (2, 3) float64 array of a pose's ends.
py::array_t<double> poseArray(const BladePose& pose);

/// Registers each part of the module (one function per binding file).
void bindErrors(py::module_& m);
void bindSettings(py::module_& m);
void bindWorld(py::module_& m);
void bindHandles(py::module_& m);
void bindSurfaces(py::module_& m);

/// Settings from keyword arguments (docs/python.md, "Settings"); unknown keys are an
/// InputError naming them.
WorldSettings worldSettingsFrom(const py::kwargs& kwargs);
/// A material from a dict of its keys (young_modulus, poisson_ratio, density, mass_damping,
/// stiffness_damping, max_internal_level, max_boundary_level) named `name`.
SceneMaterial materialFrom(const std::string& name, const py::dict& values);
/// A list of fixed boxes from a sequence of (2, 3) array-likes (lo, hi).
std::vector<FixedBox> fixedFrom(const py::handle& boxes);
/// The frame report as a dict (the Python package makes it a dataclass).
py::dict reportDict(const FrameReport& report);

}  // namespace voxcut::python
