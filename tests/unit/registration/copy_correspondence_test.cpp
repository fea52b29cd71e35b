// SPDX-License-Identifier: MIT
// The algorithms detection uses to put a copy in the original's vertex order or pose, each on
// its own: the renumberings (renumbering.h), the vertices matched after registration
// (vertex_matching.h), the self-symmetries (self_symmetry.h) and the unposing of an animated
// original's copy (animation_pose.h).
#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/registration/animation_pose.h"
#include "meshmark/registration/renumbering.h"
#include "meshmark/registration/self_symmetry.h"
#include "meshmark/registration/vertex_matching.h"

namespace meshmark
{
namespace
{

// \p mesh with its vertices numbered by \p order (new vertex k is old vertex order[k]) and its
// triangles kept in their order.
TriangleMesh renumbered(const TriangleMesh& mesh, const std::vector<std::int32_t>& order)
{
    std::vector<std::int32_t> new_of(order.size());
    for (std::size_t k = 0; k < order.size(); ++k)
    {
        new_of[static_cast<std::size_t>(order[k])] = static_cast<std::int32_t>(k);
    }
    TriangleMesh out;
    out.V.resize(mesh.V.rows(), 3);
    for (std::size_t k = 0; k < order.size(); ++k)
    {
        out.V.row(static_cast<Eigen::Index>(k)) = mesh.V.row(order[k]);
    }
    out.F = mesh.F;
    for (Eigen::Index f = 0; f < out.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            out.F(f, c) = new_of[static_cast<std::size_t>(mesh.F(f, c))];
        }
    }
    return out;
}

std::vector<std::int32_t> shuffled(Eigen::Index n, unsigned seed)
{
    std::vector<std::int32_t> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(seed));
    return order;
}

// A small smooth displacement, like a mark's (well below the vertex spacing).
Positions nudged(const Positions& V, double amplitude)
{
    Positions out = V;
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        out(i, 0) += amplitude * std::sin(3.0 * V(i, 1));
        out(i, 1) += amplitude * std::cos(2.0 * V(i, 2));
    }
    return out;
}

TEST(RenumberingTest, a_copy_renumbered_with_its_triangles_in_order_is_put_back_by_its_triangles)
{
    const TriangleMesh original = lumpy_ellipsoid(3);
    TriangleMesh copy = renumbered(original, shuffled(original.V.rows(), 1));
    copy.V = nudged(copy.V, 0.2);  // however far the vertices moved
    const std::optional<Positions> in_order = renumbered_by_triangles(original, copy);
    ASSERT_TRUE(in_order.has_value());
    EXPECT_TRUE(in_order->isApprox(nudged(original.V, 0.2), 1e-12));
    // Triangles in another order: not this situation.
    TriangleMesh turned = copy;
    turned.F.row(0).swap(turned.F.row(1));
    EXPECT_FALSE(renumbered_by_triangles(original, turned).has_value());
}

// Meshes one after the other in one mesh, each moved by its offset.
TriangleMesh joined(const std::vector<TriangleMesh>& parts,
                    const std::vector<Eigen::RowVector3d>& offsets)
{
    TriangleMesh out;
    Eigen::Index v = 0;
    Eigen::Index f = 0;
    for (const TriangleMesh& part : parts)
    {
        v += part.V.rows();
        f += part.F.rows();
    }
    out.V.resize(v, 3);
    out.F.resize(f, 3);
    v = 0;
    f = 0;
    for (std::size_t k = 0; k < parts.size(); ++k)
    {
        out.V.middleRows(v, parts[k].V.rows()) = parts[k].V.rowwise() + offsets[k];
        out.F.middleRows(f, parts[k].F.rows()) = parts[k].F.array() + static_cast<std::int32_t>(v);
        v += parts[k].V.rows();
        f += parts[k].F.rows();
    }
    return out;
}

// \p mesh numbered as a writer that goes through its triangles numbers it: vertices in the order
// the triangles first use them (those no triangle uses dropped).
TriangleMesh numbered_as_written(const TriangleMesh& mesh)
{
    std::vector<std::int32_t> new_of(static_cast<std::size_t>(mesh.V.rows()), -1);
    std::vector<std::int32_t> order;
    TriangleMesh out;
    out.F = mesh.F;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            auto& n = new_of[static_cast<std::size_t>(mesh.F(f, c))];
            if (n < 0)
            {
                n = static_cast<std::int32_t>(order.size());
                order.push_back(mesh.F(f, c));
            }
            out.F(f, c) = n;
        }
    }
    out.V.resize(static_cast<Eigen::Index>(order.size()), 3);
    for (std::size_t k = 0; k < order.size(); ++k)
    {
        out.V.row(static_cast<Eigen::Index>(k)) = mesh.V.row(order[k]);
    }
    return out;
}

