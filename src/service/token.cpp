// SPDX-License-Identifier: MIT
#include "token.h"

#include <cctype>
#include <fstream>
#include <system_error>

#include <openssl/rand.h>
#include <sys/stat.h>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark::service
{
namespace
{

namespace fs = std::filesystem;

std::string random_token()
{
    unsigned char bytes[32];
    if (RAND_bytes(bytes, sizeof bytes) != 1)
    {
        throw IoError("cannot draw a random token (OpenSSL's RAND_bytes failed).");
    }
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    for (const unsigned char b : bytes)
    {
        hex += kHex[b >> 4U];
        hex += kHex[b & 0xFU];
    }
    return hex;
}

}  // namespace

std::string load_token(const fs::path& path, bool* created)
{
    std::error_code error;
    *created = false;
    if (!fs::exists(path, error))
    {
        const std::string token = random_token();
        write_file_atomically(path, [&](std::ostream& out) { out << token << "\n"; },
                              {0600, false});
        *created = true;
        return token;
    }
    struct stat info
    {
    };
    if (::stat(path.c_str(), &info) != 0)
    {
        throw IoError(path.string() + ": cannot read the token file.");
    }
    if ((info.st_mode & 077U) != 0)
    {
        throw IoError(path.string() +
                      ": the token file may be read by others; make it private (chmod 600).");
    }
    std::ifstream in(path);
    std::string token;
    std::getline(in, token);
    while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back())) != 0)
    {
        token.pop_back();
    }
    if (!in && !in.eof())
    {
        throw IoError(path.string() + ": cannot read the token file.");
    }
    if (token.size() < 16)
    {
        throw IoError(path.string() + ": the token must have at least 16 characters.");
    }
    return token;
}

}  // namespace meshmark::service
