// SPDX-License-Identifier: MIT
// Helpers shared by the io tests: file bytes, expected cube data, exception matchers.
#pragma once

#include <array>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark::test
{

inline void put_bytes(const std::filesystem::path& path, const std::string& bytes)
{
    std::ofstream out(path, std::ios::binary);
    out << bytes;
}

inline std::filesystem::path fixture(const std::string& name)
{
    return data_dir() / name;
}

/// Reads \p path and writes it to \p out with its own positions; returns the bytes written.
inline std::string rewritten_unchanged(const std::filesystem::path& path,
                                       const std::filesystem::path& out)
{
    const MeshFile file = read_mesh_file(path);
    write_mesh_file(out, file, file.mesh.V);
    return file_bytes(out);
}

/// \p text with the first occurrence of \p from (which must occur) replaced by \p to.
inline std::string replaced_once(std::string text, const std::string& from, const std::string& to)
{
    return text.replace(text.find(from), from.size(), to);
}

using Rows = std::vector<std::array<double, 3>>;
using Triangles = std::vector<std::array<std::int32_t, 3>>;

/// The cube of the fixtures with vertex 6 at z = `top` (1.1 as float or as double).
inline Rows cube_positions(double top)
{
    return {{0, 0, 0}, {1, 0, 0}, {1, 1, 0},   {0, 1, 0},
            {0, 0, 1}, {1, 0, 1}, {1, 1, top}, {0, 1, 1}};
}

/// The cube's 6 quads, fan-triangulated in file order.
inline Triangles cube_triangles()
{
    const std::array<std::array<std::int32_t, 4>, 6> quads{
        {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 4, 7, 3}, {1, 2, 6, 5}}};
    Triangles result;
    for (const auto& q : quads)
    {
        result.push_back({q[0], q[1], q[2]});
        result.push_back({q[0], q[2], q[3]});
    }
    return result;
}

inline void expect_positions(const TriangleMesh& mesh, const Rows& expected)
{
    ASSERT_EQ(mesh.V.rows(), static_cast<Eigen::Index>(expected.size()));
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            EXPECT_EQ(mesh.V(i, d),
                      expected[static_cast<std::size_t>(i)][static_cast<std::size_t>(d)])
                << "vertex " << i << " axis " << d;
        }
    }
}

inline void expect_triangles(const TriangleMesh& mesh, const Triangles& expected)
{
    ASSERT_EQ(mesh.F.rows(), static_cast<Eigen::Index>(expected.size()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (Eigen::Index c = 0; c < 3; ++c)
        {
            EXPECT_EQ(mesh.F(f, c),
                      expected[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)])
                << "face " << f << " corner " << c;
        }
    }
}

/// The fixtures' cube: positions cube_positions(top), triangles cube_triangles().
inline void expect_cube(const TriangleMesh& mesh, double top)
{
    expect_positions(mesh, cube_positions(top));
    expect_triangles(mesh, cube_triangles());
}

/// Runs `body`, expects it to throw E with a message containing every one of `parts`.
template <typename E, typename Body>
void expect_error(Body&& body, const std::vector<std::string>& parts)
{
    try
    {
        body();
        ADD_FAILURE() << "no exception was thrown";
    }
    catch (const E& e)
    {
        const std::string message = e.what();
        for (const auto& part : parts)
        {
            EXPECT_NE(message.find(part), std::string::npos)
                << "message '" << message << "' lacks '" << part << "'";
        }
    }
}

/// Whitespace-separated tokens of each line.
inline std::vector<std::vector<std::string>> line_tokens(const std::string& text)
{
    std::vector<std::vector<std::string>> lines;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line))
    {
        std::istringstream words(line);
        std::vector<std::string> tokens;
        std::string token;
        while (words >> token)
        {
            tokens.push_back(token);
        }
        lines.push_back(std::move(tokens));
    }
    return lines;
}

}  // namespace meshmark::test
