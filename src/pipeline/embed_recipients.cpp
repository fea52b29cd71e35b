// SPDX-License-Identifier: MIT
// One marked copy per recipient from one watermark: the owner's field once, then each code's.
#include "meshmark/pipeline/embed_recipients.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <exception>
#include <fstream>
#include <functional>
#include <future>
#include <limits>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <unordered_map>

#include "embed_streamed.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/file_lock.h"
#include "meshmark/core/threads.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/family_copies.h"
#include "timer.h"

namespace meshmark
{

void EmbedRecipientsOptions::validate() const
{
    EmbedMeshOptions::validate();
    if (max_displacement > 0.0)
    {
        throw InvalidOption(
            "--max-displacement does not apply to recipient copies: a family key has one strength "
            "for "
            "every copy, present and future, and each recipient's code moves the vertices "
            "differently; "
            "cap a single copy (embed without --recipient) instead.");
    }
    if (recipients.empty())
    {
        throw InvalidOption("name at least one recipient (--recipient NAME or --recipients FILE).");
    }
    for (const std::string& name : recipients)
    {
        check_recipient_name(name);
    }
    if (lock_timeout.count() < 0)
    {
        throw InvalidOption("--lock-timeout must be >= 0 seconds.");
    }
}

std::filesystem::path recipient_output(const std::string& pattern, const std::string& name)
{
    const std::string placeholder = kRecipientPlaceholder;
    if (pattern.find(placeholder) == std::string::npos)
    {
        throw InvalidOption("-o '" + pattern + "' must contain " + placeholder +
                            " (one copy per recipient, e.g. out/" + placeholder + ".ply).");
    }
    std::string path = pattern;
    for (std::size_t at = path.find(placeholder); at != std::string::npos;
         at = path.find(placeholder, at + name.size()))
    {
        path.replace(at, placeholder.size(), name);
    }
    return path;
}

namespace
{

// \p key, as the store holds it, checked: a family key, made for \p mesh.
Key checked_family_key(Key key, const FamilyKeyStore& store, const MeshFingerprint& original,
                       const std::filesystem::path& input)
{
    if (!key.recipients)
    {
        throw IoError(store.name() +
                      ": this key marks a single owner's copy, not a family of recipients; " +
                      store.single_owner_advice());
    }
    if (original != key.original)
    {
        throw IoError(input.string() + ": this is not the original the family key " + store.name() +
                      " was made for (vertex count, face count or positions differ).");
    }
    return key;
}

// A family key in its own file, changed under the file's lock (file_lock.h).
class KeyFileStore final : public FamilyKeyStore
{
public:
    KeyFileStore(std::filesystem::path path, const EmbedRecipientsOptions& options)
        : path_(std::move(path)), options_(options)
    {
    }
    [[nodiscard]] std::string name() const override { return path_.string(); }
    [[nodiscard]] std::string single_owner_advice() const override
    {
        return "choose a new --key file to start a family.";
    }
    [[nodiscard]] std::optional<Key> peek() const override
    {
        if (!std::filesystem::exists(path_))
        {
            return std::nullopt;
        }
        return read_key(path_);
    }
    double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) override
    {
        const FileLock lock = detail::lock_key(path_, options_.lock_timeout, options_.progress);
        std::optional<Key> now;
        if (std::filesystem::exists(path_))
        {
            now = read_key(path_);
        }
        if (const std::optional<Key> changed = update(std::move(now)))
        {
            write_key(path_, *changed);
        }
        return lock.waited_seconds();
    }

private:
    std::filesystem::path path_;
    const EmbedRecipientsOptions& options_;
};

// True when \p a and \p b make the same watermark: everything but the recipients agrees. A
// family key's parameters never change once written, so this fails only when the file was
// replaced by another key between two reads.
bool same_watermark(Key a, Key b)
{
    a.recipients->recipients.clear();
    b.recipients->recipients.clear();
    return to_json(a) == to_json(b);
}

// The names of \p names in order, each once: a name given twice is issued once (one copy).
std::vector<std::string> distinct(const std::vector<std::string>& names)
{
    std::set<std::string> seen;
    std::vector<std::string> kept;
    for (const std::string& name : names)
    {
        if (seen.insert(name).second)
        {
            kept.push_back(name);
        }
    }
    return kept;
}

}  // namespace

