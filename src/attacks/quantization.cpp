// SPDX-License-Identifier: MIT
#include "meshmark/attacks/quantization.h"

#include <cmath>
#include <string>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"

namespace meshmark
{

void QuantizationOptions::validate() const
{
    if (bits < 1 || bits > 30)
    {
        throw InvalidOption("quantize: bits " + std::to_string(bits) + " is outside 1..30.");
    }
}

TriangleMesh quantize(const TriangleMesh& mesh, const QuantizationOptions& options)
{
    options.validate();
    const BoundingBox box = bounding_box(mesh.V);
    const double top_level = std::ldexp(1.0, options.bits) - 1.0;
    TriangleMesh result = mesh;
    for (int d = 0; d < 3; ++d)
    {
        const double extent = box.max(d) - box.min(d);
        if (!(extent > 0.0))
        {
            continue;
        }
        const double step = extent / top_level;
        for (Eigen::Index i = 0; i < result.V.rows(); ++i)
        {
            // Level index in 0..2^bits - 1, then back to a coordinate on the grid.
            const double level = std::round((mesh.V(i, d) - box.min(d)) / step);
            result.V(i, d) = box.min(d) + level * step;
        }
    }
    return result;
}

}  // namespace meshmark
