// SPDX-License-Identifier: MIT
// The catalogue's scan: finding a suspect's asset and recipient, the shape index, an
// interrupted add's copy, reindexing.
#include "meshmark/catalog/catalog_scan.h"

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <SQLiteCpp/SQLiteCpp.h>
#include <gtest/gtest.h>
#include <libpq-fe.h>
#include <sys/stat.h>
#include <unistd.h>

#include "catalog_test_support.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/catalog/catalog.h"
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/catalog/catalog_reindex.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

// A variant of \p mesh "scanned again": a smooth bump field of its own, \p amplitude of its
// size, the field's frequencies 2 sin(phase.first + phase.second i), i = 0..8.
TriangleMesh bumped(TriangleMesh mesh, double amplitude, std::pair<double, double> phase)
{
    Eigen::Matrix3d f;
    for (int i = 0; i < 9; ++i)
    {
        f(i / 3, i % 3) = 2.0 * std::sin(phase.first + phase.second * i);
    }
    mesh.V += amplitude * (mesh.V * f).array().sin().matrix();
    return mesh;
}

namespace fs = std::filesystem;
using namespace test;  // catalog_test_support.h

// Six variants of lumpy_ellipsoid(4) (the same triangles), v0.ply to v5.ply in \p in, each with
// a bump field of its own of \p amplitude (bumped).
void write_variants(const fs::path& in, double amplitude)
{
    fs::create_directories(in);
    for (int v = 0; v < 6; ++v)
    {
        write_mesh(in / ("v" + std::to_string(v) + ".ply"),
                   bumped(lumpy_ellipsoid(4), amplitude, {1.7 * v + 0.3, 0.9}));
    }
}

// One candidate, no second round: what the first one tried shows the ranking alone.
CatalogScanOptions first_candidate_only()
{
    CatalogScanOptions options;
    options.candidates = 1;
    options.more_candidates = 0;
    return options;
}

TEST(CatalogTest,
     scan_finds_the_asset_and_recipient_of_an_attacked_copy_and_claims_nothing_unmarked)
{
    const fs::path dir = test::temp_dir("catalog_scan");
    const fs::path in = make_originals(dir);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {in}, dir / "out", quick_options());
    CatalogIssueOptions issue;
    issue.recipients = {"alice", "bob"};
    (void)catalog_issue(catalog, "sub/torus.obj", (dir / "copies" / "{recipient}.obj").string(),
                        issue);

    const TriangleMesh bobs = read_mesh(dir / "copies" / "bob.obj");
    write_mesh(dir / "suspect.ply",
               apply_attacks(bobs, parse_attack_spec("similarity,noise=0.0002"), 5, 1).mesh);
    write_mesh(dir / "unmarked.ply", apply_attacks(read_mesh(in / "sub" / "egg.off"),
                                                   parse_attack_spec("similarity"), 5, 1)
                                         .mesh);
    CatalogScanOptions options;
    options.candidates = 2;  // (the unmarked copy is tried against two assets, not all three)
    options.more_candidates = 0;
    const CatalogScanReport report = catalog_scan(
        catalog, {dir / "suspect.ply", dir / "unmarked.ply", dir / "missing.ply"}, options);
    EXPECT_EQ(report.assets, 3U);
    ASSERT_EQ(report.suspects.size(), 3U);
    const SuspectScan& found = report.suspects[0];
    ASSERT_TRUE(found.detected);
    ASSERT_EQ(found.matches.size(), 1U);
    EXPECT_EQ(found.matches[0].asset, "sub/torus.obj");
    ASSERT_EQ(found.matches[0].recipients.size(), 1U);
    EXPECT_EQ(found.matches[0].recipients[0].name, "bob");
    // The bound is the detection's times the catalogue's size.
    EXPECT_NEAR(found.matches[0].false_positive_probability,
                std::min(1.0, 3.0 * found.matches[0].report.owner_false_positive_probability),
                1e-12 + 1e-9 * found.matches[0].false_positive_probability);
    EXPECT_FALSE(report.suspects[1].detected);
    EXPECT_FALSE(report.suspects[1].tried.empty());
    EXPECT_FALSE(report.suspects[2].detected);
    EXPECT_NE(report.suspects[2].error.find("missing.ply"), std::string::npos);
}

