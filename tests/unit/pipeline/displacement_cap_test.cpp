// SPDX-License-Identifier: MIT
// embed --max-displacement: the written file's largest displacement (float32 rounding
// included) stays under the cap, the capped copy is still detected, a cap too small for a
// detectable mark is refused naming the smallest that fits; and the embed record's hashes are
// those `sha256sum` prints, with no key material in it.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/meshmark.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/embed_record.h"
#include "seeded_options.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

// A 642-vertex ellipsoid scaled to about 60 units across, stored as float32 binary PLY.
fs::path write_input(const fs::path& dir)
{
    TriangleMesh mesh = lumpy_ellipsoid(3);
    mesh.V *= 30.0;
    const fs::path path = dir / "input.ply";
    write_mesh(path, mesh, {.use_single_precision = true});
    return path;
}

using test::seeded;

// The largest displacement between two files of the same vertices, as compare measures it.
double written_displacement(const fs::path& original, const fs::path& marked)
{
    CompareOptions options;
    options.samples = 1000;
    const DistortionReport r = compare_meshes(read_mesh(original), read_mesh(marked), options);
    EXPECT_TRUE(r.displacement.has_value());
    return r.max_displacement_rel * r.diagonal;
}

std::string sha256sum(const fs::path& path)
{
    const std::string command = "sha256sum '" + path.string() + "'";
    std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
    char digest[65] = {};
    if (!pipe || std::fread(digest, 1, 64, pipe.get()) != 64)
    {
        ADD_FAILURE() << "sha256sum failed on " << path;
    }
    return digest;
}

TEST(DisplacementCapTest, the_written_file_honours_the_cap_and_is_detected)
{
    const fs::path dir = test::temp_dir("cap-honoured");
    const fs::path input = write_input(dir);
    const EmbedReport uncapped =
        embed_file(input, dir / "default.ply", dir / "default.json", seeded(3));
    const double default_max = written_displacement(input, dir / "default.ply");
    ASSERT_GT(default_max, 0.0);

    // Half the default's largest displacement, in micrometres of a millimetre mesh.
    EmbedFileOptions options = seeded(3);
    options.unit = LengthUnit::Millimetre;
    const double cap_mm = 0.5 * default_max;
    options.max_displacement_length = Length{1000.0 * cap_mm, LengthUnit::Micrometre};
    const EmbedReport capped = embed_file(input, dir / "capped.ply", dir / "capped.json", options);
    EXPECT_NEAR(capped.cap.cap, cap_mm, 1e-12 * cap_mm);
    EXPECT_LT(capped.cap.factor, 0.51);
    EXPECT_GT(capped.cap.factor, 0.49);
    const double written = written_displacement(input, dir / "capped.ply");
    EXPECT_LE(written, cap_mm);
    EXPECT_GT(written, 0.98 * cap_mm);  // lowered once, not more than needed
    EXPECT_DOUBLE_EQ(capped.written_max_displacement, written);
    // The key records the lowered strength: detection rebuilds the capped mark.
    EXPECT_NEAR(read_key(dir / "capped.json").options.resolved_strength(),
                uncapped.key.options.resolved_strength() * capped.cap.factor, 1e-12);
    const DetectReport found = detect_file(dir / "capped.ply", input, dir / "capped.json", {});
    EXPECT_TRUE(found.detected());

    // A cap the default fits under changes nothing.
    options.max_displacement_length = Length{2.0 * default_max, std::nullopt};
    const EmbedReport loose = embed_file(input, dir / "loose.ply", dir / "loose.json", options);
    EXPECT_EQ(loose.cap.factor, 1.0);
    EXPECT_EQ(test::file_bytes(dir / "loose.ply"), test::file_bytes(dir / "default.ply"));
}

TEST(DisplacementCapTest, a_cap_too_small_for_a_detectable_mark_is_refused)
{
    const fs::path dir = test::temp_dir("cap-refused");
    const fs::path input = write_input(dir);
    EmbedFileOptions options = seeded(5);
    options.unit = LengthUnit::Millimetre;
    options.max_displacement_length = Length{1e-9, LengthUnit::Millimetre};
    try
    {
        (void)embed_file(input, dir / "marked.ply", dir / "key.json", options);
        FAIL() << "a cap of 1e-9 mm was accepted";
    }
    catch (const InvalidOption& e)
    {
        const std::string message = e.what();
        EXPECT_NE(message.find("input.ply"), std::string::npos) << message;
        EXPECT_NE(message.find("--max-displacement 1e-09 mm"), std::string::npos) << message;
        EXPECT_NE(message.find("the smallest cap that fits is"), std::string::npos) << message;
    }
    EXPECT_FALSE(fs::exists(dir / "marked.ply"));
    EXPECT_FALSE(fs::exists(dir / "key.json"));
}