TEST(RenumberingTest, a_copy_of_the_original_parts_in_another_order_is_put_back_part_by_part)
{
    // Four alike wheels, a body and a handle: parts of their own place the copy, the wheels go
    // to the nearest wheel after that.
    const TriangleMesh wheel = torus(1.0, 0.3, 12, 8);
    const TriangleMesh body = lumpy_ellipsoid(3);
    const TriangleMesh handle = icosphere(2);
    const std::vector<Eigen::RowVector3d> at = {{0, 0, 0},  {-3, -3, 0}, {3, -3, 0},
                                                {-3, 3, 0}, {3, 3, 0},   {0, 0, 4}};
    const TriangleMesh original = joined({body, wheel, wheel, wheel, wheel, handle}, at);
    // Joined in another order (the wheels too), numbered as written, moved and smoothed
    // (here: nudged far beyond any mark), and a fifth wheel that is no part of the original.
    const std::vector<int> order = {5, 3, 0, 1, 4, 2};
    std::vector<TriangleMesh> shuffled_parts;
    std::vector<Eigen::RowVector3d> shuffled_at;
    const std::vector<TriangleMesh> parts = {body, wheel, wheel, wheel, wheel, handle};
    for (const int k : order)
    {
        shuffled_parts.push_back(parts[static_cast<std::size_t>(k)]);
        shuffled_at.push_back(at[static_cast<std::size_t>(k)]);
    }
    shuffled_parts.push_back(wheel);
    shuffled_at.emplace_back(9, 9, 9);
    TriangleMesh copy = numbered_as_written(joined(shuffled_parts, shuffled_at));
    copy.V = nudged(copy.V, 0.05);
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    copy.V = (2.0 * copy.V * turn.transpose()).rowwise() + Eigen::RowVector3d(5, -1, 2);

    const std::optional<TriangleRenumbering> found = renumbered_by_parts(original, copy);
    ASSERT_TRUE(found.has_value());
    EXPECT_EQ(found->unreached, 0U);
    EXPECT_TRUE(found->reached.empty());
    Positions expected = nudged(original.V, 0.05);
    expected = (2.0 * expected * turn.transpose()).rowwise() + Eigen::RowVector3d(5, -1, 2);
    EXPECT_TRUE(found->in_order.isApprox(expected, 1e-12));

    // A wheel gone (the handle too small to matter): its vertices are left out, the rest read.
    std::vector<TriangleMesh> fewer = {handle, body, wheel, wheel, wheel};
    const TriangleMesh cut =
        numbered_as_written(joined(fewer, {at[5], at[0], at[1], at[2], at[4]}));
    const std::optional<TriangleRenumbering> partly = renumbered_by_parts(original, cut);
    ASSERT_TRUE(partly.has_value());
    EXPECT_EQ(partly->unreached, static_cast<std::size_t>(wheel.V.rows()));
    const Eigen::Index wheel3 = body.V.rows() + 2 * wheel.V.rows();  // the wheel at (-3, 3)
    EXPECT_EQ(partly->reached[static_cast<std::size_t>(wheel3)], 0);
    EXPECT_EQ(partly->reached[0], 1);
    EXPECT_TRUE(partly->in_order.row(0).isApprox(original.V.row(0), 1e-12));

    // The body's triangles in another order: most of the original is no part of the copy.
    TriangleMesh turned = copy;
    const Eigen::Index body_start = handle.F.rows() + wheel.F.rows();
    turned.F.row(body_start).swap(turned.F.row(body_start + 1));
    EXPECT_FALSE(renumbered_by_parts(original, turned).has_value());
}

TEST(RenumberingTest, a_copy_renumbered_where_it_stands_is_put_back_by_its_positions)
{
    const TriangleMesh original = lumpy_ellipsoid(3);
    const double tolerance = 0.006 * bounding_box(original.V).diagonal();
    TriangleMesh copy = original;
    copy.V = nudged(original.V, 0.0005);
    const std::vector<std::int32_t> order = shuffled(original.V.rows(), 2);
    TriangleMesh suspect = renumbered(copy, order);
    // Its triangles in another order too (a Draco traversal).
    suspect.F = suspect.F.colwise().reverse().eval();
    const std::optional<Positions> in_order = renumbered_in_place(original, suspect, tolerance, 1);
    ASSERT_TRUE(in_order.has_value());
    EXPECT_TRUE(in_order->isApprox(copy.V, 1e-12));
    // Moved elsewhere: not where it stands.
    suspect.V.col(0).array() += 1.0;
    EXPECT_FALSE(renumbered_in_place(original, suspect, tolerance, 1).has_value());
}

