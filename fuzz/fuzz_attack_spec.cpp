// SPDX-License-Identifier: MIT
// libFuzzer target: parse_attack_spec on arbitrary text, with the canonical round trip.
#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static_cast<void>(meshmark::fuzz::parse_attack_spec_bytes(data, size));
    return 0;
}
