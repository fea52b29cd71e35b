// SPDX-License-Identifier: MIT
// Generated meshes of a chosen vertex count for `meshmark bench speed` and bench/perf.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark::cli {

/// \brief A closed, manifold, asymmetric mesh with about \p vertices vertices: a torus grid of
/// rings x sides vertices (sides the largest divisor of \p vertices not above its square root,
/// so the count is exact whenever such a divisor >= 3 exists), deformed by the smooth bumps and
/// radii of lumpy_ellipsoid. Subdivided ellipsoids only reach 10 * 4^s + 2 vertices, which
/// cannot hit 10K / 100K / 1M; a grid can.
/// \throws InvalidOption if \p vertices < 9.
[[nodiscard]] inline TriangleMesh bumpy_torus(std::int64_t vertices)
{
    if (vertices < 9 || vertices > 100'000'000)
    {
        throw InvalidOption("a generated mesh needs 9 to 100000000 vertices, got " +
                            std::to_string(vertices) + ".");
    }
    const auto root = static_cast<std::int64_t>(std::sqrt(static_cast<double>(vertices)));
    std::int64_t sides = root;
    while (sides >= 3 && vertices % sides != 0)
    {
        --sides;
    }
    if (sides < 3 || vertices / sides > 50 * sides)
    {
        sides = root;  // no usable divisor: nearest grid below the requested count
    }
    const std::int64_t rings = vertices / sides;
    TriangleMesh mesh = torus(1.0, 0.35, static_cast<int>(rings), static_cast<int>(sides));
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const double x = mesh.V(i, 0);
        const double y = mesh.V(i, 1);
        const double z = mesh.V(i, 2);
        const double bump = 1.0 + 0.12 * std::sin(3.0 * x + 1.0) * std::cos(2.0 * y - 0.5) +
                            0.08 * std::sin(5.0 * z + 2.0 * x);
        mesh.V.row(i) = Eigen::RowVector3d(1.0 * x, 0.7 * y, 0.45 * z) * bump;
    }
    return mesh;
}

}  // namespace meshmark::cli
