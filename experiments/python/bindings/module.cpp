// quadtune._core: the module definition (bindings.hpp).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "quadtune/engine/api/asset_paths.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "quadtune's C++ engine: ask/tell optimisers, experiment runs, Python planners";
  m.attr("source_assets") = QUADTUNE_SOURCE_ASSETS;
  m.def("set_asset_dirs", &quadtune::engine::SetAssetDirs, pybind11::arg("dirs"),
        "Folders searched for the drone and layout files an experiment names (after the file's "
        "own folder and the working directory). quadtune/__init__.py sets them on import.");
  m.def("asset_dirs", &quadtune::engine::AssetDirs);
  // numpy is imported, and pybind11's function-local statics that convert Eigen vectors are made,
  // here under the GIL: made first on a worker thread (a Python planner's query), an import
  // that gives the GIL away inside a static's initialisation deadlocks with the next worker.
  pybind11::detail::npy_api::get();
  pybind11::cast(std::vector<Eigen::Vector3d>{Eigen::Vector3d::Zero()});
  quadtune::python::BindOptimizers(m);
  quadtune::python::BindRun(m);
  quadtune::python::BindPlanners(m);
}
