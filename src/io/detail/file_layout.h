// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "io/detail/gltf.h"
#include "io/detail/numbers.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::detail
{

/// A token of a text file: [offset, offset + length) in FileLayout::bytes.
struct TextSpan
{
    std::uint64_t offset = 0;
    std::uint32_t length = 0;
};

/// Positions of a text file (ASCII PLY, OBJ, OFF): one token per coordinate, 3 per vertex
/// in vertex order, which is also file order.
struct TextPositions
{
    std::vector<TextSpan> tokens;
    /// Declared PLY type of each axis, which a changed coordinate is written in. Empty for
    /// OBJ/OFF: float32 when the original token had <= 9 significant digits, else float64.
    std::array<std::optional<ScalarType>, 3> declared_types{};
};

/// Positions of a binary PLY: coordinate d of vertex i is stored as types[d] at byte
/// offset(i, d): first_record + i * record_stride + field_offsets[d] when the vertex records
/// have a fixed size, else coordinate_offsets[3 * i + d] (lists in the vertex element).
struct BinaryPositions
{
    std::uint64_t first_record = 0;   ///< Offset of vertex 0's record.
    std::uint64_t record_stride = 0;  ///< Record size when records are fixed-size.
    std::array<std::uint64_t, 3> field_offsets{};
    std::vector<std::uint64_t> coordinate_offsets;  ///< 3 per vertex, only for varying records.
    std::array<ScalarType, 3> types{ScalarType::Float32, ScalarType::Float32, ScalarType::Float32};
    bool is_big_endian = false;

    [[nodiscard]] std::uint64_t offset(std::size_t vertex, std::size_t axis) const
    {
        return coordinate_offsets.empty()
                   ? first_record + vertex * record_stride + field_offsets[axis]
                   : coordinate_offsets[3 * vertex + axis];
    }
};

/// STL facets: each facet's corners refer to welded vertices; the normal is recomputed for
/// facets whose corners move.
struct StlFacets
{
    bool is_binary = true;
    std::vector<std::int32_t> corner_vertices;  ///< 3 per facet.
    std::vector<TextSpan> tokens;               ///< ASCII: 12 per facet (normal, 3 corners).
};

/// One 3MF mesh object as read: the model part it is in, its id there, its world transform
/// (build item and components, first instance) and the welded vertex of each of its vertices.
struct ThreeMfObject
{
    std::string part;  ///< Zip entry name of the model part ("3D/3dmodel.model").
    std::uint32_t resource_id = 0;
    Eigen::Matrix4d to_world = Eigen::Matrix4d::Identity();
    std::vector<std::int32_t> welded;
};

/// 3MF: the mesh objects that make up MeshFile::mesh (the package itself is FileLayout::bytes).
struct ThreeMfLayout
{
    std::vector<ThreeMfObject> objects;
    TriangleMesh instances;          ///< Other instances of objects (see MeshFile::instances).
    std::optional<LengthUnit> unit;  ///< The root model's unit (see MeshFile::unit).
};

/// Everything a preserving writer needs: the original bytes and where the positions sit.
struct FileLayout
{
    MeshFormat format = MeshFormat::Ply;
    std::string bytes;  ///< The file exactly as read.
    std::variant<TextPositions, BinaryPositions, StlFacets, GltfAsset, ThreeMfLayout> positions;
};

}  // namespace meshmark::detail
