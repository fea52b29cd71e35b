// SPDX-License-Identifier: MIT
// The library facade (meshmark.h): the in-memory embed and detect give what the file pipeline
// gives, and in-place embedding replaces the input whole or not at all.
#include "meshmark/meshmark.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "meshmark/geometry/shapes.h"
#include "support/test_paths.h"

namespace meshmark {
namespace {

namespace fs = std::filesystem;

// A 642-vertex mesh as an OBJ.
fs::path write_input(const fs::path& dir)
{
    const fs::path path = dir / "input.obj";
    write_mesh(path, lumpy_ellipsoid(3));
    return path;
}

EmbedFileOptions seeded(std::uint64_t seed)
{
    EmbedFileOptions options;
    options.seed = seed;
    options.message = "owner";
    options.embed.basis_size = 60;
    return options;
}

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
        const DetectReport in_memory = detect(read_mesh(suspect), read_mesh(input), read_key(dir / "key.json"), options);
        EXPECT_EQ(in_memory.decision.is_present, from_files.decision.is_present) << suspect;
        EXPECT_EQ(in_memory.decision.correlation, from_files.decision.correlation) << suspect;
        EXPECT_EQ(in_memory.decision.matches, from_files.decision.matches) << suspect;
        EXPECT_EQ(in_memory.alignment, from_files.alignment) << suspect;
    }
    EXPECT_TRUE(detect(read_mesh(dir / "marked.obj"), read_mesh(input), read_key(dir / "key.json")).decision.is_present);
    // The original is checked against the key's fingerprint, as detect_file does.
    TriangleMesh other = read_mesh(input);
    other.V(0, 0) += 1e-3;
    EXPECT_THROW((void)detect(read_mesh(dir / "marked.obj"), other, read_key(dir / "key.json")), IoError);
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

    // A failure on the way (the key's folder does not exist): the input untouched, nothing left.
    EmbedFileOptions options = seeded(31);
    options.replace_input = true;
    EXPECT_THROW((void)embed_file(input, input, dir / "missing" / "key.json", options), IoError);
    EXPECT_EQ(test::file_bytes(input), original);
    EXPECT_EQ(hidden_files(dir), 0);

    // Asked for: the input becomes the marked copy (same bytes as to another file), keeps its
    // permissions, and no staging file remains.
    const EmbedReport report = embed_file(input, input, dir / "key.json", options);
    EXPECT_EQ(test::file_bytes(input), test::file_bytes(dir / "marked.obj"));
    EXPECT_EQ(test::file_bytes(dir / "key.json"), test::file_bytes(dir / "key-copy.json"));
    EXPECT_EQ(to_json(report.key), test::file_bytes(dir / "key.json"));  // the original's fingerprint
    EXPECT_EQ(fs::status(input).permissions() & fs::perms::all,
              fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
    EXPECT_EQ(hidden_files(dir), 0);
}

TEST(FacadeTest, make_key_takes_the_payload_from_the_message_hex_or_seed)
{
    EmbedOptions options;
    const Key from_message = make_key(options, 5, std::string("owner"));
    EXPECT_EQ(from_message.payload, payload_from_message("owner", payload_bit_count(options)));
    EXPECT_EQ(from_message.message, std::optional<std::string>("owner"));
    EXPECT_EQ(from_message.options.strength, default_strength(options.rule));
    const Key from_seed = make_key(options, 5);
    EXPECT_EQ(from_seed.payload, random_payload(5, payload_bit_count(options)));
    EXPECT_EQ(from_seed.seed, 5U);
    const Key from_hex = make_key(options, 5, std::nullopt, std::string(6, 'f'));
    EXPECT_EQ(from_hex.payload, std::vector<std::uint8_t>(24, 1));
    EXPECT_THROW((void)make_key(options, 5, std::nullopt, std::string("xyz")), InvalidOption);
}

}  // namespace meshmark
