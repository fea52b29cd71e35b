// SPDX-License-Identifier: MIT
// Recipient copies (family keys): the key file, issuing copies, tracing a suspect, collusion
// by averaging, and the refusals (docs/fingerprinting.md).
#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/attacks/subdivision.h"
#include "meshmark/core/error.h"
#include "meshmark/core/file_lock.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/meshmark.h"
#include "meshmark/metrics/distortion.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

fs::path write_input(const fs::path& dir, int subdivisions = 4)
{
    const fs::path path = dir / "input.ply";
    write_mesh(path, lumpy_ellipsoid(subdivisions));
    return path;
}

EmbedRecipientsOptions family(std::vector<std::string> names)
{
    EmbedRecipientsOptions options;
    options.seed = 21;
    options.message = "owner";
    options.recipients = std::move(names);
    return options;
}

std::vector<std::string> accused_names(const DetectReport& report)
{
    std::vector<std::string> names;
    for (const RecipientScore& r : report.accused)
    {
        names.push_back(r.name);
    }
    std::sort(names.begin(), names.end());
    return names;
}

// The eight recipients of the splice tests, issued on a 5-subdivision lumpy ellipsoid in \p dir.
const std::vector<std::string> kEight = {"ann", "ben", "cat", "dan", "eve", "fay", "gus", "hal"};

Key issue_eight(const fs::path& dir)
{
    static_cast<void>(embed_recipients(write_input(dir, 5), (dir / "{recipient}.ply").string(),
                                       dir / "family.json", family(kEight)));
    return read_key(dir / "family.json");
}

// Cut-and-splice: each third of the model along its longest axis taken from another copy
// (dir / "<name>.ply"), in the order of \p colluders.
Positions splice_thirds(const TriangleMesh& original, const fs::path& dir,
                        const std::vector<std::string>& colluders)
{
    const Eigen::RowVector3d extent =
        original.V.colwise().maxCoeff() - original.V.colwise().minCoeff();
    Eigen::Index axis = 0;
    static_cast<void>(extent.maxCoeff(&axis));
    std::vector<double> heights(original.V.col(axis).data(),
                                original.V.col(axis).data() + original.V.rows());
    std::sort(heights.begin(), heights.end());
    const double cut1 = heights[heights.size() / 3];
    const double cut2 = heights[2 * heights.size() / 3];
    Positions spliced = original.V;
    for (std::size_t c = 0; c < colluders.size(); ++c)
    {
        const Positions copy = read_mesh(dir / (colluders[c] + ".ply")).V;
        for (Eigen::Index i = 0; i < spliced.rows(); ++i)
        {
            const double h = original.V(i, axis);
            if ((h < cut1 ? 0U : (h < cut2 ? 1U : 2U)) == c)
            {
                spliced.row(i) = copy.row(i);
            }
        }
    }
    return spliced;
}

DetectReport detect_positions(const fs::path& input, const Positions& positions, const Key& key)
{
    const TriangleMesh original = read_mesh(input);
    TriangleMesh suspect = original;
    suspect.V = positions;
    return detect(suspect, original, key);
}

}  // namespace

TEST(RecipientsTest, key_file_round_trips_the_recipients_and_refuses_duplicates)
{
    EmbedOptions options;
    options.vertex_strength = 1e-3;            // as the embed calibrates it
    options.repetitions = kFamilyRepetitions;  // as the watermark resolves it for a family key
    Key key = make_key(options, 5, std::string("m"));
    key.recipients = RecipientCodes{48, 0.5, {{"alice", 0}, {"bob", 7}}};
    const Key back = parse_key(to_json(key), "k.json");
    ASSERT_TRUE(back.recipients.has_value());
    EXPECT_EQ(back.recipients->modes, 48);
    EXPECT_EQ(back.recipients->energy_share, 0.5);
    ASSERT_EQ(back.recipients->recipients.size(), 2U);
    EXPECT_EQ(back.recipients->recipients[1].name, "bob");
    EXPECT_EQ(back.recipients->recipients[1].index, 7U);
    EXPECT_FALSE(parse_key(to_json(make_key(options, 5)), "k.json").recipients.has_value());

    key.recipients->recipients.push_back({"alice", 9});
    EXPECT_THROW(static_cast<void>(parse_key(to_json(key), "k.json")), IoError);
    key.recipients->recipients.back() = {"carol", 7};
    EXPECT_THROW(static_cast<void>(parse_key(to_json(key), "k.json")), IoError);
    key.recipients->recipients.pop_back();
    key.recipients->modes = 90;  // 12 + 16 + 90 > 100 basis functions
    EXPECT_THROW(static_cast<void>(parse_key(to_json(key), "k.json")), IoError);
}

