// SPDX-License-Identifier: MIT
// `catalog add`'s tasks: their JSON, a worker's marking into a staging folder, and the
// coordinator's recording (docs/cluster.md).
#include "meshmark/catalog/catalog_mark.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <unistd.h>

#include "catalog/catalog_add_impl.h"
#include "meshmark/core/error.h"
#include "meshmark/core/hash.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace fs = std::filesystem;

namespace
{

std::string hex_of(const std::vector<std::uint8_t>& bytes)
{
    static constexpr char kDigits[] = "0123456789abcdef";
    std::string text;
    text.reserve(2 * bytes.size());
    for (const std::uint8_t b : bytes)
    {
        text += kDigits[b >> 4U];
        text += kDigits[b & 15U];
    }
    return text;
}

std::vector<std::uint8_t> bytes_of_hex(const std::string& text)
{
    const auto digit = [&](char c) -> unsigned
    {
        if (c >= '0' && c <= '9')
        {
            return static_cast<unsigned>(c - '0');
        }
        if (c >= 'a' && c <= 'f')
        {
            return static_cast<unsigned>(c - 'a' + 10);
        }
        throw InvalidOption("a marked asset's signature is not hexadecimal.");
    };
    if (text.size() % 2 != 0)
    {
        throw InvalidOption("a marked asset's signature is not hexadecimal.");
    }
    std::vector<std::uint8_t> bytes(text.size() / 2);
    for (std::size_t i = 0; i < bytes.size(); ++i)
    {
        bytes[i] = static_cast<std::uint8_t>(digit(text[2 * i]) << 4U | digit(text[2 * i + 1]));
    }
    return bytes;
}

// A task's or result's field, with one sentence naming it when missing or of another type.
template <class T>
T field(const nlohmann::json& json, const char* name, const char* what)
{
    try
    {
        return json.at(name).get<T>();
    }
    catch (const nlohmann::json::exception&)
    {
        throw InvalidOption(std::string(what) + " without a valid \"" + name + "\".");
    }
}

// The family key store of a worker's marking: the key in \p key, the caller's (a recorded key
// given, or the one the marking makes), recorded by nobody.
class MemoryKeyStore final : public FamilyKeyStore
{
public:
    MemoryKeyStore(std::string asset, std::optional<Key>& key) : asset_(std::move(asset)), key_(key)
    {
    }
    [[nodiscard]] std::string name() const override { return "asset " + asset_; }
    [[nodiscard]] std::string single_owner_advice() const override
    {
        return "the catalogue's assets are marked with family keys.";
    }
    [[nodiscard]] std::optional<Key> peek() const override { return key_; }
    double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) override
    {
        if (std::optional<Key> changed = update(key_))
        {
            key_ = std::move(changed);
        }
        return 0.0;
    }

private:
    std::string asset_;
    std::optional<Key>& key_;
};

}  // namespace

nlohmann::json CatalogMarkTask::to_json() const
{
    nlohmann::json options = {{"k", embed.embed.basis_size},
                              {"m", embed.embed.coefficients},
                              {"strength", embed.embed.strength}};
    if (embed.message)
    {
        options["message"] = *embed.message;
    }
    if (embed.seed)
    {
        options["seed"] = std::to_string(*embed.seed);  // as text: JSON numbers lose 64 bits
    }
    nlohmann::json json = {{"file", file},
                           {"asset", asset},
                           {"input", input.string()},
                           {"original", original.string()},
                           {"original_sha256", original_sha256},
                           {"output_folder", output_folder.string()},
                           {"published", published.string()},
                           {"embed", std::move(options)}};
    if (key)
    {
        json["key"] = meshmark::to_json(*key);
    }
    return json;
}

std::string CatalogMarkTask::name() const
{
    nlohmann::json content = to_json();
    content.erase("file");
    content.erase("input");
    const std::string text = content.dump();
    char name[64];
    std::snprintf(name, sizeof name, "meshmark-add-%.12s-%016llx", original_sha256.c_str(),
                  static_cast<unsigned long long>(hash_bytes(text.data(), text.size())));
    return name;
}

CatalogMarkTask parse_mark_task(const nlohmann::json& json)
{
    constexpr const char* kWhat = "a catalogue marking task";
    CatalogMarkTask task;
    task.file = field<std::size_t>(json, "file", kWhat);
    task.asset = field<std::string>(json, "asset", kWhat);
    task.input = field<std::string>(json, "input", kWhat);
    task.original = field<std::string>(json, "original", kWhat);
    task.original_sha256 = field<std::string>(json, "original_sha256", kWhat);
    task.output_folder = field<std::string>(json, "output_folder", kWhat);
    task.published = field<std::string>(json, "published", kWhat);
    const auto options = field<nlohmann::json>(json, "embed", kWhat);
    task.embed.embed.basis_size = field<int>(options, "k", kWhat);
    task.embed.embed.coefficients = field<int>(options, "m", kWhat);
    task.embed.embed.strength = field<double>(options, "strength", kWhat);
    if (options.contains("message"))
    {
        task.embed.message = field<std::string>(options, "message", kWhat);
    }
    if (options.contains("seed"))
    {
        const auto text = field<std::string>(options, "seed", kWhat);
        try
        {
            task.embed.seed = std::stoull(text);
        }
        catch (const std::exception&)
        {
            throw InvalidOption(std::string(kWhat) + " with a seed that is not a number.");
        }
    }
    if (json.contains("key"))
    {
        task.key = parse_key(field<std::string>(json, "key", kWhat), kWhat);
    }
    return task;
}