TEST(VertexMatchingTest, a_registered_reordered_copy_is_read_in_the_original_order)
{
    const TriangleMesh original = lumpy_ellipsoid(3);
    const double diagonal = bounding_box(original.V).diagonal();
    const double amplitude = 0.00059 * diagonal;
    TriangleMesh copy = original;
    copy.V = nudged(original.V, 0.2 * amplitude);
    const TriangleMesh suspect = renumbered(copy, shuffled(original.V.rows(), 3));
    const std::optional<VerticesInPlace> kept = vertices_in_place(
        original, suspect, Eigen::Matrix4d::Identity(), amplitude, 10.0 * amplitude, 2);
    ASSERT_TRUE(kept.has_value());
    EXPECT_EQ(kept->matched, static_cast<std::size_t>(original.V.rows()));
    EXPECT_TRUE(kept->in_order.isApprox(copy.V, 1e-12));
    const VertexMatching pairs = match_vertices(original.V, suspect.V, 10.0 * amplitude, 1);
    EXPECT_LT(pairs.ambiguity, 0.4);
    // With vertices added between them (the next subdivision of the same sphere keeps its
    // vertices): still the original's vertices.
    EXPECT_TRUE(vertices_in_place(original, lumpy_ellipsoid(4), Eigen::Matrix4d::Identity(),
                                  amplitude, 10.0 * amplitude, 2)
                    .has_value());
    // Left 50 amplitudes away (a pose the registration did not find): no vertex within reach.
    Eigen::Matrix4d away = Eigen::Matrix4d::Identity();
    away(0, 3) = 50.0 * amplitude;
    EXPECT_FALSE(
        vertices_in_place(original, suspect, away, amplitude, 10.0 * amplitude, 2).has_value());
}

TEST(SelfSymmetryTest, a_torus_has_symmetries_and_a_lumpy_ellipsoid_none)
{
    const TriangleMesh ring = torus(1.0, 0.3, 48, 16);
    const double diagonal = bounding_box(ring.V).diagonal();
    const std::vector<Eigen::Matrix4d> found = self_symmetries(ring, 0.00059 * diagonal, 2);
    EXPECT_GE(found.size(), 3u);
    for (const Eigen::Matrix4d& S : found)
    {
        // Each maps the surface onto itself: its linear part is orthogonal.
        const Eigen::Matrix3d R = S.topLeftCorner<3, 3>();
        EXPECT_TRUE((R * R.transpose()).isIdentity(1e-6));
        EXPECT_FALSE(same_pose(S, Eigen::Matrix4d::Identity(), Eigen::Vector3d::Zero(), diagonal));
    }
    const TriangleMesh lumpy = lumpy_ellipsoid(3);
    EXPECT_TRUE(self_symmetries(lumpy, 0.00059 * bounding_box(lumpy.V).diagonal(), 2).empty());
}

TEST(AnimationPoseTest, a_copy_in_a_frame_pose_is_taken_back_to_the_stored_frame)
{
    const TriangleMesh original = lumpy_ellipsoid(3);
    // Two frames: the stored pose turned by 30 degrees about z, and stretched along x.
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3d stretch = Eigen::Vector3d(1.6, 1.0, 1.0).asDiagonal();
    const auto posed = [&](const Eigen::Matrix3d& A, const char* name)
    {
        FramePose pose;
        pose.name = name;
        pose.V = original.V * A.transpose();
        pose.to_rest.assign(static_cast<std::size_t>(original.V.rows()), A.inverse());
        return pose;
    };
    AnimationFrames frames;
    frames.animation = {0, 0};
    frames.frame_one = 0;
    frames.pose = [&](const std::vector<std::size_t>& which,
                      const std::function<void(FramePose&&, std::size_t)>& visit)
    {
        for (const std::size_t k : which)
        {
            visit(k == 0 ? posed(turn, "turned") : posed(stretch, "stretched"), k);
        }
    };
    TriangleMesh copy = original;
    copy.V = original.V * stretch.transpose();
    const std::optional<AnimationPoseFit> fit = fit_animation_pose(original, copy, frames, 2);
    ASSERT_TRUE(fit.has_value());
    EXPECT_EQ(fit->pose.name, "stretched");
    const TriangleMesh back = unposed(original, copy, *fit);
    EXPECT_LT((back.V - original.V).cwiseAbs().maxCoeff(),
              1e-3 * bounding_box(original.V).diagonal());
}

}  // namespace
}  // namespace meshmark