// A kill between the published copy's rename and the asset's `complete` mark leaves a visible
// copy of an asset not yet complete: a scan traces it, and the next add finishes the asset with
// the same copy.
TEST(CatalogTest, a_visible_copy_of_an_interrupted_add_is_traced_and_the_next_add_keeps_it)
{
    const fs::path dir = test::temp_dir("catalog_interrupted");
    const fs::path in = make_originals(dir);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {in}, dir / "out", quick_options());
    const fs::path published = dir / "out" / "sub" / "torus.obj";
    const std::string copy = file_sha256(published);
    (void)sql(at, "UPDATE assets SET complete = 0 WHERE id = 'sub/torus.obj'");
    ASSERT_FALSE(catalog.asset("sub/torus.obj")->is_complete);
    EXPECT_EQ(catalog.complete_count(), 2U);

    write_mesh(dir / "suspect.ply",
               apply_attacks(read_mesh(published), parse_attack_spec("similarity"), 5, 1).mesh);
    const CatalogScanReport report =
        catalog_scan(catalog, {dir / "suspect.ply"}, CatalogScanOptions{});
    EXPECT_EQ(report.assets, 3U);  // the bound counts the interrupted asset too
    ASSERT_TRUE(report.suspects[0].detected);
    EXPECT_EQ(report.suspects[0].matches[0].asset, "sub/torus.obj");

    const auto finished = catalog_add(catalog, {in}, dir / "out", quick_options());
    EXPECT_EQ(outcome_of(finished, "sub/torus.obj").status, CatalogAddOutcome::Status::Marked);
    EXPECT_EQ(outcome_of(finished, "ellipsoid.ply").status, CatalogAddOutcome::Status::Present);
    EXPECT_TRUE(catalog.asset("sub/torus.obj")->is_complete);
    EXPECT_EQ(file_sha256(published), copy);
}

// The shape column of every asset, by id, as stored.
std::map<std::string, std::vector<std::uint8_t>> stored_shapes(const std::string& at)
{
    std::map<std::string, std::vector<std::uint8_t>> shapes;
    for (const auto& row : sql(at, postgres_server() ? "SELECT id, encode(shape, 'hex') FROM assets"
                                                     : "SELECT id, hex(shape) FROM assets"))
    {
        std::vector<std::uint8_t>& shape = shapes[row[0]];
        for (std::size_t i = 0; i + 1 < row[1].size(); i += 2)
        {
            shape.push_back(static_cast<std::uint8_t>(std::stoi(row[1].substr(i, 2), nullptr, 16)));
        }
    }
    return shapes;
}

