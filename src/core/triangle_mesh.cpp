// SPDX-License-Identifier: MIT
#include "meshmark/core/triangle_mesh.h"

#include <cmath>
#include <string>

#include "meshmark/core/error.h"

namespace meshmark
{

void validate(const TriangleMesh& mesh, const char* what)
{
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        for (int d = 0; d < 3; ++d)
        {
            if (!std::isfinite(mesh.V(i, d)))
            {
                throw InvalidMesh(std::string(what) + ": vertex " + std::to_string(i) +
                                  " has a non-finite coordinate (NaN or infinity).");
            }
        }
    }
    const auto n = mesh.V.rows();
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            const auto index = mesh.F(f, c);
            if (index < 0 || index >= n)
            {
                throw InvalidMesh(std::string(what) + ": face " + std::to_string(f) +
                                  " uses vertex index " + std::to_string(index) + ", outside 0.." +
                                  std::to_string(n - 1) + ".");
            }
        }
    }
}

Faces with_fans(const TriangleMesh& mesh)
{
    Faces F = mesh.F;
    const auto n = static_cast<std::int32_t>(mesh.V.rows());
    const auto in_range = [n](std::int32_t v) { return v >= 0 && v < n; };
    for (const FanTriangle& fan : mesh.fans)
    {
        // A mesh whose triangles were changed after it was read keeps fans that may no longer
        // fit: those out of range are left out (the others can only fail to match a copy's).
        if (fan.row >= 0 && fan.row < F.rows() && in_range(fan.a) && in_range(fan.b) &&
            in_range(fan.c))
        {
            F.row(fan.row) << fan.a, fan.b, fan.c;
        }
    }
    return F;
}

std::vector<std::int32_t> referenced_vertices(const TriangleMesh& mesh)
{
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    std::vector<std::int32_t> result;
    if (mesh.F.rows() == 0)
    {
        result.resize(n);
        for (std::size_t i = 0; i < n; ++i)
        {
            result[i] = static_cast<std::int32_t>(i);
        }
        return result;
    }
    std::vector<char> used(n, 0);
    for (Eigen::Index i = 0; i < mesh.F.size(); ++i)
    {
        used[static_cast<std::size_t>(mesh.F.data()[i])] = 1;
    }
    result.reserve(n);
    for (std::size_t i = 0; i < n; ++i)
    {
        if (used[i] != 0)
        {
            result.push_back(static_cast<std::int32_t>(i));
        }
    }
    return result;
}

}  // namespace meshmark
