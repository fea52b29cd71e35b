// SPDX-License-Identifier: MIT
#pragma once

// Point pairs picked by a user (the CLI's --pairs, the Python bindings' pairs): the pair itself,
// the similarity they give, and the point-pair file format. Defined in
// src/registration/point_pairs.cpp; register_to_reference (registration.h) starts from them.

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace meshmark
{

/// A point picked on the suspect and the same feature picked on the reference (the original).
struct PointPair
{
    Eigen::Vector3d suspect = Eigen::Vector3d::Zero();    ///< In the suspect's file frame.
    Eigen::Vector3d reference = Eigen::Vector3d::Zero();  ///< In the reference's file frame.
};

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

/// \brief Least-squares similarity mapping each pair's suspect point to its reference point
/// [Umeyama 1991].
/// \param allow_reflection  Also fit a mirrored map and return it when its residual is
///                          smaller (with 3 pairs both fit exactly and the proper one wins).
/// \return 4×4 suspect -> reference transform.
/// \throws InvalidOption if fewer than 3 pairs are given, or the suspect points are
/// (nearly) collinear or coincident.
[[nodiscard]] Eigen::Matrix4d similarity_from_pairs(std::span<const PointPair> pairs,
                                                    bool allow_reflection = true);

}  // namespace meshmark
