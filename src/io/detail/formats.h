// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "io/detail/file_layout.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::detail
{

// Readers: parse layout.bytes (the whole file) into a MeshFile whose layout is filled in.
// Each throws IoError/InvalidMesh naming `path`.
[[nodiscard]] TriangleMesh read_ply(const std::filesystem::path& path, FileLayout& layout,
                                    bool& is_single_precision);
[[nodiscard]] TriangleMesh read_obj(const std::filesystem::path& path, FileLayout& layout,
                                    bool& is_single_precision);
[[nodiscard]] TriangleMesh read_off(const std::filesystem::path& path, FileLayout& layout,
                                    bool& is_single_precision);
[[nodiscard]] TriangleMesh read_stl(const std::filesystem::path& path, FileLayout& layout,
                                    bool& is_single_precision);
/// 3MF (libzip + pugixml): fills layout.positions with a ThreeMfLayout.
[[nodiscard]] TriangleMesh read_3mf(const std::filesystem::path& path, FileLayout& layout);

// Generic writers: the whole file for `mesh` in one string.
[[nodiscard]] std::string ply_bytes(const TriangleMesh& mesh, const WriteOptions& options);
[[nodiscard]] std::string obj_bytes(const TriangleMesh& mesh, const WriteOptions& options);
[[nodiscard]] std::string off_bytes(const TriangleMesh& mesh, const WriteOptions& options);
[[nodiscard]] std::string stl_bytes(const TriangleMesh& mesh, const WriteOptions& options);
/// A one-object 3MF package; \p path names the target in errors.
[[nodiscard]] std::string three_mf_bytes(const std::filesystem::path& path,
                                         const TriangleMesh& mesh);

/// The 3MF package of \p layout with the x/y/z attribute values of moved vertices rewritten
/// in their model parts (every other zip entry and byte kept), or the original bytes when
/// nothing moved.
[[nodiscard]] std::string preserved_3mf_bytes(const std::filesystem::path& path,
                                              const FileLayout& layout, const Positions& original,
                                              const Positions& positions);

/// \brief The original file of \p layout with positions \p original replaced by \p positions
/// (text, binary PLY, STL layouts), as written to the source's folder: unchanged coordinates
/// keep their bytes, changed ones follow the precision rules of mesh_io.h. \p path names the
/// file in errors. A binary PLY is one copy of the original, patched in place.
/// \pre the positions are finite (check_finite).
[[nodiscard]] std::string preserved_bytes(const std::filesystem::path& path,
                                          const FileLayout& layout, const Positions& original,
                                          const Positions& positions);

/// \brief Write preserved_bytes to \p path, atomically (a binary PLY in slices, never as a
/// second whole copy). An OBJ's material libraries are relinked when \p path is in another
/// folder than the source's, \p source_folder (material_library_edits; \p link_folder: see
/// relinked).
/// \pre the positions are finite (check_finite).
void write_preserved(const std::filesystem::path& path, const FileLayout& layout,
                     const Positions& original, const Positions& positions,
                     const std::filesystem::path& source_folder,
                     const std::filesystem::path& link_folder = {});

/// A replacement of \p length bytes at \p offset of a text by \p text.
struct TextEdit
{
    std::size_t offset = 0;
    std::size_t length = 0;
    std::string text;
};

/// \brief The edits of an OBJ's text \p bytes that name each `mtllib` file that does not
/// resolve from \p output_folder as it does from \p source_folder by the relative path from
/// the output's folder to the source's library (see relinked), in file order; none in the
/// usual cases (no `mtllib`, the same folder).
[[nodiscard]] std::vector<TextEdit> material_library_edits(
    std::string_view bytes, const std::filesystem::path& source_folder,
    const std::filesystem::path& output_folder, const std::filesystem::path& link_folder = {});

/// The STL part of write_preserved (facet corners and recomputed normals).
[[nodiscard]] std::string preserved_stl_bytes(const std::filesystem::path& path,
                                              const FileLayout& layout, const StlFacets& facets,
                                              const Positions& original,
                                              const Positions& positions);

}  // namespace meshmark::detail