TEST(CatalogTest, reindex_recomputes_an_older_builds_signatures_and_leaves_a_changed_original_alone)
{
    const fs::path dir = test::temp_dir("catalog_reindex");
    const fs::path in = make_originals(dir);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {in}, dir / "out", quick_options());
    const auto added = stored_shapes(at);
    ASSERT_EQ(added.size(), 3U);
    {
        // As an older build left them: the positions' features alone, no signature, and one
        // whose original changed since.
        std::vector<std::uint8_t> older;
        const std::vector<std::uint8_t>& now = added.at("ellipsoid.ply");
        for (int v = 0; v < kShapeViews; ++v)
        {
            older.insert(older.end(), now.begin() + v * kShapeFeatures,
                         now.begin() + v * kShapeFeatures + kShapePositionFeatures);
        }
        (void)sql(
            at, "UPDATE assets SET shape = " + blob_literal(older) + " WHERE id = 'ellipsoid.ply'");
        // this build's views without the points' section (a build of 2026-11-30 wrote them)
        const std::vector<std::uint8_t>& egg = added.at("sub/egg.off");
        (void)sql(at, "UPDATE assets SET shape = " +
                          blob_literal({egg.begin(), egg.begin() + kShapeViews * kShapeFeatures}) +
                          " WHERE id = 'sub/egg.off'");
        (void)sql(at,
                  "UPDATE assets SET shape = " + blob_literal({}) + " WHERE id = 'sub/torus.obj'");
    }
    std::ofstream(in / "sub" / "torus.obj", std::ios::app) << "# edited\n";

    const auto outcomes = catalog_reindex(catalog, CatalogReindexOptions{});
    std::map<std::string, CatalogReindexOutcome::Status> status;
    for (const auto& o : outcomes)
    {
        status[o.asset] = o.status;
    }
    EXPECT_EQ(status.at("ellipsoid.ply"), CatalogReindexOutcome::Status::Updated);
    EXPECT_EQ(status.at("sub/egg.off"), CatalogReindexOutcome::Status::Updated);
    EXPECT_EQ(status.at("sub/torus.obj"), CatalogReindexOutcome::Status::Failed);
    const auto reason = std::find_if(outcomes.begin(), outcomes.end(),
                                     [](const auto& o) { return o.asset == "sub/torus.obj"; })
                            ->reason;
    EXPECT_NE(reason.find("changed since it was added"), std::string::npos) << reason;
    const auto reindexed = stored_shapes(at);
    EXPECT_EQ(reindexed.at("ellipsoid.ply"), added.at("ellipsoid.ply"));
    EXPECT_EQ(reindexed.at("sub/egg.off"), added.at("sub/egg.off"));
    EXPECT_TRUE(reindexed.at("sub/torus.obj").empty());

    // Again: nothing left to do but the changed original; --all reads every unchanged one.
    for (const auto& o : catalog_reindex(catalog, CatalogReindexOptions{}))
    {
        EXPECT_EQ(o.status, o.asset == "sub/torus.obj" ? CatalogReindexOutcome::Status::Failed
                                                       : CatalogReindexOutcome::Status::Current);
    }
    CatalogReindexOptions all;
    all.all = true;
    for (const auto& o : catalog_reindex(catalog, all))
    {
        EXPECT_EQ(o.status, o.asset == "sub/torus.obj" ? CatalogReindexOutcome::Status::Failed
                                                       : CatalogReindexOutcome::Status::Updated);
    }
    EXPECT_EQ(stored_shapes(at).at("sub/egg.off"), added.at("sub/egg.off"));
}

