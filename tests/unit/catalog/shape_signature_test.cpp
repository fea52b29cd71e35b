// SPDX-License-Identifier: MIT
#include "meshmark/geometry/shape_signature.h"

#include <array>
#include <limits>
#include <span>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/error.h"
#include "meshmark/core/hash.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/registration/shape_fit.h"

namespace meshmark
{
namespace
{

float nearest_view(const ShapeSignature& signature, const ShapeFeatures& features)
{
    float best = 1e9F;
    for (const ShapeFeatures& view : signature.views)
    {
        best = std::min(best, shape_distance(features, view));
    }
    return best;
}

// The crop view (1 to kShapeViews - 1) of \p signature nearest \p features.
int nearest_crop_view(const ShapeSignature& signature, const ShapeFeatures& features)
{
    int nearest = 1;
    for (int v = 2; v < kShapeViews; ++v)
    {
        if (shape_distance(features, signature.views[static_cast<std::size_t>(v)]) <
            shape_distance(features, signature.views[static_cast<std::size_t>(nearest)]))
        {
            nearest = v;
        }
    }
    return nearest;
}

TriangleMesh moved(TriangleMesh mesh, double scale, bool mirror)
{
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
    Eigen::Matrix3d linear = scale * rotation;
    if (mirror)
    {
        linear.col(0) *= -1.0;
    }
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        mesh.V.row(i) =
            (linear * mesh.V.row(i).transpose() + Eigen::Vector3d(5.0, -2.0, 1.0)).transpose();
    }
    return mesh;
}

TEST(ShapeSignatureTest, a_moved_scaled_mirrored_renumbered_copy_has_the_same_features)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const ShapeFeatures original = shape_features(mesh);
    TriangleMesh copy = moved(mesh, 3.5, true);
    // Faces in reverse order, each face's corners rotated: the draw does not depend on the file.
    copy.F = copy.F.colwise().reverse().eval();
    for (Eigen::Index f = 0; f < copy.F.rows(); ++f)
    {
        copy.F.row(f) = Eigen::RowVector3i(copy.F(f, 1), copy.F(f, 2), copy.F(f, 0));
    }
    EXPECT_LT(shape_distance(original, shape_features(copy)), 1e-3F);
    // Another shape is far.
    EXPECT_GT(shape_distance(original, shape_features(torus(1.0, 0.3, 48, 24))), 0.05F);
}

TEST(ShapeSignatureTest, an_original_lists_its_whole_and_crop_views_and_round_trips_through_bytes)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const ShapeSignature signature = shape_signature(mesh);
    ASSERT_EQ(signature.views.size(), static_cast<std::size_t>(kShapeViews));
    EXPECT_EQ(shape_distance(signature.views[0], shape_features(mesh)), 0.0F);
    const std::vector<std::uint8_t> bytes = signature.to_bytes();
    EXPECT_EQ(bytes.size(),
              static_cast<std::size_t>(kShapeViews * kShapeFeatures) + kShapePointBytes);
    const ShapeSignature back = ShapeSignature::from_bytes(bytes);
    ASSERT_EQ(back.views.size(), signature.views.size());
    for (std::size_t v = 0; v < back.views.size(); ++v)
    {
        EXPECT_LE(shape_distance(back.views[v], signature.views[v]), 0.01F);
    }
    // The points within 1/65,535 of their box, the normals within 1/127 and of unit length.
    ASSERT_EQ(signature.points.rows(), kShapePoints);
    ASSERT_EQ(back.points.rows(), kShapePoints);
    const double box =
        (signature.points.colwise().maxCoeff() - signature.points.colwise().minCoeff()).maxCoeff();
    EXPECT_LE((back.points - signature.points).cwiseAbs().maxCoeff(), 1e-4 * box);
    EXPECT_LE((back.normals - signature.normals).cwiseAbs().maxCoeff(), 0.02);
    EXPECT_NEAR(back.normals.rowwise().norm().minCoeff(), 1.0, 1e-9);
    // A signature stored before the points were kept: the views alone.
    const std::vector<std::uint8_t> views_only(bytes.begin(),
                                               bytes.begin() + kShapeViews * kShapeFeatures);
    EXPECT_EQ(ShapeSignature::from_bytes(views_only).points.rows(), 0);
    EXPECT_THROW((void)ShapeSignature::from_bytes(std::vector<std::uint8_t>(7)), Error);
}

TEST(ShapeSignatureTest, a_cropped_copy_is_near_one_of_the_crop_views_and_nearer_than_to_the_whole)
{
    const TriangleMesh mesh = lumpy_ellipsoid(5);
    const ShapeSignature signature = shape_signature(mesh);
    const TriangleMesh half =
        apply_attacks(mesh, parse_attack_spec("crop=0.5,similarity"), 3, 1).mesh;
    const ShapeFeatures features = shape_features(half);
    EXPECT_LT(nearest_view(signature, features),
              0.5F * shape_distance(features, signature.views[0]));
}

TEST(ShapeSignatureTest, empty_and_degenerate_meshes_give_zero_features)
{
    EXPECT_EQ(shape_features(TriangleMesh{}), ShapeFeatures{});
    TriangleMesh flat_point;
    flat_point.V = Positions::Zero(10, 3);
    EXPECT_EQ(shape_features(flat_point), ShapeFeatures{});
}

