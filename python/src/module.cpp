// The _hazmap extension module; the Python package hazmap (python/hazmap) wraps it.
#include "bindings.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/core/memory.hpp"

PYBIND11_MODULE(_hazmap, m) {
  namespace hp = hazmap::python;
  m.doc() = "hazmap: property-aware LiDAR SLAM (C++ core)";
  // Same reason as the CLI: registering scans in a loop page-faults on freed blocks otherwise.
  hazmap::retainFreedMemory();
  pybind11::register_exception<hazmap::Error>(m, "Error", PyExc_RuntimeError);
  hp::bindClouds(m);
  hp::bindSources(m);
  hp::bindRegistration(m);
  hp::bindSlam(m);
  hp::bindEvaluation(m);
  hp::bindGraph(m);
  hp::bindConfigs(m);
}