TEST(CatalogTest, a_catalogue_of_a_build_that_fanned_polygons_is_reindexed_whole_once)
{
    const fs::path dir = test::temp_dir("catalog_stale_signatures");
    const fs::path in = make_originals(dir);
    const std::string at = catalog_at(dir);
    {
        Catalog catalog(at, Catalog::Open::CreateIfMissing);
        (void)catalog_add(catalog, {in}, dir / "out", quick_options());
        EXPECT_FALSE(catalog.has_stale_signatures());
    }
    const auto added = stored_shapes(at);
    // As a build before polygons were filled left it: no mark, and a signature of this size
    // that is not its original's (a fan-triangulated reading, say): a plain reindex keeps it.
    (void)sql(at, "DELETE FROM meta WHERE name = 'signature_polygons'");
    (void)sql(at, "UPDATE assets SET shape = " + blob_literal(added.at("ellipsoid.ply")) +
                      " WHERE id = 'sub/torus.obj'");
    Catalog catalog(at, Catalog::Open::Existing);
    ASSERT_TRUE(catalog.has_stale_signatures());
    EXPECT_EQ(catalog_scan_json(catalog, CatalogScanReport{}, CatalogScanOptions{})
                  .at("stale_signatures"),
              true);

    // A migrated copy is as stale as its source.
    const fs::path copy_dir = test::temp_dir("catalog_stale_signatures_copy");
    Catalog copy(catalog_at(copy_dir), Catalog::Open::CreateIfMissing);
    EXPECT_FALSE(copy.has_stale_signatures());
    EXPECT_EQ(copy.copy_from(catalog), 3U);
    EXPECT_TRUE(copy.has_stale_signatures());

    // An original that changed fails: the mark stays, and a later run redoes every asset.
    const fs::path egg = in / "sub" / "egg.off";
    const std::string egg_bytes = test::file_bytes(egg);
    std::ofstream(egg, std::ios::app) << "# edited\n";
    for (const auto& o : catalog_reindex(catalog, CatalogReindexOptions{}))
    {
        EXPECT_EQ(o.status, o.asset == "sub/egg.off" ? CatalogReindexOutcome::Status::Failed
                                                     : CatalogReindexOutcome::Status::Updated);
    }
    EXPECT_TRUE(catalog.has_stale_signatures());
    EXPECT_EQ(stored_shapes(at).at("sub/torus.obj"), added.at("sub/torus.obj"));

    std::ofstream(egg, std::ios::binary | std::ios::trunc) << egg_bytes;
    for (const auto& o : catalog_reindex(catalog, CatalogReindexOptions{}))
    {
        EXPECT_EQ(o.status, CatalogReindexOutcome::Status::Updated) << o.asset << ": " << o.reason;
    }
    EXPECT_FALSE(catalog.has_stale_signatures());
    EXPECT_EQ(catalog_scan_json(catalog, CatalogScanReport{}, CatalogScanOptions{})
                  .at("stale_signatures"),
              false);
    EXPECT_EQ(stored_shapes(at), added);
    for (const auto& o : catalog_reindex(catalog, CatalogReindexOptions{}))
    {
        EXPECT_EQ(o.status, CatalogReindexOutcome::Status::Current) << o.asset;
    }
}

TEST(CatalogTest, scan_reports_the_same_tries_in_rank_order_on_one_thread_or_several)
{
    const fs::path dir = test::temp_dir("catalog_scan_threads");
    const fs::path in = make_originals(dir);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {in}, dir / "out", quick_options());
    const auto listed = catalog.assets();
    ASSERT_EQ(listed.size(), 3U);
    write_mesh(dir / "suspect.ply",
               apply_attacks(read_mesh(listed[1].published),
                             parse_attack_spec("similarity,noise=0.0002"), 5, 1)
                   .mesh);
    // What a scan reports, but its times: every try and match with its rank order and figures.
    const auto summary = [](const CatalogScanReport& report)
    {
        std::vector<std::string> lines;
        for (const SuspectScan& scan : report.suspects)
        {
            for (const CatalogTry& tried : scan.tried)
            {
                lines.push_back("tried " + tried.asset + " " +
                                std::to_string(tried.shape_distance) + " " +
                                std::to_string(tried.false_positive_probability));
            }
            for (const CatalogMatch& match : scan.matches)
            {
                lines.push_back("match " + match.asset + " " + std::to_string(match.rank) + " " +
                                std::to_string(match.score));
            }
        }
        return lines;
    };
    // The marked copy tried against every asset (the nearest alone, the two others at once when
    // there are threads for them), on one thread or on several: the same tries in rank order.
    CatalogScanOptions options;
    options.candidates = 3;
    options.stop_at_match = false;
    options.detect.threads = 1;
    const auto one = summary(catalog_scan(catalog, {dir / "suspect.ply"}, options));
    options.detect.threads = 3;
    const auto several = summary(catalog_scan(catalog, {dir / "suspect.ply"}, options));
    EXPECT_EQ(one, several);
    ASSERT_EQ(one.size(), 3U);  // two tries and the match
    EXPECT_EQ(
        std::count_if(one.begin(), one.end(),
                      [](const std::string& l) { return l.starts_with("match sub/egg.off "); }),
        1);
}

