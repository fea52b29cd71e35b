// SPDX-License-Identifier: MIT
// The regression test's groups of cases (detect_regression_test.cpp,
// detect_regression_gltf_test.cpp): run the program, compare with the saved expectations.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "meshmark/io/file_sha256.h"
#include "support/cli_run.h"
#include "support/test_paths.h"

namespace meshmark::regression
{

namespace fs = std::filesystem;

using Json = nlohmann::ordered_json;

inline bool is_updating()
{
    const char* env = std::getenv("MESHMARK_UPDATE_EXPECTATIONS");
    return env != nullptr && *env != '\0' && std::string(env) != "0";
}

inline std::string quoted(const fs::path& path)
{
    return "\"" + path.string() + "\"";
}

// Where JSON \p found differs from \p saved: one line per field ("registration.method: saved
// "x", found "y""), numbers compared as printed.
inline void differences(const Json& saved, const Json& found, const std::string& at,
                        std::vector<std::string>& out)
{
    const auto name = [&](const std::string& field)
    { return at.empty() ? field : at + "." + field; };
    if (saved.is_object() && found.is_object())
    {
        for (const auto& [field, value] : saved.items())
        {
            if (!found.contains(field))
            {
                out.push_back(name(field) + ": saved " + value.dump() + ", missing now");
            }
            else
            {
                differences(value, found.at(field), name(field), out);
            }
        }
        for (const auto& [field, value] : found.items())
        {
            if (!saved.contains(field))
            {
                out.push_back(name(field) + ": not saved, found " + value.dump());
            }
        }
        return;
    }
    if (saved.is_array() && found.is_array() && saved.size() == found.size())
    {
        for (std::size_t i = 0; i < saved.size(); ++i)
        {
            differences(saved[i], found[i], at + "[" + std::to_string(i) + "]", out);
        }
        return;
    }
    if (saved.dump() != found.dump())
    {
        out.push_back((at.empty() ? "(whole)" : at) + ": saved " + saved.dump() + ", found " +
                      found.dump());
    }
}

/// One group of cases: its files in a temporary folder, what the program printed and wrote,
/// compared with (or saved as) tests/data/expectations/detect/<name>.json by finish().
class Group
{
public:
    explicit Group(std::string name)
        : name_(std::move(name)), dir_(test::temp_dir("regression_" + name_))
    {
        ::setenv("MESHMARK_BASIS_KERNEL", "portable", 1);
    }

    [[nodiscard]] const fs::path& dir() const { return dir_; }
    [[nodiscard]] fs::path at(const std::string& file) const { return dir_ / file; }

    /// `meshmark ARGUMENTS`, which must exit with \p expected_exit; its stdout.
    std::string run(const std::string& arguments, int expected_exit = 0)
    {
        const test::CliRun run = test::run_cli(arguments, dir_);
        EXPECT_EQ(run.exit_code, expected_exit) << "meshmark " << arguments << "\n" << run.err;
        return run.out;
    }

    /// embed \p input with --seed \p seed (and \p more options) into \p output and \p key; the
    /// SHA-256 of \p outputs (default: the marked copy and the key) are recorded under "embed".
    void embed(const std::string& label, const fs::path& input, const std::string& output,
               const std::string& key, std::uint64_t seed, const std::string& more = "",
               std::vector<std::string> outputs = {})
    {
        run("embed " + quoted(input) + " -o " + quoted(at(output)) + " --key " + quoted(at(key)) +
            " --seed " + std::to_string(seed) + " " + more + " --quiet");
        if (outputs.empty())
        {
            outputs = {output, key};
        }
        for (const std::string& file : outputs)
        {
            found_["embed"][label][file] = fs::exists(at(file)) ? file_sha256(at(file)) : "missing";
        }
    }

