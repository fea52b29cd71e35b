// SPDX-License-Identifier: MIT
// libFuzzer target: the .glb reader (read_mesh_file) on arbitrary bytes.
#include "fuzz_entry.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    static_cast<void>(meshmark::fuzz::read_mesh_bytes(data, size, ".glb"));
    return 0;
}
