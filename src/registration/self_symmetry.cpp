// SPDX-License-Identifier: MIT
// The self-symmetries of an original (docs/algorithms/detection.md, "Other poses"): the
// rotations and mirror images that lay its surface on itself, tried by moments, then on a
// sample of its vertices, a plane's nearly symmetric mirror refitted by rigid point-to-plane
// steps. Distances on the original only, never a key.
#include "meshmark/registration/self_symmetry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <span>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/registration/point_to_plane.h"
#include "meshmark/registration/registration.h"

namespace meshmark
{
namespace
{

// A map counts as a symmetry when it lays the sample within this many mark amplitudes RMS of
// the original's surface: a copy registered in a pose that far off would still be read where
// the mark is (the mark is one amplitude), and an asymmetric shape lies tens of amplitudes off.
constexpr double kSymmetryTolerance = 2.0;
// Turns are tested vertex on vertex, tighter (mark amplitudes RMS, vertex to nearest vertex):
// a registration settles only where vertices land on vertices.
constexpr double kSymmetryOnVertices = 0.25;
// Orders of the turns tried about each axis (2 pi j / k), and the most poses read besides the
// registered one (the false-positive probability is multiplied by the poses read).
constexpr std::array<int, 10> kSymmetryOrders = {3, 5, 6, 8, 10, 12, 16, 20, 24, 32};
constexpr std::size_t kMaxSymmetries = 47;
// Moments a symmetry must keep, as a share of the RMS radius squared / cubed: far above the
// sampling error of kSymmetryMomentRows rows, far below what an asymmetric shape changes.
constexpr double kSymmetryMoments = 0.02;
// Vertices of the sample laid on the surface: enough for an RMS to 1/sqrt(2048) = 2%.
constexpr Eigen::Index kSymmetrySample = 2048;
// Vertices the moments are taken from: a large asymmetric original is turned away in
// milliseconds.
constexpr std::size_t kSymmetryMomentRows = 65536;
// A map this close to one already found (Frobenius norm of the difference, about 4 degrees) is
// the same symmetry seen from the other frame: the registration from either pose lands in the
// same place, so it is not read (nor paid for) twice.
constexpr double kSameSymmetry = 0.1;

// The 24 orthogonal maps of determinant \p sign (+1: rotations, -1: mirror images) that map
// the coordinate axes onto signed coordinate axes.
std::vector<Eigen::Matrix3d> signed_axis_maps(double sign)
{
    std::vector<Eigen::Matrix3d> out;
    std::array<int, 3> order = {0, 1, 2};
    do
    {
        for (int signs = 0; signs < 8; ++signs)
        {
            Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
            for (int row = 0; row < 3; ++row)
            {
                R(row, order[static_cast<std::size_t>(row)]) = (signs >> row & 1) != 0 ? -1.0 : 1.0;
            }
            if (R.determinant() * sign > 0.0)
            {
                out.push_back(R);
            }
        }
    } while (std::next_permutation(order.begin(), order.end()));
    return out;
}

// A mirror image that lays most of the original on its own surface but not all of it: a
// character or vehicle modelled with a Mirror modifier and then given a part on one side only
// (Blender's creature of "Two more game-like assets": 98% of its vertices within 2 mark
// amplitudes of their mirror image, RMS 14 amplitudes for the part left). That part also moves
// the centroid and tilts the principal frame, so the mirror \p R about the centroid is refitted:
// rounds of a rigid point-to-plane step (rigid_step) of the mirrored \p sample onto its
// closest points on the original, on the kNearMirrorShare of pairs nearest, while the
// farthest of those pairs shrinks each round to less than kNearMirrorStall of the last (an
// asymmetric shape stalls at once: fertility 11.5 -> 10.7 amplitudes, and the search
// stops) and is not yet settled (within kNearMirrorSettled of the tolerance: a twin pose that
// close matches vertices as the exact one would), for at most kNearMirrorRounds. The refitted
// map counts when that share of the sample then lies within kSymmetryTolerance amplitudes of
// the surface (the creature from 1.9 to 0.03 in one round, Blender's vehicle from 7.1 to 0.04
// in two, the boxy walker of the held-out assets from 24.6 to 0.22 in six). Point to point
// (Umeyama), as first written, slides along flat parts a little each round: the vehicle took
// ten rounds, and the walker stalled at 6.3 (its rounds shrank the farthest pair by 8%) and
// was not found. \p sample is centred on \p centroid.
constexpr double kNearMirrorShare =
    0.9;  // the one-sided part (2% of the creature) left out of the fit
constexpr double kNearMirrorStall = 0.9;  // an asymmetric shape shrinks less than 10% per round
constexpr double kNearMirrorSettled =
    0.25;  // of kSymmetryTolerance: matches vertices as the exact mirror
constexpr int kNearMirrorRounds = 12;  // the walker took six rounds, twice that bounds the cost

// The map x -> R (x - centroid) + centroid of the original's frame, as a 4x4 transform.
Eigen::Matrix4d about_centroid(const Eigen::Matrix3d& R, const Eigen::RowVector3d& centroid)
{
    Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
    S.topLeftCorner<3, 3>() = R;
    S.topRightCorner<3, 1>() = centroid.transpose() - R * centroid.transpose();
    return S;
}

// One Gauss-Newton step of the rigid map that lays the rows of \p moved listed in \p kept onto
// the planes of their closest triangles of the original (\p closest, by row of \p moved), as
// the registration's fine stage steps without its scale (point_to_plane_step), as a 4x4
// transform. Nullopt when the step is not finite.
std::optional<Eigen::Matrix4d> rigid_step(const Positions& moved,
                                          const std::vector<SurfaceMatch>& closest,
                                          std::span<const Eigen::Index> kept)
{
    const std::optional<PointToPlaneStep<6>> update = point_to_plane_step<6>(moved, closest, kept);
    if (!update)
    {
        return std::nullopt;
    }
    const Eigen::Vector3d omega = update->delta.head<3>() / update->radius;
    const double angle = omega.norm();
    const Eigen::Matrix3d dR = angle > 0.0
                                   ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                                   : Eigen::Matrix3d::Identity();
    // y' = c + dR (y - c) + tau
    const Eigen::Vector3d& c = update->centre;
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    step.topLeftCorner<3, 3>() = dR;
    step.topRightCorner<3, 1>() = c - dR * c + update->delta.tail<3>();
    return step;
}

// \p moved and \p closest: the sample mirrored by \p R and its closest points, as the surface
// test found them (the first round's).
std::optional<Eigen::Matrix4d> near_mirror(const SurfaceMatcher& surface, const Positions& sample,
                                           const Eigen::RowVector3d& centroid,
                                           const Eigen::Matrix3d& R, Positions moved,
                                           std::vector<SurfaceMatch> closest, double amplitude,
                                           int threads)
{
    Eigen::Matrix4d S = about_centroid(R, centroid);  // original -> original
    const Positions points = sample.rowwise() + centroid;
    const auto kept_count =
        static_cast<Eigen::Index>(kNearMirrorShare * static_cast<double>(points.rows()));
    if (kept_count < 6)
    {
        return std::nullopt;
    }
    const double tolerance = kSymmetryTolerance * amplitude;
    std::vector<Eigen::Index> order(static_cast<std::size_t>(points.rows()));
    double previous = std::numeric_limits<double>::infinity();
    for (int round = 0;; ++round)
    {
        if (round > 0)
        {
            moved = transform_points(S, points);
            surface.match_all(moved, closest, threads);
        }
        std::iota(order.begin(), order.end(), Eigen::Index{0});
        const auto kth = order.begin() + kept_count - 1;
        std::nth_element(order.begin(), kth, order.end(),
                         [&](Eigen::Index a, Eigen::Index b)
                         {
                             return closest[static_cast<std::size_t>(a)].distance <
                                    closest[static_cast<std::size_t>(b)].distance;
                         });
        const double farthest = closest[static_cast<std::size_t>(*kth)].distance;
        if (farthest <= kNearMirrorSettled * tolerance || farthest > kNearMirrorStall * previous ||
            round == kNearMirrorRounds)
        {
            return farthest <= tolerance ? std::optional<Eigen::Matrix4d>(S) : std::nullopt;
        }
        previous = farthest;
        const std::optional<Eigen::Matrix4d> step = rigid_step(
            moved, closest,
            std::span<const Eigen::Index>(order.data(), static_cast<std::size_t>(kept_count)));
        if (!step)
        {
            return std::nullopt;
        }
        S = *step * S;
    }
}

}  // namespace

std::vector<Eigen::Matrix4d> self_symmetries(const TriangleMesh& original, double amplitude,
                                             int threads, const SurfaceMatcher* given_surface)
{
    std::vector<Eigen::Matrix4d> found;
    if (original.is_point_cloud() || original.V.rows() < 4)
    {
        return found;
    }
    // The moments from at most kSymmetryMomentRows evenly spaced vertices (their sampling error,
    // about 1/sqrt(rows) of the radius' powers, stays well inside kSymmetryMoments): a large
    // asymmetric original is turned away in a few milliseconds.
    const std::vector<std::int32_t> rows = referenced_vertices(original);
    const auto stride = std::max<std::size_t>(1, rows.size() / kSymmetryMomentRows);
    const auto n = static_cast<Eigen::Index>((rows.size() + stride - 1) / stride);
    Eigen::MatrixX3d X(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        X.row(i) = original.V.row(rows[static_cast<std::size_t>(i) * stride]);
    }
    const Eigen::RowVector3d centroid = X.colwise().mean();
    X.rowwise() -= centroid;
    const Eigen::Matrix3d C = X.transpose() * X / static_cast<double>(n);
    const double radius = std::sqrt(C.trace());
    if (!(radius > 0.0))
    {
        return found;
    }
    std::array<double, 27> third{};
    for (Eigen::Index i = 0; i < n; ++i)
    {
        for (int a = 0; a < 3; ++a)
        {
            for (int b = 0; b < 3; ++b)
            {
                for (int c = 0; c < 3; ++c)
                {
                    third[static_cast<std::size_t>(9 * a + 3 * b + c)] +=
                        X(i, a) * X(i, b) * X(i, c);
                }
            }
        }
    }
    for (double& t : third)
    {
        t /= static_cast<double>(n);
    }
    const auto keeps_moments = [&](const Eigen::Matrix3d& R)
    {
        if ((R * C * R.transpose() - C).norm() > kSymmetryMoments * radius * radius)
        {
            return false;
        }
        double difference = 0.0;
        for (int a = 0; a < 3; ++a)
        {
            for (int b = 0; b < 3; ++b)
            {
                for (int c = 0; c < 3; ++c)
                {
                    double rotated = 0.0;  // (R . R . R third)_abc
                    for (int i = 0; i < 3; ++i)
                    {
                        for (int j = 0; j < 3; ++j)
                        {
                            for (int k = 0; k < 3; ++k)
                            {
                                rotated += R(a, i) * R(b, j) * R(c, k) *
                                           third[static_cast<std::size_t>(9 * i + 3 * j + k)];
                            }
                        }
                    }
                    const double d = rotated - third[static_cast<std::size_t>(9 * a + 3 * b + c)];
                    difference += d * d;
                }
            }
        }
        return std::sqrt(difference) <= kSymmetryMoments * radius * radius * radius;
    };
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> principal(C);
    Eigen::Matrix3d P = principal.eigenvectors();
    if (P.determinant() < 0.0)
    {
        P.col(0) = -P.col(0);
    }
    // The coordinate-axis rotations (tested against the surface), and the turns by 2 pi j / k
    // about each axis (tested vertex on vertex: a surface of revolution fits its own surface at
    // any angle, but a registration settles only where its vertices land on vertices, as a UV
    // sphere's 12 meridians do every 30 degrees).
    struct Candidate
    {
        Eigen::Matrix3d R;
        bool on_vertices = false;
    };
    std::vector<Candidate> candidates;  // rotations, then mirror images
    const auto add = [&](const Eigen::Matrix3d& R, bool on_vertices)
    {
        const bool is_new = !R.isIdentity(1e-9) &&
                            std::none_of(candidates.begin(), candidates.end(),
                                         [&](const auto& Q) { return (Q.R - R).norm() < 1e-6; });
        if (is_new && keeps_moments(R))
        {
            candidates.push_back({R, on_vertices});
        }
    };
    for (const Eigen::Matrix3d& frame : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), P})
    {
        for (const Eigen::Matrix3d& A : signed_axis_maps(1.0))
        {
            add(frame * A * frame.transpose(), false);
        }
    }
    for (const Eigen::Matrix3d& frame : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), P})
    {
        for (int axis = 0; axis < 3; ++axis)
        {
            for (const int k : kSymmetryOrders)
            {
                for (int j = 1; j < k; ++j)
                {
                    const double angle =
                        2.0 * std::numbers::pi * static_cast<double>(j) / static_cast<double>(k);
                    add(Eigen::AngleAxisd(angle, frame.col(axis)).toRotationMatrix(), true);
                }
            }
        }
    }
    // Last the mirror images (a plane of symmetry, as most animals, vehicles and teapots have):
    // after the rotations, so a shape with many of those keeps them within kMaxSymmetries.
    for (const Eigen::Matrix3d& frame : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), P})
    {
        for (const Eigen::Matrix3d& A : signed_axis_maps(-1.0))
        {
            add(frame * A * frame.transpose(), false);
        }
    }
    if (candidates.empty())
    {
        return found;
    }
    // The original's surface: the registration's own when it kept it (no second structure over
    // the original: on the generated 1M-vertex mesh, whose mirror maps keep its moments, a
    // bounding-volume hierarchy of its 2M triangles took 0.18 s of a 3 s detection).
    std::unique_ptr<SurfaceMatcher> built;
    if (given_surface == nullptr)
    {
        built = std::make_unique<SurfaceMatcher>(original);
    }
    const SurfaceMatcher& surface = given_surface != nullptr ? *given_surface : *built;
    std::optional<PointKdTree> vertices;
    const Eigen::Index step = std::max<Eigen::Index>(1, n / kSymmetrySample);
    Positions sample((n + step - 1) / step, 3);
    for (Eigen::Index i = 0; i < sample.rows(); ++i)
    {
        sample.row(i) = X.row(i * step);
    }
    for (const auto& [R, on_vertices] : candidates)
    {
        if (found.size() >= kMaxSymmetries)
        {
            break;
        }
        if (std::any_of(found.begin(), found.end(),
                        [&](const Eigen::Matrix4d& S)
                        { return (S.topLeftCorner<3, 3>() - R).norm() < kSameSymmetry; }))
        {
            continue;
        }
        Positions moved = (sample * R.transpose()).rowwise() + centroid;
        std::vector<SurfaceMatch> closest;  // on the surface (not on_vertices)
        double squares = 0.0;
        if (on_vertices)
        {
            if (!vertices)
            {
                Positions all(static_cast<Eigen::Index>(rows.size()), 3);
                for (std::size_t i = 0; i < rows.size(); ++i)
                {
                    all.row(static_cast<Eigen::Index>(i)) = original.V.row(rows[i]);
                }
                vertices.emplace(std::move(all));
            }
            for (Eigen::Index i = 0; i < moved.rows(); ++i)
            {
                double squared = 0.0;
                (void)vertices->nearest(moved.row(i).transpose(), squared);
                squares += squared;
            }
        }
        else
        {
            surface.match_all(moved, closest, threads);
            for (const SurfaceMatch& c : closest)
            {
                squares += c.distance * c.distance;
            }
        }
        const double tolerance = on_vertices ? kSymmetryOnVertices : kSymmetryTolerance;
        if (std::sqrt(squares / static_cast<double>(sample.rows())) <= tolerance * amplitude)
        {
            found.push_back(about_centroid(R, centroid));
        }
        else if (R.determinant() < 0.0 &&
                 std::abs(R.trace() - 1.0) < 1e-6)  // a plane's mirror image
        {
            if (const std::optional<Eigen::Matrix4d> S =
                    near_mirror(surface, sample, centroid, R, std::move(moved), std::move(closest),
                                amplitude, threads))
            {
                found.push_back(*S);
            }
        }
    }
    return found;
}

// Whether two suspect -> original maps are one pose found twice (a symmetry's twin pose that
// the registration's other handedness already is): within kSameSymmetry in their linear parts
// (over the scale) and in where they take the suspect's bounding-box centre \p centre (over the
// original's \p diagonal).
bool same_pose(const Eigen::Matrix4d& A, const Eigen::Matrix4d& B, const Eigen::Vector3d& centre,
               double diagonal)
{
    const double scale = std::cbrt(std::abs(A.topLeftCorner<3, 3>().determinant()));
    const Eigen::Vector4d c(centre.x(), centre.y(), centre.z(), 1.0);
    return (A.topLeftCorner<3, 3>() - B.topLeftCorner<3, 3>()).norm() <= kSameSymmetry * scale &&
           ((A - B) * c).norm() <= kSameSymmetry * diagonal;
}

}  // namespace meshmark
