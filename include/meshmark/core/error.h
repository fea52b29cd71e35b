// SPDX-License-Identifier: MIT
#pragma once

#include <stdexcept>
#include <string>

namespace meshmark
{

/// \brief Base of every exception the library throws.
/// \details Messages are one sentence that names what failed, where, and what was expected;
/// the CLI prints them as they are.
class Error : public std::runtime_error
{
public:
    using std::runtime_error::runtime_error;
};

/// A file could not be opened, read, parsed or written (names the file, and the line or byte
/// offset where that helps).
class IoError : public Error
{
public:
    using Error::Error;
};

/// The mesh is unusable: non-finite coordinates, index out of range, too few vertices, ...
class InvalidMesh : public Error
{
public:
    using Error::Error;
};

/// An option or argument is out of its allowed range (names the field, value and range).
class InvalidOption : public Error
{
public:
    using Error::Error;
};

/// A factorization or orthogonalization failed (degenerate Gram matrix, ...).
class NumericalError : public Error
{
public:
    using Error::Error;
};

/// Process exit codes shared by every command (docs/cli.md).
enum class ExitCode : int
{
    Ok = 0,            ///< Success; for `detect`: watermark found.
    NotDetected = 1,   ///< `detect` only: watermark not found.
    Usage = 2,         ///< Bad command line or option.
    InvalidInput = 3,  ///< Unreadable or invalid input file.
    Numerical = 4,     ///< Numerical failure.
    Internal = 5,      ///< Anything else (a bug).
};

/// Exit code for an exception caught at the top level of a program.
[[nodiscard]] ExitCode exit_code_for(const std::exception& e) noexcept;

}  // namespace meshmark

/// Invariant check: active in Debug and sanitizer builds, compiled out in Release.
#ifdef NDEBUG
#define MESHMARK_ASSERT(cond, message) \
    do                                 \
    {                                  \
    } while (0)
#else
#include <cstdio>
#include <cstdlib>
#define MESHMARK_ASSERT(cond, message)                                                            \
    do                                                                                            \
    {                                                                                             \
        if (!(cond))                                                                              \
        {                                                                                         \
            std::fprintf(stderr, "%s:%d: assertion '%s' failed: %s\n", __FILE__, __LINE__, #cond, \
                         message);                                                                \
            std::abort();                                                                         \
        }                                                                                         \
    } while (0)
#endif
