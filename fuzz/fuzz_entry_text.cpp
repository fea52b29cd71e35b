// SPDX-License-Identifier: MIT
#include <stdexcept>
#include <string_view>

#include "fuzz_entry.h"
#include "meshmark/core/error.h"
#include "meshmark/watermark/key.h"

namespace meshmark::fuzz
{

bool parse_key_bytes(const std::uint8_t* data, std::size_t size)
{
    const std::string text(reinterpret_cast<const char*>(data), size);
    std::string json;
    try
    {
        json = to_json(parse_key(text, "fuzz.key"));
    }
    catch (const Error&)
    {
        return false;
    }
    // A key that parsed must serialize and parse back unchanged; any failure here (even a
    // meshmark::Error) is a bug, reported as a std::logic_error.
    try
    {
        if (to_json(parse_key(json, "fuzz-roundtrip.key")) == json)
        {
            return true;
        }
    }
    catch (const Error& e)
    {
        throw std::logic_error(std::string("key round trip threw: ") + e.what());
    }
    throw std::logic_error("key round trip changed the key: " + json);
}

}  // namespace meshmark::fuzz