std::vector<IssuedCopy> assign_recipient_indices(
    Key& key, const std::vector<std::string>& names,
    const std::function<std::filesystem::path(const std::string&)>& output_of)
{
    RecipientCodes& codes = *key.recipients;
    // One lookup table rather than RecipientCodes::find per name: a call issuing thousands
    // of copies against a key holding thousands would otherwise be quadratic.
    std::unordered_map<std::string, std::uint32_t> known;
    known.reserve(codes.recipients.size() + names.size());
    std::uint32_t next = 0;
    for (const Recipient& r : codes.recipients)
    {
        known.emplace(r.name, r.index);
        next = std::max(next, r.index + 1);
    }
    std::vector<IssuedCopy> copies;
    for (const std::string& name : names)
    {
        IssuedCopy copy;
        copy.name = name;
        copy.path = output_of(name);
        if (const auto it = known.find(name); it != known.end())
        {
            copy.index = it->second;
        }
        else
        {
            if (next == std::numeric_limits<std::uint32_t>::max())
            {
                throw InvalidOption("the family key holds as many recipients as it can.");
            }
            copy.index = next++;
            copy.is_new = true;
            codes.recipients.push_back({name, copy.index});
            known.emplace(name, copy.index);
        }
        copies.push_back(std::move(copy));
    }
    return copies;
}

EmbedRecipientsReport embed_recipients(const std::filesystem::path& input,
                                       const std::string& output_pattern,
                                       const std::filesystem::path& key_path,
                                       const EmbedRecipientsOptions& options)
{
    options.validate();
    (void)recipient_output(output_pattern, "x");  // the placeholder, before any work
    if (is_same_file(input, key_path))
    {
        throw InvalidOption(key_path.string() + ": the key file must differ from the input.");
    }
    for (const std::string& name : options.recipients)
    {
        if (recipient_output(output_pattern, name) == key_path)
        {
            throw InvalidOption(key_path.string() +
                                ": a recipient's copy may replace neither the input nor the key.");
        }
    }
    KeyFileStore store(key_path, options);
    return embed_recipients(
        input, nullptr,
        [&](const std::string& name) { return recipient_output(output_pattern, name); }, store,
        options);
}

