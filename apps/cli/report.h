// SPDX-License-Identifier: MIT
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/pipeline/report_json.h"  // the --json reports (shared with the Python package)

namespace meshmark::cli
{

/// Prints a JSON object on stdout (one line per object, for scripts).
void print_json(const nlohmann::json& object);

/// Formats a number with \p digits significant digits ("%.*g").
[[nodiscard]] std::string format_number(double value, int digits = 3);

// shell_word and shortest: the library's (report_json.h), for the commands' evidence reports.

}  // namespace meshmark::cli
