// SPDX-License-Identifier: MIT
// Zip archives in memory through libzip: reading entries with a size cap, replacing some
// entries while libzip copies the others with their compressed bytes, writing a new archive.
#include "io/detail/zip_archive.h"

#include <ctime>
#include <memory>

#include <zip.h>

#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// zip_error_t owns a message buffer; this one is released when it goes out of scope.
class ZipError
{
public:
    ZipError() { zip_error_init(&error_); }
    ZipError(const ZipError&) = delete;
    ZipError& operator=(const ZipError&) = delete;
    ~ZipError() { zip_error_fini(&error_); }
    zip_error_t* get() { return &error_; }
    std::string text() { return zip_error_strerror(&error_); }

private:
    zip_error_t error_{};
};

// libzip deflates at level 9 unless told otherwise; zlib's default level 6 is what slicers'
// zip writers use, about as small on model XML and several times faster (a 5.7 MB PrusaSlicer
// model part: 1.1 s of a 1.7 s embed went to deflate at level 9).
constexpr zip_uint32_t kDeflateLevel = 6;

struct SourceFree
{
    void operator()(zip_source_t* source) const { zip_source_free(source); }
};
using SourcePtr = std::unique_ptr<zip_source_t, SourceFree>;

struct ArchiveDiscard
{
    void operator()(zip_t* archive) const { zip_discard(archive); }
};
using ArchivePtr = std::unique_ptr<zip_t, ArchiveDiscard>;

struct FileClose
{
    void operator()(zip_file_t* file) const { zip_fclose(file); }
};
using FilePtr = std::unique_ptr<zip_file_t, FileClose>;

// A buffer source on \p bytes (not copied: libzip only reads it; a write to the source makes
// a new buffer) and an archive opened on it. The caller keeps \p source referenced when it
// needs the written archive after zip_close.
ArchivePtr open_archive(const fs::path& path, const std::string& bytes, int flags,
                        SourcePtr& source)
{
    ZipError error;
    source.reset(zip_source_buffer_create(bytes.data(), bytes.size(), 0, error.get()));
    if (source == nullptr)
    {
        fail_io(path, "cannot read the zip container: " + error.text());
    }
    zip_source_keep(source.get());  // one reference for the archive, one for the caller
    ArchivePtr archive(zip_open_from_source(source.get(), flags, error.get()));
    if (archive == nullptr)
    {
        zip_source_free(source.get());  // the archive's reference, which it did not take
        fail_io(path, "not a valid 3MF package: not a zip archive (" + error.text() + ")");
    }
    return archive;
}

// Close \p archive (writing its changes into \p source) and return the archive's bytes.
std::string close_into_bytes(const fs::path& path, ArchivePtr archive, zip_source_t* source)
{
    if (zip_close(archive.get()) != 0)
    {
        fail_io(path, std::string("cannot write the zip container: ") +
                          zip_error_strerror(zip_get_error(archive.get())));
    }
    static_cast<void>(archive.release());  // zip_close freed it
    if (zip_source_open(source) != 0 || zip_source_seek(source, 0, SEEK_END) != 0)
    {
        fail_io(path, std::string("cannot read back the zip container: ") +
                          zip_error_strerror(zip_source_error(source)));
    }
    const zip_int64_t size = zip_source_tell(source);
    std::string bytes(size > 0 ? static_cast<std::size_t>(size) : 0U, '\0');
    const bool ok = size >= 0 && zip_source_seek(source, 0, SEEK_SET) == 0 &&
                    zip_source_read(source, bytes.data(), bytes.size()) == size;
    zip_source_close(source);
    if (!ok)
    {
        fail_io(path, "cannot read back the zip container");
    }
    return bytes;
}

// Add \p content as entry \p name, or replace entry \p index when it is given.
void put_entry(const fs::path& path, zip_t* archive, const std::string& name,
               const std::string& content, std::optional<std::uint64_t> index)
{
    // The data stay in the caller's strings until zip_close.
    zip_source_t* source = zip_source_buffer(archive, content.data(), content.size(), 0);
    if (source == nullptr)
    {
        fail_io(path, "cannot store zip entry " + detail::quoted(name));
    }
    const bool ok = index.has_value()
                        ? zip_file_replace(archive, *index, source, 0) == 0
                        : zip_file_add(archive, name.c_str(), source, ZIP_FL_ENC_UTF_8) >= 0;
    if (!ok)
    {
        zip_source_free(source);
        fail_io(path, "cannot store zip entry " + detail::quoted(name) + ": " +
                          zip_error_strerror(zip_get_error(archive)));
    }
}

}  // namespace

ZipArchive::ZipArchive(const fs::path& path, const std::string& bytes) : path_(path)
{
    SourcePtr source;
    archive_ = open_archive(path, bytes, ZIP_RDONLY, source).release();
}

ZipArchive::~ZipArchive()
{
    zip_discard(archive_);
}

std::optional<std::uint64_t> ZipArchive::find(const std::string& name) const
{
    zip_int64_t index = zip_name_locate(archive_, name.c_str(), 0);
    if (index < 0)
    {
        index = zip_name_locate(archive_, name.c_str(), ZIP_FL_NOCASE);
    }
    if (index < 0)
    {
        return std::nullopt;
    }
    return static_cast<std::uint64_t>(index);
}

