// SPDX-License-Identifier: MIT
// Uses meshmark as an installed library: watermark a mesh, then look for the mark in the
// marked copy (found) and in the unmarked original (not found), once through the file
// pipeline and once in memory, all through the one header meshmark/meshmark.h.
//
// Usage: meshmark_example [INPUT] OUTDIR
//   INPUT   a mesh (.ply .obj .off .stl); without it a 2,562-vertex demo mesh is generated.
//   OUTDIR  where the marked copy and the key are written (created if missing).
// Exit code 0 when all three verdicts are right, 1 when one is wrong, 3 on an error.
#include <cstdio>
#include <exception>
#include <filesystem>

#include "meshmark/geometry/shapes.h"
#include "meshmark/meshmark.h"

namespace fs = std::filesystem;

namespace
{

void print(const char* what, const meshmark::Decision& decision)
{
    std::printf("%s: detected=%s R=%.4f matches=%d/%d false_positive_probability=%.3g\n", what,
                decision.is_present ? "yes" : "no", decision.correlation, decision.matches,
                decision.bit_count, decision.false_positive_probability);
}

}  // namespace

int main(int argc, char** argv)
{
    if (argc < 2 || argc > 3)
    {
        std::fprintf(stderr, "usage: %s [INPUT] OUTDIR\n", argv[0]);
        return 2;
    }
    try
    {
        const fs::path out_dir = argv[argc - 1];
        fs::create_directories(out_dir);
        fs::path input;
        if (argc == 3)
        {
            input = argv[1];
        }
        else
        {
            input = out_dir / "generated.ply";
            meshmark::write_mesh(input, meshmark::lumpy_ellipsoid(4));
        }
        const fs::path marked = out_dir / ("marked" + input.extension().string());
        const fs::path key_path = out_dir / "example.key.json";

        // 1. Embed: read, watermark, write the marked copy and the key (both atomically).
        meshmark::EmbedFileOptions options;
        options.message = "(c) meshmark library example";
        options.seed = 2026;
        options.force = true;  // the example may be run again into the same folder
        const meshmark::EmbedReport embedded =
            meshmark::embed_file(input, marked, key_path, options);
        std::printf(
            "embedded %zu bits into %lld vertices: RMS displacement %.3g of the bbox "
            "diagonal\n",
            embedded.key.payload.size(), static_cast<long long>(embedded.vertex_count),
            embedded.stats.rms_displacement_rel);

        // 2. Detect with the file pipeline: in the marked copy, then in the original itself.
        const meshmark::DetectReport in_marked = meshmark::detect_file(marked, input, key_path, {});
        const meshmark::DetectReport in_original =
            meshmark::detect_file(input, input, key_path, {});
        print("marked copy", in_marked.decision);
        print("original", in_original.decision);

        // 3. The same in memory: embed the original with the same options (same seed: the
        //    positions of the marked file and the same key), then detect in the marked mesh.
        const meshmark::TriangleMesh original = meshmark::read_mesh(input);
        const meshmark::EmbedResult result = meshmark::embed(original, options);
        meshmark::TriangleMesh marked_mesh = original;
        marked_mesh.V = result.positions;
        const meshmark::DetectReport in_memory =
            meshmark::detect(marked_mesh, original, result.key);
        print("in memory", in_memory.decision);

        const bool is_right = in_marked.decision.is_present && !in_original.decision.is_present &&
                              in_memory.decision.is_present;
        std::printf("%s\n", is_right ? "OK" : "WRONG VERDICT");
        return is_right ? 0 : 1;
    }
    catch (const std::exception& e)
    {
        std::fprintf(stderr, "meshmark_example: %s\n", e.what());
        return 3;
    }
}
