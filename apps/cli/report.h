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

/// An argument as the shell reads it back: quoted unless made of safe characters only (the
/// command an evidence report gives to repeat a check).
[[nodiscard]] std::string shell_word(const std::string& word);

/// The shortest text that reads back as \p value ("1e-06", "0.5").
[[nodiscard]] std::string shortest(double value);

}  // namespace meshmark::cli
