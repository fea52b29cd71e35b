// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace meshmark
{

/// One `mtllib` statement of an OBJ: where its names stand in the file and the names.
struct MaterialLibraryStatement
{
    std::size_t offset = 0;  ///< of the names (the rest of the line, trimmed) in the bytes
    std::size_t length = 0;
    std::vector<std::string> names;  ///< relative to the OBJ's folder, as written
};

/// \brief The material libraries the `mtllib` statements of an OBJ's bytes \p obj name, the OBJ
/// being in \p folder: the rest of a line names one file when \p folder holds a file by that
/// whole name (exporters write names with spaces), else each word names one, as the format says.
/// \details Lines are found by searching the bytes for "mtllib" (a pass over every line cost
/// about 5% of a `catalog add` of artists' files).
[[nodiscard]] std::vector<MaterialLibraryStatement> material_libraries(
    std::string_view obj, const std::filesystem::path& folder);

/// \brief The texture files a material library's bytes \p mtl name: the last word of each
/// `map_*`, `bump`, `disp`, `decal`, `refl` and `norm` statement (keywords in any case), as
/// written: relative to the library's own folder.
[[nodiscard]] std::vector<std::string> material_textures(std::string_view mtl);

}  // namespace meshmark
