// SPDX-License-Identifier: MIT
#include "meshmark/core/threads.h"

#include <algorithm>

#include <omp.h>

namespace meshmark
{

int resolve_threads(int requested)
{
    return requested > 0 ? requested : std::max(1, omp_get_max_threads());
}

}  // namespace meshmark