TEST(CatalogTest,
     shape_candidates_take_the_two_rankings_in_turn_and_rank_an_older_catalogues_assets)
{
    TriangleMesh egg = icosphere(4);
    egg.V.col(2) *= 1.7;
    const std::vector<TriangleMesh> meshes = {lumpy_ellipsoid(3), torus(1.0, 0.3, 48, 24), egg};
    std::vector<Catalog::IndexEntry> index;
    for (std::size_t m = 0; m < meshes.size(); ++m)
    {
        index.push_back(
            index_entry("asset" + std::to_string(m), shape_signature(meshes[m]).to_bytes()));
    }
    // The torus as a catalogue of an older build holds it: the positions' features alone.
    std::vector<std::uint8_t> older;
    for (std::size_t at = 0; at < index[1].views.size(); at += kShapeFeatures)
    {
        older.insert(
            older.end(), index[1].views.begin() + static_cast<std::ptrdiff_t>(at),
            index[1].views.begin() + static_cast<std::ptrdiff_t>(at + kShapePositionFeatures));
    }
    index[1].views = older;
    const TriangleMesh moved = apply_attacks(meshes[1], parse_attack_spec("similarity"), 3, 1).mesh;
    const auto ranked = shape_candidates(index, shape_features(moved), 3);
    ASSERT_EQ(ranked.size(), 3U);
    // The torus is not in the ranking by every feature (it has no normals' features), so it
    // comes second, first of the positions' ranking, at the distance of an exact copy.
    EXPECT_EQ(ranked[1].second, 1U);
    EXPECT_LT(ranked[1].first, 0.01F);
    std::set<std::size_t> listed;
    for (const auto& [distance, a] : ranked)
    {
        listed.insert(a);
    }
    EXPECT_EQ(listed.size(), 3U);
    // A current entry is first when it is first by every feature.
    const auto egg_first = shape_candidates(
        index, shape_features(apply_attacks(egg, parse_attack_spec("similarity"), 3, 1).mesh), 1);
    ASSERT_EQ(egg_first.size(), 1U);
    EXPECT_EQ(egg_first[0].second, 2U);
}

TEST(CatalogTest, shape_fit_ranking_fits_the_variants_of_a_good_fit_the_index_left_out)
{
    // Two variants of one mesh (the same triangles, each with its own bump field), a torus and
    // an egg. The index's ranking is given with the crop's own variant last and a shortlist of
    // one: only the other variant is fitted from the shortlist, and the crop's variant is
    // fitted because it has that one's vertex and face counts. Without the variants (or
    // without the counts matching) the crop's asset is not ranked at all.
    std::vector<TriangleMesh> meshes;
    for (int v = 0; v < 2; ++v)
    {
        meshes.push_back(bumped(lumpy_ellipsoid(3), 0.03, {1.3 * v + 0.5, 0.7}));
    }
    TriangleMesh egg = icosphere(4);  // not the variants' counts (lumpy_ellipsoid(3)'s)
    egg.V.col(2) *= 1.7;
    meshes.push_back(torus(1.0, 0.3, 48, 24));
    meshes.push_back(egg);
    std::vector<Catalog::IndexEntry> index;
    for (std::size_t m = 0; m < meshes.size(); ++m)
    {
        index.push_back(index_entry("asset" + std::to_string(m),
                                    shape_signature(meshes[m]).to_bytes(), meshes[m].V.rows(),
                                    meshes[m].F.rows()));
    }
    const TriangleMesh suspect =
        apply_attacks(meshes[1], parse_attack_spec("crop=0.75,similarity"), 11, 1).mesh;
    const std::vector<std::pair<float, std::size_t>> by_shape = {
        {0.1F, 0}, {0.2F, 2}, {0.3F, 3}, {0.4F, 1}};
    const std::vector<bool> taken(index.size(), false);
    const ShapeFeatures features = shape_features(suspect);
    const auto assets_of = [&](const std::vector<bool>& taken_now)
    {
        std::vector<std::size_t> assets;
        double last = 0.0;
        for (const auto& [fit, a] :
             shape_fit_ranking(index, by_shape, taken_now, suspect, features, 1, 32, 1))
        {
            EXPECT_GE(fit, last);  // best first
            last = fit;
            assets.push_back(a);
        }
        return assets;
    };
    // The shortlist's one and its variant, the crop's own variant first; not the torus nor the egg.
    EXPECT_EQ(assets_of(taken), (std::vector<std::size_t>{1, 0}));
    // An asset already taken (tried in the suspect's numbering) is neither fitted nor ranked.
    std::vector<bool> first_taken(index.size(), false);
    first_taken[1] = true;
    EXPECT_EQ(assets_of(first_taken), std::vector<std::size_t>{0});
    // Another mesh's counts: no variant, the shortlist alone.
    index[1].vertex_count += 1;
    EXPECT_EQ(assets_of(taken), std::vector<std::size_t>{0});
}

