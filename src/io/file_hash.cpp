// SPDX-License-Identifier: MIT
// The SHA-256 of a file (OpenSSL's libcrypto): the embed record's commitments to its files.
#include "meshmark/io/file_hash.h"

#include <fstream>
#include <memory>
#include <vector>

#include <openssl/evp.h>

#include "meshmark/core/error.h"

namespace meshmark {

std::string sha256_of_file(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
    {
        throw IoError(path.string() + ": cannot open the file to hash it.");
    }
    const std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
    const auto fail = [&] { return IoError(path.string() + ": cannot compute the file's SHA-256."); };
    if (!context || EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) != 1)
    {
        throw fail();
    }
    std::vector<char> chunk(std::size_t{1} << 20U);
    while (in)
    {
        in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
        if (in.gcount() > 0 &&
            EVP_DigestUpdate(context.get(), chunk.data(), static_cast<std::size_t>(in.gcount())) != 1)
        {
            throw fail();
        }
    }
    if (in.bad())
    {
        throw IoError(path.string() + ": cannot read the file to hash it.");
    }
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int size = 0;
    if (EVP_DigestFinal_ex(context.get(), digest, &size) != 1)
    {
        throw fail();
    }
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    hex.reserve(2 * size);
    for (unsigned int i = 0; i < size; ++i)
    {
        hex += kHex[digest[i] >> 4U];
        hex += kHex[digest[i] & 0xFU];
    }
    return hex;
}

}  // namespace meshmark
