// SPDX-License-Identifier: MIT
#include "meshmark/registration/similarity_fit.h"

#include <Eigen/Geometry>

namespace meshmark
{

Eigen::Matrix4d fit_similarity(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to)
{
    return Eigen::umeyama(from, to, true);
}

Eigen::Matrix4d fit_similarity_rows(const Positions& from, const Positions& to)
{
    return Eigen::umeyama(from.transpose(), to.transpose(), true);
}

SimilarityTransform similarity_parts(const Eigen::Matrix4d& A)
{
    SimilarityTransform T;
    T.scale = A.block<3, 1>(0, 0).norm();
    T.rotation = A.block<3, 3>(0, 0) / T.scale;
    T.translation = A.block<3, 1>(0, 3);
    return T;
}

}  // namespace meshmark
