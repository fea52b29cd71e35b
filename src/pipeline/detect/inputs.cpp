// SPDX-License-Identifier: MIT
#include "pipeline/detect/inputs.h"

#include <array>
#include <exception>
#include <iterator>
#include <string>
#include <thread>
#include <utility>

#include "meshmark/core/error.h"
#include "meshmark/pipeline/embed_file.h"

namespace meshmark::detail
{
namespace
{

void check_original(const TriangleMesh& original, const Key& key, const std::filesystem::path& path)
{
    const MeshFingerprint found = fingerprint(original);
    if (found.vertex_count != key.original.vertex_count ||
        found.face_count != key.original.face_count)
    {
        throw IoError(path.string() + ": this is not the original the key was made for (it has " +
                      std::to_string(found.vertex_count) + " vertices and " +
                      std::to_string(found.face_count) + " faces, the key's original " +
                      std::to_string(key.original.vertex_count) + " and " +
                      std::to_string(key.original.face_count) + ").");
    }
    if (found.position_hash != key.original.position_hash)
    {
        throw IoError(path.string() +
                      ": this is not the original the key was made for (same counts, "
                      "but its vertex positions differ from the fingerprint in the key).");
    }
}

// An empty mesh for the inputs that have no other instances.
const TriangleMesh& no_instances()
{
    static const TriangleMesh none;
    return none;
}

}  // namespace

const Key* key_of(const DetectSources& sources, const ReadInputs& read)
{
    if (sources.key != nullptr)
    {
        return sources.key;
    }
    return read.key ? &*read.key : nullptr;
}

DetectInputs read_inputs(const DetectSources& sources, const DetectFileOptions& options,
                         PhaseTimer& timer, ReadInputs& read)
{
    if (sources.mark != nullptr)  // a watermark built from the original already (detect_mesh)
    {
        return {*sources.original, no_instances(), *sources.suspect, sources.suspect_path, nullptr};
    }
    if (sources.original != nullptr)  // meshes in memory (detect)
    {
        check_original(*sources.original, *sources.key, sources.original_path);
        check_basis_input(*sources.original, sources.key->options, sources.original_path);
        return {*sources.original, no_instances(), *sources.suspect, sources.suspect_path, nullptr};
    }
    timer.begin("read");
    read.key = sources.key != nullptr ? *sources.key : read_key(sources.key_path);
    const Key& key = *read.key;
    // Both meshes are read side by side (each reader is serial); errors are still reported in
    // the order of a serial run: the key, the original, its checks, then the suspect.
    std::array<std::exception_ptr, 2> failures;
    const auto read_original = [&]
    {
        try
        {
            read.original = read_mesh_file(sources.original_path);
            // (an animation that only moves the whole asset, a turntable, shows no other pose
            // to read through)
            std::copy_if(read.original.animations.begin(), read.original.animations.end(),
                         std::back_inserter(read.animated.animations),
                         [](const AnimationSpan& a) { return !a.moves_only_as_a_whole; });
            if (read.animated.animations.empty())
            {
                read.original.layout.reset();  // (only posing would read it again)
            }
        }
        catch (...)
        {
            failures[0] = std::current_exception();
        }
    };
    const auto read_copy = [&]
    {
        try
        {
            if (sources.suspect == nullptr)
            {
                read.suspect = read_mesh(sources.suspect_path);
            }
        }
        catch (...)
        {
            failures[1] = std::current_exception();
        }
    };
    if (options.threads == 1 || sources.suspect != nullptr)
    {
        read_original();
        read_copy();
    }
    else
    {
        std::thread reader(read_original);
        read_copy();
        reader.join();
    }
    if (failures[0])
    {
        std::rethrow_exception(failures[0]);
    }
    const TriangleMesh& original = read.original.mesh;
    check_original(original, key, sources.original_path);
    check_basis_input(original, key.options, sources.original_path);
    if (failures[1])
    {
        std::rethrow_exception(failures[1]);
    }
    timer.lap("read");
    read.animated.file = &read.original;
    return {original, read.original.instances,
            sources.suspect != nullptr ? *sources.suspect : read.suspect, sources.suspect_path,
            read.animated.animations.empty() ? nullptr : &read.animated};
}

}  // namespace meshmark::detail
