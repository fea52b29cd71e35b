// SPDX-License-Identifier: MIT
// What the catalogue's tests share (catalog_test.cpp, catalog_scan_test.cpp): the backend of the
// run (SQLite, or PostgreSQL under postgres.CatalogTest), SQL on it, originals to add, threads.
#pragma once

#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <SQLiteCpp/SQLiteCpp.h>
#include <gtest/gtest.h>
#include <libpq-fe.h>
#include <unistd.h>

#include "meshmark/catalog/catalog_add.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::test
{

// The backend of this run: SQLite files, or, when MESHMARK_TEST_POSTGRES names a server
// (postgres_server.py, test postgres.CatalogTest), a new PostgreSQL database for each catalogue.
inline const char* postgres_server()
{
    const char* url = std::getenv("MESHMARK_TEST_POSTGRES");
    return url != nullptr && *url != '\0' ? url : nullptr;
}

// Rows of \p statement ($1, $2, ... bound to \p params) in the catalogue at \p location, as text.
inline std::vector<std::vector<std::string>> sql(const std::string& location,
                                                 const std::string& statement,
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
inline std::string catalog_at(const std::filesystem::path& dir)
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
inline std::string blob_literal(const std::vector<std::uint8_t>& bytes)
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
inline std::filesystem::path make_originals(const std::filesystem::path& root)
{
    const std::filesystem::path in = root / "in";
    std::filesystem::create_directories(in / "sub");
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

inline const CatalogAddOutcome& outcome_of(const std::vector<CatalogAddOutcome>& outcomes,
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

inline CatalogAddOptions quick_options()
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

}  // namespace meshmark::test
