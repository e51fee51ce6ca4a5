// The compiled part of the voxcut Python package (docs/python.md): the world, its handles and
// its arrays. The pure-Python package around it (python/voxcut/) adds the value types as
// dataclasses, the sweeps and the docstrings users read.

#include <pybind11/pybind11.h>

#include "Convert.h"
#include "voxcut/core/Error.h"
#include "voxcut/core/Parallel.h"

namespace py = pybind11;
using namespace voxcut::python;

namespace {

// Each C++ error becomes the Python exception docs/python.md, "Errors", names. The classes
// are made here and re-exported by the package.
void bindErrorsImpl(py::module_& m) {
  static py::exception<voxcut::InputError> inputError(m, "InputError", PyExc_ValueError);
  static py::exception<StaleHandleError> staleError(m, "StaleHandleError", PyExc_KeyError);
  static py::exception<BusyError> busyError(m, "BusyError", PyExc_RuntimeError);
  static py::exception<voxcut::StepError> stepError(m, "StepError", PyExc_RuntimeError);
  static py::exception<voxcut::Interrupted> interrupted(m, "Interrupted", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const voxcut::StepError& e) {
      // The exception carries the failed frame and the body's slot, as attributes.
      py::object exc = py::handle(stepError.ptr())(e.what());
      exc.attr("frame") = e.frame();
      exc.attr("body_slot") = e.body().valid() ? py::object(py::int_(e.body().slot())) : py::none();
      PyErr_SetObject(stepError.ptr(), exc.ptr());
    } catch (const voxcut::InputError& e) {
      PyErr_SetString(inputError.ptr(), e.what());
    } catch (const StaleHandleError& e) {
      PyErr_SetString(staleError.ptr(), e.what());
    } catch (const BusyError& e) {
      PyErr_SetString(busyError.ptr(), e.what());
    } catch (const voxcut::Interrupted& e) {
      PyErr_SetString(interrupted.ptr(), e.what());
    }
  });
}

}  // namespace

namespace voxcut::python {
void bindErrors(py::module_& m) { bindErrorsImpl(m); }
}  // namespace voxcut::python

PYBIND11_MODULE(_voxcut, m) {
  m.doc() = "voxcut's compiled core: use the voxcut package, which wraps it (docs/python.md).";
  bindErrors(m);
  bindSettings(m);
  bindWorld(m);
  bindHandles(m);
  bindSurfaces(m);
  m.def(
      "set_threads",
      [](int threads) {
        // One limit for the process, as TBB has it: 0 lifts it.
        static std::unique_ptr<voxcut::ThreadLimit> limit;
        if (threads < 0) throw voxcut::InputError("set_threads: must be >= 0");
        limit.reset();
        if (threads > 0) limit = std::make_unique<voxcut::ThreadLimit>(threads);
      },
      py::arg("threads"),
      "Limits the worker threads of every world in the process (0: all cores). Results do not "
      "depend on it.");
  m.attr("__version__") = "0.1.0";
}
