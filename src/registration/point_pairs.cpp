// SPDX-License-Identifier: MIT
#include "meshmark/registration/point_pairs.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>

#include "meshmark/core/error.h"

namespace meshmark {
namespace {

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
            if (ec != std::errc() || !std::isfinite(value) ||
                (ptr != last && !is_separator(*ptr)))
            {
                throw IoError(line_error(source, line_number,
                                         "expected six numbers 'x y z  x' y' z'', found '" +
                                             std::string(line) + "'."));
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
            throw IoError(line_error(source, line_number,
                                     "expected six numbers 'x y z  x' y' z'', found " +
                                         std::to_string(count) + "."));
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

}  // namespace meshmark