TEST(DisplacementCapTest, the_smallest_cap_named_in_a_refusal_fits)
{
    const fs::path dir = test::temp_dir("cap-smallest");
    const fs::path input = write_input(dir);
    EmbedFileOptions options = seeded(5);
    options.unit = LengthUnit::Millimetre;
    options.max_displacement_length = Length{1e-7, LengthUnit::Millimetre};
    std::string message;
    try
    {
        (void)embed_file(input, dir / "marked.ply", dir / "key.json", options);
    }
    catch (const InvalidOption& e)
    {
        message = e.what();
    }
    const auto at = message.find("fits is ");
    ASSERT_NE(at, std::string::npos) << message;
    const double smallest = std::stod(message.substr(at + 8));
    options.max_displacement_length = Length{smallest, LengthUnit::Millimetre};  // as printed
    const EmbedReport report = embed_file(input, dir / "marked.ply", dir / "key.json", options);
    EXPECT_LE(written_displacement(input, dir / "marked.ply"), smallest);
    EXPECT_TRUE(detect_file(dir / "marked.ply", input, dir / "key.json", {}).detected());
    EXPECT_LT(report.cap.factor, 1.0);
}

TEST(DisplacementCapTest, a_bare_number_needs_a_unit_and_recipients_are_refused)
{
    const fs::path dir = test::temp_dir("cap-unitless");
    const fs::path input = write_input(dir);
    EmbedFileOptions options = seeded(5);
    options.max_displacement_length = Length{0.01, std::nullopt};
    EXPECT_THROW((void)embed_file(input, dir / "marked.ply", dir / "key.json", options),
                 InvalidOption);
    options.max_displacement_length =
        Length{0.01, LengthUnit::Millimetre};  // a unit, but the mesh has none
    EXPECT_THROW((void)embed_file(input, dir / "marked.ply", dir / "key.json", options),
                 InvalidOption);
    EXPECT_FALSE(fs::exists(dir / "key.json"));

    EmbedRecipientsOptions family;
    family.seed = 5;
    family.recipients = {"bob"};
    family.max_displacement = 0.01;
    EXPECT_THROW(
        (void)embed_recipients(input, dir / "copy-{recipient}.ply", dir / "family.json", family),
        InvalidOption);
}

TEST(EmbedRecordTest, hashes_are_sha256sum_and_no_key_material_is_recorded)
{
    const fs::path dir = test::temp_dir("embed-record");
    const fs::path input = write_input(dir);
    const EmbedReport report =
        embed_file(input, dir / "marked.ply", dir / "key.json", seeded(0x5eed1234abcdULL));
    const EmbedRecord record =
        make_embed_record(input, dir / "marked.ply", dir / "key.json", report.key);
    EXPECT_EQ(record.original.sha256, sha256sum(input));
    EXPECT_EQ(record.marked.sha256, sha256sum(dir / "marked.ply"));
    EXPECT_EQ(record.key.sha256, sha256sum(dir / "key.json"));
    EXPECT_EQ(record.marked.bytes, fs::file_size(dir / "marked.ply"));
    EXPECT_EQ(record.created_utc.size(), 20U);
    EXPECT_EQ(record.created_utc.back(), 'Z');

    write_embed_record(dir / "record.json", record);
    const std::string text = test::file_bytes(dir / "record.json");
    EXPECT_NE(text.find(record.key.sha256), std::string::npos);
    // Neither the seed, nor the payload (bits or message), nor the key's parameters.
    EXPECT_EQ(text.find("5eed1234abcd"), std::string::npos) << text;
    EXPECT_EQ(text.find(to_bit_string(report.key.payload)), std::string::npos) << text;
    EXPECT_EQ(text.find("owner"), std::string::npos) << text;
    for (const char* field :
         {"\"seed\"", "\"payload\"", "\"bits\"", "\"embedding\"", "\"strength\""})
    {
        EXPECT_EQ(text.find(field), std::string::npos) << field;
    }
    // The key file itself does hold them (the test would not notice their absence otherwise).
    const std::string key = test::file_bytes(dir / "key.json");
    EXPECT_NE(key.find("5eed1234abcd"), std::string::npos);
    EXPECT_NE(key.find(to_bit_string(report.key.payload)), std::string::npos);
}

}  // namespace
}  // namespace meshmark
