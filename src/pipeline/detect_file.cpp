// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/detect_file.h"

#include <cmath>

#include <Eigen/Geometry>
#include <string>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "timer.h"

namespace meshmark {
namespace {

void check_original(const TriangleMesh& original, const Key& key, const std::filesystem::path& path)
{
    const MeshFingerprint found = fingerprint(original);
    if (found.vertex_count != key.original.vertex_count || found.face_count != key.original.face_count)
    {
        throw IoError(path.string() + ": this is not the original the key was made for (it has " +
                      std::to_string(found.vertex_count) + " vertices and " +
                      std::to_string(found.face_count) + " faces, the key's original " +
                      std::to_string(key.original.vertex_count) + " and " +
                      std::to_string(key.original.face_count) + ").");
    }
    if (found.position_hash != key.original.position_hash)
    {
        throw IoError(path.string() + ": this is not the original the key was made for (same counts, "
                      "but its vertex positions differ from the fingerprint in the key).");
    }
}

}  // namespace

DetectReport detect_file(const std::filesystem::path& suspect_path,
                         const std::filesystem::path& original_path,
                         const std::filesystem::path& key_path, const DetectFileOptions& options)
{
    options.decision.validate();
    DetectReport report;
    detail::PhaseTimer timer(report.seconds, options.progress);

    const Key key = read_key(key_path);
    const TriangleMesh original = read_mesh(original_path);
    check_original(original, key, original_path);
    const TriangleMesh suspect = read_mesh(suspect_path);
    report.suspect_vertices = suspect.vertex_count();
    report.original_vertices = original.vertex_count();
    timer.lap("read");

    const SpectralWatermark mark(original, key, options.threads);
    timer.lap("basis");

    // Correspondence: the suspect keeps the watermarked mesh's vertices in order (noise,
    // smoothing, quantization, float rounding).
    if (suspect.vertex_count() != original.vertex_count())
    {
        throw InvalidOption(suspect_path.string() + ": the suspect has " +
                            std::to_string(suspect.vertex_count()) + " vertices but the original " +
                            std::to_string(original.vertex_count()) +
                            "; this detection mode needs the same vertices in the same order.");
    }
    report.alignment = "same-connectivity";
    const Positions marked = original.V + mark.displacement();
    const double diagonal = bounding_box(original.V).diagonal();
    // With vertex correspondence the best similarity onto the watermarked mesh is closed-form
    // [Umeyama 1991]; it undoes a moved or scaled copy. What it may absorb of the watermark's
    // own similarity component is removed on both sides by the nuisance fit of the extraction.
    const Eigen::Matrix4d T = Eigen::umeyama(suspect.V.transpose(), marked.transpose(), true);
    const Positions aligned =
        (suspect.V * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose();
    report.transform = T;
    report.registration_rms =
        std::sqrt((aligned - marked).rowwise().squaredNorm().mean()) / diagonal;
    timer.lap("correspondence");

    const Extraction extraction = mark.extract(aligned, options.decision);
    report.decision = mark.decide(extraction, options.decision);
    timer.lap("extract");
    return report;
}

}  // namespace meshmark
