// SPDX-License-Identifier: MIT
// The attack-spec entry point, apart from the key's: it needs the attacks library (CGAL), which
// the sanitizer job's replay leaves out (tests/unit/fuzz_regressions/CMakeLists.txt).
#include <stdexcept>
#include <string_view>

#include "fuzz_entry.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/error.h"

namespace meshmark::fuzz
{

bool parse_attack_spec_bytes(const std::uint8_t* data, std::size_t size)
{
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    std::string canonical;
    try
    {
        canonical = to_string(parse_attack_spec(text));
    }
    catch (const Error&)
    {
        return false;
    }
    // The canonical text must parse back to the same chain (documented round trip).
    try
    {
        if (to_string(parse_attack_spec(canonical)) == canonical)
        {
            return true;
        }
    }
    catch (const Error& e)
    {
        throw std::logic_error("attack spec round trip of '" + canonical + "' threw: " + e.what());
    }
    throw std::logic_error("attack spec round trip changed '" + canonical + "'");
}

}  // namespace meshmark::fuzz
