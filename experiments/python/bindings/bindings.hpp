#pragma once
/// \file
/// quadtune._core, the extension module of the Python package quadtune (pybind11). Each Bind*
/// adds one part to the module; the Python side (experiments/python/quadtune/*.py) turns dicts
/// into the YAML the C++ loaders read, so every check and error message is the engine's own.
///
/// GIL: every call that does C++ work (ask, tell, a run) releases the GIL; the engine's worker
/// threads take it only to call a Python planner (planner.cpp), one call at a time.

#include <pybind11/pybind11.h>

#include <string>

namespace quadtune::python {

/// The ask/tell optimisers: _core.Optimizer (optimizers.cpp).
void BindOptimizers(pybind11::module_& m);
/// Experiment runs: _core.run (run.cpp).
void BindRun(pybind11::module_& m);
/// Planners written in Python: _core.register_planner (planner.cpp).
void BindPlanners(pybind11::module_& m);

/// Called by a Python planner whose call raised (on a worker thread, without the GIL): the run in
/// progress is cancelled (the round in flight is not stored) and _core.run raises RuntimeError
/// with `message`.
void ReportPlannerFailure(const std::string& message);

}  // namespace quadtune::python