TEST(CatalogTest, scan_tries_first_the_asset_whose_numbering_a_copy_keeps)
{
    // Two assets of one surface: the same vertices in reverse order ("a_reversed", first in the
    // index's order) and as made ("z_made"). Their signatures are equal (the draw does not
    // depend on the numbering), so the shape index ranks them as a tie; a moved copy of
    // z_made's published copy keeps z_made's numbering, and is tried against it first.
    const fs::path dir = test::temp_dir("catalog_in_order");
    fs::create_directories(dir / "in");
    const TriangleMesh made = lumpy_ellipsoid(3);
    TriangleMesh reversed = made;
    const auto n = static_cast<std::int32_t>(made.V.rows());
    for (std::int32_t i = 0; i < n; ++i)
    {
        reversed.V.row(i) = made.V.row(n - 1 - i);
    }
    for (Eigen::Index f = 0; f < made.F.rows(); ++f)
    {
        for (int k = 0; k < 3; ++k)
        {
            reversed.F(f, k) = n - 1 - made.F(f, k);
        }
    }
    write_mesh(dir / "in" / "a_reversed.ply", reversed);
    write_mesh(dir / "in" / "z_made.ply", made);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {dir / "in"}, dir / "out", quick_options());
    write_mesh(dir / "suspect.ply",
               apply_attacks(read_mesh(dir / "out" / "z_made.ply"),
                             parse_attack_spec("similarity,noise=0.0005"), 5, 1)
                   .mesh);
    CatalogScanOptions options;
    options.candidates = 1;
    const CatalogScanReport report = catalog_scan(catalog, {dir / "suspect.ply"}, options);
    ASSERT_EQ(report.suspects.size(), 1U);
    ASSERT_EQ(report.suspects[0].matches.size(), 1U);
    EXPECT_EQ(report.suspects[0].matches[0].asset, "z_made.ply");
    EXPECT_TRUE(report.suspects[0].tried.empty());
}

TEST(CatalogTest, scan_tells_near_duplicate_variants_apart_by_the_fit_of_their_points)
{
    // Six variants of one surface, each "scanned again": a smooth bump field of its own, about
    // 1.5% of the size. The shape index's features of a remeshed copy of one lie about as near
    // the others' (without the fit, the test fails). The fit of the copy's points onto each
    // variant's tells them apart, so the right one is the first tried.
    const fs::path dir = test::temp_dir("catalog_variants");
    write_variants(dir / "in", 0.015);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {dir / "in"}, dir / "out", quick_options());
    const CatalogScanOptions options = first_candidate_only();
    for (const std::string v : {"v1.ply", "v4.ply"})
    {
        write_mesh(dir / ("suspect-" + v),
                   apply_attacks(read_mesh(dir / "out" / v),
                                 parse_attack_spec("remesh=0.8,similarity"), 7, 1)
                       .mesh);
        const CatalogScanReport report = catalog_scan(catalog, {dir / ("suspect-" + v)}, options);
        ASSERT_EQ(report.suspects.size(), 1U);
        ASSERT_EQ(report.suspects[0].matches.size(), 1U) << v;
        EXPECT_EQ(report.suspects[0].matches[0].asset, v);
    }
}

