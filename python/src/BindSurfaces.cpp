// A body's surface as numpy arrays (docs/python.md, "Surfaces"): an owning, compact copy
// (Body.surface), or a zero-copy, read-only view of the world's own slot arrays
// (Body.surface_view) for renderers. A view's arrays keep the view alive, the view keeps its
// world alive, and while any view of a world is alive the calls that would move the memory it
// shows (step, restore, body edits) are refused, so a view never dangles.

#include <pybind11/stl.h>

#include <cstring>

#include "Convert.h"
#include "voxcut/core/Error.h"

namespace voxcut::python {

namespace {

struct PySurfaceView {
  std::shared_ptr<PyWorld> world;
  BodyId body;
  SurfaceView view;

  PySurfaceView(std::shared_ptr<PyWorld> w, BodyId b) : world(std::move(w)), body(b) {
    PyWorld::Guard g(*world);
    world->check(body);
    view = world->world.surface(body);
    world->viewOpened();
  }
  ~PySurfaceView() { world->viewClosed(); }
  PySurfaceView(const PySurfaceView&) = delete;
  PySurfaceView& operator=(const PySurfaceView&) = delete;
};

// A read-only array over `data` whose base is `owner` (the view object).
py::array readOnly(py::dtype dtype, std::vector<py::ssize_t> shape,
                   std::vector<py::ssize_t> strides, const void* data, const py::handle& owner) {
  static const double empty[3] = {0.0, 0.0, 0.0};  // an address for arrays of no element
  if (data == nullptr) data = empty;
  py::array a(std::move(dtype), std::move(shape), std::move(strides), data, owner);
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

// The first tag's byte `offset` (0 material, 1 cut), or null for no triangle.
const void* tagByte(const SurfaceView& v, int offset) {
  if (v.triangleTags.empty()) return nullptr;
  const auto* base = reinterpret_cast<const std::uint8_t*>(v.triangleTags.data());
  return base + offset;
}

py::dict surfaceCopy(const SurfaceMesh& s) {
  py::dict d;
  d["vertices"] = vec3Array(s.positions);
  d["normals"] = vec3Array(s.normals);
  const auto nt = static_cast<py::ssize_t>(s.triangles.size());
  py::array_t<std::int32_t> tri({nt, py::ssize_t{3}});
  if (nt > 0) std::memcpy(tri.mutable_data(), s.triangles.data(), s.triangles.size() * 12);
  d["triangles"] = tri;
  py::array_t<std::uint8_t> material(nt);
  py::array_t<bool> cut(nt);
  for (py::ssize_t t = 0; t < nt; ++t) {
    const bool tagged = static_cast<std::size_t>(t) < s.triangleTags.size();
    material.mutable_at(t) = tagged ? s.triangleTags[static_cast<std::size_t>(t)].material : 0;
    cut.mutable_at(t) = tagged && s.triangleTags[static_cast<std::size_t>(t)].cut != 0;
  }
  d["materials"] = material;
  d["cut"] = cut;
  return d;
}

}  // namespace

void bindSurfaces(py::module_& m) {
  static_assert(sizeof(Vec3d) == 3 * sizeof(double), "Vec3d must be three packed doubles");
  static_assert(sizeof(std::array<int, 3>) == 12, "triangles must be three packed ints");
  static_assert(sizeof(TriangleTag) == 2, "a triangle tag must be two bytes");

  py::class_<PySurfaceView>(m, "SurfaceView",
                            "Zero-copy, read-only view of a body's surface slots (renderers). "
                            "While it or any of its arrays is alive, the world refuses step(), "
                            "restore() and body edits.")
      .def_property_readonly("vertices",
                             [](const py::object& self) {
                               auto& v = self.cast<PySurfaceView&>();
                               const auto n = static_cast<py::ssize_t>(v.view.positions.size());
                               return readOnly(py::dtype::of<double>(), {n, 3}, {24, 8},
                                               v.view.positions.data(), self);
                             })
      .def_property_readonly("normals",
                             [](const py::object& self) {
                               auto& v = self.cast<PySurfaceView&>();
                               const auto n = static_cast<py::ssize_t>(v.view.normals.size());
                               return readOnly(py::dtype::of<double>(), {n, 3}, {24, 8},
                                               v.view.normals.data(), self);
                             })
      .def_property_readonly("triangles",
                             [](const py::object& self) {
                               auto& v = self.cast<PySurfaceView&>();
                               const auto n = static_cast<py::ssize_t>(v.view.triangles.size());
                               return readOnly(py::dtype::of<std::int32_t>(), {n, 3}, {12, 4},
                                               v.view.triangles.data(), self);
                             })
      .def_property_readonly("materials",
                             [](const py::object& self) {
                               auto& v = self.cast<PySurfaceView&>();
                               const auto n = static_cast<py::ssize_t>(v.view.triangleTags.size());
                               return readOnly(py::dtype::of<std::uint8_t>(), {n}, {2},
                                               tagByte(v.view, 0), self);
                             })
      .def_property_readonly("cut",
                             [](const py::object& self) {
                               auto& v = self.cast<PySurfaceView&>();
                               const auto n = static_cast<py::ssize_t>(v.view.triangleTags.size());
                               return readOnly(py::dtype::of<std::uint8_t>(), {n}, {2},
                                               tagByte(v.view, 1), self);
                             })
      .def_property_readonly("revision",
                             [](const PySurfaceView& v) { return v.view.revision; });

  // The surface reads of Body (bound in BindHandles.cpp), added to the same class.
  auto body = py::reinterpret_borrow<py::class_<PyBody>>(m.attr("Body"));
  body.def(
          "_surface",
          [](const PyBody& b) {
            PyWorld::Guard g(*b.world);
            return surfaceCopy(b.live().world.surfaceMesh(b.id));
          })
      .def(
          "surface_view",
          [](const PyBody& b) { return std::make_unique<PySurfaceView>(b.world, b.id);
          },
          "A zero-copy, read-only view of the surface's slot arrays (dead slots included: "
          "their triangles read -1); see SurfaceView.")
      .def("_surface_changes", [](const PyBody& b, std::uint64_t since) {
        PyWorld::Guard g(*b.world);
        const SurfaceChanges c = b.live().world.surfaceChanges(b.id, since);
        py::dict d;
        d["from"] = c.from;
        d["to"] = c.to;
        d["full"] = c.full;
        d["added_vertices"] = c.addedVertices;
        d["removed_vertices"] = c.removedVertices;
        d["added_triangles"] = c.addedTriangles;
        d["removed_triangles"] = c.removedTriangles;
        return d;
      });
}

}  // namespace voxcut::python
