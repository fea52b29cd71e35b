// SPDX-License-Identifier: MIT
#include "meshmark/catalog/catalog.h"

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
#include "meshmark/catalog/catalog_add.h"
#include "meshmark/catalog/catalog_reindex.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using namespace test;  // catalog_test_support.h

TEST(CatalogTest, a_new_catalogue_is_private_and_a_missing_or_foreign_file_is_refused)
{
    const fs::path dir = test::temp_dir("catalog_open");
    if (const char* server = postgres_server())
    {
        // A database must exist; an empty one is no catalogue but for `add` (CreateIfMissing);
        // one of other tables is refused; the password is in no message and not in path().
        const std::string secret = std::string(server).insert(13 + 8, ":hunter2");
        ASSERT_EQ(secret.substr(0, 30), "postgresql://postgres:hunter2@");
        try
        {
            const Catalog none(secret + "/no_such_database", Catalog::Open::Existing);
            ADD_FAILURE() << "opened a missing database";
        }
        catch (const IoError& e)
        {
            EXPECT_EQ(std::string(e.what()).find("hunter2"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("no_such_database"), std::string::npos);
        }
        const std::string at = catalog_at(dir);
        const std::string at_secret = secret + at.substr(at.rfind('/'));
        EXPECT_THROW(Catalog(at_secret, Catalog::Open::Existing), IoError);
        {
            const Catalog catalog(at_secret + "?application_name=t&password=hunter2",
                                  Catalog::Open::CreateIfMissing);
            EXPECT_EQ(catalog.path().string(), at + "?application_name=t");
            EXPECT_TRUE(catalog.assets().empty());
            EXPECT_EQ(catalog.complete_count(), 0U);
        }
        EXPECT_NO_THROW(Catalog(at, Catalog::Open::Existing));
        const std::string other = catalog_at(dir);
        (void)sql(other, "CREATE TABLE assets (x INTEGER)");
        EXPECT_THROW(Catalog(other, Catalog::Open::CreateIfMissing), IoError);
        return;
    }
    EXPECT_THROW(Catalog(dir / "none.db", Catalog::Open::Existing), IoError);
    {
        const Catalog catalog(dir / "sub" / "cat.db", Catalog::Open::CreateIfMissing);
        EXPECT_TRUE(catalog.assets().empty());
        EXPECT_EQ(catalog.complete_count(), 0U);
    }
    struct stat info
    {
    };
    ASSERT_EQ(::stat((dir / "sub" / "cat.db").c_str(), &info), 0);
    EXPECT_EQ(info.st_mode & 0777U, 0600U);
    EXPECT_NO_THROW(Catalog(dir / "sub" / "cat.db", Catalog::Open::Existing));
    std::ofstream(dir / "text.db")
        << "hello, not SQLite at all, and long enough to be read as a header.....";
    EXPECT_THROW(Catalog(dir / "text.db", Catalog::Open::Existing), IoError);
}

TEST(CatalogTest, add_marks_every_file_reports_each_outcome_and_a_second_run_changes_nothing)
{
    const fs::path dir = test::temp_dir("catalog_add");
    const fs::path in = make_originals(dir);
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    const auto outcomes = catalog_add(catalog, {in}, dir / "out", quick_options());
    ASSERT_EQ(outcomes.size(), 5U);  // notes.txt is not a mesh file
    for (const char* asset : {"ellipsoid.ply", "sub/torus.obj", "sub/egg.off"})
    {
        const CatalogAddOutcome& o = outcome_of(outcomes, asset);
        EXPECT_EQ(o.status, CatalogAddOutcome::Status::Marked) << asset << ": " << o.reason;
        EXPECT_TRUE(fs::exists(dir / "out" / asset)) << asset;
    }
    EXPECT_EQ(outcome_of(outcomes, "tiny.stl").status, CatalogAddOutcome::Status::Unmarkable);
    EXPECT_NE(outcome_of(outcomes, "tiny.stl").reason.find("tiny.stl"), std::string::npos);
    EXPECT_EQ(outcome_of(outcomes, "broken.obj").status, CatalogAddOutcome::Status::Failed);
    EXPECT_NE(outcome_of(outcomes, "broken.obj").reason.find("broken.obj"), std::string::npos);
    EXPECT_FALSE(fs::exists(dir / "out" / "tiny.stl"));
    EXPECT_FALSE(fs::exists(dir / "out" / "broken.obj"));

    const std::vector<CatalogAsset> assets = catalog.assets();
    ASSERT_EQ(assets.size(), 3U);
    std::set<std::uint64_t> seeds;
    for (const CatalogAsset& a : assets)
    {
        EXPECT_TRUE(a.is_complete);
        EXPECT_EQ(a.original_sha256.size(), 64U);
        ASSERT_TRUE(a.key.recipients.has_value());
        ASSERT_EQ(a.key.recipients->recipients.size(), 1U);
        EXPECT_EQ(a.key.recipients->recipients[0].name, kPublishedRecipient);
        seeds.insert(a.key.seed);
        const auto recipients = catalog.recipients(a.id);
        ASSERT_EQ(recipients.size(), 1U);
        EXPECT_TRUE(recipients[0].is_delivered);
        EXPECT_EQ(recipients[0].path, a.published);
    }
    EXPECT_EQ(seeds.size(), 3U) << "one --seed, yet every asset its own key";

    const std::string before = test::file_bytes(dir / "out" / "sub" / "torus.obj");
    const auto again = catalog_add(catalog, {in}, dir / "out", quick_options());
    for (const char* asset : {"ellipsoid.ply", "sub/torus.obj", "sub/egg.off"})
    {
        EXPECT_EQ(outcome_of(again, asset).status, CatalogAddOutcome::Status::Present) << asset;
    }
    EXPECT_EQ(test::file_bytes(dir / "out" / "sub" / "torus.obj"), before);
}

TEST(CatalogTest, a_changed_original_is_refused_unless_forced_and_then_gets_a_new_key)
{
    const fs::path dir = test::temp_dir("catalog_changed");
    const fs::path in = dir / "in";
    fs::create_directories(in);
    write_mesh(in / "a.ply", lumpy_ellipsoid(4));
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    ASSERT_EQ(catalog_add(catalog, {in}, dir / "out", quick_options())[0].status,
              CatalogAddOutcome::Status::Marked);
    const std::uint64_t first_seed = catalog.asset("a.ply")->key.seed;
    TriangleMesh other = lumpy_ellipsoid(4);
    other.V *= 2.0;
    write_mesh(in / "a.ply", other);
    const auto refused = catalog_add(catalog, {in}, dir / "out", quick_options());
    EXPECT_EQ(refused[0].status, CatalogAddOutcome::Status::Failed);
    EXPECT_NE(refused[0].reason.find("changed since it was added"), std::string::npos)
        << refused[0].reason;
    EXPECT_EQ(catalog.asset("a.ply")->key.seed, first_seed);
    CatalogAddOptions force = quick_options();
    force.force = true;
    force.embed.seed = 12;
    EXPECT_EQ(catalog_add(catalog, {in}, dir / "out", force)[0].status,
              CatalogAddOutcome::Status::Marked);
    EXPECT_NE(catalog.asset("a.ply")->key.seed, first_seed);
}

TEST(CatalogTest, an_obj_copy_gets_its_material_library_and_textures_beside_it)
{
    const fs::path dir = test::temp_dir("catalog_materials");
    const fs::path in = dir / "in";
    fs::create_directories(in / "maps");
    write_mesh(in / "model.obj", lumpy_ellipsoid(4));
    const std::string mesh = test::file_bytes(in / "model.obj");
    std::ofstream(in / "model.obj") << "mtllib model.mtl\nusemtl skin\n" << mesh;
    std::ofstream(in / "model.mtl")
        << "newmtl skin\nmap_Kd -s 1 1 1 maps/skin.png\nbump ../outside.png\n";
    std::ofstream(in / "maps" / "skin.png") << "PNG bytes";
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    const auto outcomes = catalog_add(catalog, {in}, dir / "out", quick_options());
    ASSERT_EQ(outcomes[0].status, CatalogAddOutcome::Status::Marked) << outcomes[0].reason;
    EXPECT_EQ(test::file_bytes(dir / "out" / "model.mtl"), test::file_bytes(in / "model.mtl"));
    EXPECT_EQ(test::file_bytes(dir / "out" / "maps" / "skin.png"), "PNG bytes");
    EXPECT_NE(test::file_bytes(dir / "out" / "model.obj").find("mtllib model.mtl"),
              std::string::npos);

    // An OBJ too small for a mark leaves no material beside a copy it does not get (a worker's
    // marking leaves none either: docs/cluster.md).
    fs::create_directories(in / "small");
    std::ofstream(in / "small" / "tri.obj")
        << "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::ofstream(in / "small" / "tri.mtl") << "newmtl none\n";
    const auto again = catalog_add(catalog, {in}, dir / "out", quick_options());
    ASSERT_EQ(again.size(), 2U);
    EXPECT_EQ(again[1].status, CatalogAddOutcome::Status::Unmarkable) << again[1].reason;
    EXPECT_FALSE(fs::exists(dir / "out" / "small" / "tri.mtl"));
}

TEST(CatalogTest, issue_records_names_before_copies_and_threads_at_once_never_share_a_code)
{
    const fs::path dir = test::temp_dir("catalog_issue");
    const fs::path in = dir / "in";
    fs::create_directories(in);
    write_mesh(in / "a.ply", lumpy_ellipsoid(4));
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    ASSERT_EQ(catalog_add(catalog, {in}, dir / "out", quick_options())[0].status,
              CatalogAddOutcome::Status::Marked);
    EXPECT_THROW(
        (void)catalog_issue(catalog, "nope.ply", (dir / "c" / "{recipient}.ply").string(), {}),
        InvalidOption);

    on_threads(4,
               [&](int t)
               {
                   Catalog mine(at, Catalog::Open::Existing);
                   CatalogIssueOptions options;
                   options.recipients = {"buyer" + std::to_string(t), "shared"};
                   options.threads = 1;
                   (void)catalog_issue(mine, "a.ply", (dir / "copies" / "{recipient}.ply").string(),
                                       options);
               });
    const auto recipients = catalog.recipients("a.ply");
    ASSERT_EQ(recipients.size(), 6U);  // published, shared, buyer0..3
    std::set<std::uint32_t> codes;
    for (const CatalogRecipient& r : recipients)
    {
        codes.insert(r.index);
        EXPECT_TRUE(r.is_delivered) << r.name;
    }
    EXPECT_EQ(codes.size(), recipients.size());
    const auto key = catalog.asset("a.ply")->key;
    EXPECT_EQ(key.recipients->recipients.size(), 6U);

    // A name issued again gets the same bytes.
    const std::string first = test::file_bytes(dir / "copies" / "buyer2.ply");
    CatalogIssueOptions again;
    again.recipients = {"buyer2"};
    (void)catalog_issue(catalog, "a.ply", (dir / "again" / "{recipient}.ply").string(), again);
    EXPECT_EQ(test::file_bytes(dir / "again" / "buyer2.ply"), first);
}

TEST(CatalogTest,
     record_recipient_gives_each_name_one_code_from_many_connections_and_copies_match_issue)
{
    const fs::path dir = test::temp_dir("catalog_record");
    const fs::path in = dir / "in";
    fs::create_directories(in);
    write_mesh(in / "a.ply", lumpy_ellipsoid(4));
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing);
    ASSERT_EQ(catalog_add(catalog, {in}, dir / "out", quick_options())[0].status,
              CatalogAddOutcome::Status::Marked);
    EXPECT_THROW((void)catalog.record_recipient("nope.ply", "x"), InvalidOption);
    EXPECT_THROW((void)catalog.record_recipient("a.ply", "../x"), InvalidOption);

    // 4 connections (as 4 processes), 25 names each, 5 of them shared by all.
    std::vector<std::vector<std::pair<std::string, std::uint32_t>>> got(4);
    on_threads(4,
               [&](int t)
               {
                   Catalog mine(at, Catalog::Open::Existing);
                   for (int i = 0; i < 25; ++i)
                   {
                       const std::string name =
                           i < 5 ? "shared" + std::to_string(i)
                                 : "t" + std::to_string(t) + "n" + std::to_string(i);
                       got[static_cast<std::size_t>(t)].emplace_back(
                           name, mine.record_recipient("a.ply", name).index);
                   }
               });
    const auto recipients = catalog.recipients("a.ply");
    ASSERT_EQ(recipients.size(), 1U + 5U + 4U * 20U);  // published, the shared, each thread's own
    std::map<std::string, std::uint32_t> recorded;
    std::set<std::uint32_t> codes;
    for (const CatalogRecipient& r : recipients)
    {
        recorded[r.name] = r.index;
        codes.insert(r.index);
    }
    EXPECT_EQ(codes.size(), recipients.size());
    for (const auto& names : got)
    {
        for (const auto& [name, index] : names)
        {
            EXPECT_EQ(recorded.at(name), index) << name;
        }
    }
    EXPECT_FALSE(catalog.record_recipient("a.ply", "shared3").is_new);
    EXPECT_EQ(catalog.asset("a.ply")->key.recipients->recipients.size(), recipients.size());

    // catalog_issue of a recorded name writes the copy of its recorded code.
    CatalogIssueOptions again;
    again.recipients = {"t2n7"};
    const auto report =
        catalog_issue(catalog, "a.ply", (dir / "c" / "{recipient}.ply").string(), again);
    ASSERT_EQ(report.copies.size(), 1U);
    EXPECT_EQ(report.copies[0].index, recorded.at("t2n7"));
    EXPECT_FALSE(report.copies[0].is_new);
}

