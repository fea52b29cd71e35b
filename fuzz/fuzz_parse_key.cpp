// SPDX-License-Identifier: MIT
// libFuzzer target: parse_key (the key file's JSON) on arbitrary text, with a round trip.
#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static_cast<void>(meshmark::fuzz::parse_key_bytes(data, size));
    return 0;
}
