// SPDX-License-Identifier: MIT
// The extension module meshmark._meshmark; the package python/meshmark re-exports it.
#include <pybind11/pybind11.h>

#include "bindings.h"

PYBIND11_MODULE(_meshmark, m)
{
    using namespace meshmark::python;
    m.doc() = "meshmark's compiled core: see the meshmark package.";
    m.attr("__version__") = MESHMARK_VERSION;
    bind_errors(m);
    bind_key(m);
    bind_memory(m);
    bind_files(m);
    bind_compare(m);
    bind_catalog(m);
    bind_cluster(m);
}
