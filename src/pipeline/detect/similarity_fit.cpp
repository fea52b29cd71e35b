// SPDX-License-Identifier: MIT
#include "pipeline/detect/similarity_fit.h"

#include <algorithm>

#include <Eigen/Geometry>

#include "meshmark/registration/similarity_fit.h"

namespace meshmark::detail
{

Eigen::Matrix4d similarity_onto_original(const Positions& original, const Positions& suspect,
                                         const std::vector<std::uint8_t>* kept)
{
    if (kept == nullptr)
    {
        return fit_similarity_rows(original, suspect).inverse();
    }
    const auto count = static_cast<Eigen::Index>(
        std::count_if(kept->begin(), kept->end(), [](std::uint8_t k) { return k != 0; }));
    Eigen::Matrix3Xd from(3, count);
    Eigen::Matrix3Xd to(3, count);
    for (Eigen::Index i = 0, k = 0; i < original.rows(); ++i)
    {
        if ((*kept)[static_cast<std::size_t>(i)] != 0)
        {
            from.col(k) = original.row(i).transpose();
            to.col(k) = suspect.row(i).transpose();
            ++k;
        }
    }
    return fit_similarity(from, to).inverse();
}

}  // namespace meshmark::detail
