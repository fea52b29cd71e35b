// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief Exact nearest-neighbour queries on a point set: nanoflann's kd-tree (leaf size 10)
/// over the rows of a Positions matrix, built once.
/// \details The one kd-tree of the library: ClosestPointIndex uses it for point clouds and
/// registration for its ICP correspondences. Queries are const and thread-safe. Ties between
/// points at exactly the same distance are broken by nanoflann's traversal, which depends only
/// on the points and their order: the same input gives the same answer on every run.
class PointKdTree
{
public:
    /// \brief Build the tree over the rows of \p points (#P×3), which it keeps.
    /// \p points may be empty; then no query may be made.
    explicit PointKdTree(Positions points);
    ~PointKdTree();
    PointKdTree(PointKdTree&&) noexcept;
    PointKdTree& operator=(PointKdTree&&) noexcept;
    PointKdTree(const PointKdTree&) = delete;
    PointKdTree& operator=(const PointKdTree&) = delete;

    /// The points, as given (row i is point i).
    [[nodiscard]] const Positions& points() const noexcept;

    /// \brief Index of the point nearest to \p query; \p squared receives its squared distance.
    /// \pre The tree has at least one point.
    [[nodiscard]] std::uint32_t nearest(const Eigen::Vector3d& query, double& squared) const;

    /// \brief Index of the point nearest to \p query if one is nearer than the square root of
    /// \p bound (\p squared receives its squared distance), nothing otherwise.
    /// \details Far cheaper than nearest() for a query far from every point: the search leaves
    /// out every part of the tree beyond the bound.
    [[nodiscard]] std::optional<std::uint32_t> nearest_within(const Eigen::Vector3d& query,
                                                              double bound, double& squared) const;

    /// \brief The \p k points nearest to \p query, nearest first, into \p index and \p squared
    /// (each with room for \p k values). \return how many were found: min(k, point count).
    std::size_t nearest(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* index,
                        double* squared) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace meshmark