// A change waits for one in progress elsewhere (SQLite: a writer; PostgreSQL: the catalogue's
// advisory lock held exclusively, as a migration holds it) up to the busy timeout, then fails
// saying so, and records nothing.
TEST(CatalogTest, a_change_waits_for_another_up_to_the_busy_timeout_then_says_the_catalogue_is_busy)
{
    const fs::path dir = test::temp_dir("catalog_busy");
    fs::create_directories(dir / "in");
    write_mesh(dir / "in" / "a.ply", lumpy_ellipsoid(3));
    const std::string at = catalog_at(dir);
    Catalog catalog(at, Catalog::Open::CreateIfMissing, std::chrono::milliseconds(300));
    ASSERT_EQ(catalog_add(catalog, {dir / "in"}, dir / "out", quick_options())[0].status,
              CatalogAddOutcome::Status::Marked);
    const auto held_while = [&](auto&& work)
    {
        if (postgres_server() != nullptr)
        {
            PGconn* other = PQconnectdb(at.c_str());
            PQclear(PQexec(other, "SELECT pg_advisory_lock(28013, 0)"));  // 0x6d6d: meshmark's
            work();
            PQfinish(other);
        }
        else
        {
            SQLite::Database other(at, SQLite::OPEN_READWRITE);
            SQLite::Transaction writing(other, SQLite::TransactionBehavior::IMMEDIATE);
            work();
        }
    };
    held_while(
        [&]
        {
            const auto start = std::chrono::steady_clock::now();
            try
            {
                (void)catalog.record_recipient("a.ply", "late");
                ADD_FAILURE() << "recorded while another change held the catalogue";
            }
            catch (const IoError& e)
            {
                EXPECT_NE(std::string(e.what()).find("stayed busy"), std::string::npos) << e.what();
            }
            EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(250));
        });
    EXPECT_FALSE(catalog.recipient_index("a.ply", "late").has_value());
    EXPECT_TRUE(catalog.record_recipient("a.ply", "late").is_new);
}

