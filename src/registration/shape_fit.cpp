// SPDX-License-Identifier: MIT
// A quick fit of a suspect's points onto an asset's: the shape index's candidates checked by
// geometry (shape_fit.h).
#include "meshmark/registration/shape_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "meshmark/geometry/shape_signature.h"
#include "meshmark/registration/point_to_plane.h"
#include "meshmark/registration/similarity_fit.h"
#include "registration/detail/coarse_alignment.h"

namespace meshmark
{
namespace
{

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr Eigen::Index kMinPoints = 8;
// Weight of the distance along the asset's surface (to the nearest sample point) beside the
// distance across it: the samples are about a sixth of the radius apart, which would
// otherwise set the floor of every fit.
constexpr double kLateral = 0.01;

// Centroid, principal axes (columns, largest variance first, a right-handed frame) and RMS
// radius of a point set.
struct Frame
{
    Vec3 centre = Vec3::Zero();
    Mat3 axes = Mat3::Identity();
    double radius = 0.0;
};

template <typename Rows>
Frame frame_of(const Rows& points)
{
    Frame frame;
    const auto n = static_cast<double>(points.rows());
    frame.centre = points.colwise().mean().transpose();
    const Eigen::MatrixX3d centred = points.rowwise() - frame.centre.transpose();
    const Mat3 covariance = centred.transpose() * centred / n;
    frame.radius = std::sqrt(covariance.trace());
    frame.axes = detail::principal_frame(covariance);
    return frame;
}

// A similarity x -> s R x + t (R proper) from the suspect's (possibly mirrored) points onto the
// asset's, and the fit's relative RMS.
struct Pose
{
    double scale = 1.0;
    Mat3 rotation = Mat3::Identity();
    Vec3 translation = Vec3::Zero();
    double error = std::numeric_limits<double>::infinity();
};

// One point-to-plane step (point_to_plane_step, with scale) of the kept pairs, \p from moved
// by \p pose onto the planes of \p to and \p to_normals: a sparse sample's nearest points pull a
// point-to-point fit off the surface, the planes do not.
void step_across(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                 const Eigen::Matrix3Xd& to_normals, Pose& pose)
{
    Positions moved = ((pose.scale * pose.rotation) * from).transpose();
    moved.rowwise() += pose.translation.transpose();
    std::vector<SurfaceMatch> matches(static_cast<std::size_t>(from.cols()));
    std::vector<Eigen::Index> kept(matches.size());
    for (Eigen::Index k = 0; k < from.cols(); ++k)
    {
        matches[static_cast<std::size_t>(k)] = {to.col(k), to_normals.col(k), 0.0};
        kept[static_cast<std::size_t>(k)] = k;
    }
    const std::optional<PointToPlaneStep<7>> update = point_to_plane_step<7>(moved, matches, kept);
    if (!update || !(update->radius > 0.0))
    {
        return;
    }
    const Vec3 omega = update->delta.head<3>() / update->radius;
    const double grow = 1.0 + update->delta(3) / update->radius;
    if (!(grow > 0.5 && grow < 2.0))
    {
        return;
    }
    const double angle = omega.norm();
    const Mat3 turn =
        angle > 0.0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix() : Mat3::Identity();
    const Vec3& c = update->centre;
    // y' = c + k dR (y - c) + tau, composed with y = s R x + t (as the registration's ICP does).
    pose.scale *= grow;
    pose.rotation = turn * pose.rotation;
    pose.translation = c + grow * (turn * (pose.translation - c)) + update->delta.tail<3>();
}

// ICP rounds of \p source (rows: the suspect's points, mirrored or not) onto \p tree's points,
// from \p pose; each round pairs every point with its nearest, keeps the closest kKept, and
// fits the similarity of those pairs [Umeyama 1991]; a round that improves the fit by less than
// the share \p settled ends it. With \p rounds 0 the pose is only scored; then a point farther
// than the square root of \p bound from every asset point counts as that far (the search
// leaves out the rest of the tree: ShapeFitOptions::start_bound).
void refine(const Eigen::MatrixX3d& source, double source_radius, const PointKdTree& tree,
            const Positions& normals, int rounds, double kept_share, bool to_plane, bool across,
            double settled, Pose& pose, double bound = std::numeric_limits<double>::infinity())
{
    const Eigen::Index n = source.rows();
    const auto kept =
        std::max<Eigen::Index>(3, static_cast<Eigen::Index>(kept_share * static_cast<double>(n)));
    std::vector<std::pair<double, Eigen::Index>> order(static_cast<std::size_t>(n));
    std::vector<std::uint32_t> nearest(static_cast<std::size_t>(n));
    Eigen::Matrix3Xd from(3, kept);
    Eigen::Matrix3Xd to(3, kept);
    Eigen::Matrix3Xd to_normals(3, across ? kept : 0);
    const Positions& target = tree.points();
    for (int round = 0; round <= rounds; ++round)
    {
        for (Eigen::Index i = 0; i < n; ++i)
        {
            const Vec3 moved =
                pose.scale * (pose.rotation * source.row(i).transpose()) + pose.translation;
            double squared = 0.0;
            std::uint32_t p = 0;
            if (rounds == 0 && std::isfinite(bound))
            {
                const std::optional<std::uint32_t> near =
                    tree.nearest_within(moved, bound, squared);
                if (!near)
                {
                    order[static_cast<std::size_t>(i)] = {bound, i};
                    continue;
                }
                p = *near;
            }
            else
            {
                p = tree.nearest(moved, squared);
            }
            nearest[static_cast<std::size_t>(i)] = p;
            if (to_plane)
            {
                const double along = normals.row(p).dot(moved - target.row(p).transpose());
                // the normal's part, and a little of the rest: a point beside a sample point
                // is near its plane, one far beyond the surface's edge is not
                squared = along * along + kLateral * (squared - along * along);
            }
            order[static_cast<std::size_t>(i)] = {squared, i};
        }
        std::nth_element(order.begin(), order.begin() + (kept - 1), order.end());
        double sum = 0.0;
        for (Eigen::Index k = 0; k < kept; ++k)
        {
            sum += order[static_cast<std::size_t>(k)].first;
        }
        // In the suspect's own units: the asset's distances over the scale the fit gave it.
        const double before = pose.error;
        pose.error = std::sqrt(sum / static_cast<double>(kept)) / (pose.scale * source_radius);
        if (round == rounds || (round > 0 && pose.error > before * (1.0 - settled)))
        {
            return;
        }
        for (Eigen::Index k = 0; k < kept; ++k)
        {
            const Eigen::Index i = order[static_cast<std::size_t>(k)].second;
            from.col(k) = source.row(i).transpose();
            to.col(k) = target.row(nearest[static_cast<std::size_t>(i)]).transpose();
            if (across)
            {
                to_normals.col(k) = normals.row(nearest[static_cast<std::size_t>(i)]).transpose();
            }
        }
        if (across)
        {
            step_across(from, to, to_normals, pose);
            continue;
        }
        const Eigen::Matrix4d fit = fit_similarity(from, to);
        const double scale = fit.block<3, 1>(0, 0).norm();
        if (!(scale > 0.0) || !std::isfinite(scale))
        {
            return;
        }
        pose.scale = scale;
        pose.rotation = fit.block<3, 3>(0, 0) / scale;
        pose.translation = fit.block<3, 1>(0, 3);
    }
}

}  // namespace

double shape_fit(const Positions& suspect, const Positions& asset, const Positions& asset_normals,
                 const PointKdTree& tree, std::span<const int> views,
                 const ShapeFitOptions& options, ShapeFitPose* pose_out)
{
    if (suspect.rows() < kMinPoints || asset.rows() < kMinPoints)
    {
        return std::numeric_limits<double>::infinity();
    }
    // The parts of the asset to start from: the whole, then each crop view's points.
    std::vector<Frame> parts{frame_of(asset)};
    const std::vector<Vec3> directions = shape_crop_directions();
    const auto fractions = static_cast<int>(kShapeCropFractions.size());
    std::vector<double> heights(static_cast<std::size_t>(asset.rows()));
    for (const int view : views)
    {
        if (view < 1 || view >= kShapeViews)
        {
            continue;
        }
        const Vec3& d = directions[static_cast<std::size_t>((view - 1) / fractions)];
        const double fraction =
            kShapeCropFractions[static_cast<std::size_t>((view - 1) % fractions)];
        for (Eigen::Index i = 0; i < asset.rows(); ++i)
        {
            heights[static_cast<std::size_t>(i)] = asset.row(i).dot(d);
        }
        std::vector<double> sorted = heights;
        const auto drop = std::min<std::size_t>(
            static_cast<std::size_t>(
                std::lround((1.0 - fraction) * static_cast<double>(sorted.size()))),
            sorted.size() - 1);
        std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(drop),
                         sorted.end());
        const double threshold = sorted[drop];
        std::vector<Eigen::Index> rows;
        for (Eigen::Index i = 0; i < asset.rows(); ++i)
        {
            if (heights[static_cast<std::size_t>(i)] >= threshold)
            {
                rows.push_back(i);
            }
        }
        if (static_cast<Eigen::Index>(rows.size()) >= kMinPoints)
        {
            parts.push_back(frame_of(Eigen::MatrixX3d(asset(rows, Eigen::all))));
        }
    }
    // The suspect as given and mirrored in its first coordinate; a quarter of the points (every
    // fourth: the draw is stratified over the surface) for the start poses.
    std::array<Eigen::MatrixX3d, 2> sources{suspect, suspect};
    sources[1].col(0) *= -1.0;
    const Frame own = frame_of(suspect);
    if (!(own.radius > 0.0))
    {
        return std::numeric_limits<double>::infinity();
    }
    struct Start
    {
        int source = 0;
        Pose pose;
    };
    // Every start pose scored as it stands on an eighth of the points; the best few refined.
    const std::vector<Mat3> turns = detail::axis_rotations();
    const double bound = options.start_bound > 0.0
                             ? std::pow(options.start_bound * parts.front().radius, 2)
                             : std::numeric_limits<double>::infinity();
    std::vector<Start> starts;
    for (int m = 0; m < 2; ++m)
    {
        const Eigen::MatrixX3d& source = sources[static_cast<std::size_t>(m)];
        const Frame from = frame_of(source);
        const Eigen::MatrixX3d eighth =
            source(Eigen::seq(0, source.rows() - 1, options.start_stride), Eigen::all);
        for (const Frame& part : parts)
        {
            if (!(part.radius > 0.0))
            {
                continue;
            }
            // The source's axes onto the part's, in each of the 24 ways a cube can be turned:
            // principal axes of nearly equal variances swap between a copy and its original.
            for (const Mat3& turn : turns)
            {
                Start start{m, {}};
                start.pose.rotation = part.axes * turn * from.axes.transpose();
                start.pose.scale = part.radius / from.radius;
                start.pose.translation =
                    part.centre - start.pose.scale * (start.pose.rotation * from.centre);
                refine(eighth, from.radius, tree, asset_normals, 0, options.kept, options.to_plane,
                       false, 0.0, start.pose, bound);
                starts.push_back(start);
            }
        }
    }
    const auto by_error = [](const Start& a, const Start& b)
    { return a.pose.error < b.pose.error; };
    const std::size_t coarse =
        std::min<std::size_t>(starts.size(), static_cast<std::size_t>(options.coarse_poses));
    std::partial_sort(starts.begin(), starts.begin() + static_cast<std::ptrdiff_t>(coarse),
                      starts.end(), by_error);
    starts.resize(coarse);
    for (Start& start : starts)
    {
        const Eigen::MatrixX3d& source = sources[static_cast<std::size_t>(start.source)];
        refine(source(Eigen::seq(0, source.rows() - 1, options.coarse_stride), Eigen::all),
               own.radius, tree, asset_normals, options.coarse_rounds, options.kept,
               options.to_plane, false, options.settled, start.pose);
    }
    std::sort(starts.begin(), starts.end(), by_error);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < starts.size() && k < static_cast<std::size_t>(options.fine_poses);
         ++k)
    {
        Pose pose = starts[k].pose;
        const Eigen::MatrixX3d& source = sources[static_cast<std::size_t>(starts[k].source)];
        refine(source(Eigen::seq(0, source.rows() - 1, options.fine_stride), Eigen::all),
               own.radius, tree, asset_normals, options.fine_rounds, options.kept, options.to_plane,
               options.across, options.settled, pose);
        if (pose.error < best)
        {
            best = pose.error;
            if (pose_out != nullptr)
            {
                *pose_out = {starts[k].source == 1, pose.scale, pose.rotation, pose.translation};
            }
        }
    }
    return best;
}

}  // namespace meshmark