TEST(RecipientsTest, names_that_cannot_be_part_of_a_file_name_are_refused)
{
    EXPECT_NO_THROW(check_recipient_name("Studio B (contract 12)"));
    for (const std::string& bad : std::vector<std::string>{
             "", ".hidden", "a/b", "a\\b", "tab\there", std::string(101, 'x'), "q\"uote"})
    {
        EXPECT_THROW(check_recipient_name(bad), InvalidOption) << bad;
    }
    EXPECT_EQ(recipient_output("out/{recipient}-{recipient}.ply", "ann"),
              fs::path("out/ann-ann.ply"));
    EXPECT_THROW(static_cast<void>(recipient_output("out/copy.ply", "ann")), InvalidOption);
}

TEST(RecipientsTest, codes_are_keyed_per_recipient_and_do_not_depend_on_their_length)
{
    const auto a = recipient_code(3, 0, 192);
    const auto b = recipient_code(3, 1, 192);
    const auto other_seed = recipient_code(4, 0, 192);
    EXPECT_NE(a, b);
    EXPECT_NE(a, other_seed);
    const auto prefix = recipient_code(3, 0, 50);
    EXPECT_TRUE(std::equal(prefix.begin(), prefix.end(), a.begin()));
    const long ones = std::count(a.begin(), a.end(), std::uint8_t{1});
    EXPECT_GT(ones, 60);  // about half of 192 (a fair code)
    EXPECT_LT(ones, 132);
}

TEST(RecipientsTest, each_copy_accuses_its_recipient_only_and_an_average_accuses_colluders_only)
{
    const fs::path dir = test::temp_dir("recipients-issue");
    const fs::path input = write_input(dir);
    const std::vector<std::string> names = {"ann", "ben", "cat", "dan", "eve", "fay"};
    const EmbedRecipientsReport report = embed_recipients(input, (dir / "{recipient}.ply").string(),
                                                          dir / "family.json", family(names));
    ASSERT_TRUE(report.key_created);
    ASSERT_EQ(report.copies.size(), names.size());
    const Key key = read_key(dir / "family.json");
    ASSERT_TRUE(key.recipients.has_value());
    ASSERT_EQ(key.recipients->recipients.size(), names.size());

    // The same distortion as a single mark of the same strength: the same surface distance,
    // exactly (the energy is shared, and each code scaled); the vertex displacement, which the
    // strength no longer fixes, within 20%.
    EmbedMeshOptions single;
    single.seed = 21;
    single.message = "owner";
    const EmbedResult alone = embed(read_mesh(input), single);
    EXPECT_NEAR(alone.stats.surface_rms_rel, key.options.strength, 1e-9 * key.options.strength);
    for (const IssuedCopy& copy : report.copies)
    {
        EXPECT_NEAR(copy.stats.surface_rms_rel, key.options.strength, 1e-9 * key.options.strength)
            << copy.name;
        EXPECT_NEAR(copy.stats.rms_displacement_rel, alone.stats.rms_displacement_rel,
                    0.2 * alone.stats.rms_displacement_rel)
            << copy.name;
    }

    // A new family is calibrated on the owner's mark and each code scaled: every copy's
    // surface distance is the strength's.
    EXPECT_EQ(key.options.measure, StrengthMeasure::Surface);
    EXPECT_GT(key.options.vertex_strength, 0.0);
    const TriangleMesh original = read_mesh(input);
    const double diagonal =
        (original.V.colwise().maxCoeff() - original.V.colwise().minCoeff()).norm();
    for (const std::string& name : names)
    {
        const double surface =
            surface_rms_displacement(original, read_mesh(dir / (name + ".ply")).V - original.V);
        EXPECT_NEAR(surface / diagonal, key.options.strength, 1e-9 * key.options.strength) << name;
    }

    std::vector<Positions> copies;
    for (const std::string& name : names)
    {
        copies.push_back(read_mesh(dir / (name + ".ply")).V);
        const DetectReport found = detect_positions(input, copies.back(), key);
        EXPECT_TRUE(found.detected()) << name;
        EXPECT_TRUE(found.decision.is_present) << name << ": the owner's mark";
        EXPECT_EQ(found.recipients_traced, names.size());
        EXPECT_EQ(accused_names(found), std::vector<std::string>{name});
    }

    const DetectReport unmarked = detect_positions(input, read_mesh(input).V, key);
    EXPECT_FALSE(unmarked.detected());
    EXPECT_TRUE(unmarked.accused.empty());

    // Two buyers average their copies: the owner's mark is intact, and only they are accused.
    const Positions average = (copies[1] + copies[4]) / 2.0;
    const DetectReport pooled = detect_positions(input, average, key);
    EXPECT_TRUE(pooled.decision.is_present);
    ASSERT_FALSE(pooled.accused.empty());
    for (const std::string& name : accused_names(pooled))
    {
        EXPECT_TRUE(name == "ben" || name == "eve") << name << " is innocent";
    }
    // Not tracing: the owner's verdict alone.
    DetectFileOptions owner_only;
    owner_only.trace = false;
    TriangleMesh suspect = read_mesh(input);
    suspect.V = average;
    const DetectReport untraced = detect(suspect, read_mesh(input), key, owner_only);
    EXPECT_EQ(untraced.recipients_traced, 0U);
    EXPECT_TRUE(untraced.detected());
}