nlohmann::json CatalogMarkedAsset::to_json() const
{
    nlohmann::json json = {{"outcome", meshmark::to_json(outcome)},
                           {"signature", hex_of(signature)},
                           {"faces", face_count}};
    if (key)
    {
        json["key"] = meshmark::to_json(*key);
    }
    return json;
}

CatalogMarkedAsset parse_marked_asset(const nlohmann::json& json)
{
    constexpr const char* kWhat = "a marked asset";
    CatalogMarkedAsset marked;
    marked.outcome = parse_add_outcome(field<nlohmann::json>(json, "outcome", kWhat));
    marked.signature = bytes_of_hex(field<std::string>(json, "signature", kWhat));
    marked.face_count = field<std::int64_t>(json, "faces", kWhat);
    if (json.contains("key"))
    {
        marked.key = parse_key(field<std::string>(json, "key", kWhat), kWhat);
    }
    return marked;
}

CatalogMarkedAsset catalog_mark(const CatalogMarkTask& task, int threads)
{
    CatalogMarkedAsset marked;
    try
    {
        // The bytes the coordinator planned for, or none: a task names its original's hash.
        if (file_sha256(task.original) != task.original_sha256)
        {
            throw IoError(task.input.string() +
                          ": the original changed since the catalogue add began; run it again.");
        }
        const catalog_detail::StagingFolder staging;
        marked.key = task.key;
        marked.outcome = catalog_detail::mark_asset(
            task, staging.path(), threads,
            [&](CatalogAsset prototype, ShapeSignature shape) -> std::unique_ptr<FamilyKeyStore>
            {
                marked.signature = shape.to_bytes();
                marked.face_count = prototype.face_count;
                return std::make_unique<MemoryKeyStore>(task.asset, marked.key);
            });
        if (marked.outcome.status != CatalogAddOutcome::Status::Marked)
        {
            marked.key.reset();
            return marked;
        }
        // Every file the marking wrote, the copy itself last.
        const fs::path copy = staging.path() / task.asset;
        for (auto it = fs::recursive_directory_iterator(staging.path());
             it != fs::recursive_directory_iterator(); ++it)
        {
            if (it->is_regular_file() && it->path() != copy)
            {
                marked.files.emplace_back(
                    it->path().lexically_relative(staging.path()).generic_string(),
                    catalog_detail::read_staged(it->path()));
            }
        }
        std::sort(marked.files.begin(), marked.files.end());
        marked.files.emplace_back(task.asset, catalog_detail::read_staged(copy));
    }
    catch (const std::exception& e)
    {
        marked.outcome.path = task.input;
        marked.outcome.asset = task.asset;
        marked.outcome.status = CatalogAddOutcome::Status::Failed;
        marked.outcome.reason = e.what();
        marked.key.reset();
        marked.files.clear();
    }
    return marked;
}

CatalogAddOutcome catalog_record(Catalog& catalog, const CatalogMarkTask& task,
                                 CatalogMarkedAsset marked)
{
    CatalogAddOutcome outcome = std::move(marked.outcome);
    if (outcome.status != CatalogAddOutcome::Status::Marked)
    {
        return outcome;
    }
    try
    {
        if (!marked.key || marked.files.empty() || marked.files.back().first != task.asset)
        {
            throw InvalidOption(task.input.string() + ": the marked asset came back incomplete.");
        }
        if (const std::optional<CatalogAsset> known = catalog.asset(task.asset);
            known && known->is_complete && known->original_sha256 == task.original_sha256)
        {
            outcome.status = CatalogAddOutcome::Status::Present;  // recorded meanwhile
            outcome.published = known->published;
            return outcome;
        }
        CatalogAsset prototype;
        prototype.id = task.asset;
        prototype.original = task.original;
        prototype.original_sha256 = task.original_sha256;
        prototype.published = task.published;
        prototype.vertex_count = outcome.vertex_count;
        prototype.face_count = marked.face_count;
        const std::unique_ptr<FamilyKeyStore> store = catalog.family_store(
            task.asset, std::move(prototype), ShapeSignature::from_bytes(marked.signature));
        const std::string made = to_json(*marked.key);
        (void)store->change(
            [&](std::optional<Key> now) -> std::optional<Key>
            {
                if (!now)
                {
                    return marked.key;
                }
                if (to_json(*now) != made)
                {
                    throw IoError(task.input.string() + ": asset '" + task.asset +
                                  "' was recorded meanwhile with another key; run the add again.");
                }
                return std::nullopt;  // this task's key, recorded by an interrupted run
            });
        // Recorded: now the files, the published copy last.
        for (const auto& [relative, bytes] : marked.files)
        {
            catalog_detail::write_unless_same(task.output_folder / relative, bytes);
        }
        IssuedCopy copy;
        copy.name = kPublishedRecipient;
        copy.path = task.published;
        if (const Recipient* r = marked.key->recipients
                                     ? marked.key->recipients->find(kPublishedRecipient)
                                     : nullptr)
        {
            copy.index = r->index;
        }
        store->delivered({copy});
        outcome.published = task.published;
    }
    catch (const std::exception& e)
    {
        outcome.status = CatalogAddOutcome::Status::Failed;
        outcome.reason = e.what();
        outcome.published.clear();
    }
    return outcome;
}

}  // namespace meshmark