EmbedRecipientsReport embed_recipients(
    const std::filesystem::path& input, const MeshFile* given,
    const std::function<std::filesystem::path(const std::string&)>& output_of,
    FamilyKeyStore& store, const EmbedRecipientsOptions& options)
{
    options.validate();
    for (const std::string& name : options.recipients)
    {
        const std::filesystem::path path = output_of(name);
        (void)format_from_extension(path);
        if (is_same_file(input, path))
        {
            throw InvalidOption(path.string() +
                                ": a recipient's copy may replace neither the input nor the key.");
        }
    }
    if (options.embed.basis == BasisType::Laplacian ||
        options.embed.rule != EmbeddingRule::Additive)
    {
        throw InvalidOption("recipient copies need the RBF basis and the additive rule.");
    }

    EmbedRecipientsReport report;
    detail::PhaseTimer timer(report.seconds, options.progress);
    timer.begin("read");
    std::optional<MeshFile> read;
    if (given == nullptr)
    {
        read.emplace(read_mesh_file(input));
    }
    const MeshFile& file = given != nullptr ? *given : *read;
    report.input_format = file.format;
    report.vertex_count = file.mesh.vertex_count();
    report.face_count = file.mesh.face_count();
    check_basis_input(file.mesh, options.embed, input);
    timer.lap("read");

    timer.begin("basis");
    const std::vector<std::string> names = distinct(options.recipients);
    const MeshFingerprint original = fingerprint(file.mesh);
    // The watermark depends only on the key's parameters, which a family key never changes: an
    // existing key is read without the lock (a key file is replaced whole, by a rename, never
    // written in place) and its basis built while other calls may be issuing on it.
    std::optional<Key> seen = store.peek();
    if (seen)
    {
        seen = checked_family_key(std::move(*seen), store, original, input);
    }
    std::optional<SpectralWatermark> mark;
    if (seen)
    {
        mark.emplace(watermark_of(file.mesh, *seen, input, options.threads));
    }
    Key key;
    EmbedStats owner_stats;
    Positions owner;
    // A new family key, its watermark and the owner's mark (the basis and the calibration: most
    // of a small file's embedding).
    const auto make_key = [&]
    {
        key = detail::new_key(options);
        key.recipients = RecipientCodes{options.recipient_modes, options.recipient_share, {}};
        key.recipients->validate(key.options);
        key.recipients->shorten_to_span = true;
        key.original = original;
        mark.emplace(watermark_of(file.mesh, key, input, options.threads));
        // The automatic repetitions and the code's modes, as the watermark resolved them.
        key.options = mark->key().options;
        key.recipients->modes = mark->key().recipients->modes;
        key.recipients->shorten_to_span = false;
        owner = mark->displacement(&owner_stats);
        // A new family key is calibrated on the owner's mark, at its share of the energy
        // (docs/algorithms/embedding.md, "Strength"); each copy's code is scaled below.
        if (key.options.needs_calibration())
        {
            mark->calibrate_strength(file.mesh, owner, &owner_stats);
            key.options.vertex_strength = mark->key().options.vertex_strength;
            // Synthesized again from the recorded strength, as a later call adding recipients
            // does: the scaled field may differ from it in the last bit, the copies may not.
            owner = mark->displacement(&owner_stats);
        }
    };
    // With no key yet, one is made before the store's step, outside its lock: calls marking
    // other assets of a catalogue at once then build their bases at once (inside, they took
    // turns). It is used only if the store still has none when its step runs.
    const bool made_before = !seen;
    if (made_before)
    {
        make_key();
    }
    // Issuing is one step of the store (under the key file's lock, or a catalogue's
    // transaction): the key as it is now, the indices of the new names, the key recorded durably
    // (file and folder fsync'ed, or committed). Copies are made only after it: recorded before
    // released (docs/fingerprinting.md, "Issuing at once").
    const Key prepared = key;
    const double waited = store.change(
        [&](std::optional<Key> now) -> std::optional<Key>
        {
            report.key_created = !now.has_value();
            if (report.key_created)
            {
                if (made_before && mark)
                {
                    key = prepared;
                }
                else
                {
                    make_key();
                }
            }
            else
            {
                key = checked_family_key(std::move(*now), store, original, input);
                if (made_before || (seen && !same_watermark(*seen, key)))
                {
                    // made here but another call recorded its key first, or replaced
                    // meanwhile by another family key of this original
                    mark.reset();
                }
            }
            report.copies = assign_recipient_indices(key, names, output_of);
            const bool adds = std::any_of(report.copies.begin(), report.copies.end(),
                                          [](const IssuedCopy& copy) { return copy.is_new; });
            return report.key_created || adds ? std::optional<Key>(key) : std::nullopt;
        });
    if (!mark)
    {
        mark.emplace(watermark_of(file.mesh, key, input, options.threads));
    }
    if (!report.key_created)
    {
        owner = mark->displacement(&owner_stats);
    }
    const FamilyCopies family(file, std::move(*mark), std::move(owner), owner_stats);
    timer.lap("basis");

    // The copies this call created, with their file's identity: on a failure those still ours are
    // removed (another call issuing the same name may have replaced one with its own since).
    std::vector<std::pair<std::filesystem::path, FileIdentity>> created;
    // One phase, "copies", with a progress fraction per copy; the time spent synthesizing the
    // codes' fields and writing is reported as "codes" and "write" inside it.
    double code_seconds = 0.0;
    double write_seconds = 0.0;
    using Clock = std::chrono::steady_clock;
    auto seconds_since = [](Clock::time_point t)
    { return std::chrono::duration<double>(Clock::now() - t).count(); };
    timer.begin("copies");
    const int threads = resolve_threads(options.threads);
    // Copies are made kBatch at a time (FamilyCopies::make: a copy's bytes do not depend on the
    // batch, so a re-issue reproduces it); the previous batch is written on another thread
    // meanwhile (the writes wait on the disk, the sums on the CPU).
    constexpr std::size_t kBatch = FamilyCopies::kBatch;
    // Two sets of kBatch copies, reused: one being computed while the other is written.
    std::array<std::vector<Positions>, 2> buffers;
    auto make_batch = [&](std::size_t first, std::size_t count, std::vector<Positions>& positions)
    {
        const auto code_start = Clock::now();
        std::array<std::uint32_t, kBatch> indices{};
        std::array<EmbedStats, kBatch> stats{};
        for (std::size_t b = 0; b < count; ++b)
        {
            indices[b] = report.copies[first + b].index;
        }
        family.make(std::span(indices.data(), count), positions, std::span(stats.data(), count),
                    threads);
        for (std::size_t b = 0; b < count; ++b)
        {
            report.copies[first + b].stats = stats[b];
        }
        code_seconds += seconds_since(code_start);
    };
    // A batch's files are written by kWriters threads at once: each write ends in an fsync
    // that waits on the device, so one writer leaves it idle between files.
    constexpr std::size_t kWriters = 4;
    std::mutex created_mutex;
    auto write_batch = [&](std::size_t first, const std::vector<Positions>& positions)
    {
        const auto write_start = Clock::now();
        std::vector<std::future<void>> writers;
        for (std::size_t w = 0; w < std::min(kWriters, positions.size()); ++w)
        {
            writers.push_back(
                std::async(std::launch::async,
                           [&, w]
                           {
                               for (std::size_t b = w; b < positions.size(); b += kWriters)
                               {
                                   const IssuedCopy& copy = report.copies[first + b];
                                   const bool existed = std::filesystem::exists(copy.path);
                                   WriteOptions write;
                                   if (options.link_folder)
                                   {
                                       write.link_folder = options.link_folder(copy.path);
                                   }
                                   write_mesh_file(copy.path, file, positions[b], write);
                                   if (!existed)
                                   {
                                       const std::lock_guard lock(created_mutex);
                                       created.emplace_back(copy.path, file_identity(copy.path));
                                   }
                               }
                           }));
        }
        std::exception_ptr failure;
        for (auto& writer : writers)
        {
            try
            {
                writer.get();
            }
            catch (...)
            {
                failure = failure ? failure : std::current_exception();
            }
        }
        write_seconds += seconds_since(write_start);
        if (failure)
        {
            std::rethrow_exception(failure);
        }
    };
    auto write_copies = [&]()
    {
        std::future<void> writing;
        std::size_t batch_index = 0;
        for (std::size_t first = 0; first < report.copies.size(); first += kBatch, ++batch_index)
        {
            std::vector<Positions>& batch = buffers[batch_index % 2];
            make_batch(first, std::min(kBatch, report.copies.size() - first), batch);
            if (writing.valid())
            {
                writing.get();  // the other buffer is free again; passes on a write's exception
            }
            writing = std::async(std::launch::async,
                                 [&write_batch, &batch, first] { write_batch(first, batch); });
            if (options.progress)
            {
                options.progress("copies", static_cast<double>(first) /
                                               static_cast<double>(report.copies.size()));
            }
        }
        if (writing.valid())
        {
            writing.get();
        }
    };
    try
    {
        write_copies();
    }
    catch (...)
    {
        // Nothing delivered. The names stay recorded in the key: a recorded name without its
        // copy accuses nobody, and another call may already have delivered the same copy; a
        // later call issues it again, byte for byte.
        for (const auto& [path, identity] : created)
        {
            if (file_identity(path) == identity)
            {
                std::error_code ignored;
                std::filesystem::remove(path, ignored);
            }
        }
        throw;
    }
    store.delivered(report.copies);
    timer.lap("copies");
    report.seconds.phases.emplace_back("codes", code_seconds);
    report.seconds.phases.emplace_back("write", write_seconds);
    report.seconds.phases.emplace_back("lock", waited);  // the part of "basis" spent waiting
    report.key = std::move(key);
    return report;
}

std::vector<std::string> read_recipients_file(const std::filesystem::path& path)
{
    std::ifstream in(path);
    if (!in)
    {
        throw IoError(path.string() + ": cannot open the recipients file.");
    }
    std::vector<std::string> names;
    std::string line;
    while (std::getline(in, line))
    {
        const auto first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos || line[first] == '#')
        {
            continue;
        }
        const auto last = line.find_last_not_of(" \t\r");
        names.push_back(line.substr(first, last - first + 1));
    }
    if (in.bad())
    {
        throw IoError(path.string() + ": cannot read the recipients file.");
    }
    return names;
}

}  // namespace meshmark