TEST(CatalogTest, a_version_1_catalogue_is_read_with_its_recipients_and_upgraded)
{
    const fs::path dir = test::temp_dir("catalog_v1");
    const fs::path in = dir / "in";
    fs::create_directories(in);
    write_mesh(in / "a.ply", lumpy_ellipsoid(4));
    Key before;
    const std::string at = catalog_at(dir);
    {
        Catalog catalog(at, Catalog::Open::CreateIfMissing);
        ASSERT_EQ(catalog_add(catalog, {in}, dir / "out", quick_options())[0].status,
                  CatalogAddOutcome::Status::Marked);
        CatalogIssueOptions issue;
        issue.recipients = {"alice", "bob"};
        (void)catalog_issue(catalog, "a.ply", (dir / "c" / "{recipient}.ply").string(), issue);
        before = catalog.asset("a.ply")->key;
    }
    // Make it what version 1 wrote: the recipients inside the key's JSON as well.
    (void)sql(at, "UPDATE assets SET key_json = $1 WHERE id = 'a.ply'", {to_json(before)});
    (void)sql(at, "UPDATE meta SET value = '1' WHERE name = 'version'");
    Catalog catalog(at, Catalog::Open::Existing);
    EXPECT_EQ(to_json(catalog.asset("a.ply")->key), to_json(before));
    EXPECT_EQ(sql(at, "SELECT value FROM meta WHERE name = 'version'")[0][0], "3");
    EXPECT_EQ(sql(at, "SELECT key_json FROM assets WHERE id = 'a.ply'")[0][0].find("alice"),
              std::string::npos);
}

}  // namespace
}  // namespace meshmark
