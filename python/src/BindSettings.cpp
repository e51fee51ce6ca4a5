// Lists the package shows its users: solver choices, frame stages, built-in models.

#include <pybind11/stl.h>

#include "Convert.h"
#include "voxcut/io/ModelSource.h"

namespace voxcut::python {

void bindSettings(py::module_& m) {
  m.def(
      "solver_choices",
      [] {
        std::vector<std::string> names;
        for (const SolverChoice c : kSolverChoices) names.emplace_back(solverChoiceName(c));
        return names;
      },
      "The names World(preconditioner=...) takes, 'auto' first.");
  m.def(
      "frame_stage_names", [] { return frameStageNames(); },
      "The stages of a frame, in order (the keys of FrameReport.stage_ms).");
  m.def(
      "builtin_models", [] { return builtinModelNames(); },
      "The built-in models add_body takes by name.");
}

}  // namespace voxcut::python