std::uint64_t ZipArchive::size(std::uint64_t index) const
{
    zip_stat_t stat;
    zip_stat_init(&stat);
    if (zip_stat_index(archive_, index, 0, &stat) != 0 || (stat.valid & ZIP_STAT_SIZE) == 0)
    {
        fail_io(path_, "cannot read zip entry " + std::to_string(index));
    }
    return stat.size;
}

std::string ZipArchive::name(std::uint64_t index) const
{
    const char* name = zip_get_name(archive_, index, 0);
    return name != nullptr ? name : std::to_string(index);
}

std::string ZipArchive::read(std::uint64_t index, std::uint64_t max_bytes) const
{
    const std::string name = this->name(index);
    const std::uint64_t declared = size(index);
    if (declared > max_bytes)
    {
        fail_io(path_,
                "zip entry " + detail::quoted(name) + " declares " + std::to_string(declared) +
                    " uncompressed bytes, more than the limit of " + std::to_string(max_bytes));
    }
    const FilePtr file(zip_fopen_index(archive_, index, 0));
    if (file == nullptr)
    {
        fail_io(path_, "cannot open zip entry " + detail::quoted(name) + ": " +
                           zip_error_strerror(zip_get_error(archive_)));
    }
    std::string content(static_cast<std::size_t>(declared), '\0');
    std::uint64_t done = 0;
    while (done < declared)
    {
        const zip_int64_t n = zip_fread(file.get(), content.data() + done, declared - done);
        if (n <= 0)
        {
            fail_io(path_, "cannot decompress zip entry " + detail::quoted(name) + ": " +
                               (n < 0 ? zip_file_strerror(file.get())
                                      : "its data end before the declared size"));
        }
        done += static_cast<std::uint64_t>(n);
    }
    // One more read reaches the end of the data, where libzip checks the CRC; data that go on
    // past the declared size are refused rather than read.
    char extra = 0;
    const zip_int64_t n = zip_fread(file.get(), &extra, 1);
    if (n != 0)
    {
        fail_io(path_, "cannot decompress zip entry " + detail::quoted(name) + ": " +
                           (n < 0 ? zip_file_strerror(file.get())
                                  : "its data go on past the declared size"));
    }
    return content;
}

std::string replace_zip_entries(const fs::path& path, const std::string& bytes,
                                const std::vector<std::pair<std::string, std::string>>& contents)
{
    SourcePtr source;
    ArchivePtr archive = open_archive(path, bytes, 0, source);
    for (const auto& [name, content] : contents)
    {
        const zip_int64_t index = zip_name_locate(archive.get(), name.c_str(), 0);
        zip_stat_t stat;
        zip_stat_init(&stat);
        if (index < 0 ||
            zip_stat_index(archive.get(), static_cast<zip_uint64_t>(index), 0, &stat) != 0)
        {
            fail_io(path, "zip entry " + detail::quoted(name) + " is missing");
        }
        const auto entry = static_cast<zip_uint64_t>(index);
        put_entry(path, archive.get(), name, content, entry);
        // Keep the entry's method where libzip can write it (stored stays stored).
        zip_int32_t method = ZIP_CM_DEFLATE;
        if ((stat.valid & ZIP_STAT_COMP_METHOD) != 0 &&
            (stat.comp_method == ZIP_CM_STORE ||
             zip_compression_method_supported(stat.comp_method, 1) != 0))
        {
            method = static_cast<zip_int32_t>(stat.comp_method);
        }
        // libzip 1.7 drops the level when the method equals the entry's original one; deflate
        // asked for as ZIP_CM_DEFAULT keeps it (and is stored as deflate).
        if (zip_set_file_compression(archive.get(), entry,
                                     method == ZIP_CM_DEFLATE ? ZIP_CM_DEFAULT : method,
                                     method == ZIP_CM_DEFLATE ? kDeflateLevel : 0) != 0 ||
            ((stat.valid & ZIP_STAT_MTIME) != 0 &&
             zip_file_set_mtime(archive.get(), entry, stat.mtime, 0) != 0))
        {
            fail_io(path, "cannot store zip entry " + detail::quoted(name) + ": " +
                              zip_error_strerror(zip_get_error(archive.get())));
        }
    }
    return close_into_bytes(path, std::move(archive), source.get());
}

std::string new_zip(const fs::path& path,
                    const std::vector<std::pair<std::string, std::string>>& entries)
{
    const std::string empty;
    SourcePtr source;
    ArchivePtr archive = open_archive(path, empty, ZIP_CREATE | ZIP_TRUNCATE, source);
    // A fixed time (2000-01-01) makes the package depend on the mesh only.
    constexpr std::time_t kEntryTime = 946684800;
    for (const auto& [name, content] : entries)
    {
        put_entry(path, archive.get(), name, content, std::nullopt);
        const auto entry = static_cast<zip_uint64_t>(zip_get_num_entries(archive.get(), 0) - 1);
        if (zip_set_file_compression(archive.get(), entry, ZIP_CM_DEFLATE, kDeflateLevel) != 0 ||
            zip_file_set_mtime(archive.get(), entry, kEntryTime, 0) != 0)
        {
            fail_io(path, "cannot store zip entry " + detail::quoted(name));
        }
    }
    return close_into_bytes(path, std::move(archive), source.get());
}

}  // namespace meshmark::detail
