// SPDX-License-Identifier: MIT
// `catalog add`: every mesh file of a tree marked, its published copy written, all recorded.
#include "meshmark/catalog/catalog_add.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <exception>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <string_view>
#include <thread>

#include "catalog/catalog_add_impl.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/hash.h"
#include "meshmark/core/threads.h"
#include "meshmark/io/file_bytes.h"
#include "meshmark/io/obj_materials.h"

namespace meshmark
{
namespace fs = std::filesystem;

const char* to_string(CatalogAddOutcome::Status status) noexcept
{
    switch (status)
    {
        case CatalogAddOutcome::Status::Marked:
            return "marked";
        case CatalogAddOutcome::Status::Present:
            return "present";
        case CatalogAddOutcome::Status::Unmarkable:
            return "unmarkable";
        case CatalogAddOutcome::Status::Failed:
            return "failed";
    }
    return "failed";
}

namespace
{

bool is_mesh_file(const fs::path& path)
{
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    static const std::set<std::string> kExtensions = {".ply",  ".obj", ".off", ".stl",
                                                      ".gltf", ".glb", ".3mf"};
    return kExtensions.contains(ext);
}

bool is_hidden(const fs::path& relative)
{
    return std::any_of(relative.begin(), relative.end(),
                       [](const fs::path& part)
                       {
                           const std::string s = part.string();
                           return s.size() > 1 && s[0] == '.' && s != "..";
                       });
}

// A relative path that stays below its folder ("a/b.png", not "../b.png" nor "/b.png").
bool stays_inside(const fs::path& relative)
{
    const fs::path normal = relative.lexically_normal();
    return normal.is_relative() && !normal.empty() && *normal.begin() != "..";
}

// The outcome of a failure: InvalidMesh and NumericalError say the mesh cannot carry a mark.
CatalogAddOutcome failed(CatalogAddOutcome outcome, const std::exception& e, bool unmarkable)
{
    outcome.status =
        unmarkable ? CatalogAddOutcome::Status::Unmarkable : CatalogAddOutcome::Status::Failed;
    outcome.reason = e.what();
    return outcome;
}

}  // namespace

namespace catalog_detail
{

std::string read_staged(const fs::path& path)
{
    return read_file(path);
}

void write_unless_same(const fs::path& to, const std::string& bytes)
{
    std::error_code error;
    if (fs::is_regular_file(to, error) && fs::file_size(to, error) == bytes.size() &&
        read_file(to) == bytes)
    {
        return;
    }
    write_file_atomically(to, [&](std::ostream& out) { out << bytes; });
}

namespace
{

// Copies \p from to \p to (folders made) unless \p to already holds the same bytes.
void copy_beside(const fs::path& from, const fs::path& to)
{
    std::string bytes;
    try
    {
        bytes = read_file(from);
    }
    catch (const IoError&)
    {
        throw IoError(from.string() + ": cannot read this file that the mesh references.");
    }
    write_unless_same(to, bytes);
}

}  // namespace

// The copy's folder shows what the original's does (a glTF's writer copies its images itself;
// io/obj.cpp, material_library_edits, links back what is left out): the OBJ's material
// libraries and their textures, each relative to the file that names it.
void copy_obj_materials(const fs::path& input, const fs::path& output)
{
    const fs::path from = input.parent_path();
    const fs::path to = output.parent_path();
    std::error_code error;
    for (const MaterialLibraryStatement& statement : material_libraries(read_file(input), from))
    {
        for (const std::string& name : statement.names)
        {
            if (!stays_inside(name) || !fs::is_regular_file(from / name, error))
            {
                continue;
            }
            copy_beside(from / name, to / name);
            const fs::path library_folder = fs::path(name).parent_path();
            for (const std::string& texture : material_textures(read_file(from / name)))
            {
                const fs::path relative = library_folder / texture;
                if (stays_inside(relative) && fs::is_regular_file(from / relative, error))
                {
                    copy_beside(from / relative, to / relative);
                }
            }
        }
    }
}

namespace
{

// A key store that copies an OBJ's materials beside its copy once the key is made (change()).
class MaterialsOnRecord final : public FamilyKeyStore
{
public:
    MaterialsOnRecord(FamilyKeyStore& inner, fs::path obj, fs::path copy)
        : inner_(inner), obj_(std::move(obj)), copy_(std::move(copy))
    {
    }
    [[nodiscard]] std::string name() const override { return inner_.name(); }
    [[nodiscard]] std::string single_owner_advice() const override
    {
        return inner_.single_owner_advice();
    }
    [[nodiscard]] std::optional<Key> peek() const override { return inner_.peek(); }
    double change(const std::function<std::optional<Key>(std::optional<Key>)>& update) override
    {
        const double waited = inner_.change(update);
        if (!obj_.empty())
        {
            copy_obj_materials(obj_, copy_);
            obj_.clear();
        }
        return waited;
    }
    void delivered(const std::vector<IssuedCopy>& copies) override { inner_.delivered(copies); }

private:
    FamilyKeyStore& inner_;
    fs::path obj_;
    fs::path copy_;
};

}  // namespace

CatalogAddOutcome mark_asset(const CatalogMarkTask& task, const fs::path& output_root, int threads,
                             const KeyStoreFactory& store_of)
{
    const auto start = std::chrono::steady_clock::now();
    CatalogAddOutcome outcome;
    outcome.path = task.input;
    outcome.asset = task.asset;
    const auto finish = [&](CatalogAddOutcome done)
    {
        done.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return done;
    };
    try
    {
        // A file the readers refuse failed; a mesh read but unable to carry a mark (below) is
        // unmarkable.
        std::optional<MeshFile> read;
        try
        {
            read.emplace(read_mesh_file(task.original));
        }
        catch (const Error& e)
        {
            return finish(failed(std::move(outcome), e, false));
        }
        const MeshFile& file = *read;
        outcome.vertex_count = file.mesh.vertex_count();
        CatalogAsset prototype;
        prototype.id = task.asset;
        prototype.original = task.original;
        prototype.original_sha256 = task.original_sha256;
        prototype.published = task.published;
        prototype.vertex_count = file.mesh.vertex_count();
        prototype.face_count = file.mesh.face_count();
        ShapeSignature signature = shape_signature(file.mesh);
        EmbedRecipientsOptions embed = task.embed;
        embed.recipients = {kPublishedRecipient};
        embed.threads = threads;
        embed.progress = nullptr;
        const fs::path copy = output_root / task.asset;
        if (copy != task.published)
        {
            embed.link_folder = [&task](const fs::path&) { return task.published.parent_path(); };
        }
        const std::unique_ptr<FamilyKeyStore> recorded =
            store_of(std::move(prototype), std::move(signature));
        // An OBJ's materials are copied once its key is made (a mesh that cannot carry a mark
        // leaves none: the output folder holds the same whether it was marked here or on a
        // worker), before its copy is written (the writer finds them beside it).
        MaterialsOnRecord store(*recorded,
                                file.format == MeshFormat::Obj ? task.original : fs::path(), copy);
        (void)embed_recipients(
            task.original, &file, [&](const std::string&) { return copy; }, store, embed);
        outcome.status = CatalogAddOutcome::Status::Marked;
        outcome.published = task.published;
    }
    catch (const InvalidMesh& e)
    {
        outcome = failed(std::move(outcome), e, true);
    }
    catch (const NumericalError& e)
    {
        outcome = failed(std::move(outcome), e, true);
    }
    catch (const std::exception& e)
    {
        outcome = failed(std::move(outcome), e, false);
    }
    return finish(std::move(outcome));
}

}  // namespace catalog_detail

std::vector<std::pair<fs::path, std::string>> find_mesh_files(const std::vector<fs::path>& inputs,
                                                              const fs::path& skip)
{
    std::vector<std::pair<fs::path, std::string>> found;
    std::error_code error;
    const fs::path skipped = skip.empty() ? fs::path() : fs::weakly_canonical(skip, error);
    for (const fs::path& input : inputs)
    {
        if (fs::is_regular_file(input, error))
        {
            found.emplace_back(input, input.filename().generic_string());
            continue;
        }
        if (!fs::is_directory(input, error))
        {
            throw InvalidOption(input.string() + ": no such file or folder.");
        }
        std::vector<std::pair<fs::path, std::string>> here;
        for (auto it = fs::recursive_directory_iterator(
                 input, fs::directory_options::skip_permission_denied, error);
             it != fs::recursive_directory_iterator(); it.increment(error))
        {
            if (error)
            {
                throw IoError(input.string() + ": cannot list the folder (" + error.message() +
                              ").");
            }
            const fs::path relative = it->path().lexically_relative(input);
            if (is_hidden(relative) ||
                (!skipped.empty() && fs::weakly_canonical(it->path(), error) == skipped))
            {
                if (it->is_directory(error))
                {
                    it.disable_recursion_pending();
                }
                continue;
            }
            if (it->is_regular_file(error) && is_mesh_file(it->path()))
            {
                here.emplace_back(it->path(), relative.generic_string());
            }
        }
        std::sort(here.begin(), here.end(),
                  [](const auto& a, const auto& b) { return a.second < b.second; });
        found.insert(found.end(), here.begin(), here.end());
    }
    return found;
}

CatalogAddPlan catalog_plan_add(Catalog& catalog, const std::vector<fs::path>& inputs,
                                const fs::path& output_folder, const CatalogAddOptions& options)
{
    if (options.jobs < 0)
    {
        throw InvalidOption("--jobs must be >= 0 (0 = one more than the cores).");
    }
    {
        EmbedRecipientsOptions check = options.embed;
        check.recipients = {kPublishedRecipient};
        check.validate();
    }
    if (output_folder.empty())
    {
        throw InvalidOption("name the folder of the marked copies with -o.");
    }
    const auto files = find_mesh_files(inputs, output_folder);
    const fs::path output_root = fs::absolute(output_folder).lexically_normal();
    CatalogAddPlan plan;
    plan.outcomes.resize(files.size());
    std::set<std::string> claimed;  // two files naming one asset in this call: the first claims it
    // The originals' SHA-256 first, on every core (read one after another, the 377 MB of 820
    // artists' OBJ files took 0.8 s of a 16 s add with the other core idle); a file that
    // cannot be read fails below, where it would have been read.
    std::vector<std::string> digests(files.size());
    std::vector<std::exception_ptr> unreadable(files.size());
    for_each_index(files.size(), resolve_threads(options.embed.threads),
                   [&](std::size_t f)
                   {
                       try
                       {
                           digests[f] =
                               file_sha256(fs::absolute(files[f].first).lexically_normal());
                       }
                       catch (...)
                       {
                           unreadable[f] = std::current_exception();
                       }
                   });
    std::random_device device;
    for (std::size_t f = 0; f < files.size(); ++f)
    {
        const auto start = std::chrono::steady_clock::now();
        const auto& [input, id] = files[f];
        CatalogAddOutcome& outcome = plan.outcomes[f];
        outcome.path = input;
        outcome.asset = id;
        CatalogMarkTask task;
        task.file = f;
        task.asset = id;
        task.input = input;
        task.output_folder = output_root;
        task.published = (output_root / id).lexically_normal();
        try
        {
            if (!claimed.insert(id).second)
            {
                throw InvalidOption(input.string() +
                                    ": another file of this call is already asset '" + id +
                                    "'; add the two from separate folders.");
            }
            task.original = fs::absolute(input).lexically_normal();
            if (is_same_file(task.original, task.published))
            {
                throw InvalidOption(
                    input.string() +
                    ": the marked copy would replace the original; choose another -o.");
            }
            if (unreadable[f])
            {
                std::rethrow_exception(unreadable[f]);
            }
            task.original_sha256 = std::move(digests[f]);
            if (const std::optional<CatalogAsset> known = catalog.asset(id))
            {
                if (known->original != task.original)
                {
                    throw InvalidOption(input.string() + ": the catalogue's asset '" + id +
                                        "' is another file, " + known->original.string() +
                                        "; add this one from another folder.");
                }
                if (known->original_sha256 == task.original_sha256 && known->is_complete)
                {
                    outcome.status = CatalogAddOutcome::Status::Present;
                    outcome.published = known->published;
                    outcome.vertex_count = known->vertex_count;
                    outcome.seconds =
                        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
                            .count();
                    continue;
                }
                if (known->original_sha256 != task.original_sha256)
                {
                    if (known->is_complete && !options.force)
                    {
                        throw InvalidOption(
                            input.string() +
                            ": the original changed since it was added as asset '" + id +
                            "'; pass --force to mark it again with a new key (copies "
                            "issued before are then no longer traced).");
                    }
                    catalog.remove(id);  // an interrupted add of other bytes, or --force
                }
                else
                {
                    task.key = known->key;  // an interrupted add of these bytes: its key again
                }
            }
            task.embed = options.embed;
            task.embed.progress = nullptr;
            task.embed.seed =
                options.embed.seed
                    ? splitmix64(*options.embed.seed ^ hash_bytes(id.data(), id.size()))
                    : (std::uint64_t{device()} << 32U) ^ device();
            plan.tasks.push_back(std::move(task));
        }
        catch (const std::exception& e)
        {
            outcome = failed(std::move(outcome), e, false);
            outcome.seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        }
    }
    return plan;
}

std::vector<CatalogAddOutcome> catalog_add(Catalog& catalog, const std::vector<fs::path>& inputs,
                                           const fs::path& output_folder,
                                           const CatalogAddOptions& options)
{
    CatalogAddPlan plan = catalog_plan_add(catalog, inputs, output_folder, options);
    const std::size_t total = plan.outcomes.size();
    // One more file than cores: each file's writes wait on the disk (its copy and the
    // catalogue's records are synced before the next step), and another file's work fills that
    // core meanwhile (820 artists' OBJ files on 2 cores: 10.2 s with 2 at once, 9.5 s with 3;
    // bench/results/2026-11-30-add-and-scan.md).
    const int cores = resolve_threads(0);
    const int jobs =
        std::max(1, std::min<int>(options.jobs > 0 ? options.jobs : cores + 1,
                                  static_cast<int>(std::max<std::size_t>(plan.tasks.size(), 1))));
    const int threads = std::max(1, resolve_threads(options.embed.threads) / jobs);
    std::atomic<std::size_t> done{total - plan.tasks.size()};
    std::mutex progress_mutex;
    for_each_index(plan.tasks.size(), jobs,
                   [&](std::size_t t)
                   {
                       const CatalogMarkTask& task = plan.tasks[t];
                       // Marked in place: the catalogue's store records the key before the copy is
                       // written.
                       plan.outcomes[task.file] = catalog_detail::mark_asset(
                           task, task.output_folder, threads,
                           [&](CatalogAsset prototype, ShapeSignature shape) {
                               return catalog.family_store(task.asset, std::move(prototype),
                                                           std::move(shape));
                           });
                       const std::size_t finished = ++done;
                       if (options.progress)
                       {
                           const std::lock_guard lock(progress_mutex);
                           options.progress(
                               "files", static_cast<double>(finished) / static_cast<double>(total));
                       }
                   });
    return std::move(plan.outcomes);
}

}  // namespace meshmark