TEST(RecipientsTest, a_copy_spliced_from_three_copies_accuses_colluders_only)
{
    // Cut-and-splice: each third of the model (along its longest axis) from another copy. The
    // code of one copy confined to a third reads weakly on the whole model; the regions find it.
    const fs::path dir = test::temp_dir("recipients-splice");
    const Key key = issue_eight(dir);
    const fs::path input = dir / "input.ply";
    const TriangleMesh original = read_mesh(input);
    const std::vector<std::string>& names = kEight;
    const std::vector<std::string> colluders = {"ben", "dan", "gus"};
    const Positions spliced = splice_thirds(original, dir, colluders);
    const DetectReport report = detect_positions(input, spliced, key);
    EXPECT_TRUE(report.decision.is_present) << "the owner's mark is in every third";
    ASSERT_FALSE(report.accused.empty());
    for (const RecipientScore& r : report.accused)
    {
        EXPECT_TRUE(std::find(colluders.begin(), colluders.end(), r.name) != colluders.end())
            << r.name << " is innocent";
    }
    // Every colluder is found; the middle third's is found by its region alone (its
    // whole-model z is far below any accusation threshold).
    EXPECT_EQ(accused_names(report), (std::vector<std::string>{"ben", "dan", "gus"}));
    ASSERT_EQ(report.traced.size(), names.size());
    const RecipientScore& middle = report.traced[3];
    ASSERT_EQ(middle.name, "dan");
    EXPECT_LT(middle.score, 4.0);
    EXPECT_GT(middle.region_score, 7.0);
}

TEST(RecipientsTest, a_resampled_splice_is_read_by_its_regions_through_the_normals)
{
    // The splice of three copies above, then resampled by a midpoint subdivision (the same
    // surface, 4x the faces), read as a resampled suspect (vertex matching off): a resampled
    // suspect keeps only the normal components of the change, which on this smooth model hide
    // much of each code. The regions undo part of that with the whole model's sampling matrix
    // (Extraction::code_sampling). Read through the normals alone the colluders' regions scored
    // 4.87 (ben), 4.69 (dan) and 6.68 (gus), and only gus was accused; unsampled, 6.34, 4.60
    // and 7.29 (8.21, 7.78 and 9.20 vertex for vertex).
    const fs::path dir = test::temp_dir("recipients-splice-resampled");
    const Key key = issue_eight(dir);
    const TriangleMesh original = read_mesh(dir / "input.ply");
    const std::vector<std::string>& names = kEight;
    TriangleMesh spliced = original;
    spliced.V = splice_thirds(original, dir, {"ben", "dan", "gus"});
    const DetectReport in_place = detect(spliced, original, key);
    const TriangleMesh subdivided =
        subdivide(spliced, SubdivisionOptions{SubdivisionScheme::Midpoint, 1});
    // By default the subdivided copy keeps the original's vertices, so they are matched and
    // read vertex for vertex, every component: all three colluders accused, as in place.
    const DetectReport matched = detect(subdivided, original, key);
    EXPECT_EQ(matched.correspondence, Correspondence::VerticesMatched);
    EXPECT_EQ(accused_names(matched), (std::vector<std::string>{"ben", "dan", "gus"}));
    EXPECT_EQ(accused_names(in_place), (std::vector<std::string>{"ben", "dan", "gus"}));
    DetectFileOptions resample_only;
    resample_only.match_vertices = false;
    const DetectReport resampled = detect(subdivided, original, key, resample_only);
    EXPECT_EQ(resampled.extraction.code_sampling.size(), 192U * 192U)
        << "the subdivided splice is resampled";
    EXPECT_EQ(accused_names(resampled), (std::vector<std::string>{"ben", "gus"}));
    ASSERT_EQ(resampled.traced.size(), names.size());
    ASSERT_EQ(in_place.traced.size(), names.size());
    EXPECT_GT(resampled.traced[1].region_score, 5.8);  // ben
    EXPECT_GT(resampled.traced[6].region_score, 7.0);  // gus
    for (const std::size_t index : {1U, 3U, 6U})
    {
        EXPECT_LT(resampled.traced[index].region_score, in_place.traced[index].region_score)
            << "the normals alone never read more than the whole change";
    }
    for (const std::size_t index : {0U, 2U, 4U, 5U, 7U})
    {
        EXPECT_LT(resampled.traced[index].region_score, 4.0)
            << resampled.traced[index].name << " is innocent";
    }
}

