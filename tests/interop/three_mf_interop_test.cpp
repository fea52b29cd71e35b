// SPDX-License-Identifier: MIT
// The interop suite's 3MF test (docs/interop.md): a 3MF exported by PrusaSlicer, marked by
// `meshmark embed`, read back by `prusa-slicer --info` (the object stays where it was) and by
// `meshmark detect`; every package entry but the model parts is kept byte for byte.
#include <cmath>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <zip.h>

#include "interop_support.h"
#include "support/test_paths.h"

namespace meshmark::test::interop
{
namespace
{

// `prusa-slicer --info` of a 3MF: size_x/y/z and min_x/y/z.
std::map<std::string, double> prusa_info(const fs::path& file, const fs::path& scratch,
                                         std::string* error)
{
    const ToolRun r = run(
        {tools().xvfb_run.string(), "-a", tools().prusa_slicer.string(), "--info", file.string()},
        scratch);
    std::map<std::string, double> info;
    if (!r.ok())
    {
        *error = r.describe();
        return info;
    }
    const std::regex line(R"(^(size|min)_([xyz]) = (-?[0-9.eE+-]+))");
    std::stringstream lines(r.result.out);
    std::string text;
    while (std::getline(lines, text))
    {
        std::smatch match;
        if (std::regex_search(text, match, line))
        {
            info[match[1].str() + "_" + match[2].str()] = std::stod(match[3].str());
        }
    }
    if (info.size() != 6)
    {
        *error = "`prusa-slicer --info " + file.string() + "` printed " +
                 std::to_string(info.size()) + " of the 6 size_/min_ values: " + tail(r.result.out);
    }
    return info;
}

// The entries of a zip file: name -> content (libzip).
std::map<std::string, std::string> zip_entries(const fs::path& file, std::string* error)
{
    std::map<std::string, std::string> entries;
    int code = 0;
    zip_t* archive = zip_open(file.c_str(), ZIP_RDONLY, &code);
    if (archive == nullptr)
    {
        *error = file.string() + ": libzip cannot open it (error " + std::to_string(code) + ")";
        return entries;
    }
    const zip_int64_t count = zip_get_num_entries(archive, 0);
    for (zip_int64_t i = 0; i < count; ++i)
    {
        zip_stat_t stat;
        zip_stat_init(&stat);
        if (zip_stat_index(archive, static_cast<zip_uint64_t>(i), 0, &stat) != 0)
        {
            *error = file.string() + ": cannot stat zip entry " + std::to_string(i);
            break;
        }
        std::string content(static_cast<std::size_t>(stat.size), '\0');
        zip_file_t* entry = zip_fopen_index(archive, static_cast<zip_uint64_t>(i), 0);
        const zip_int64_t got = entry != nullptr ? zip_fread(entry, content.data(), stat.size) : -1;
        if (entry != nullptr)
        {
            zip_fclose(entry);
        }
        if (got != static_cast<zip_int64_t>(stat.size))
        {
            *error = file.string() + ": cannot read zip entry " + stat.name;
            break;
        }
        entries[stat.name] = std::move(content);
    }
    zip_close(archive);
    return entries;
}

TEST(ThreeMfInterop, PrusaSlicerBunny)
{
    const fs::path mesh = mesh_dir() / "bunny.stl";
    if (!fs::exists(mesh))
    {
        GTEST_SKIP() << mesh << " is missing (shared meshes not available)";
    }
    INTEROP_REQUIRE_TOOLS("meshmark", "prusa-slicer");

    std::string error;
    const std::string stamp =
        "prusa-slicer --export-3mf\n" + file_stamp(mesh) + file_stamp(tools().prusa_slicer);
    const fs::path folder = corpus_entry(
        "bunny.prusa_3mf", stamp,
        [&](const fs::path& staging)
        {
            const ToolRun r =
                run({tools().xvfb_run.string(), "-a", tools().prusa_slicer.string(), "--export-3mf",
                     "-o", (staging / "in.3mf").string(), mesh.string()},
                    staging);
            return r.ok() && fs::exists(staging / "in.3mf") ? std::string{} : r.describe();
        },
        &error);
    ASSERT_FALSE(folder.empty()) << "cannot make the PrusaSlicer 3MF: " << error;
    const fs::path in = folder / "in.3mf";
    const fs::path scratch = temp_dir("interop-bunny-3mf");
    const fs::path out = scratch / "out.3mf";
    const fs::path key = scratch / "out.key";

    const ToolRun embed = meshmark(
        {"embed", in.string(), "-o", out.string(), "--key", key.string(), "--seed", kSeed, "-q"},
        scratch);
    ASSERT_TRUE(embed.ok()) << "embed of the PrusaSlicer 3MF (bunny.stl) failed: "
                            << embed.describe();

    // PrusaSlicer's own reading of both packages: the object must stay where it was.
    std::string in_error;
    std::string out_error;
    const auto in_info = prusa_info(in, scratch, &in_error);
    const auto out_info = prusa_info(out, scratch, &out_error);
    EXPECT_TRUE(in_error.empty()) << "prusa-slicer --info on the input: " << in_error;
    EXPECT_TRUE(out_error.empty()) << "prusa-slicer --info on meshmark's output: " << out_error;
    if (in_error.empty() && out_error.empty())
    {
        const double diagonal = std::sqrt(in_info.at("size_x") * in_info.at("size_x") +
                                          in_info.at("size_y") * in_info.at("size_y") +
                                          in_info.at("size_z") * in_info.at("size_z"));
        for (const auto& [name, value] : in_info)
        {
            EXPECT_LE(std::abs(out_info.at(name) - value), 0.01 * diagonal)
                << "prusa-slicer --info: " << name << " of the marked 3MF is " << out_info.at(name)
                << ", of the input " << value << " (diagonal " << diagonal << ")";
        }
    }

    const ToolRun found = meshmark(
        {"detect", out.string(), "--original", in.string(), "--key", key.string(), "-q"}, scratch);
    EXPECT_EQ(found.result.exit_code, 0) << "detect on the marked 3MF: " << found.describe();

    // Everything in the package but the model parts is the input's, byte for byte.
    std::string zip_error;
    const auto in_entries = zip_entries(in, &zip_error);
    const auto out_entries = zip_entries(out, &zip_error);
    ASSERT_TRUE(zip_error.empty()) << zip_error;
    const std::regex model(R"(^3D/.*\.model$)");
    std::set<std::string> names;
    for (const auto& entries : {in_entries, out_entries})
    {
        for (const auto& [name, content] : entries)
        {
            if (!std::regex_match(name, model))
            {
                names.insert(name);
            }
        }
    }
    for (const auto& name : names)
    {
        const auto a = in_entries.find(name);
        const auto b = out_entries.find(name);
        if (a == in_entries.end() || b == out_entries.end())
        {
            ADD_FAILURE() << "3MF entry " << name << " is only in "
                          << (a == in_entries.end() ? "the marked output" : "the input");
            continue;
        }
        EXPECT_TRUE(a->second == b->second)
            << "3MF entry " << name << " differs: input " << a->second.size()
            << " bytes, marked output " << b->second.size() << " bytes";
    }
}

}  // namespace
}  // namespace meshmark::test::interop
