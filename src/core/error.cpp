// SPDX-License-Identifier: MIT
#include "meshmark/core/error.h"

namespace meshmark
{

ExitCode exit_code_for(const std::exception& e) noexcept
{
    if (dynamic_cast<const IoError*>(&e) != nullptr ||
        dynamic_cast<const InvalidMesh*>(&e) != nullptr)
    {
        return ExitCode::InvalidInput;
    }
    if (dynamic_cast<const InvalidOption*>(&e) != nullptr)
    {
        return ExitCode::Usage;
    }
    if (dynamic_cast<const NumericalError*>(&e) != nullptr)
    {
        return ExitCode::Numerical;
    }
    return ExitCode::Internal;
}

}  // namespace meshmark
