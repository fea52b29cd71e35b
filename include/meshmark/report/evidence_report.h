// SPDX-License-Identifier: MIT
#pragma once

/// \file
/// \brief The evidence report of `meshmark detect --report FILE.html|FILE.pdf` (docs/evidence.md):
/// one self-contained file that states in plain words what was checked and found, for readers
/// who have never heard of spectral watermarks. Every claim in it is read from the detect
/// report's JSON (detect_report_json), so the report and `--json` cannot disagree.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "meshmark/core/length_unit.h"
#include "meshmark/core/triangle_mesh.h"
#include "meshmark/render/heatmap_image.h"
#include "meshmark/render/image.h"
#include "meshmark/render/view.h"

namespace meshmark
{

/// The file kinds an evidence report is written as, chosen by the file's extension.
enum class EvidenceFormat
{
    Html,  ///< `.html` / `.htm`: one page, pictures inlined as PNG data URIs.
    Pdf,   ///< `.pdf`: A4 pages drawn by cairo.
};

/// \brief The format of a report written to \p path: `.html`, `.htm` or `.pdf` (any case).
/// \throws InvalidOption with one sentence naming \p path for any other extension.
[[nodiscard]] EvidenceFormat evidence_format(const std::filesystem::path& path);

/// A file the report names: as given, its size and its SHA-256.
struct EvidenceFile
{
    std::string name;  ///< The path as given on the command line.
    std::uintmax_t size_bytes = 0;
    std::string sha256;  ///< Lower-case hex.
};

/// \brief The name, size and SHA-256 of \p path (file_sha256).
/// \throws IoError when it cannot be read.
[[nodiscard]] EvidenceFile evidence_file(const std::filesystem::path& path);

/// What the report is made of besides the meshes.
struct EvidenceFacts
{
    EvidenceFile suspect;
    EvidenceFile original;
    /// The key file's SHA-256 stands for the key (its fingerprint); nothing else of the key (seed,
    /// payload bits) is ever written.
    EvidenceFile key;
    nlohmann::json detect;  ///< detect_report_json of the check (without diagnostics).
    std::string version;    ///< The tool's version, e.g. "meshmark 0.1.0".
    std::string command;    ///< The command line that repeats the check (with --json).
    std::string created;    ///< When the report was made (UTC, ISO 8601); empty = not stated.
    /// The unit of length the original's file declares (MeshFile::unit: 3MF, glTF): distances
    /// are then stated in it too. Empty: in % of the diagonal only (never guessed).
    std::optional<LengthUnit> unit;
    double original_diagonal = 0.0;  ///< The original's bounding-box diagonal, in its coordinates.
};

/// Options of evidence_pictures.
struct EvidencePictureOptions
{
    ImageSize panel{560, 440};       ///< Size of each of the two panels of the alignment picture.
    ImageSize heatmap{960, 600};     ///< Size of the difference picture, colour bar included.
    ViewAngles view = kDefaultView;  ///< Direction the models are seen from.
    UpAxis up = UpAxis::PosY;        ///< The original's up axis.
    /// Samples per pixel along each axis (1 to 4); 1 for meshes with more triangles (suspect and
    /// original together) than a panel has pixels.
    int supersampling = 2;
    int threads = 0;  ///< 0 = all cores; the pictures do not depend on it.
};

/// The two pictures of a report and the numbers their captions state.
struct EvidencePictures
{
    /// Left: the suspect as received (orange), framed on its own; right: the suspect moved onto
    /// the original by the check's transform (orange) over the original (light grey), seen
    /// from the same direction.
    RgbImage alignment;
    /// The aligned suspect coloured by each vertex's distance to the original's surface, with
    /// a colour bar in % of the original's bounding-box diagonal.
    HeatmapPicture difference;
    double median_distance_rel = 0.0;  ///< Median vertex distance / the original's diagonal.
    double red_distance_rel = 0.0;     ///< The distance drawn red (99.5th percentile) / diagonal.
};

/// \brief Draw the report's pictures with the software rasterizer (render module).
/// \details The suspect is moved by `detect["registration"]["transform"]` (suspect -> original
/// frame); its vertices' distances to the original's surface are exact point-to-triangle
/// distances (ClosestPointIndex). Point clouds are drawn as discs.
/// \throws InvalidOption for a detect report without a transform, InvalidMesh for a mesh with
/// nothing to draw.
[[nodiscard]] EvidencePictures evidence_pictures(const TriangleMesh& suspect,
                                                 const TriangleMesh& original,
                                                 const nlohmann::json& detect,
                                                 const EvidencePictureOptions& options = {});

/// One part of the report: a heading, paragraphs, a table of (label, value) rows, and which
/// picture follows it.
struct EvidenceSection
{
    enum class Figure
    {
        None,
        Alignment,
        Difference,
    };
    std::string heading;
    std::vector<std::string> paragraphs;
    std::vector<std::pair<std::string, std::string>> rows;
    Figure figure = Figure::None;
    std::string caption;  ///< Of the figure.
};

/// The words of a report, shared by its HTML and PDF forms.
struct EvidenceText
{
    std::string title;
    bool is_claimed = false;
    std::string verdict;                      ///< "CLAIMED: ..." or "NOT SHOWN: ...".
    std::string chance;                       ///< The sentence with the "1 in N".
    double false_positive_probability = 1.0;  ///< The verdict's, as in the JSON.
    std::vector<std::string> accused;         ///< Recipients named, as in the JSON.
    std::vector<EvidenceSection> sections;
};

/// \brief The report's words, from \p facts (its `detect` JSON above all) and the numbers of
/// \p pictures.
/// \throws InvalidOption when a field the report states is missing from `facts.detect`.
[[nodiscard]] EvidenceText evidence_text(const EvidenceFacts& facts,
                                         const EvidencePictures& pictures);

/// \brief The report as one self-contained HTML page: inline CSS, the pictures as base64 PNG
/// data URIs, no script, no external file; prints on at most 3 A4 pages.
[[nodiscard]] std::string evidence_html(const EvidenceText& text, const EvidencePictures& pictures);

/// \brief The report as a PDF of at most 3 A4 pages (cairo's PDF surface, its toy text API).
/// \throws IoError when cairo fails.
[[nodiscard]] std::string evidence_pdf(const EvidenceText& text, const EvidencePictures& pictures);

/// \brief Write the report of \p facts to \p path, as HTML or PDF by its extension
/// (evidence_format), atomically (write_file_atomically: a failed report leaves no file).
/// \throws InvalidOption for another extension; IoError when it cannot be written.
void write_evidence_report(const std::filesystem::path& path, const EvidenceFacts& facts,
                           const EvidencePictures& pictures);

/// Options of write_detection_report.
struct DetectionReportOptions
{
    EvidencePictureOptions pictures;
    std::string version;   ///< EvidenceFacts::version.
    std::string command;   ///< EvidenceFacts::command.
    bool is_dated = true;  ///< State when the report was made (the current UTC time).
};

/// \brief The whole report of one check: reads the suspect and the original, names the three
/// files (evidence_file), draws the pictures and writes \p path (write_evidence_report).
/// \param detect detect_report_json of the check of \p suspect against \p original with \p key.
/// \throws InvalidOption for an extension other than .html/.htm/.pdf (checked before any work);
/// IoError, InvalidMesh as read_mesh.
void write_detection_report(const std::filesystem::path& path, const std::filesystem::path& suspect,
                            const std::filesystem::path& original, const std::filesystem::path& key,
                            const nlohmann::json& detect,
                            const DetectionReportOptions& options = {});

/// \brief write_detection_report with the key named by \p key (a key without a file of its own: a
/// catalogue's record, named by the SHA-256 of its key file as `catalog export` writes it).
void write_detection_report(const std::filesystem::path& path, const std::filesystem::path& suspect,
                            const std::filesystem::path& original, const EvidenceFile& key,
                            const nlohmann::json& detect,
                            const DetectionReportOptions& options = {});

}  // namespace meshmark
