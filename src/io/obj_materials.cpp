// SPDX-License-Identifier: MIT
// The files an OBJ references beside it: its material libraries and their textures.
#include "meshmark/io/obj_materials.h"

#include <algorithm>
#include <cctype>

#include "io/detail/support.h"

namespace meshmark
{

using detail::is_blank;
using detail::LineCursor;
using detail::TokenCursor;

std::vector<MaterialLibraryStatement> material_libraries(std::string_view obj,
                                                         const std::filesystem::path& folder)
{
    std::vector<MaterialLibraryStatement> statements;
    std::error_code error;
    std::size_t next = 0;  // past the line of the last "mtllib" seen
    for (std::size_t hit = obj.find("mtllib"); hit != std::string_view::npos;
         hit = obj.find("mtllib", next))
    {
        const std::size_t before = obj.rfind('\n', hit);
        const std::size_t start = before == std::string_view::npos ? 0 : before + 1;
        next = std::min(obj.find('\n', hit), obj.size());
        const std::string_view line = obj.substr(start, next - start);
        TokenCursor tokens(line);
        std::string_view keyword;
        if (!tokens.next(keyword) || keyword != "mtllib")
        {
            continue;
        }
        auto first = static_cast<std::size_t>(keyword.data() + keyword.size() - line.data());
        auto last = line.size();
        while (first < last && is_blank(line[first]))
        {
            ++first;
        }
        while (last > first && is_blank(line[last - 1]))
        {
            --last;
        }
        const std::string_view rest = line.substr(first, last - first);
        MaterialLibraryStatement statement{start + first, last - first, {}};
        if (!rest.empty() && std::filesystem::is_regular_file(folder / std::string(rest), error))
        {
            statement.names.emplace_back(rest);
        }
        else
        {
            TokenCursor parts(rest);
            for (std::string_view name; parts.next(name);)
            {
                statement.names.emplace_back(name);
            }
        }
        statements.push_back(std::move(statement));
    }
    return statements;
}

std::vector<std::string> material_textures(std::string_view mtl)
{
    std::vector<std::string> textures;
    LineCursor lines(mtl);
    for (std::string_view line; lines.next(line);)
    {
        TokenCursor tokens(line);
        std::string_view keyword;
        if (!tokens.next(keyword))
        {
            continue;
        }
        std::string lower(keyword);
        std::transform(lower.begin(), lower.end(), lower.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (!lower.starts_with("map_") && lower != "bump" && lower != "disp" && lower != "decal" &&
            lower != "refl" && lower != "norm")
        {
            continue;
        }
        std::string_view last;
        for (std::string_view word; tokens.next(word);)
        {
            last = word;
        }
        if (!last.empty())
        {
            textures.emplace_back(last);
        }
    }
    return textures;
}

}  // namespace meshmark
