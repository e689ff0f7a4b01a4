// quadtune._core: the module definition (bindings.hpp).
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
  quadtune::python::BindOptimizers(m);
  quadtune::python::BindRun(m);
  quadtune::python::BindPlanners(m);
}