// A buyer's mirrored copy of a mirror-symmetric asset (an icosphere bent in its y-z plane:
// the mirror image in x maps it onto itself, vertices onto vertices) is matched where it
// stands, each vertex taken for its mirror partner, or, moved, registers unmirrored: the
// trace is read in the mirrored pose too and accuses that buyer only, with the probability
// of the unmirrored copy (each pays for the two poses); the unmarked original mirrored so
// accuses nobody.
TEST(RecipientsTest, a_mirrored_copy_of_a_mirror_symmetric_original_accuses_its_recipient)
{
    const fs::path dir = test::temp_dir("recipients-mirror");
    TriangleMesh bent = icosphere(4);
    for (Eigen::Index i = 0; i < bent.V.rows(); ++i)
    {
        const Eigen::Vector3d p = bent.V.row(i);
        bent.V.row(i) =
            Eigen::RowVector3d(p.x(), 1.5 * p.y() + 0.4 * p.z() * p.z(), 2.0 * p.z() + 0.3 * p.y());
    }
    write_mesh(dir / "bent.ply", bent);
    static_cast<void>(embed_recipients(dir / "bent.ply", (dir / "{recipient}.ply").string(),
                                       dir / "family.json", family({"ann", "ben", "cat"})));
    const Key key = read_key(dir / "family.json");
    const TriangleMesh bens = read_mesh(dir / "ben.ply");
    const DetectReport unmirrored =
        detect(apply_attacks(bens, parse_attack_spec("reorder"), 3, 1).mesh, bent, key);
    ASSERT_EQ(accused_names(unmirrored), std::vector<std::string>{"ben"});
    for (const std::string moved : {"reorder", "reorder,similarity"})
    {
        const auto mirrored = [&](const TriangleMesh& mesh) {
            return apply_attacks(mesh, parse_attack_spec("similarity:mirror=x," + moved), 3, 1)
                .mesh;
        };
        const DetectReport found = detect(mirrored(bens), bent, key);
        EXPECT_EQ(accused_names(found), std::vector<std::string>{"ben"}) << moved;
        EXPECT_TRUE(found.owner_detected) << moved;
        EXPECT_LT((found.transform.topLeftCorner<3, 3>().determinant()), 0.0) << moved;
        ASSERT_FALSE(found.accused.empty());
        EXPECT_NEAR(found.accused.front().false_positive_probability,
                    unmirrored.accused.front().false_positive_probability,
                    1e-6 * unmirrored.accused.front().false_positive_probability)
            << moved << ": the same reading as the unmirrored copy's, both paying for two poses";
        const DetectReport clean = detect(mirrored(bent), bent, key);
        EXPECT_TRUE(clean.accused.empty()) << moved;
        EXPECT_FALSE(clean.owner_detected) << moved;
    }
}

