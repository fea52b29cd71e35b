// SPDX-License-Identifier: MIT
// One marked copy per recipient from one watermark: the owner's field once, then each code's.
#include "meshmark/pipeline/embed_recipients.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <set>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "embed_streamed.h"
#include "timer.h"

namespace meshmark {

void EmbedRecipientsOptions::validate() const
{
    EmbedMeshOptions::validate();
    if (recipients.empty())
    {
        throw InvalidOption("name at least one recipient (--recipient NAME or --recipients FILE).");
    }
    std::set<std::string> seen;
    for (const std::string& name : recipients)
    {
        check_recipient_name(name);
        if (!seen.insert(name).second)
        {
            throw InvalidOption("recipient '" + name + "' is named twice.");
        }
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

namespace {

// The family key: the one at key_path (checked against the input), or a new one.
Key family_key(const std::filesystem::path& key_path, const TriangleMesh& mesh, const std::filesystem::path& input,
               const EmbedRecipientsOptions& options, bool* created)
{
    *created = !std::filesystem::exists(key_path);
    if (*created)
    {
        Key key = detail::new_key(options);
        key.recipients = RecipientCodes{options.recipient_modes, options.recipient_share, {}};
        key.recipients->validate(key.options);
        key.original = fingerprint(mesh);
        return key;
    }
    Key key = read_key(key_path);
    if (!key.recipients)
    {
        throw IoError(key_path.string() + ": this key marks a single owner's copy, not a family of recipients; "
                      "choose a new --key file to start a family.");
    }
    if (fingerprint(mesh) != key.original)
    {
        throw IoError(input.string() + ": this is not the original the family key " + key_path.string() +
                      " was made for (vertex count, face count or positions differ).");
    }
    return key;
}

// The recipients of this call, each with its index: the key's for a name it holds, the next
// free one for a new name (added to the key).
std::vector<IssuedCopy> assign_indices(Key& key, const std::vector<std::string>& names, const std::string& pattern)
{
    RecipientCodes& codes = *key.recipients;
    std::uint32_t next = 0;
    for (const Recipient& r : codes.recipients)
    {
        next = std::max(next, r.index + 1);
    }
    std::vector<IssuedCopy> copies;
    for (const std::string& name : names)
    {
        IssuedCopy copy;
        copy.name = name;
        copy.path = recipient_output(pattern, name);
        if (const Recipient* known = codes.find(name))
        {
            copy.index = known->index;
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
        }
        copies.push_back(std::move(copy));
    }
    return copies;
}

// Axis-aligned bounding-box diagonal of the analysed rows (EmbedStats' unit).
double analysed_diagonal(const Positions& V, const std::vector<std::int32_t>& active)
{
    Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::RowVector3d hi = -lo;
    for (const std::int32_t i : active)
    {
        lo = lo.cwiseMin(V.row(i));
        hi = hi.cwiseMax(V.row(i));
    }
    return (hi - lo).norm();
}

}  // namespace

EmbedRecipientsReport embed_recipients(const std::filesystem::path& input, const std::string& output_pattern,
                                       const std::filesystem::path& key_path, const EmbedRecipientsOptions& options)
{
    options.validate();
    (void)recipient_output(output_pattern, "x");  // the placeholder, before any work
    if (is_same_file(input, key_path))
    {
        throw InvalidOption(key_path.string() + ": the key file must differ from the input.");
    }
    for (const std::string& name : options.recipients)
    {
        const std::filesystem::path path = recipient_output(output_pattern, name);
        (void)format_from_extension(path);
        if (is_same_file(input, path) || path == key_path)
        {
            throw InvalidOption(path.string() + ": a recipient's copy may replace neither the input nor the key.");
        }
    }
    if (options.embed.basis == BasisType::Laplacian || options.embed.rule != EmbeddingRule::Additive)
    {
        throw InvalidOption("recipient copies need the RBF basis and the additive rule.");
    }

    EmbedRecipientsReport report;
    detail::PhaseTimer timer(report.seconds, options.progress);
    timer.begin("read");
    const MeshFile file = read_mesh_file(input);
    report.input_format = file.format;
    report.vertex_count = file.mesh.vertex_count();
    report.face_count = file.mesh.face_count();
    check_basis_input(file.mesh, options.embed, input);
    timer.lap("read");

    timer.begin("basis");
    Key key = family_key(key_path, file.mesh, input, options, &report.key_created);
    report.copies = assign_indices(key, options.recipients, output_pattern);
    const SpectralWatermark mark(file.mesh, key, options.threads);
    EmbedStats owner_stats;
    Positions owner = mark.displacement(&owner_stats);
    owner += file.mesh.V;  // the positions every copy shares
    // The recipient modes, explicitly: one product per copy instead of a pass over the basis.
    const int head = key.options.first_mode + modulated_modes(key.options);
    const int modes = mark.recipient_modes();
    const Eigen::MatrixXd code_modes = mark.basis().modes_dense(head + modes).rightCols(modes);
    const std::vector<std::int32_t>& active = mark.mesh_rows()->active();
    const double diagonal = analysed_diagonal(file.mesh.V, active);
    timer.lap("basis");

    std::vector<std::filesystem::path> created;
    // One phase, "copies", with a progress fraction per copy; the time spent synthesizing the
    // codes' fields and writing is reported as "codes" and "write" inside it.
    double code_seconds = 0.0;
    double write_seconds = 0.0;
    using Clock = std::chrono::steady_clock;
    auto seconds_since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    timer.begin("copies");
    auto write_copies = [&]() {
        const int threads = resolve_threads(options.threads);
        for (std::size_t n = 0; n < report.copies.size(); ++n)
        {
            IssuedCopy& copy = report.copies[n];
            const auto code_start = Clock::now();
            // Field of the code: U_M C (file axes), row by row in a fixed order, so the copy is
            // the same bytes for any thread count and on every re-issue.
            const Eigen::MatrixX3d change = mark.recipient_change(copy.index);
            Positions positions = owner;
            const auto rows = static_cast<std::int64_t>(active.size());
#pragma omp parallel for num_threads(threads) schedule(static)
            for (std::int64_t a = 0; a < rows; ++a)
            {
                double d[3] = {0.0, 0.0, 0.0};
                for (int mode = 0; mode < modes; ++mode)
                {
                    const double u = code_modes(a, mode);
                    d[0] += u * change(mode, 0);
                    d[1] += u * change(mode, 1);
                    d[2] += u * change(mode, 2);
                }
                const auto i = active[static_cast<std::size_t>(a)];
                positions(i, 0) += d[0];
                positions(i, 1) += d[1];
                positions(i, 2) += d[2];
            }
            DisplacementSummary summary;
            for (const std::int32_t i : active)
            {
                const Eigen::RowVector3d d = positions.row(i) - file.mesh.V.row(i);
                summary.add(d.data());
            }
            mark.describe(summary, diagonal, owner_stats.orthogonality_error, &copy.stats);
            code_seconds += seconds_since(code_start);
            const auto write_start = Clock::now();
            const bool existed = std::filesystem::exists(copy.path);
            write_mesh_file(copy.path, file, positions);
            if (!existed)
            {
                created.push_back(copy.path);
            }
            write_seconds += seconds_since(write_start);
            if (options.progress)
            {
                options.progress("copies", static_cast<double>(n + 1) / static_cast<double>(report.copies.size()));
            }
        }
    };
    try
    {
        detail::write_mesh_and_key(key_path, key, write_copies);
    }
    catch (...)
    {
        for (const auto& path : created)
        {
            std::error_code ignored;
            std::filesystem::remove(path, ignored);
        }
        throw;
    }
    timer.lap("copies");
    report.seconds.phases.emplace_back("codes", code_seconds);
    report.seconds.phases.emplace_back("write", write_seconds);
    report.key = std::move(key);
    return report;
}

}  // namespace meshmark
