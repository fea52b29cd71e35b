// SPDX-License-Identifier: MIT
#include "support/test_shapes.h"

#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "meshmark/geometry/shapes.h"

namespace meshmark::test {

TriangleMesh joined(const std::vector<TriangleMesh>& parts)
{
    TriangleMesh whole;
    Eigen::Index v = 0;
    Eigen::Index f = 0;
    for (const TriangleMesh& part : parts)
    {
        whole.V.conservativeResize(v + part.V.rows(), 3);
        whole.F.conservativeResize(f + part.F.rows(), 3);
        whole.V.bottomRows(part.V.rows()) = part.V;
        whole.F.bottomRows(part.F.rows()) = part.F.array() + static_cast<std::int32_t>(v);
        v += part.V.rows();
        f += part.F.rows();
    }
    return whole;
}

TriangleMesh tyre(const Eigen::Vector3d& centre)
{
    TriangleMesh t = torus(0.24, 0.1, 64, 20);
    const Eigen::Matrix3d upright = Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
    for (Eigen::Index i = 0; i < t.V.rows(); ++i)
    {
        t.V.row(i) = (upright * t.V.row(i).transpose() + centre).transpose();
    }
    return t;
}

TriangleMesh vehicle(bool roof_box)
{
    std::vector<TriangleMesh> parts;
    auto boxy = [](const Eigen::Vector3d& half, const Eigen::Vector3d& centre) {
        TriangleMesh m = icosphere(2);
        for (Eigen::Index i = 0; i < m.V.rows(); ++i)
        {
            for (int d = 0; d < 3; ++d)
            {
                const double x = m.V(i, d);
                m.V(i, d) = centre(d) + half(d) * std::copysign(std::pow(std::abs(x), 0.3), x);
            }
        }
        return m;
    };
    parts.push_back(boxy({1.1, 0.5, 0.25}, {0.0, 0.0, 0.6}));
    parts.push_back(boxy({0.5, 0.42, 0.22}, {-0.4, 0.0, 1.05}));
    for (const double x : {0.75, -0.75})
    {
        for (const double y : {0.55, -0.55})
        {
            parts.push_back(tyre({x, y, 0.32}));
        }
    }
    for (const double y : {0.35, -0.35})
    {
        parts.push_back(boxy({0.1, 0.15, 0.15}, {1.15, y, 0.7}));
    }
    if (roof_box)
    {
        parts.push_back(boxy({0.12, 0.12, 0.12}, {0.0, 0.5, 1.3}));
    }
    TriangleMesh whole = joined(parts);
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(25.0 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    whole.V = (whole.V * turn.transpose()).eval();
    return whole;
}

}  // namespace meshmark::test