TEST(RecipientsTest, a_later_call_adds_recipients_and_reissues_known_ones_byte_for_byte)
{
    const fs::path dir = test::temp_dir("recipients-extend");
    const fs::path input = write_input(dir, 3);
    static_cast<void>(embed_recipients(input, (dir / "first-{recipient}.ply").string(),
                                       dir / "family.json", family({"ann", "ben"})));
    EmbedRecipientsOptions later = family({"ben", "cat"});
    later.seed.reset();  // the key's seed decides, not the options
    const EmbedRecipientsReport report = embed_recipients(
        input, (dir / "second-{recipient}.ply").string(), dir / "family.json", later);
    EXPECT_FALSE(report.key_created);
    ASSERT_EQ(report.copies.size(), 2U);
    EXPECT_FALSE(report.copies[0].is_new);
    EXPECT_TRUE(report.copies[1].is_new);
    EXPECT_EQ(report.copies[1].index, 2U);
    EXPECT_EQ(test::file_bytes(dir / "first-ben.ply"), test::file_bytes(dir / "second-ben.ply"));
    const Key key = read_key(dir / "family.json");
    ASSERT_EQ(key.recipients->recipients.size(), 3U);
    EXPECT_EQ(key.recipients->recipients[2].name, "cat");
}

TEST(RecipientsTest, refusals_leave_no_file_behind)
{
    const fs::path dir = test::temp_dir("recipients-refuse");
    const fs::path input = write_input(dir, 3);
    // A single-owner key is not extended into a family.
    static_cast<void>(
        embed_file(input, dir / "single.ply", dir / "single.json", EmbedFileOptions{}));
    EXPECT_THROW(static_cast<void>(embed_recipients(input, (dir / "{recipient}.ply").string(),
                                                    dir / "single.json", family({"ann"}))),
                 IoError);
    EXPECT_FALSE(fs::exists(dir / "ann.ply"));
    // A family key belongs to its original.
    static_cast<void>(embed_recipients(input, (dir / "f-{recipient}.ply").string(),
                                       dir / "family.json", family({"ann"})));
    const fs::path other = dir / "other.ply";
    write_mesh(other, lumpy_ellipsoid(2));
    EXPECT_THROW(static_cast<void>(embed_recipients(other, (dir / "o-{recipient}.ply").string(),
                                                    dir / "family.json", family({"ben"}))),
                 IoError);
    EXPECT_FALSE(fs::exists(dir / "o-ben.ply"));
    // Bad patterns and names, before any work.
    EXPECT_THROW(static_cast<void>(embed_recipients(input, (dir / "copy.ply").string(),
                                                    dir / "new.json", family({"ann"}))),
                 InvalidOption);
    EXPECT_THROW(static_cast<void>(embed_recipients(input, (dir / "n-{recipient}.ply").string(),
                                                    dir / "new.json", family({"ann", "bad/name"}))),
                 InvalidOption);
    EXPECT_FALSE(fs::exists(dir / "new.json"));
    // A copy that cannot be written: the copies written before it are removed. The names stay
    // recorded (recorded before released: another call may have delivered them meanwhile), and
    // a later call delivers the same copies.
    fs::create_directories(dir / "blocked");
    fs::create_directories(dir / "blocked" / "zed.ply");  // a directory where a copy should go
    EXPECT_ANY_THROW(
        static_cast<void>(embed_recipients(input, (dir / "blocked" / "{recipient}.ply").string(),
                                           dir / "blocked.json", family({"amy", "zed"}))));
    EXPECT_FALSE(fs::exists(dir / "blocked" / "amy.ply"));
    ASSERT_EQ(read_key(dir / "blocked.json").recipients->recipients.size(), 2U);
    fs::remove(dir / "blocked" / "zed.ply");
    const EmbedRecipientsReport again =
        embed_recipients(input, (dir / "blocked" / "{recipient}.ply").string(),
                         dir / "blocked.json", family({"amy", "zed"}));
    EXPECT_FALSE(again.copies[0].is_new);
    EXPECT_EQ(again.copies[1].index, 1U);
    EXPECT_TRUE(fs::exists(dir / "blocked" / "zed.ply"));
}

TEST(RecipientsTest, a_name_given_twice_is_issued_once_and_missing_folders_are_created)
{
    const fs::path dir = test::temp_dir("recipients-twice");
    const fs::path input = write_input(dir, 3);
    const EmbedRecipientsReport report =
        embed_recipients(input, (dir / "copies" / "{recipient}.ply").string(),
                         dir / "keys" / "family.json", family({"ann", "ben", "ann"}));
    ASSERT_EQ(report.copies.size(), 2U);
    EXPECT_EQ(report.copies[0].name, "ann");
    EXPECT_EQ(report.copies[1].name, "ben");
    EXPECT_TRUE(fs::exists(dir / "copies" / "ann.ply"));
    EXPECT_EQ(read_key(dir / "keys" / "family.json").recipients->recipients.size(), 2U);
    EXPECT_FALSE(fs::exists(lock_companion(dir / "keys" / "family.json")));  // released and removed
}

