// SPDX-License-Identifier: MIT
#include "meshmark/attacks/attack_result.h"

namespace meshmark
{

Eigen::Matrix4d AppliedSimilarity::matrix() const
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = scale * rotation;
    m.topRightCorner<3, 1>() = translation;
    return m;
}

AppliedSimilarity AppliedSimilarity::then(const AppliedSimilarity& next) const
{
    // next(this(p)) = s2 R2 (s1 R1 p + t1) + t2.
    AppliedSimilarity result;
    result.rotation = next.rotation * rotation;
    result.scale = next.scale * scale;
    result.translation = next.scale * (next.rotation * translation) + next.translation;
    return result;
}

AppliedSimilarity AppliedSimilarity::inverse() const
{
    // p = R^T (q - t) / s.
    AppliedSimilarity result;
    result.rotation = rotation.transpose();
    result.scale = 1.0 / scale;
    result.translation = -(result.rotation * translation) / scale;
    return result;
}

std::vector<std::int32_t> identity_correspondence(Eigen::Index n)
{
    std::vector<std::int32_t> result(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < result.size(); ++i)
    {
        result[i] = static_cast<std::int32_t>(i);
    }
    return result;
}

}  // namespace meshmark
