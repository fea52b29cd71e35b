// SPDX-License-Identifier: MIT
// Running attack steps: apply_attack() and apply_attacks() of attack_spec.h (parsing and
// canonical text are in attack_spec.cpp).
#include <string>
#include <utility>

#include "meshmark/attacks/attack_spec.h"

namespace meshmark
{
namespace
{

AttackResult with_identity(TriangleMesh mesh)
{
    AttackResult result;
    result.source_vertex = identity_correspondence(mesh.V.rows());
    result.mesh = std::move(mesh);
    return result;
}

AttackResult without_correspondence(TriangleMesh mesh)
{
    AttackResult result;
    result.mesh = std::move(mesh);
    return result;
}

template <typename... Visitors>
struct Overloaded : Visitors...
{
    using Visitors::operator()...;
};
// Explicit guide: clang before 17 lacks C++20 aggregate CTAD (needed by the clang fuzz build).
template <typename... Visitors>
Overloaded(Visitors...) -> Overloaded<Visitors...>;

}  // namespace

AttackResult apply_attack(const TriangleMesh& mesh, const AttackSpec& spec, Rng& rng, int threads)
{
    return std::visit(
        Overloaded{
            [&](const SimilarityOptions& o) { return apply_similarity(mesh, o, rng); },
            [&](const NoiseOptions& o) { return with_identity(add_noise(mesh, o, rng, threads)); },
            [&](const LaplacianSmoothingOptions& o)
            { return with_identity(smooth_laplacian(mesh, o, threads)); },
            [&](const TaubinSmoothingOptions& o)
            { return with_identity(smooth_taubin(mesh, o, threads)); },
            [&](const QuantizationOptions& o) { return with_identity(quantize(mesh, o)); },
            [&](const SimplificationOptions& o)
            { return without_correspondence(simplify(mesh, o)); },
            [&](const RemeshingOptions& o) { return without_correspondence(remesh(mesh, o)); },
            [&](const SubdivisionOptions& o) { return without_correspondence(subdivide(mesh, o)); },
            [&](const CropOptions& o) { return crop(mesh, o, rng); },
            [&](const ReorderOptions& o) { return reorder(mesh, o, rng); },
            [&](const VoxelRemeshingOptions& o)
            { return without_correspondence(voxel_remesh(mesh, o, threads)); },
        },
        spec);
}

AttackResult apply_attacks(const TriangleMesh& mesh, const std::vector<AttackSpec>& specs,
                           std::uint64_t seed, int threads)
{
    AttackResult total = with_identity(mesh);
    for (std::size_t k = 0; k < specs.size(); ++k)
    {
        // Each step draws from its own stream, named by its position and attack.
        const std::string purpose =
            "attack/" + std::to_string(k) + "/" + std::string(attack_name(specs[k]));
        Rng rng(derive_seed(seed, purpose));
        AttackResult step = apply_attack(total.mesh, specs[k], rng, threads);

        // Compose the similarity and the correspondence with those of the steps before.
        if (step.similarity)
        {
            total.similarity =
                total.similarity ? total.similarity->then(*step.similarity) : *step.similarity;
        }
        if (total.source_vertex && step.source_vertex)
        {
            for (auto& source : *step.source_vertex)
            {
                source = (*total.source_vertex)[static_cast<std::size_t>(source)];
            }
            total.source_vertex = std::move(step.source_vertex);
        }
        else
        {
            total.source_vertex.reset();
        }
        total.mesh = std::move(step.mesh);
    }
    return total;
}

}  // namespace meshmark
