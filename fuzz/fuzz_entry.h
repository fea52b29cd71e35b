// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

/// Entry points shared by the libFuzzer targets (fuzz/*.cpp) and the corpus replay test
/// (tests/unit/fuzz_regressions): each feeds untrusted bytes to one parser and lets only
/// meshmark::Error escape-free; anything else (another exception, a crash, a sanitizer
/// report) is a finding.
namespace meshmark::fuzz
{

/// \brief Write \p data to a temporary file ending in \p extension (".ply", ".obj", ".off",
/// ".stl") and read it with read_mesh_file. \return true if it was read, false if it was
/// rejected with a meshmark::Error. Other exceptions propagate.
bool read_mesh_bytes(const std::uint8_t* data, std::size_t size, const std::string& extension);

/// \brief parse_key on \p data as text. \return true if accepted, false on meshmark::Error.
bool parse_key_bytes(const std::uint8_t* data, std::size_t size);

/// \brief parse_attack_spec on \p data as text. \return true if accepted, false on
/// meshmark::Error.
bool parse_attack_spec_bytes(const std::uint8_t* data, std::size_t size);

}  // namespace meshmark::fuzz
