// SPDX-License-Identifier: MIT
#include "meshmark/attacks/attack_spec.h"

#include <string>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

// The InvalidOption message of parsing \p text, or "" if it parses.
std::string parse_error(const std::string& text)
{
    try
    {
        (void)parse_attack_spec(text);
    }
    catch (const InvalidOption& e)
    {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(AttackSpecTest, parses_the_documented_example_into_typed_steps)
{
    const auto specs = parse_attack_spec("similarity,simplify=0.1,noise=0.001");
    ASSERT_EQ(specs.size(), 3U);
    EXPECT_TRUE(std::get<SimilarityOptions>(specs[0]).is_random);
    EXPECT_EQ(std::get<SimplificationOptions>(specs[1]).vertex_fraction, 0.1);
    EXPECT_EQ(std::get<NoiseOptions>(specs[2]).amplitude, 0.001);

    const auto keyed = parse_attack_spec(
        "noise=0.005:dist=gaussian:dir=normal:ref=centroid, smooth=30:lambda=0.2,"
        "taubin=5:lambda=0.4:mu=-0.45,quantize=8,simplify=0.02:policy=lt,remesh=0.05:iter=5,"
        "subdivide=sqrt3:steps=2,crop=0.7:axis=y,reorder,"
        "similarity:axis=x:angle=30:scale=2.5:tx=1:ty=-2:tz=0.5");
    ASSERT_EQ(keyed.size(), 10U);
    const auto& noise = std::get<NoiseOptions>(keyed[0]);
    EXPECT_EQ(noise.distribution, NoiseDistribution::Gaussian);
    EXPECT_EQ(noise.direction, NoiseDirection::Normal);
    EXPECT_EQ(noise.reference, NoiseReference::CentroidDistance);
    EXPECT_EQ(std::get<LaplacianSmoothingOptions>(keyed[1]).iterations, 30);
    EXPECT_EQ(std::get<LaplacianSmoothingOptions>(keyed[1]).lambda, 0.2);
    EXPECT_EQ(std::get<TaubinSmoothingOptions>(keyed[2]).mu, -0.45);
    EXPECT_EQ(std::get<QuantizationOptions>(keyed[3]).bits, 8);
    EXPECT_EQ(std::get<SimplificationOptions>(keyed[4]).policy,
              SimplificationPolicy::LindstromTurk);
    EXPECT_EQ(std::get<RemeshingOptions>(keyed[5]).iterations, 5);
    EXPECT_EQ(std::get<SubdivisionOptions>(keyed[6]).scheme, SubdivisionScheme::Sqrt3);
    EXPECT_EQ(std::get<SubdivisionOptions>(keyed[6]).steps, 2);
    EXPECT_EQ(*std::get<CropOptions>(keyed[7]).direction, Eigen::Vector3d::UnitY());
    EXPECT_TRUE(std::holds_alternative<ReorderOptions>(keyed[8]));
    const auto& similarity = std::get<SimilarityOptions>(keyed[9]);
    EXPECT_FALSE(similarity.is_random);
    EXPECT_EQ(similarity.axis, Eigen::Vector3d::UnitX());
    EXPECT_EQ(similarity.angle_deg, 30.0);
    EXPECT_EQ(similarity.scale, 2.5);
    EXPECT_EQ(similarity.translation, Eigen::Vector3d(1.0, -2.0, 0.5));
    for (std::size_t k = 0; k < keyed.size(); ++k)
    {
        EXPECT_EQ(parse_attack_spec(to_string(keyed[k])).front(), keyed[k]) << to_string(keyed[k]);
    }
}

TEST(AttackSpecTest, to_string_is_canonical_and_round_trips)
{
    EXPECT_EQ(to_string(parse_attack_spec("noise")), "noise=0.001");
    EXPECT_EQ(to_string(parse_attack_spec("simplify=0.10,noise=1e-3:dist=uniform")),
              "simplify=0.1,noise=0.001");
    EXPECT_EQ(to_string(parse_attack_spec("similarity:scale=1")), "similarity:scale=1");
    EXPECT_EQ(to_string(parse_attack_spec("similarity:mirror=y")), "similarity:mirror=y");
    EXPECT_EQ(to_string(parse_attack_spec("similarity:mirror=x:angle=90")),
              "similarity:angle=90:mirror=x");
    EXPECT_EQ(to_string(parse_attack_spec("crop=0.5:ax=1:ay=2:az=0")), "crop=0.5:ax=1:ay=2:az=0");
    EXPECT_EQ(to_string(parse_attack_spec("subdivide")), "subdivide=loop");
    EXPECT_EQ(to_string(parse_attack_spec("voxel")), "voxel=150");
    EXPECT_EQ(to_string(parse_attack_spec("voxel=3e2")), "voxel=300");
    EXPECT_EQ(std::get<VoxelRemeshingOptions>(parse_attack_spec("voxel=300").front()).resolution,
              300.0);

    // Awkward doubles and every alternative survive text and back bit for bit.
    const std::vector<AttackSpec> specs = {
        SimilarityOptions{.is_random = false,
                          .axis = {0.1 + 0.2, -1e-17, 3.0},
                          .angle_deg = 1.0 / 3.0,
                          .scale = 1e-300,
                          .translation = {-0.0, 5e-324, 1e300}},
        SimilarityOptions{.max_scale = 2.0 / 3.0 + 1.0, .max_translation_radii = 0.0},
        NoiseOptions{.amplitude = 0.1 + 0.7, .distribution = NoiseDistribution::Gaussian},
        LaplacianSmoothingOptions{.iterations = 0, .lambda = 1.0},
        TaubinSmoothingOptions{.iterations = 100000, .lambda = 0.1, .mu = -1.0},
        QuantizationOptions{.bits = 1},
        SimplificationOptions{.vertex_fraction = 1.0 / 7.0},
        RemeshingOptions{.vertex_fraction = 1.0, .iterations = 20},
        SubdivisionOptions{.scheme = SubdivisionScheme::Midpoint, .steps = 4},
        CropOptions{.vertex_fraction = 0.123456789, .direction = Eigen::Vector3d(0, 0, -1)},
        CropOptions{},
        ReorderOptions{},
        VoxelRemeshingOptions{.resolution = 1000.0 / 3.0},
    };
    const auto back = parse_attack_spec(to_string(specs));
    ASSERT_EQ(back.size(), specs.size());
    for (std::size_t k = 0; k < specs.size(); ++k)
    {
        EXPECT_EQ(back[k], specs[k]) << to_string(specs[k]);
    }
}

TEST(AttackSpecTest, bad_specs_throw_invalid_option_naming_the_problem)
{
    EXPECT_NE(parse_error("nosie=0.1").find("unknown attack 'nosie'"), std::string::npos);
    EXPECT_NE(parse_error("nosie=0.1").find("known attacks: similarity"), std::string::npos);
    EXPECT_NE(parse_error("noise=abc").find("'abc' is not a number"), std::string::npos);
    EXPECT_NE(parse_error("noise=0.1:foo=1").find("unknown key 'foo'"), std::string::npos);
    EXPECT_NE(parse_error("noise=0.1:foo=1").find("dist, dir, ref"), std::string::npos);
    EXPECT_NE(parse_error("noise=2").find("outside [0, 1]"), std::string::npos);
    EXPECT_NE(parse_error("simplify=0.1,noise=2").find("'noise=2'"), std::string::npos);
    EXPECT_NE(parse_error("voxel=5").find("resolution 5 is outside [10, 2000]"), std::string::npos);
    EXPECT_NE(parse_error("voxel=150:adapt=0").find("voxel, which takes no keys"),
              std::string::npos);
    for (const char* bad : {"",
                            " ",
                            ",",
                            "noise,,smooth",
                            "noise,",
                            "noise=",
                            "noise:dist",
                            "noise:=3",
                            "noise=-0.1",
                            "noise=nan",
                            "noise=0.1:dist=cauchy",
                            "noise=0.1:dir=up",
                            "noise=0.1:ref=radius",
                            "noise=0.1:dist=gaussian:dist=uniform",
                            "smooth=2.5",
                            "smooth=10:lambda=0",
                            "smooth=-1",
                            "taubin=10:mu=0.2",
                            "taubin=10:lambda=0.6",
                            "quantize=0",
                            "quantize=31",
                            "quantize=8:bits=9",
                            "simplify=0",
                            "simplify=1.5",
                            "simplify=0.5:policy=qem",
                            "remesh=0",
                            "remesh=1.5",
                            "remesh=0.25:iter=0",
                            "subdivide=butterfly",
                            "subdivide=loop:steps=0",
                            "crop=0",
                            "crop=1.5",
                            "crop=0.5:axis=w",
                            "crop=0.5:ax=0:ay=0:az=0",
                            "reorder=1",
                            "reorder:x=1",
                            "similarity=3",
                            "similarity:axis=w",
                            "similarity:axis=x:ax=1",
                            "similarity:angle=30:smax=2",
                            "similarity:scale=0",
                            "similarity:scale=-2",
                            "similarity:smax=0.5",
                            "similarity:mirror=w",
                            "similarity:mirror=x:smax=2",
                            "similarity:angle=ten",
                            "NOISE=0.1",
                            "voxel=9.99",
                            "voxel=2001",
                            "voxel=0",
                            "voxel=-150",
                            "voxel=inf",
                            "voxel=nan",
                            "voxel=1/150",
                            "voxel=150:adapt=0"})
    {
        EXPECT_THROW((void)parse_attack_spec(bad), InvalidOption) << "'" << bad << "'";
    }
}

TEST(AttackSpecTest, names_follow_the_grammar)
{
    const auto specs = parse_attack_spec(
        "similarity,noise,smooth,taubin,quantize,simplify,remesh,subdivide,crop,reorder,voxel");
    const std::vector<std::string> names = {"similarity", "noise",    "smooth", "taubin",
                                            "quantize",   "simplify", "remesh", "subdivide",
                                            "crop",       "reorder",  "voxel"};
    ASSERT_EQ(specs.size(), names.size());
    for (std::size_t k = 0; k < specs.size(); ++k)
    {
        EXPECT_EQ(attack_name(specs[k]), names[k]);
    }
}

TEST(AttackSpecTest, chains_are_deterministic_per_seed_and_compose_transform_and_correspondence)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const auto specs = parse_attack_spec("similarity,reorder,crop=0.7,similarity,noise=0");
    const AttackResult a = apply_attacks(mesh, specs, 42);
    EXPECT_TRUE(test::bit_identical(a.mesh, apply_attacks(mesh, specs, 42, 1).mesh));
    EXPECT_FALSE(test::bit_identical(a.mesh, apply_attacks(mesh, specs, 43).mesh));

    // Output vertex k is the composed similarity applied to input vertex source[k].
    ASSERT_TRUE(a.similarity.has_value());
    ASSERT_TRUE(a.source_vertex.has_value());
    ASSERT_EQ(a.source_vertex->size(), static_cast<std::size_t>(a.mesh.V.rows()));
    double worst = 0.0;
    for (std::size_t k = 0; k < a.source_vertex->size(); ++k)
    {
        const Eigen::Vector3d expected =
            a.similarity->apply(mesh.V.row((*a.source_vertex)[k]).transpose());
        worst = std::max(
            worst, (a.mesh.V.row(static_cast<Eigen::Index>(k)).transpose() - expected).norm() /
                       a.similarity->scale);
    }
    EXPECT_LT(worst, 1e-9);

    // A step that makes new vertices ends the correspondence.
    const AttackResult simplified =
        apply_attacks(mesh, parse_attack_spec("noise=0.001,simplify=0.5"), 1);
    EXPECT_FALSE(simplified.source_vertex.has_value());
    EXPECT_FALSE(simplified.similarity.has_value());
    EXPECT_EQ(simplified.mesh.V.rows(), (mesh.V.rows() + 1) / 2);
}

TEST(AttackSpecTest, each_step_draws_from_its_own_stream)
{
    // The same attack at two positions of a chain gets two different streams.
    const TriangleMesh mesh = icosphere(3);
    const auto twice = parse_attack_spec("noise=0.01,noise=0.01");
    const AttackResult chained = apply_attacks(mesh, twice, 5);
    const AttackResult first = apply_attacks(mesh, {twice[0]}, 5);
    const Positions step_one = first.mesh.V - mesh.V;
    const Positions step_two = chained.mesh.V - first.mesh.V;
    EXPECT_GT((step_two - step_one).cwiseAbs().maxCoeff(), 1e-4);
    // Attack failures name the attack.
    EXPECT_THROW((void)apply_attacks(test::point_cloud_of(mesh), parse_attack_spec("smooth=5"), 1),
                 InvalidMesh);
}

}  // namespace meshmark
