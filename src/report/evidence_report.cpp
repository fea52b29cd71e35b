// SPDX-License-Identifier: MIT
// Which kind of report a path asks for, and writing it whole or not at all.
#include "meshmark/report/evidence_report.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <ctime>
#include <future>
#include <ostream>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

EvidenceFormat evidence_format(const std::filesystem::path& path)
{
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (ext == ".html" || ext == ".htm")
    {
        return EvidenceFormat::Html;
    }
    if (ext == ".pdf")
    {
        return EvidenceFormat::Pdf;
    }
    throw InvalidOption("--report " + path.string() + " must name a .html or a .pdf file.");
}

void write_evidence_report(const std::filesystem::path& path, const EvidenceFacts& facts,
                           const EvidencePictures& pictures)
{
    const EvidenceFormat format = evidence_format(path);
    const EvidenceText text = evidence_text(facts, pictures);
    const std::string bytes = format == EvidenceFormat::Html ? evidence_html(text, pictures)
                                                             : evidence_pdf(text, pictures);
    write_file_atomically(path, [&bytes](std::ostream& out)
                          { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

void write_detection_report(const std::filesystem::path& path, const std::filesystem::path& suspect,
                            const std::filesystem::path& original, const std::filesystem::path& key,
                            const nlohmann::json& detect, const DetectionReportOptions& options)
{
    (void)evidence_format(path);  // a wrong extension before any work
    write_detection_report(path, suspect, original, evidence_file(key), detect, options);
}

void write_detection_report(const std::filesystem::path& path, const std::filesystem::path& suspect,
                            const std::filesystem::path& original, const EvidenceFile& key,
                            const nlohmann::json& detect, const DetectionReportOptions& options)
{
    (void)evidence_format(path);  // a wrong extension before any work
    EvidenceFacts facts;
    facts.suspect = evidence_file(suspect);
    facts.original = evidence_file(original);
    facts.key = key;
    facts.detect = detect;
    facts.version = options.version;
    facts.command = options.command;
    if (options.is_dated)
    {
        const std::time_t now =
            std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
        std::tm utc{};
        gmtime_r(&now, &utc);
        char text[32];
        std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S UTC", &utc);
        facts.created = text;
    }
    // The two meshes are read at once (a text file's parsing is serial).
    std::future<MeshFile> original_read =
        std::async(std::launch::async, [&original] { return read_mesh_file(original); });
    const TriangleMesh suspect_mesh = read_mesh(suspect);
    const MeshFile original_file = original_read.get();
    const TriangleMesh& original_mesh = original_file.mesh;
    facts.unit = original_file.unit;
    facts.original_diagonal = bounding_box(original_mesh.V).diagonal();
    write_evidence_report(path, facts,
                          evidence_pictures(suspect_mesh, original_mesh, detect, options.pictures));
}

}  // namespace meshmark
