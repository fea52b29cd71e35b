// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "meshmark/registration/registration.h"

namespace meshmark
{

/// \brief Parse point pairs from text: one pair per line, `x y z  x' y' z'`, the first point
/// on the suspect and the second on the reference (the original).
/// \details Numbers are separated by spaces, tabs or commas and read with std::from_chars
/// (locale-independent). `#` starts a comment that runs to the end of the line; blank lines
/// are skipped.
/// \param text    The file's contents.
/// \param source  Names the text in error messages (usually the file name).
/// \throws IoError naming \p source and the line when a line does not hold exactly six
/// finite numbers.
[[nodiscard]] std::vector<PointPair> parse_point_pairs(std::string_view text,
                                                       const std::string& source);

/// \brief Read a point-pair file (the CLI's `--pairs FILE`). See parse_point_pairs.
/// \throws IoError when the file cannot be read or a line is malformed; InvalidOption when it
/// holds fewer than 3 pairs.
[[nodiscard]] std::vector<PointPair> read_point_pairs(const std::filesystem::path& path);

}  // namespace meshmark
