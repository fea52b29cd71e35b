// SPDX-License-Identifier: MIT
// The library facade (meshmark.h): the in-memory embed and detect give what the file pipeline
// gives, and in-place embedding replaces the input whole or not at all.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/atomic_file.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/meshmark.h"
#include "meshmark/metrics/distortion.h"
#include "seeded_options.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

// A 642-vertex mesh as an OBJ.
fs::path write_input(const fs::path& dir)
{
    const fs::path path = dir / "input.obj";
    write_mesh(path, lumpy_ellipsoid(3));
    return path;
}

// \p mesh written into \p dir and marked there with the defaults and seed 7: its key and the

using test::seeded;

// Files in \p dir whose name starts with a dot (staging files of the atomic writes).
int hidden_files(const fs::path& dir)
{
    int count = 0;
    for (const auto& entry : fs::directory_iterator(dir))
    {
        count += entry.path().filename().string().starts_with(".") ? 1 : 0;
    }
    return count;
}

}  // namespace

TEST(FacadeTest, in_memory_embed_gives_the_positions_and_key_of_embed_file)
{
    const fs::path dir = test::temp_dir("facade-embed");
    const fs::path input = write_input(dir);
    const EmbedReport report = embed_file(input, dir / "marked.obj", dir / "key.json", seeded(11));

    const TriangleMesh mesh = read_mesh(input);
    const EmbedResult result = embed(mesh, seeded(11));
    ASSERT_EQ(result.positions.rows(), mesh.V.rows());
    // Written as embed_file writes them, the positions give the same file (an OBJ keeps the
    // shortest digits of the file's precision, so the file is compared, not the doubles).
    write_mesh_file(dir / "in-memory.obj", read_mesh_file(input), result.positions);
    EXPECT_EQ(test::file_bytes(dir / "in-memory.obj"), test::file_bytes(dir / "marked.obj"));
    EXPECT_LT((result.positions - read_mesh(dir / "marked.obj").V).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_EQ(to_json(result.key), test::file_bytes(dir / "key.json"));
    EXPECT_EQ(to_json(result.key), to_json(report.key));
    EXPECT_EQ(result.stats.rms_displacement_rel, report.stats.rms_displacement_rel);
    EXPECT_GT((result.positions - mesh.V).norm(), 0.0);
    // Another seed, other positions: the comparison above can fail.
    EXPECT_FALSE(embed(mesh, seeded(12)).positions == result.positions);
}

TEST(FacadeTest, in_memory_detect_gives_the_report_of_detect_file)
{
    const fs::path dir = test::temp_dir("facade-detect");
    const fs::path input = write_input(dir);
    (void)embed_file(input, dir / "marked.obj", dir / "key.json", seeded(21));
    const DetectFileOptions options;
    for (const fs::path& suspect : {dir / "marked.obj", input})
    {
        const DetectReport from_files = detect_file(suspect, input, dir / "key.json", options);
        const DetectReport in_memory =
            detect(read_mesh(suspect), read_mesh(input), read_key(dir / "key.json"), options);
        EXPECT_EQ(in_memory.decision.is_present, from_files.decision.is_present) << suspect;
        EXPECT_EQ(in_memory.decision.correlation, from_files.decision.correlation) << suspect;
        EXPECT_EQ(in_memory.decision.matches, from_files.decision.matches) << suspect;
        EXPECT_EQ(in_memory.correspondence, from_files.correspondence) << suspect;
    }
    EXPECT_TRUE(detect(read_mesh(dir / "marked.obj"), read_mesh(input), read_key(dir / "key.json"))
                    .decision.is_present);
    // The original is checked against the key's fingerprint, as detect_file does.
    TriangleMesh other = read_mesh(input);
    other.V(0, 0) += 1e-3;
    EXPECT_THROW((void)detect(read_mesh(dir / "marked.obj"), other, read_key(dir / "key.json")),
                 IoError);
}

TEST(FacadeTest, in_place_embed_replaces_the_input_whole_with_the_marked_copy)
{
    const fs::path dir = test::temp_dir("facade-in-place");
    const fs::path input = write_input(dir);
    const std::string original = test::file_bytes(input);
    (void)embed_file(input, dir / "marked.obj", dir / "key-copy.json", seeded(31));
    fs::permissions(input, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);

    // Not asked for: refused, the input untouched.
    EXPECT_THROW((void)embed_file(input, input, dir / "key.json", seeded(31)), InvalidOption);
    EXPECT_EQ(test::file_bytes(input), original);
    EXPECT_FALSE(fs::exists(dir / "key.json"));

    // A failure on the way (a file where the key's folder should be): the input untouched,
    // nothing left.
    EmbedFileOptions options = seeded(31);
    options.replace_input = true;
    write_file_atomically(dir / "blocker", [](std::ostream& out) { out << "not a folder"; });
    EXPECT_THROW((void)embed_file(input, input, dir / "blocker" / "key.json", options), IoError);
    EXPECT_EQ(test::file_bytes(input), original);
    EXPECT_EQ(hidden_files(dir), 0);
    fs::remove(dir / "blocker");

    // Asked for: the input becomes the marked copy (same bytes as to another file), keeps its
    // permissions, and no staging file remains.
    const EmbedReport report = embed_file(input, input, dir / "key.json", options);
    EXPECT_EQ(test::file_bytes(input), test::file_bytes(dir / "marked.obj"));
    EXPECT_EQ(test::file_bytes(dir / "key.json"), test::file_bytes(dir / "key-copy.json"));
    EXPECT_EQ(to_json(report.key),
              test::file_bytes(dir / "key.json"));  // the original's fingerprint
    EXPECT_EQ(fs::status(input).permissions() & fs::perms::all,
              fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
    EXPECT_EQ(hidden_files(dir), 0);
}

// A mesh with fewer usable vertices than the basis has functions (a box, a lone triangle, a
// glTF whose primitives are lines) is refused in one sentence naming the file, by embed and by
// the recipients' embed, with nothing written.
TEST(FacadeTest, a_mesh_too_small_for_the_basis_is_refused_naming_the_file)
{
    const fs::path dir = test::temp_dir("facade-small");
    write_mesh(dir / "small.obj", icosphere(1));
    std::ofstream(dir / "nothing.obj") << "o empty\n";
    const auto expect_refused =
        [&](const auto& run, const std::string& name, const std::string& reason)
    {
        try
        {
            run();
            ADD_FAILURE() << name << " was accepted";
        }
        catch (const InvalidMesh& e)
        {
            const std::string what = e.what();
            EXPECT_EQ(what.rfind((dir / name).string() + ": ", 0), 0U) << what;
            EXPECT_NE(what.find(reason), std::string::npos) << what;
        }
        EXPECT_FALSE(fs::exists(dir / "marked.obj"));
        EXPECT_FALSE(fs::exists(dir / "key.json"));
    };
    expect_refused(
        [&]
        { (void)embed_file(dir / "small.obj", dir / "marked.obj", dir / "key.json", seeded(3)); },
        "small.obj", "42 usable vertices, fewer than the 60 basis functions");
    expect_refused(
        [&]
        { (void)embed_file(dir / "nothing.obj", dir / "marked.obj", dir / "key.json", seeded(3)); },
        "nothing.obj", "nothing to watermark");
    EmbedRecipientsOptions family;
    family.seed = 3;
    family.recipients = {"ann"};
    expect_refused(
        [&]
        {
            (void)embed_recipients(dir / "small.obj", (dir / "{recipient}.obj").string(),
                                   dir / "key.json", family);
        },
        "small.obj", "42 usable vertices, fewer than the");
    EXPECT_FALSE(fs::exists(dir / "ann.obj"));
}

TEST(FacadeTest, make_key_takes_the_payload_from_the_message_hex_or_seed)
{
    EmbedOptions options;
    const Key from_message = make_key(options, 5, std::string("owner"));
    EXPECT_EQ(from_message.payload, payload_from_message("owner", payload_bit_count(options)));
    EXPECT_EQ(from_message.message, std::optional<std::string>("owner"));
    EXPECT_EQ(from_message.options.strength, default_strength(options.rule));
    EXPECT_EQ(from_message.options.measure, StrengthMeasure::Surface);
    EXPECT_TRUE(from_message.options.needs_calibration());  // until an embed calibrates it
    const Key from_seed = make_key(options, 5);
    EXPECT_EQ(from_seed.payload, random_payload(5, payload_bit_count(options)));
    EXPECT_EQ(from_seed.seed, 5U);
    const Key from_hex = make_key(options, 5, std::nullopt, std::string(6, 'f'));
    EXPECT_EQ(from_hex.payload, std::vector<std::uint8_t>(24, 1));
    EXPECT_THROW((void)make_key(options, 5, std::nullopt, std::string("xyz")), InvalidOption);
}

TEST(FacadeTest, the_default_strength_is_the_surface_distance_whatever_the_sampling)
{
    // An ellipsoid whose upper half is sampled 4x finer than the lower (its upper triangles
    // split in four): the same RMS vertex displacement would move the sparse half more.
    TriangleMesh mesh = lumpy_ellipsoid(3);
    {
        std::vector<Eigen::RowVector3d> V;
        for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
        {
            V.push_back(mesh.V.row(i));
        }
        std::map<std::pair<int, int>, int> midpoint;
        auto middle = [&](int a, int b)
        {
            const auto edge = std::minmax(a, b);
            const auto [at, added] = midpoint.emplace(edge, static_cast<int>(V.size()));
            if (added)
            {
                V.push_back(0.5 *
                            (V[static_cast<std::size_t>(a)] + V[static_cast<std::size_t>(b)]));
            }
            return at->second;
        };
        std::vector<Eigen::RowVector3i> F;
        for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        {
            const int a = mesh.F(f, 0), b = mesh.F(f, 1), c = mesh.F(f, 2);
            if (mesh.V(a, 2) + mesh.V(b, 2) + mesh.V(c, 2) > 0.0)
            {
                const int ab = middle(a, b), bc = middle(b, c), ca = middle(c, a);
                F.insert(F.end(), {{a, ab, ca}, {ab, b, bc}, {ca, bc, c}, {ab, bc, ca}});
            }
            else
            {
                F.emplace_back(a, b, c);
            }
        }
        // Edges shared with the coarse half are split on one side only: the T-junctions leave
        // no hole a surface metric would see.
        mesh.V.resize(static_cast<Eigen::Index>(V.size()), 3);
        for (std::size_t i = 0; i < V.size(); ++i)
        {
            mesh.V.row(static_cast<Eigen::Index>(i)) = V[i];
        }
        mesh.F.resize(static_cast<Eigen::Index>(F.size()), 3);
        for (std::size_t f = 0; f < F.size(); ++f)
        {
            mesh.F.row(static_cast<Eigen::Index>(f)) = F[f];
        }
    }
    const double strength = default_strength(EmbeddingRule::Additive);
    const EmbedResult surface = embed(mesh, seeded(31));
    EXPECT_EQ(surface.key.options.measure, StrengthMeasure::Surface);
    EXPECT_NEAR(surface.stats.surface_rms_rel, strength, 1e-12);
    EXPECT_GT(surface.key.options.vertex_strength, 0.0);
    TriangleMesh marked = mesh;
    marked.V = surface.positions;
    CompareOptions compare;
    compare.samples = 200000;
    const DistortionReport measured = compare_meshes(mesh, marked, compare);
    EXPECT_LE(measured.mrms_rel, strength * 1.003);
    EXPECT_GE(measured.mrms_rel, strength * 0.95);
    // Detection rebuilds the modulation from the recorded vertex strength: a perfect read.
    const DetectReport found = detect(marked, mesh, surface.key);
    EXPECT_TRUE(found.detected());
    EXPECT_GT(found.decision.score, 9.0);

    // The vertex measure at the strength the key recorded gives the same positions: the
    // calibration is one factor on the field, nothing else.
    EmbedFileOptions vertex = seeded(31);
    vertex.embed.measure = StrengthMeasure::Vertex;
    vertex.embed.strength = surface.key.options.vertex_strength;
    const EmbedResult same = embed(mesh, vertex);
    EXPECT_LT((same.positions - surface.positions).cwiseAbs().maxCoeff(),
              1e-12 * measured.diagonal);
    // ... and 1e-3 of the vertex measure moves this mesh's surface by another amount.
    vertex.embed.strength = 1e-3;
    EXPECT_GT(std::abs(embed(mesh, vertex).stats.surface_rms_rel - strength), 0.05 * strength);
}

}  // namespace meshmark
