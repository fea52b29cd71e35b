// SPDX-License-Identifier: MIT
#include "support/test_shapes.h"

#include <array>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "meshmark/geometry/shapes.h"

namespace meshmark::test
{

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
    const Eigen::Matrix3d upright =
        Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
    for (Eigen::Index i = 0; i < t.V.rows(); ++i)
    {
        t.V.row(i) = (upright * t.V.row(i).transpose() + centre).transpose();
    }
    return t;
}

TriangleMesh vehicle(bool roof_box)
{
    std::vector<TriangleMesh> parts;
    auto boxy = [](const Eigen::Vector3d& half, const Eigen::Vector3d& centre)
    {
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
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(25.0 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitZ())
            .toRotationMatrix();
    whole.V = (whole.V * turn.transpose()).eval();
    return whole;
}

TriangleMesh outline_plate()
{
    constexpr int kPerArc = 25;
    constexpr int kPerLayer = 4 * kPerArc;
    const std::array<std::array<double, 2>, 4> corners{
        {{152.0, 152.0}, {-152.0, 152.0}, {-152.0, -152.0}, {152.0, -152.0}}};
    TriangleMesh plate;
    plate.V.resize(2 * kPerLayer, 3);
    for (int layer = 0; layer < 2; ++layer)
    {
        for (int c = 0; c < 4; ++c)
        {
            for (int a = 0; a < kPerArc; ++a)
            {
                const double angle = (c + a / (kPerArc - 1.0)) * std::numbers::pi / 2.0;
                plate.V.row(layer * kPerLayer + c * kPerArc + a)
                    << corners[c][0] + 3.0 * std::cos(angle),
                    corners[c][1] + 3.0 * std::sin(angle), layer == 0 ? 0.0 : -3.0;
            }
        }
    }
    plate.F.resize(2 * (kPerLayer - 2) + 2 * kPerLayer, 3);
    Eigen::Index f = 0;
    for (int i = 1; i + 1 < kPerLayer; ++i)
    {
        plate.F.row(f++) << 0, i, i + 1;                                  // top fan
        plate.F.row(f++) << kPerLayer, kPerLayer + i + 1, kPerLayer + i;  // bottom fan
    }
    for (int i = 0; i < kPerLayer; ++i)
    {
        const int j = (i + 1) % kPerLayer;
        plate.F.row(f++) << i, kPerLayer + i, j;
        plate.F.row(f++) << j, kPerLayer + i, kPerLayer + j;
    }
    return plate;
}

}  // namespace meshmark::test
