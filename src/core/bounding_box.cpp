// SPDX-License-Identifier: MIT
#include "meshmark/core/bounding_box.h"

namespace meshmark
{

BoundingBox bounding_box(const Positions& V)
{
    BoundingBox box;
    if (V.rows() == 0)
    {
        return box;
    }
    box.min = V.colwise().minCoeff().transpose();
    box.max = V.colwise().maxCoeff().transpose();
    return box;
}

BoundingBox bounding_box(const Positions& V, const std::vector<std::int32_t>& rows)
{
    BoundingBox box;
    if (rows.empty())
    {
        return box;
    }
    box.min = V.row(rows.front()).transpose();
    box.max = box.min;
    for (const auto i : rows)
    {
        box.min = box.min.cwiseMin(V.row(i).transpose());
        box.max = box.max.cwiseMax(V.row(i).transpose());
    }
    return box;
}

}  // namespace meshmark
