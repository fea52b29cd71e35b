// SPDX-License-Identifier: MIT
#include "meshmark/io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <memory>
#include <string>
#include <variant>

#include "io/detail/file_layout.h"
#include "io/detail/formats.h"
#include "io/detail/support.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

void write_bytes(const std::filesystem::path& path, const std::string& bytes)
{
    write_file_atomically(path, [&bytes](std::ostream& out)
                          { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

// The bytes of write_mesh's file for \p mesh in \p format; \p path names it in errors.
std::string generic_bytes(const std::filesystem::path& path, MeshFormat format,
                          const TriangleMesh& mesh, const WriteOptions& options)
{
    options.validate(mesh.V.rows());
    validate(mesh, path.string().c_str());
    switch (format)
    {
        case MeshFormat::Ply:
            return detail::ply_bytes(mesh, options);
        case MeshFormat::Obj:
            return detail::obj_bytes(mesh, options);
        case MeshFormat::Off:
            return detail::off_bytes(mesh, options);
        case MeshFormat::Stl:
            return detail::stl_bytes(mesh, options);
        case MeshFormat::Gltf:
        case MeshFormat::Glb:
            return detail::gltf_bytes(mesh, format == MeshFormat::Glb);
        case MeshFormat::ThreeMf:
            return detail::three_mf_bytes(path, mesh);
    }
    return {};
}

// write_mesh_file's and mesh_file_bytes's shared checks: one row per vertex of the source.
void check_rows(const char* function, const MeshFile& source, const Positions& positions)
{
    if (positions.rows() != source.mesh.V.rows())
    {
        throw InvalidOption(std::string(function) + ": positions have " +
                            std::to_string(positions.rows()) + " rows, but " +
                            source.path.string() + " has " + std::to_string(source.mesh.V.rows()) +
                            " vertices.");
    }
}

// The source's triangles under \p positions, for a writer that converts.
TriangleMesh converted(const MeshFile& source, const Positions& positions)
{
    TriangleMesh mesh;
    mesh.V = positions;
    mesh.F = source.mesh.F;
    return mesh;
}

}  // namespace

MeshFormat format_from_extension(const std::filesystem::path& path)
{
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".ply")
    {
        return MeshFormat::Ply;
    }
    if (ext == ".obj")
    {
        return MeshFormat::Obj;
    }
    if (ext == ".off")
    {
        return MeshFormat::Off;
    }
    if (ext == ".stl")
    {
        return MeshFormat::Stl;
    }
    if (ext == ".gltf")
    {
        return MeshFormat::Gltf;
    }
    if (ext == ".glb")
    {
        return MeshFormat::Glb;
    }
    if (ext == ".3mf")
    {
        return MeshFormat::ThreeMf;
    }
    detail::fail_io(path, "unknown mesh file extension " +
                              (ext.empty() ? std::string("(none)") : detail::quoted(ext)) +
                              "; expected .ply, .obj, .off, .stl, .gltf, .glb or .3mf");
}

const char* to_string(MeshFormat format) noexcept
{
    switch (format)
    {
        case MeshFormat::Ply:
            return "PLY";
        case MeshFormat::Obj:
            return "OBJ";
        case MeshFormat::Off:
            return "OFF";
        case MeshFormat::Stl:
            return "STL";
        case MeshFormat::Gltf:
            return "glTF";
        case MeshFormat::Glb:
            return "GLB";
        case MeshFormat::ThreeMf:
            return "3MF";
    }
    return "?";
}

void WriteOptions::validate(Eigen::Index vertex_count) const
{
    if (vertex_colors != nullptr &&
        static_cast<Eigen::Index>(vertex_colors->size()) != vertex_count)
    {
        throw InvalidOption("WriteOptions::vertex_colors has " +
                            std::to_string(vertex_colors->size()) +
                            " entries; expected one per "
                            "vertex (" +
                            std::to_string(vertex_count) + ").");
    }
}

MeshFile read_mesh_file(const std::filesystem::path& path)
{
    MeshFile file;
    file.format = format_from_extension(path);
    file.path = path;
    auto layout = std::make_shared<detail::FileLayout>();
    layout->format = file.format;
    layout->bytes = detail::read_file_bytes(path);
    switch (file.format)
    {
        case MeshFormat::Ply:
            file.mesh = detail::read_ply(path, *layout, file.is_single_precision);
            break;
        case MeshFormat::Obj:
            file.mesh = detail::read_obj(path, *layout, file.is_single_precision);
            break;
        case MeshFormat::Off:
            file.mesh = detail::read_off(path, *layout, file.is_single_precision);
            break;
        case MeshFormat::Stl:
            file.mesh = detail::read_stl(path, *layout, file.is_single_precision);
            break;
        case MeshFormat::Gltf:
        case MeshFormat::Glb:
        {
            auto& asset = layout->positions.emplace<detail::GltfAsset>();
            file.mesh =
                detail::read_gltf(path, layout->bytes, file.format == MeshFormat::Glb, asset);
            file.instances = std::move(asset.instances);
            file.animations = std::move(asset.animations);
            file.is_single_precision = true;
            file.unit =
                LengthUnit::Metre;  // glTF 2.0: "the units for all linear distances are meters"
            break;
        }
        case MeshFormat::ThreeMf:
            file.mesh = detail::read_3mf(path, *layout);
            file.instances =
                std::move(std::get<detail::ThreeMfLayout>(layout->positions).instances);
            file.unit = std::get<detail::ThreeMfLayout>(layout->positions).unit;
            file.is_single_precision = true;
            break;
    }
    file.layout = std::move(layout);
    return file;
}

void for_each_animation_pose(const MeshFile& file, std::span<const double> times,
                             const std::function<void(ShownPose&&)>& visit, std::size_t animation)
{
    const auto* asset =
        file.layout == nullptr ? nullptr : std::get_if<detail::GltfAsset>(&file.layout->positions);
    if (asset == nullptr || asset->model == nullptr)  // (no animation: no time poses the mesh)
    {
        for (std::size_t k = 0; k < times.size(); ++k)
        {
            visit(ShownPose{});
        }
        return;
    }
    detail::visit_gltf_poses(file.path, *asset, times, visit, animation);
}

void for_each_animation_pose(const std::filesystem::path& path, std::span<const double> times,
                             const std::function<void(ShownPose&&)>& visit, std::size_t animation)
{
    const MeshFormat format = format_from_extension(path);
    if (format != MeshFormat::Gltf && format != MeshFormat::Glb)
    {
        for_each_animation_pose(MeshFile{}, times, visit, animation);
        return;
    }
    for_each_animation_pose(read_mesh_file(path), times, visit, animation);
}

TriangleMesh read_mesh(const std::filesystem::path& path)
{
    return std::move(read_mesh_file(path).mesh);
}

void write_mesh(const std::filesystem::path& path, const TriangleMesh& mesh,
                const WriteOptions& options)
{
    const auto format = format_from_extension(path);
    write_bytes(path, generic_bytes(path, format, mesh, options));
}

void write_mesh_file(const std::filesystem::path& path, const MeshFile& source,
                     const Positions& positions, const WriteOptions& options)
{
    check_rows("write_mesh_file", source, positions);
    const auto format = format_from_extension(path);
    if (format != source.format || source.layout == nullptr)
    {
        write_mesh(path, converted(source, positions), options);
        return;
    }
    detail::check_finite(path, positions);
    if (const auto* asset = std::get_if<detail::GltfAsset>(&source.layout->positions))
    {
        detail::write_gltf_preserving(path, format == MeshFormat::Glb, *asset, source.mesh.V,
                                      positions, options.link_folder);
        return;
    }
    if (std::holds_alternative<detail::ThreeMfLayout>(source.layout->positions))
    {
        write_bytes(path,
                    detail::preserved_3mf_bytes(path, *source.layout, source.mesh.V, positions));
        return;
    }
    detail::write_preserved(path, *source.layout, source.mesh.V, positions,
                            source.path.parent_path(), options.link_folder);
}

std::string mesh_file_bytes(const MeshFile& source, const Positions& positions, MeshFormat format,
                            const WriteOptions& options)
{
    check_rows("mesh_file_bytes", source, positions);
    if (format != source.format || source.layout == nullptr)
    {
        return generic_bytes(source.path, format, converted(source, positions), options);
    }
    // The preserving writers of write_mesh_file, for an output beside the source.
    detail::check_finite(source.path, positions);
    if (const auto* asset = std::get_if<detail::GltfAsset>(&source.layout->positions))
    {
        return detail::preserved_gltf_bytes(source.path, format == MeshFormat::Glb, *asset,
                                            source.mesh.V, positions);
    }
    if (std::holds_alternative<detail::ThreeMfLayout>(source.layout->positions))
    {
        return detail::preserved_3mf_bytes(source.path, *source.layout, source.mesh.V, positions);
    }
    return detail::preserved_bytes(source.path, *source.layout, source.mesh.V, positions);
}

}  // namespace meshmark
