// SPDX-License-Identifier: MIT
#include "meshmark/geometry/point_kd_tree.h"

#include <utility>

#include <nanoflann.hpp>

namespace meshmark
{
namespace
{

/// nanoflann dataset adaptor over the rows of a Positions matrix.
struct PositionsAdaptor
{
    const Positions* V = nullptr;

    [[nodiscard]] std::size_t kdtree_get_point_count() const
    {
        return static_cast<std::size_t>(V->rows());
    }
    [[nodiscard]] double kdtree_get_pt(std::size_t i, std::size_t dim) const
    {
        return (*V)(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(dim));
    }
    template <class Box>
    bool kdtree_get_bbox(Box& /*box*/) const
    {
        return false;  // Let nanoflann compute the bounding box.
    }
};

using Tree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PositionsAdaptor>,
                                        PositionsAdaptor, 3, std::uint32_t>;

// nanoflann's default leaf size; single-nearest-neighbour queries are not sensitive to it.
constexpr std::size_t kLeafSize = 10;

}  // namespace

struct PointKdTree::Impl
{
    Positions V;  // The address stays fixed behind the unique_ptr, as the tree requires.
    PositionsAdaptor adaptor;
    Tree tree;

    explicit Impl(Positions points)
        : V(std::move(points)),
          adaptor{&V},
          tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize))
    {
    }
};

PointKdTree::PointKdTree(Positions points) : impl_(std::make_unique<Impl>(std::move(points))) {}

PointKdTree::~PointKdTree() = default;
PointKdTree::PointKdTree(PointKdTree&&) noexcept = default;
PointKdTree& PointKdTree::operator=(PointKdTree&&) noexcept = default;

const Positions& PointKdTree::points() const noexcept
{
    return impl_->V;
}

std::uint32_t PointKdTree::nearest(const Eigen::Vector3d& query, double& squared) const
{
    std::uint32_t index = 0;
    impl_->tree.knnSearch(query.data(), 1, &index, &squared);
    return index;
}

std::optional<std::uint32_t> PointKdTree::nearest_within(const Eigen::Vector3d& query, double bound,
                                                         double& squared) const
{
    std::uint32_t index = 0;
    double found = 0.0;
    nanoflann::KNNResultSet<double, std::uint32_t> result(1);
    result.init(&index, &found);
    // The result set's worst distance is the bound: nanoflann prunes every cell beyond it and
    // adds only points nearer.
    found = bound;
    impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
    if (result.size() == 0)
    {
        return std::nullopt;
    }
    squared = found;
    return index;
}

std::size_t PointKdTree::nearest(const Eigen::Vector3d& query, std::size_t k, std::uint32_t* index,
                                 double* squared) const
{
    return impl_->tree.knnSearch(query.data(), k, index, squared);
}

}  // namespace meshmark