TEST(CatalogTest, scan_tries_the_fits_of_a_wider_shortlist_when_no_candidate_matched)
{
    // One surface remeshed six ways (no variants of one mesh: each has counts of its own),
    // which neither the index nor a fit can tell apart. A crop of one's published
    // copy, moved, that the index does not rank first. With one candidate and only the index's
    // first asset fitted, the first round tries a wrong asset; the more candidates come from
    // the fit of the index's next ones, and one of them is the right asset.
    const fs::path dir = test::temp_dir("catalog_wider");
    fs::create_directories(dir / "in");
    for (int t = 0; t < 6; ++t)
    {
        write_mesh(dir / "in" / ("t" + std::to_string(t) + ".ply"),
                   apply_attacks(lumpy_ellipsoid(4),
                                 parse_attack_spec("remesh=" + std::to_string(0.8 + 0.04 * t)),
                                 static_cast<std::uint64_t>(t), 1)
                       .mesh);
    }
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {dir / "in"}, dir / "out", quick_options());
    const std::vector<Catalog::IndexEntry> index = catalog.shape_index();
    ASSERT_EQ(index.size(), 6U);
    std::string asset;
    for (int t = 0; t < 6 && asset.empty(); ++t)
    {
        const std::string name = "t" + std::to_string(t) + ".ply";
        const TriangleMesh crop = apply_attacks(read_mesh(dir / "out" / name),
                                                parse_attack_spec("crop=0.75,similarity"), 3, 1)
                                      .mesh;
        if (index[shape_candidates(index, shape_features(crop), 1)[0].second].id != name)
        {
            asset = name;
            write_mesh(dir / "suspect.ply", crop);
        }
    }
    ASSERT_FALSE(asset.empty()) << "every crop ranked first by the index: nothing to test";
    CatalogScanOptions options;
    options.candidates = 1;
    options.fit_shortlist = 1;
    options.more_candidates = 0;
    const CatalogScanReport without = catalog_scan(catalog, {dir / "suspect.ply"}, options);
    ASSERT_EQ(without.suspects.size(), 1U);
    EXPECT_FALSE(without.suspects[0].detected);
    ASSERT_EQ(without.suspects[0].tried.size(), 1U);
    // The five others are the more candidates; tried in order, stopping at the match.
    options.more_candidates = 5;
    const CatalogScanReport with = catalog_scan(catalog, {dir / "suspect.ply"}, options);
    ASSERT_EQ(with.suspects.size(), 1U);
    ASSERT_EQ(with.suspects[0].matches.size(), 1U);
    const CatalogMatch& match = with.suspects[0].matches[0];
    EXPECT_EQ(match.asset, asset);
    EXPECT_GE(match.rank, 1);
    ASSERT_EQ(with.suspects[0].tried.size(), static_cast<std::size_t>(match.rank));
    EXPECT_EQ(with.suspects[0].tried[0].asset, without.suspects[0].tried[0].asset);
}

TEST(CatalogTest, scan_tries_the_variant_whose_own_surface_fits_a_crop_best_first)
{
    // Six variants of one mesh (the same triangles, each with a faint bump field of its own):
    // a crop of one fits the points of them all about alike (with that fit alone, two
    // candidates missed at least one of these six crops). A fit onto each variant's own
    // surface tells them apart: each crop's asset is the first tried.
    const fs::path dir = test::temp_dir("catalog_variant_surfaces");
    write_variants(dir / "in", 0.004);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    (void)catalog_add(catalog, {dir / "in"}, dir / "out", quick_options());
    const CatalogScanOptions options = first_candidate_only();
    for (int v = 0; v < 6; ++v)
    {
        const std::string name = "v" + std::to_string(v) + ".ply";
        write_mesh(dir / "suspect.ply", apply_attacks(read_mesh(dir / "out" / name),
                                                      parse_attack_spec("crop=0.6,similarity"),
                                                      static_cast<std::uint64_t>(v), 1)
                                            .mesh);
        const CatalogScanReport report = catalog_scan(catalog, {dir / "suspect.ply"}, options);
        ASSERT_EQ(report.suspects[0].matches.size(), 1U) << name;
        EXPECT_EQ(report.suspects[0].matches[0].asset, name);
    }
}

}  // namespace
}  // namespace meshmark
