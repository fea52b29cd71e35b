// SPDX-License-Identifier: MIT
// The CGAL-backed attacks on real, messy meshes: closed scans, a CAD part with sharp features,
// and files with non-manifold edges, open boundaries and unreferenced vertices.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "attack_test_util.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

class SharedMeshAttackTest : public ::testing::TestWithParam<const char*>
{
protected:
    void SetUp() override
    {
        const auto path = test::mesh_dir() / GetParam();
        if (!std::filesystem::exists(path))
        {
            GTEST_SKIP() << path << " is not available";
        }
        mesh_ = read_mesh(path);
        referenced_ = static_cast<double>(referenced_vertices(mesh_).size());
        const EdgeStatistics edges = edge_statistics(mesh_);
        is_closed_ = edges.is_closed();
        non_manifold_edges_ = static_cast<Eigen::Index>(edges.non_manifold_edge_count);
    }

    AttackResult run(const std::string& spec) const
    {
        return apply_attacks(mesh_, parse_attack_spec(spec), 7);
    }

    TriangleMesh mesh_;
    double referenced_ = 0.0;
    bool is_closed_ = false;
    Eigen::Index non_manifold_edges_ = 0;
};

TEST_P(SharedMeshAttackTest, simplification_hits_the_target_and_stays_edge_manifold)
{
    for (const auto& [spec, fraction] :
         {std::pair{"simplify=0.1", 0.1}, std::pair{"simplify=0.25:policy=lt", 0.25},
          std::pair{"simplify=0.01", 0.01}})
    {
        const TriangleMesh out = run(spec).mesh;
        EXPECT_LE(test::relative_error(static_cast<double>(out.V.rows()), fraction * referenced_),
                  0.1)
            << spec << ": " << out.V.rows() << " vertices";
        const EdgeStatistics edges = edge_statistics(out);
        EXPECT_TRUE(edges.is_consistently_oriented()) << spec;
        if (is_closed_)
        {
            EXPECT_TRUE(edges.is_closed()) << spec;
        }
    }
}

TEST_P(SharedMeshAttackTest, remeshing_hits_the_target_and_stays_edge_manifold)
{
    const TriangleMesh out = run("remesh=0.25").mesh;
    EXPECT_LE(test::relative_error(static_cast<double>(out.V.rows()), 0.25 * referenced_), 0.1)
        << out.V.rows() << " vertices";
    const EdgeStatistics edges = edge_statistics(out);
    EXPECT_TRUE(edges.is_consistently_oriented());
    if (is_closed_)
    {
        EXPECT_TRUE(edges.is_closed());
    }
}

TEST_P(SharedMeshAttackTest, subdivision_refines_every_face)
{
    for (const auto& [spec, factor] :
         {std::pair{"subdivide=loop", 4}, std::pair{"subdivide=midpoint", 4},
          std::pair{"subdivide=sqrt3", 3}})
    {
        const TriangleMesh out = run(spec).mesh;
        const EdgeStatistics edges = edge_statistics(out);
        EXPECT_TRUE(edges.is_consistently_oriented()) << spec;
        if (is_closed_)
        {
            // Clean input goes through unrepaired: exact counts.
            EXPECT_EQ(out.F.rows(), factor * mesh_.F.rows()) << spec;
            EXPECT_TRUE(edges.is_closed()) << spec;
        }
        else
        {
            // The repair drops about one face per non-manifold edge (and degenerate or duplicate
            // faces, which these files do not have); everything else is subdivided.
            EXPECT_GE(out.F.rows(), factor * (mesh_.F.rows() - 2 * non_manifold_edges_)) << spec;
            EXPECT_LE(out.F.rows(), factor * mesh_.F.rows()) << spec;
        }
    }
}

TEST_P(SharedMeshAttackTest, vertex_attacks_chain_with_correspondence)
{
    const AttackResult out = run("similarity,noise=0.003,smooth=5,quantize=10,crop=0.7,reorder");
    ASSERT_TRUE(out.source_vertex.has_value());
    EXPECT_LE(test::relative_error(static_cast<double>(out.mesh.V.rows()), 0.7 * referenced_),
              0.03);
    EXPECT_EQ(out.source_vertex->size(), static_cast<std::size_t>(out.mesh.V.rows()));
}

INSTANTIATE_TEST_SUITE_P(SmallMeshes, SharedMeshAttackTest,
                         ::testing::Values("bunny.off", "fandisk.obj", "dragon_vrip_res4.ply",
                                           "beetle.obj", "teapot.obj"),
                         [](const auto& info)
                         {
                             std::string name = info.param;
                             for (char& c : name)
                             {
                                 c = std::isalnum(static_cast<unsigned char>(c)) != 0 ? c : '_';
                             }
                             return name;
                         });

}  // namespace
}  // namespace meshmark
