// SPDX-License-Identifier: MIT
#include "meshmark/watermark/key.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

Key sample_key()
{
    Key key;
    key.seed = 0xFEDCBA9876543210ULL;
    key.options.rule = EmbeddingRule::Paper;
    key.options.basis_size = 80;
    key.options.coefficients = 6;
    key.options.repetitions = 3;
    key.options.first_mode = 5;
    key.options.strength = 0.02;
    key.payload = payload_from_message("(c) ACME", 18);
    key.message = "(c) ACME";
    key.original = fingerprint(icosphere(2));
    return key;
}

}  // namespace

TEST(KeyTest, json_round_trip_keeps_every_field)
{
    const Key key = sample_key();
    const Key back = parse_key(to_json(key), "k.json");
    EXPECT_EQ(back.seed, key.seed);
    EXPECT_EQ(back.options.rule, key.options.rule);
    EXPECT_EQ(back.options.basis_size, 80);
    EXPECT_EQ(back.options.coefficients, 6);
    EXPECT_EQ(back.options.repetitions, 3);
    EXPECT_EQ(back.options.first_mode, 5);
    EXPECT_DOUBLE_EQ(back.options.strength, 0.02);
    EXPECT_EQ(back.payload, key.payload);
    EXPECT_EQ(back.message, key.message);
    EXPECT_EQ(back.original, key.original);
}

// Keys written before spreading existed have no "repetitions": they embedded every bit once.
TEST(KeyTest, keys_without_repetitions_read_as_one_copy_per_bit)
{
    auto content = nlohmann::json::parse(to_json(sample_key()));
    content.erase("checksum");
    content["embedding"].erase("repetitions");
    content["embedding"].erase("first_mode");
    const std::string text = content.dump();
    char checksum[17];
    std::snprintf(checksum, sizeof checksum, "%016llx",
                  static_cast<unsigned long long>(hash_bytes(text.data(), text.size(), 0x6B6579U)));
    content["checksum"] = checksum;
    const Key back = parse_key(content.dump(2), "old.json");
    EXPECT_EQ(back.options.repetitions, 1);
    EXPECT_EQ(back.options.first_mode, 0);
    EXPECT_EQ(back.options.coefficients, 6);

    Key bad = sample_key();
    bad.options.repetitions = 20;  // 6 * 20 > 80 basis functions
    EXPECT_THROW(bad.options.validate(), InvalidOption);
    bad.options.repetitions = -1;
    EXPECT_THROW(bad.options.validate(), InvalidOption);
    bad.options.repetitions =
        EmbedOptions::kAutoRepetitions;  // the watermark chooses: valid options
    EXPECT_NO_THROW(bad.options.validate());
    bad.options.repetitions = 3;
    bad.options.first_mode = 63;  // 63 + 18 > 80
    EXPECT_THROW(bad.options.validate(), InvalidOption);
    bad.options.first_mode = -1;
    EXPECT_THROW(bad.options.validate(), InvalidOption);
}

// The embedding records the repetitions it chose: a key file that asks for the automatic
// choice (0) is refused, naming the field, rather than resolved again by a rule that may change.
TEST(KeyTest, a_key_file_without_its_repetitions_is_refused)
{
    auto content = nlohmann::json::parse(to_json(sample_key()));
    content.erase("checksum");
    content["embedding"]["repetitions"] = 0;
    const std::string text = content.dump();
    char checksum[17];
    std::snprintf(checksum, sizeof checksum, "%016llx",
                  static_cast<unsigned long long>(hash_bytes(text.data(), text.size(), 0x6B6579U)));
    content["checksum"] = checksum;
    try
    {
        (void)parse_key(content.dump(2), "auto.json");
        FAIL() << "a key with repetitions 0 was accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("auto.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("embedding.repetitions"), std::string::npos)
            << e.what();
    }
}

namespace
{

// The key text with \p edit applied to its content and the checksum recomputed (a genuine key
// of another version, not a tampered one).
std::string resigned(const Key& key, const std::function<void(nlohmann::json&)>& edit)
{
    auto content = nlohmann::json::parse(to_json(key));
    content.erase("checksum");
    edit(content);
    const std::string text = content.dump();
    char checksum[17];
    std::snprintf(checksum, sizeof checksum, "%016llx",
                  static_cast<unsigned long long>(hash_bytes(text.data(), text.size(), 0x6B6579U)));
    content["checksum"] = checksum;
    return content.dump(2);
}

}  // namespace

