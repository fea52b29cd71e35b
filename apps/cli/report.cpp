// SPDX-License-Identifier: MIT
#include "report.h"

#include <unistd.h>

#include <cstdio>
#include <iostream>

namespace meshmark::cli {

ProgressCallback make_progress(const GlobalArgs& global, const std::string& command)
{
    if (global.quiet || ::isatty(STDERR_FILENO) == 0)
    {
        return {};
    }
    return [command](std::string_view phase, double fraction) {
        std::fprintf(stderr, "\r\033[Kmeshmark %s: %.*s %3.0f%%", command.c_str(),
                     static_cast<int>(phase.size()), phase.data(), 100.0 * fraction);
        if (fraction >= 1.0)
        {
            std::fputc('\n', stderr);
        }
        std::fflush(stderr);
    };
}

nlohmann::json to_json(const PhaseTimings& timings)
{
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [name, seconds] : timings.phases)
    {
        object[name] = seconds;
    }
    object["total"] = timings.total;
    return object;
}

void print_json(const nlohmann::json& object)
{
    std::cout << object.dump() << std::endl;
}

std::string format_number(double value, int digits)
{
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.*g", digits, value);
    return buffer;
}

}  // namespace meshmark::cli
