// SPDX-License-Identifier: MIT
// SHA-256 of files and of bytes in memory (OpenSSL's libcrypto).
#include "meshmark/io/file_sha256.h"

#include <fstream>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <openssl/evp.h>

#include "meshmark/core/error.h"

namespace meshmark
{

namespace
{

// One SHA-256 digest fed in pieces; \p what names the input in errors.
class Sha256
{
public:
    explicit Sha256(std::string what) : what_(std::move(what))
    {
        if (!context_ || EVP_DigestInit_ex(context_.get(), EVP_sha256(), nullptr) != 1)
        {
            fail();
        }
    }
    void add(const char* data, std::size_t size)
    {
        if (size > 0 && EVP_DigestUpdate(context_.get(), data, size) != 1)
        {
            fail();
        }
    }
    // Lower-case hex, as sha256sum prints it.
    std::string hex()
    {
        unsigned char digest[EVP_MAX_MD_SIZE];
        unsigned int size = 0;
        if (EVP_DigestFinal_ex(context_.get(), digest, &size) != 1)
        {
            fail();
        }
        static constexpr char kHex[] = "0123456789abcdef";
        std::string out;
        for (unsigned int i = 0; i < size; ++i)
        {
            out += kHex[digest[i] >> 4U];
            out += kHex[digest[i] & 0xFU];
        }
        return out;
    }

private:
    [[noreturn]] void fail() const { throw IoError(what_ + ": cannot compute the SHA-256."); }

    std::string what_;
    std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context_{EVP_MD_CTX_new(),
                                                                     &EVP_MD_CTX_free};
};

}  // namespace

std::string file_sha256(const std::filesystem::path& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
    {
        throw IoError(path.string() + ": cannot open the file.");
    }
    Sha256 digest(path.string());
    std::vector<char> chunk(std::size_t{1} << 20U);
    while (in)
    {
        in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
        digest.add(chunk.data(), static_cast<std::size_t>(in.gcount()));
    }
    if (in.bad())
    {
        throw IoError(path.string() + ": cannot read the file.");
    }
    return digest.hex();
}

std::string bytes_sha256(std::string_view bytes)
{
    Sha256 digest("bytes in memory");
    digest.add(bytes.data(), bytes.size());
    return digest.hex();
}

}  // namespace meshmark