// A catalogue holds the signatures of the build that added its assets, and a later build
// computes the suspects' features: the same mesh must give the same bytes. The hash is of the
// positions' features of every view, as the signature code of 2026-11-29 wrote them (before
// the normals' features were added after them): a change of those features, draws or bins
// changes it, and catalogues of older builds would then be ranked wrong.
TEST(ShapeSignatureTest, the_positions_features_of_a_fixed_mesh_are_those_older_catalogues_hold)
{
    std::vector<std::uint8_t> bytes = shape_signature(lumpy_ellipsoid(3)).to_bytes();
    ASSERT_EQ(bytes.size(),
              static_cast<std::size_t>(kShapeViews * kShapeFeatures) + kShapePointBytes);
    bytes.resize(static_cast<std::size_t>(kShapeViews * kShapeFeatures));  // the views
    std::vector<std::uint8_t> positions;
    for (std::size_t at = 0; at < bytes.size(); at += kShapeFeatures)
    {
        positions.insert(positions.end(), bytes.begin() + static_cast<std::ptrdiff_t>(at),
                         bytes.begin() + static_cast<std::ptrdiff_t>(at + kShapePositionFeatures));
    }
    EXPECT_EQ(hash_bytes(positions.data(), positions.size()), 0x37136d98ea3969a1ULL);
}

// Every bit of a signature, not only its stored bytes: the views' floats, the points and normals
// as doubles, and a suspect's features (views[0]). Pinned with the code before the speed-ups of
// 2026-12 (sort once, exact selection, counts by level codes), which had to leave every bit as
// it was; a surface, a torus (many triangles alike, so the order of ties counts) and a point
// cloud (the vertices drawn).
std::uint64_t signature_bits(const TriangleMesh& mesh)
{
    const ShapeSignature s = shape_signature(mesh);
    const ShapeFeatures whole = shape_features(mesh);
    Hasher hasher(s.views.size() * sizeof(ShapeFeatures) +
                  sizeof(double) * static_cast<std::size_t>(s.points.size() + s.normals.size()) +
                  sizeof whole);
    hasher.update(s.views.data(), s.views.size() * sizeof(ShapeFeatures));
    hasher.update(s.points.data(), sizeof(double) * static_cast<std::size_t>(s.points.size()));
    hasher.update(s.normals.data(), sizeof(double) * static_cast<std::size_t>(s.normals.size()));
    hasher.update(whole.data(), sizeof whole);
    return hasher.value();
}

TEST(ShapeSignatureTest, every_bit_of_the_signatures_of_fixed_meshes_is_as_pinned)
{
    TriangleMesh cloud = lumpy_ellipsoid(3);
    cloud.F.resize(0, 3);
    EXPECT_EQ(signature_bits(lumpy_ellipsoid(4)), 0x89e1cade3da7219eULL);
    EXPECT_EQ(signature_bits(torus(1.0, 0.3, 48, 24)), 0xcc8ad5a7b8aa636dULL);
    EXPECT_EQ(signature_bits(cloud), 0xd8a0ae775a94c9e5ULL);
}

// shape_fit: a resampled, moved and mirrored copy fits its own surface closer than a
// stretched variant of it, and a half of it fits from the crop view nearest its features.
TEST(ShapeFitTest, a_resampled_mirrored_copy_fits_its_surface_better_than_a_stretched_variant)
{
    const TriangleMesh asset = lumpy_ellipsoid(4);
    TriangleMesh variant = asset;
    variant.V.col(0) *= 1.15;
    TriangleMesh copy = apply_attacks(asset, parse_attack_spec("remesh=0.8,similarity"), 3, 1).mesh;
    copy.V.col(1) *= -1.0;  // a mirror image
    const Positions points = shape_sample(copy, kShapePoints);
    const auto fit = [&](const TriangleMesh& onto, std::span<const int> views)
    {
        const ShapeSignature s = shape_signature(onto);
        const PointKdTree tree(s.points);
        return shape_fit(points, s.points, s.normals, tree, views);
    };
    const double own = fit(asset, {});
    EXPECT_LT(own, 0.02);
    EXPECT_LT(1.5 * own, fit(variant, {}));

    const TriangleMesh half =
        apply_attacks(asset, parse_attack_spec("crop=0.5,similarity"), 5, 1).mesh;
    const Positions half_points = shape_sample(half, kShapePoints);
    const ShapeSignature s = shape_signature(asset);
    const PointKdTree tree(s.points);
    const ShapeFeatures features = shape_features(half);
    const std::array<int, 1> views{nearest_crop_view(s, features)};
    const double half_fit = shape_fit(half_points, s.points, s.normals, tree, views);
    EXPECT_LT(half_fit, 0.1);
    // onto another surface (a torus of the same size), from its nearest view too
    const ShapeSignature other = shape_signature(torus(1.0, 0.4, 48, 24));
    const PointKdTree other_tree(other.points);
    const std::array<int, 1> other_views{nearest_crop_view(other, features)};
    EXPECT_LT(1.5 * half_fit,
              shape_fit(half_points, other.points, other.normals, other_tree, other_views));
    // Too few points to fit: no fit.
    EXPECT_EQ(shape_fit(half_points.topRows(4), s.points, s.normals, tree, views),
              std::numeric_limits<double>::infinity());
}

}  // namespace
}  // namespace meshmark