    /// attack \p input with \p spec and --seed \p seed into \p output.
    void attack(const std::string& input, const std::string& spec, std::uint64_t seed,
                const std::string& output)
    {
        run("attack " + quoted(at(input)) + " " + spec + " -o " + quoted(at(output)) + " --seed " +
            std::to_string(seed) + " --quiet");
    }

    /// detect --json of \p suspect against \p original with \p key (and \p more options, saved
    /// as "options" when given), recorded as case \p label: the suspect's SHA-256, the exit code
    /// and the JSON without its timings.
    void detect(const std::string& label, const std::string& suspect, const fs::path& original,
                const std::string& key, const std::string& more = "")
    {
        const test::CliRun run = test::run_cli(
            "detect " + quoted(at(suspect)) + " --original " + quoted(original) + " --key " +
                quoted(at(key)) + (more.empty() ? "" : " " + more) + " --json --quiet",
            dir_);
        Json result;
        if (!more.empty())
        {
            result["options"] = more;
        }
        result["suspect_sha256"] = fs::exists(at(suspect)) ? file_sha256(at(suspect)) : "missing";
        result["exit_code"] = run.exit_code;
        try
        {
            Json report = Json::parse(run.out);
            report.erase("seconds");
            result["detect"] = std::move(report);
        }
        catch (const std::exception&)
        {
            result["detect"] = "unparsable stdout: " + run.out + " stderr: " + run.err;
        }
        found_["cases"][label] = std::move(result);
    }

    /// What detect printed for case \p label (null when it was not run or did not parse): the
    /// tests check with it that a case still takes the path it is there for.
    [[nodiscard]] Json report(const std::string& label) const
    {
        if (!found_.at("cases").contains(label) ||
            !found_.at("cases").at(label).at("detect").is_object())
        {
            return Json(nullptr);
        }
        return found_.at("cases").at(label).at("detect");
    }

    /// Saves the expectations (MESHMARK_UPDATE_EXPECTATIONS) or compares with them.
    void finish()
    {
        const fs::path saved_path = fs::path(MESHMARK_EXPECTATIONS_DIR) / (name_ + ".json");
        if (is_updating())
        {
            fs::create_directories(saved_path.parent_path());
            std::ofstream(saved_path) << found_.dump(2) << "\n";
            std::printf("wrote %s\n", saved_path.string().c_str());
            return;
        }
        std::ifstream in(saved_path);
        ASSERT_TRUE(in) << "no saved expectations " << saved_path
                        << " (MESHMARK_UPDATE_EXPECTATIONS=1 writes them; see this test's header)";
        const Json saved = Json::parse(in);
        std::vector<std::string> lines;
        for (const char* part : {"embed", "cases"})
        {
            const Json& s = saved.contains(part) ? saved.at(part) : Json::object();
            const Json& f = found_.contains(part) ? found_.at(part) : Json::object();
            for (const auto& [label, value] : s.items())
            {
                std::vector<std::string> fields;
                differences(value, f.contains(label) ? f.at(label) : Json(nullptr), "", fields);
                for (const std::string& field : fields)
                {
                    lines.push_back(std::string(part) + " '" + name_ + "/" + label + "', " + field);
                }
            }
            for (const auto& [label, value] : f.items())
            {
                if (!s.contains(label))
                {
                    lines.push_back(std::string(part) + " '" + name_ + "/" + label +
                                    "': not in the saved expectations");
                }
            }
        }
        std::string report;
        for (std::size_t i = 0; i < lines.size() && i < 60; ++i)
        {
            report += "  " + lines[i] + "\n";
        }
        EXPECT_TRUE(lines.empty())
            << lines.size() << " difference(s) from " << saved_path << ":\n"
            << report << "(MESHMARK_KEEP_TEST_DIRS=1 keeps the files in " << dir_ << ")";
    }

private:
    std::string name_;
    fs::path dir_;
    Json found_ = {{"embed", Json::object()}, {"cases", Json::object()}};
};

}  // namespace meshmark::regression