TEST(KeyTest, basis_and_centers_round_trip_and_old_keys_read_as_rbf_random)
{
    Key key = sample_key();
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.basis, BasisType::Rbf);
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.centers, CenterSelection::Random);
    key.options.basis = BasisType::Laplacian;
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.basis, BasisType::Laplacian);
    key.options.basis = BasisType::Rbf;
    key.options.centers = CenterSelection::Decimate;
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.centers, CenterSelection::Decimate);
    EXPECT_NE(to_json(key).find("\"basis\": \"rbf\""), std::string::npos);

    // Keys written before the fields existed: no "basis" (RBF), "centers" absent or "random".
    key.options.centers = CenterSelection::Random;
    const Key old = parse_key(
        resigned(key, [](nlohmann::json& j) { j["embedding"].erase("basis"); }), "old.json");
    EXPECT_EQ(old.options.basis, BasisType::Rbf);
    EXPECT_EQ(old.options.centers, CenterSelection::Random);
    const Key older = parse_key(resigned(key,
                                         [](nlohmann::json& j)
                                         {
                                             j["embedding"].erase("basis");
                                             j["embedding"].erase("centers");
                                         }),
                                "older.json");
    EXPECT_EQ(older.options.centers, CenterSelection::Random);

    // Unknown names are refused, naming the file.
    try
    {
        (void)parse_key(
            resigned(key, [](nlohmann::json& j) { j["embedding"]["basis"] = "wavelet"; }),
            "w.json");
        FAIL() << "unknown basis accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("w.json"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("wavelet"), std::string::npos);
    }
    EXPECT_THROW(
        (void)parse_key(
            resigned(key, [](nlohmann::json& j) { j["embedding"]["centers"] = "grid"; }), "g.json"),
        IoError);
    EXPECT_EQ(parse_basis_type("laplacian"), BasisType::Laplacian);
    EXPECT_THROW((void)parse_center_selection("kmeans"), InvalidOption);
}

TEST(KeyTest, strength_measure_round_trips_and_old_keys_read_as_the_vertex_measure)
{
    Key key = sample_key();
    key.options.rule = EmbeddingRule::Additive;
    key.options.strength = 6e-4;
    key.options.measure = StrengthMeasure::Surface;
    key.options.vertex_strength = 9.5e-4;
    const Key back = parse_key(to_json(key), "k.json");
    EXPECT_EQ(back.options.measure, StrengthMeasure::Surface);
    EXPECT_DOUBLE_EQ(back.options.vertex_strength, 9.5e-4);
    EXPECT_DOUBLE_EQ(back.options.modulation_strength(), 9.5e-4);
    EXPECT_FALSE(back.options.needs_calibration());

    // A key with the surface measure but no calibration cannot rebuild its modulation.
    key.options.vertex_strength = -1.0;
    EXPECT_TRUE(key.options.needs_calibration());
    EXPECT_DOUBLE_EQ(key.options.modulation_strength(), std::sqrt(3.0) * 6e-4);
    try
    {
        (void)parse_key(to_json(key), "uncalibrated.json");
        FAIL() << "an uncalibrated surface key was read";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("uncalibrated.json"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("calibrated"), std::string::npos);
    }

    // Keys written before the field existed meant the RMS vertex displacement.
    key.options.vertex_strength = 9.5e-4;
    const Key old = parse_key(resigned(key,
                                       [](nlohmann::json& j)
                                       {
                                           j["embedding"].erase("strength_measure");
                                           j["embedding"].erase("vertex_strength");
                                       }),
                              "old.json");
    EXPECT_EQ(old.options.measure, StrengthMeasure::Vertex);
    EXPECT_DOUBLE_EQ(old.options.modulation_strength(), 6e-4);
    EXPECT_THROW((void)parse_key(resigned(key, [](nlohmann::json& j)
                                          { j["embedding"]["strength_measure"] = "area"; }),
                                 "a.json"),
                 IoError);
    EXPECT_EQ(parse_strength_measure("vertex"), StrengthMeasure::Vertex);
    EXPECT_THROW((void)parse_strength_measure("normal"), InvalidOption);
    EXPECT_DOUBLE_EQ(default_strength(EmbeddingRule::Additive), 5.9e-4);
    EXPECT_DOUBLE_EQ(default_strength(EmbeddingRule::Additive, StrengthMeasure::Vertex), 1e-3);
}

