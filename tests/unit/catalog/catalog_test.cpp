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

// The backend of this run: SQLite files, or, when MESHMARK_TEST_POSTGRES names a server
// (postgres_server.py, test postgres.CatalogTest), a new PostgreSQL database for each catalogue.
const char* postgres_server()
{
    const char* url = std::getenv("MESHMARK_TEST_POSTGRES");
    return url != nullptr && *url != '\0' ? url : nullptr;
}

// Rows of \p statement ($1, $2, ... bound to \p params) in the catalogue at \p location, as text.
std::vector<std::vector<std::string>> sql(const std::string& location, const std::string& statement,
                                          const std::vector<std::string>& params = {})
{
    std::vector<std::vector<std::string>> rows;
    if (postgres_server() == nullptr)
    {
        SQLite::Database db(location, SQLite::OPEN_READWRITE);
        SQLite::Statement query(db, statement);
        for (std::size_t p = 0; p < params.size(); ++p)
        {
            query.bind(static_cast<int>(p) + 1, params[p]);
        }
        while (query.executeStep())
        {
            rows.emplace_back();
            for (int c = 0; c < query.getColumnCount(); ++c)
            {
                rows.back().push_back(query.getColumn(c).getString());
            }
        }
        return rows;
    }
    PGconn* conn = PQconnectdb(location.c_str());
    std::vector<const char*> values;
    for (const std::string& p : params)
    {
        values.push_back(p.c_str());
    }
    PGresult* result = PQexecParams(conn, statement.c_str(), static_cast<int>(params.size()),
                                    nullptr, values.data(), nullptr, nullptr, 0);
    const ExecStatusType status = PQresultStatus(result);
    const std::string error = PQresultErrorMessage(result);
    for (int r = 0; r < PQntuples(result); ++r)
    {
        rows.emplace_back();
        for (int c = 0; c < PQnfields(result); ++c)
        {
            rows.back().emplace_back(PQgetvalue(result, r, c));
        }
    }
    PQclear(result);
    PQfinish(conn);
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK)
    {
        throw std::runtime_error(statement + ": " + error);
    }
    return rows;
}

// Where a test's catalogue is: \p dir/cat.db, or a new database of the test server.
std::string catalog_at(const fs::path& dir)
{
    const char* server = postgres_server();
    if (server == nullptr)
    {
        return (dir / "cat.db").string();
    }
    static int count = 0;
    const std::string name =
        "catalog_test_" + std::to_string(::getpid()) + "_" + std::to_string(count++);
    (void)sql(std::string(server) + "/postgres", "CREATE DATABASE " + name);
    return std::string(server) + "/" + name;
}

// \p bytes as an SQL literal of the backend: X'..' (SQLite), '\x..'::bytea (PostgreSQL).
std::string blob_literal(const std::vector<std::uint8_t>& bytes)
{
    std::string hex;
    for (const std::uint8_t b : bytes)
    {
        static const char* digits = "0123456789abcdef";
        hex += digits[b >> 4U];
        hex += digits[b & 15U];
    }
    return postgres_server() ? "'\\x" + hex + "'::bytea" : "X'" + hex + "'";
}

// A folder of three markable originals (two in a subfolder), one too small, one unreadable.
fs::path make_originals(const fs::path& root)
{
    const fs::path in = root / "in";
    fs::create_directories(in / "sub");
    write_mesh(in / "ellipsoid.ply", lumpy_ellipsoid(4));
    write_mesh(in / "sub" / "torus.obj", torus(1.0, 0.3, 48, 24));
    TriangleMesh sphere = icosphere(4);
    sphere.V.col(2) *= 1.7;
    write_mesh(in / "sub" / "egg.off", sphere);
    write_mesh(in / "tiny.stl", icosphere(0));
    std::ofstream(in / "broken.obj") << "v 0 0 0\nf 1 2 3\n";
    std::ofstream(in / "notes.txt") << "not a mesh\n";
    return in;
}

const CatalogAddOutcome& outcome_of(const std::vector<CatalogAddOutcome>& outcomes,
                                    const std::string& asset)
{
    for (const CatalogAddOutcome& o : outcomes)
    {
        if (o.asset == asset)
        {
            return o;
        }
    }
    throw std::runtime_error("no outcome for " + asset);
}

CatalogAddOptions quick_options()
{
    CatalogAddOptions options;
    options.embed.seed = 11;
    return options;
}

// Runs \p work(t) for t = 0 .. count-1 on threads of their own (each opening its own catalogue
// connection, as separate processes would) and expects none to throw.
template <class Work>
void on_threads(int count, Work&& work)
{
    std::vector<std::thread> threads;
    std::vector<std::exception_ptr> failures(static_cast<std::size_t>(count));
    for (int t = 0; t < count; ++t)
    {
        threads.emplace_back(
            [&, t]
            {
                try
                {
                    work(t);
                }
                catch (...)
                {
                    failures[static_cast<std::size_t>(t)] = std::current_exception();
                }
            });
    }
    for (std::thread& thread : threads)
    {
        thread.join();
    }
    for (const auto& failure : failures)
    {
        EXPECT_FALSE(failure);
    }
}

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
    EXPECT_EQ(sql(at, "SELECT value FROM meta WHERE name = 'version'")[0][0], "2");
    EXPECT_EQ(sql(at, "SELECT key_json FROM assets WHERE id = 'a.ply'")[0][0].find("alice"),
              std::string::npos);
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
        (void)sql(at, "UPDATE assets SET shape = " + blob_literal({}) +
                          " WHERE id IN ('sub/egg.off', 'sub/torus.obj')");
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
        index.push_back({"asset" + std::to_string(m), shape_signature(meshes[m]).to_bytes()});
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

}  // namespace
}  // namespace meshmark
