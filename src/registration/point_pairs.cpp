// SPDX-License-Identifier: MIT
#include "meshmark/registration/point_pairs.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include <Eigen/SVD>

#include "meshmark/core/error.h"
#include "meshmark/registration/similarity_fit.h"
#include "registration/detail/registration_problem.h"

namespace meshmark
{
namespace
{

bool is_separator(char c)
{
    return c == ' ' || c == '\t' || c == ',' || c == '\r';
}

std::string line_error(const std::string& source, std::size_t line, const std::string& what)
{
    return source + ": line " + std::to_string(line) + ": " + what;
}

}  // namespace

std::vector<PointPair> parse_point_pairs(std::string_view text, const std::string& source)
{
    std::vector<PointPair> pairs;
    std::size_t line_number = 0;
    while (!text.empty())
    {
        ++line_number;
        const std::size_t end = text.find('\n');
        std::string_view line = text.substr(0, end);
        text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
        line = line.substr(0, line.find('#'));

        std::array<double, 6> values{};
        std::size_t count = 0;
        std::size_t i = 0;
        while (i < line.size())
        {
            if (is_separator(line[i]))
            {
                ++i;
                continue;
            }
            double value = 0.0;
            const char* first = line.data() + i;
            const char* last = line.data() + line.size();
            // from_chars does not accept a leading '+'; skip it for hand-written files.
            if (*first == '+')
            {
                ++first;
            }
            const auto [ptr, ec] = std::from_chars(first, last, value);
            if (ec != std::errc() || !std::isfinite(value) || (ptr != last && !is_separator(*ptr)))
            {
                throw IoError(line_error(
                    source, line_number,
                    "expected six numbers 'x y z  x' y' z'', found '" + std::string(line) + "'."));
            }
            if (count < values.size())
            {
                values[count] = value;
            }
            ++count;
            i = static_cast<std::size_t>(ptr - line.data());
        }
        if (count == 0)
        {
            continue;
        }
        if (count != 6)
        {
            throw IoError(line_error(
                source, line_number,
                "expected six numbers 'x y z  x' y' z'', found " + std::to_string(count) + "."));
        }
        pairs.push_back({Eigen::Vector3d(values[0], values[1], values[2]),
                         Eigen::Vector3d(values[3], values[4], values[5])});
    }
    return pairs;
}

std::vector<PointPair> read_point_pairs(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
    {
        throw IoError(path.string() + ": cannot open the point-pair file.");
    }
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad())
    {
        throw IoError(path.string() + ": cannot read the point-pair file.");
    }
    std::vector<PointPair> pairs = parse_point_pairs(buffer.str(), path.string());
    if (pairs.size() < 3)
    {
        throw InvalidOption(path.string() + ": a point-pair file needs at least 3 pairs, found " +
                            std::to_string(pairs.size()) + ".");
    }
    return pairs;
}

Eigen::Matrix4d similarity_from_pairs(std::span<const PointPair> pairs, bool allow_reflection)
{
    if (pairs.size() < 3)
    {
        throw InvalidOption("point pairs: a similarity needs at least 3 pairs, got " +
                            std::to_string(pairs.size()) + ".");
    }
    const auto n = static_cast<Eigen::Index>(pairs.size());
    Eigen::Matrix3Xd src(3, n);
    Eigen::Matrix3Xd dst(3, n);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        src.col(i) = pairs[static_cast<std::size_t>(i)].suspect;
        dst.col(i) = pairs[static_cast<std::size_t>(i)].reference;
    }
    // Collinear or coincident suspect points leave a rotation free: refuse them (the second
    // singular value of the centred points below this share of the first).
    constexpr double kCollinear = 1e-9;
    const Eigen::Matrix3Xd centered = src.colwise() - src.rowwise().mean();
    const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centered);
    const auto sv = svd.singularValues();
    if (!(sv(1) > kCollinear * sv(0)))
    {
        throw InvalidOption(
            "point pairs: the suspect points are collinear or coincident, so they "
            "do not determine a rotation.");
    }
    auto residual = [&](const Eigen::Matrix4d& A, const Eigen::Matrix3Xd& from)
    { return ((A.block<3, 3>(0, 0) * from).colwise() + A.block<3, 1>(0, 3) - dst).squaredNorm(); };
    const Eigen::Matrix4d proper = fit_similarity(src, dst);
    if (!allow_reflection)
    {
        return proper;
    }
    // The mirrored fit: the suspect points mirrored (x -> -x), fitted, and the mirror put back
    // into the map.
    const Eigen::Matrix3d M = detail::mirror_matrix();
    const Eigen::Matrix3Xd mirrored_src = M * src;
    Eigen::Matrix4d mirrored = fit_similarity(mirrored_src, dst);
    const double proper_residual = residual(proper, src);
    const double mirrored_residual = residual(mirrored, mirrored_src);
    // The mirrored fit must be clearly better (half the proper one's squared residual): with 3
    // pairs both are exact, and a copy is far more often unmirrored.
    constexpr double kMirroredGain = 0.5;
    if (mirrored_residual < kMirroredGain * proper_residual)
    {
        mirrored.block<3, 3>(0, 0) = mirrored.block<3, 3>(0, 0) * M;
        return mirrored;
    }
    return proper;
}

}  // namespace meshmark
