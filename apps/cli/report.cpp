// SPDX-License-Identifier: MIT
#include "report.h"

#include <cstdio>
#include <iostream>

namespace meshmark::cli
{

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