TEST(RecipientsTest, threads_issuing_on_one_new_key_at_once_get_one_key_and_a_code_each)
{
    // Eight calls at once on a key none of them finds: each issues two names of its own and
    // "common". One key results; every name holds one index; "common" gets the same bytes in
    // every call; each copy accuses its own recipient only.
    const fs::path dir = test::temp_dir("recipients-threads");
    const fs::path input = write_input(dir, 3);
    constexpr int kCalls = 8;
    std::vector<std::thread> calls;
    std::vector<std::string> errors(kCalls);
    for (int c = 0; c < kCalls; ++c)
    {
        calls.emplace_back(
            [&, c]
            {
                try
                {
                    EmbedRecipientsOptions options =
                        family({"a" + std::to_string(c), "common", "b" + std::to_string(c)});
                    options.seed = 100 + c;  // a different key each, were each to create its own
                    options.threads = 1;
                    static_cast<void>(embed_recipients(
                        input, (dir / ("call" + std::to_string(c)) / "{recipient}.ply").string(),
                        dir / "family.json", options));
                }
                catch (const std::exception& e)
                {
                    errors[static_cast<std::size_t>(c)] = e.what();
                }
            });
    }
    for (auto& call : calls)
    {
        call.join();
    }
    for (const std::string& error : errors)
    {
        EXPECT_EQ(error, "");
    }
    const Key key = read_key(dir / "family.json");
    ASSERT_EQ(key.recipients->recipients.size(), 2U * kCalls + 1U);
    std::set<std::uint32_t> indices;
    for (const Recipient& r : key.recipients->recipients)
    {
        EXPECT_TRUE(indices.insert(r.index).second) << r.name << " shares index " << r.index;
    }
    const std::string common = test::file_bytes(dir / "call0" / "common.ply");
    for (int c = 1; c < kCalls; ++c)
    {
        EXPECT_EQ(test::file_bytes(dir / ("call" + std::to_string(c)) / "common.ply"), common)
            << "call " << c;
    }
    for (const int c : {0, 5})
    {
        const std::string name = "b" + std::to_string(c);
        const DetectReport report =
            detect_file(dir / ("call" + std::to_string(c)) / (name + ".ply"), input,
                        dir / "family.json", DetectFileOptions{});
        EXPECT_EQ(accused_names(report), std::vector<std::string>{name});
    }
}

TEST(RecipientsTest, the_accusation_bound_is_paid_for_every_recipient_of_the_key)
{
    // An innocent's z is compared at the level divided by the number of recipients: with one
    // recipient more than a bound allows, the same score is no longer an accusation.
    EmbedOptions family;
    family.repetitions = kFamilyRepetitions;
    Key key = make_key(family, 9);
    key.recipients = RecipientCodes{};
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    key.original = fingerprint(mesh);
    for (std::uint32_t i = 0; i < 10; ++i)
    {
        key.recipients->recipients.push_back({"r" + std::to_string(i), i});
    }
    const SpectralWatermark mark(mesh, key);
    Extraction extraction;
    const Eigen::MatrixX3d signs = mark.recipient_signs(3);
    for (Eigen::Index c = 0; c < signs.size(); ++c)
    {
        extraction.recipient_change.push_back(signs(c / 3, c % 3));
        extraction.recipient_weights.push_back(1.0);
    }
    const std::vector<RecipientScore> scores = mark.trace(extraction, DetectOptions{});
    ASSERT_EQ(scores.size(), 10U);
    EXPECT_NEAR(scores[3].score, std::sqrt(static_cast<double>(signs.size())), 1e-9);
    EXPECT_TRUE(scores[3].is_accused);
    // Every code sign agrees, each with weight 1: a sum of random signs does that with
    // probability 2^-n, times 3 weightings and 10 recipients.
    const auto n = static_cast<int>(signs.size());
    EXPECT_NEAR(scores[3].false_positive_probability / (10.0 * 3.0 * binomial_tail_half(n, n)), 1.0,
                1e-8);
    EXPECT_LT(scores[3].false_positive_probability,
              10.0 * 3.0 * rademacher_tail_bound(scores[3].score));
    for (const RecipientScore& s : scores)
    {
        EXPECT_EQ(s.is_accused, s.index == 3) << s.name << " z " << s.score;
    }
}

}  // namespace meshmark
