// SPDX-License-Identifier: MIT
#pragma once

// The pipeline tests' embed options: a fixed seed and message, a basis small enough for tests.

#include <cstdint>

#include "meshmark/pipeline/embed_file.h"

namespace meshmark::test
{

/// Embed options with seed \p seed, message "owner" and a 60-function basis.
inline EmbedFileOptions seeded(std::uint64_t seed)
{
    EmbedFileOptions options;
    options.seed = seed;
    options.message = "owner";
    options.embed.basis_size = 60;
    return options;
}

}  // namespace meshmark::test
