// SPDX-License-Identifier: MIT
#include "meshmark/attacks/quantization.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{

TEST(QuantizationTest, coordinates_land_on_the_grid_within_half_a_step)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const BoundingBox box = bounding_box(mesh.V);
    for (const int bits : {7, 8, 9, 10, 11, 12})
    {
        const TriangleMesh q = quantize(mesh, {.bits = bits});
        EXPECT_EQ(q.F, mesh.F);
        const double levels = std::ldexp(1.0, bits);
        for (int d = 0; d < 3; ++d)
        {
            const double step = (box.max(d) - box.min(d)) / (levels - 1.0);
            std::set<double> distinct;
            double worst = 0.0;
            for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
            {
                worst = std::max(worst, std::abs(q.V(i, d) - mesh.V(i, d)));
                const double k = (q.V(i, d) - box.min(d)) / step;
                EXPECT_NEAR(k, std::round(k), 1e-6);
                EXPECT_GE(k, -1e-9);
                EXPECT_LE(k, levels - 1.0 + 1e-9);
                distinct.insert(q.V(i, d));
            }
            EXPECT_LE(worst, 0.5 * step * (1 + 1e-9)) << bits << " bits, axis " << d;
            EXPECT_GT(worst, 0.4 * step) << bits << " bits, axis " << d;  // it did quantize
            EXPECT_LE(static_cast<double>(distinct.size()), levels);
        }
    }
}

TEST(QuantizationTest, flat_axis_is_left_alone_and_bits_are_checked)
{
    const TriangleMesh grid = plane_grid(7, 5);  // z = 0 everywhere
    const TriangleMesh q = quantize(grid, {.bits = 3});
    EXPECT_TRUE(q.V.col(2).isZero(0.0));
    EXPECT_THROW((void)quantize(grid, {.bits = 0}), InvalidOption);
    EXPECT_THROW((void)quantize(grid, {.bits = 31}), InvalidOption);
}

}  // namespace meshmark
