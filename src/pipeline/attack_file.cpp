// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/attack_file.h"

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "timer.h"

namespace meshmark
{

AttackFileReport attack_file(const std::filesystem::path& input,
                             const std::filesystem::path& output, const std::string& spec,
                             const AttackFileOptions& options)
{
    // Check everything that needs no reading first.
    const auto specs = parse_attack_spec(spec);
    if (!options.force && is_same_file(output, input))
    {
        throw InvalidOption("attack: the output " + output.string() +
                            " is the input file; write elsewhere or pass --force.");
    }
    (void)format_from_extension(output);

    AttackFileReport report;
    report.spec = to_string(specs);
    report.seed = options.seed;
    detail::PhaseTimer timer(report.seconds, options.progress);
    timer.begin("read");
    const TriangleMesh mesh = read_mesh(input);
    timer.lap("read");

    timer.begin("attack");
    AttackResult result;
    try
    {
        result = apply_attacks(mesh, specs, options.seed, options.threads);
    }
    catch (const InvalidMesh& e)
    {
        throw InvalidMesh(input.string() + ": " + e.what());
    }
    timer.lap("attack");

    timer.begin("write");
    write_mesh(output, result.mesh);
    timer.lap("write");

    report.vertices_before = mesh.vertex_count();
    report.faces_before = mesh.face_count();
    report.vertices_after = result.mesh.vertex_count();
    report.faces_after = result.mesh.face_count();
    report.has_correspondence = result.source_vertex.has_value();
    if (result.similarity)
    {
        report.similarity = result.similarity->matrix();
    }
    return report;
}

}  // namespace meshmark