TEST(KeyTest, gram_rows_round_trips_old_keys_mean_every_row_and_tiny_samples_are_refused)
{
    Key key = sample_key();
    EXPECT_EQ(key.options.gram_rows, EmbedOptions::kDefaultGramRows);
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.gram_rows, EmbedOptions::kDefaultGramRows);
    key.options.gram_rows = 0;
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.gram_rows, 0);
    key.options.gram_rows = 123457;
    EXPECT_EQ(parse_key(to_json(key), "k.json").options.gram_rows, 123457);

    // Keys written before the field existed built the Gram matrix from every row.
    const Key old = parse_key(
        resigned(key, [](nlohmann::json& j) { j["embedding"].erase("gram_rows"); }), "old.json");
    EXPECT_EQ(old.options.gram_rows, 0);

    // At least 16 rows per basis function (80 here), or 0.
    key.options.gram_rows = 16 * 80;
    EXPECT_NO_THROW(key.options.validate());
    key.options.gram_rows = 16 * 80 - 1;
    try
    {
        key.options.validate();
        FAIL() << "a 1279-row sample for 80 basis functions was accepted";
    }
    catch (const InvalidOption& e)
    {
        EXPECT_NE(std::string(e.what()).find("--gram-rows"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("1280"), std::string::npos);
    }
    key.options.gram_rows = -1;
    EXPECT_THROW(key.options.validate(), InvalidOption);
    EXPECT_THROW(
        (void)parse_key(resigned(key, [](nlohmann::json& j) { j["embedding"]["gram_rows"] = 7; }),
                        "tiny.json"),
        IoError);
}

TEST(KeyTest, tampered_truncated_or_foreign_keys_are_rejected_with_a_clear_message)
{
    const std::string text = to_json(sample_key());
    std::string tampered = text;
    tampered.replace(tampered.find("\"basis_size\": 80"), 16, "\"basis_size\": 81");
    try
    {
        (void)parse_key(tampered, "k.json");
        FAIL() << "tampered key accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("k.json"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos);
    }
    EXPECT_THROW((void)parse_key(text.substr(0, text.size() / 2), "k.json"), IoError);
    EXPECT_THROW((void)parse_key("{\"format\": \"other\"}", "k.json"), IoError);
    std::string future = text;
    future.replace(future.find("\"version\": 1"), 12, "\"version\": 2");
    try
    {
        (void)parse_key(future, "k.json");
        FAIL() << "future version accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("version 2"), std::string::npos);
    }
}

TEST(KeyTest, deep_nesting_is_refused_but_brackets_inside_strings_are_text)
{
    // Hostile nesting is refused before parsing, with a message that names the file.
    const std::string deep = std::string(100000, '[') + std::string(100000, ']');
    try
    {
        (void)parse_key(deep, "deep.json");
        FAIL() << "deeply nested text accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("deep.json"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("levels deep"), std::string::npos);
    }
    // A message full of brackets and escaped quotes is a string, not nesting.
    Key key = sample_key();
    const std::string message = "[[[[[[[[[[[[[[[[[[[[{{{{{{{{{{{{{{{{{{{{ \"[[[[[[[[[[[[[[[[[[[[";
    key.message = message;
    key.payload = payload_from_message(message, 18);
    const Key back = parse_key(to_json(key), "k.json");
    EXPECT_EQ(back.message, key.message);
}

TEST(KeyTest, key_file_is_private_and_reads_back)
{
    const auto dir = test::temp_dir("key");
    const auto path = dir / "key.json";
    write_key(path, sample_key());
    struct stat st
    {
    };
    ASSERT_EQ(::stat(path.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777U, 0600U);
    EXPECT_EQ(read_key(path).seed, sample_key().seed);
    EXPECT_THROW((void)read_key(dir / "missing.json"), IoError);
}

TEST(PayloadTest, hex_round_trip_and_validation)
{
    const auto bits = payload_from_hex("a5c3f0", 24);
    EXPECT_EQ(to_bit_string(bits), "101001011100001111110000");
    EXPECT_EQ(to_hex(bits), "a5c3f0");
    EXPECT_THROW((void)payload_from_hex("a5c3f", 24), InvalidOption);
    EXPECT_THROW((void)payload_from_hex("a5c3fg", 24), InvalidOption);
    EXPECT_EQ(payload_from_hex("f8", 5).size(), 5U);
    EXPECT_THROW((void)payload_from_hex("f9", 5), InvalidOption);  // padding bits must be 0
}

TEST(PayloadTest, message_payload_is_stable_and_mask_depends_on_seed)
{
    EXPECT_EQ(payload_from_message("hello", 24), payload_from_message("hello", 24));
    EXPECT_NE(payload_from_message("hello", 24), payload_from_message("hellp", 24));
    EXPECT_NE(payload_mask(1, 24), payload_mask(2, 24));
    EXPECT_NE(random_payload(1, 24), payload_mask(1, 24));
}

}  // namespace meshmark
