// SPDX-License-Identifier: MIT
// The steps of `catalog add` that meshmark.cluster (python/meshmark/cluster.py) runs on a Dask
// cluster (docs/cluster.md): the plan and the recording on the coordinator, the marking on a
// worker. Private (underscored): the public API is Catalog.add(client=...) and meshmark.cluster.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/stl.h>

#include "bindings.h"
#include "convert.h"
#include "meshmark/catalog/catalog_copies.h"
#include "meshmark/catalog/catalog_json.h"
#include "meshmark/catalog/catalog_mark.h"
#include "meshmark/core/error.h"
#include "typed.h"

namespace meshmark::python
{
namespace
{

using Path = std::filesystem::path;
using Files = std::vector<std::pair<std::string, py::bytes>>;

nlohmann::json parsed(const std::string& text, const char* what)
{
    try
    {
        return nlohmann::json::parse(text);
    }
    catch (const nlohmann::json::exception&)
    {
        throw InvalidOption(std::string(what) + " that is not JSON.");
    }
}

CatalogMarkTask task_of(const std::string& text)
{
    try
    {
        return parse_mark_task(nlohmann::json::parse(text));
    }
    catch (const nlohmann::json::exception&)
    {
        throw InvalidOption("a catalogue marking task that is not JSON.");
    }
}

}  // namespace

void bind_cluster(py::module_& m)
{
    m.def(
        "_catalog_plan_add",
        [](Catalog& catalog, const std::vector<Path>& inputs, const Path& output,
           const OptionalInt& seed, const OptionalFloat& strength, const OptionalStr& message,
           int basis_size, int coefficients, bool force)
        {
            const CatalogAddOptions options =
                catalog_add_options(seed, strength, message, basis_size, coefficients, force);
            std::optional<CatalogAddPlan> plan;
            {
                py::gil_scoped_release release;
                plan.emplace(catalog_plan_add(catalog, inputs, output, options));
            }
            // Every file's outcome as JSON (those of tasks: None), and each task's JSON and name.
            std::vector<std::optional<std::string>> outcomes(plan->outcomes.size());
            for (std::size_t f = 0; f < outcomes.size(); ++f)
            {
                outcomes[f] = to_json(plan->outcomes[f]).dump();
            }
            std::vector<std::pair<std::string, std::string>> tasks;
            for (const CatalogMarkTask& task : plan->tasks)
            {
                outcomes[task.file].reset();
                tasks.emplace_back(task.to_json().dump(), task.name());
            }
            return std::make_pair(outcomes, tasks);
        },
        py::arg("catalog"), py::arg("inputs"), py::arg("output"), py::kw_only(),
        py::arg("seed") = py::none(), py::arg("strength") = py::none(),
        py::arg("message") = py::none(), py::arg("basis_size") = EmbedOptions{}.basis_size,
        py::arg("coefficients") = EmbedOptions{}.coefficients, py::arg("force") = false,
        "catalog add's plan: (per file, its outcome's JSON or None for a task; the tasks' "
        "(JSON, name)).");
    m.def(
        "_catalog_mark",
        [](const std::string& task_json, int threads)
        {
            const CatalogMarkTask task = task_of(task_json);
            std::optional<CatalogMarkedAsset> marked;
            {
                py::gil_scoped_release release;
                marked.emplace(catalog_mark(task, threads));
            }
            Files files;
            for (auto& [relative, bytes] : marked->files)
            {
                files.emplace_back(relative, py::bytes(bytes));
            }
            return std::make_pair(marked->to_json().dump(), std::move(files));
        },
        py::arg("task"), py::arg("threads") = 1,
        "A worker's marking of one task: (the marked asset's JSON, [(relative path, bytes)]).");
    m.def(
        "_catalog_record",
        [](Catalog& catalog, const std::string& task_json, const std::string& marked_json,
           const Files& files)
        {
            const CatalogMarkTask task = task_of(task_json);
            CatalogMarkedAsset marked;
            try
            {
                marked = parse_marked_asset(nlohmann::json::parse(marked_json));
            }
            catch (const nlohmann::json::exception&)
            {
                throw InvalidOption("a marked asset that is not JSON.");
            }
            for (const auto& [relative, bytes] : files)
            {
                marked.files.emplace_back(relative, std::string(bytes));
            }
            py::gil_scoped_release release;
            return to_json(catalog_record(catalog, task, std::move(marked))).dump();
        },
        py::arg("catalog"), py::arg("task"), py::arg("marked"), py::arg("files"),
        "The coordinator's recording of a marked asset: its outcome's JSON.");
    m.def(
        "_catalog_add_report",
        [](const Catalog& catalog, const std::vector<std::string>& outcomes) -> Report
        {
            std::vector<CatalogAddOutcome> parsed;
            for (const std::string& text : outcomes)
            {
                parsed.push_back(parse_add_outcome(nlohmann::json::parse(text)));
            }
            return to_python(catalog_add_json(catalog, parsed));
        },
        py::arg("catalog"), py::arg("outcomes"),
        "catalog add --json's report of the outcomes' JSON.");

    m.def(
        "_catalog_plan_issue",
        [](Catalog& catalog, const std::string& asset, const std::vector<std::string>& recipients,
           const std::string& output_pattern, const OptionalPath& recipients_file,
           double lock_timeout, std::size_t per_task)
        {
            CatalogIssueOptions options;
            options.recipients = recipients;
            if (const auto file = path_from(recipients_file.handle(), "recipients_file"))
            {
                const std::vector<std::string> listed = read_recipients_file(*file);
                options.recipients.insert(options.recipients.end(), listed.begin(), listed.end());
            }
            options.lock_timeout = timeout_of(lock_timeout);
            std::optional<CatalogIssuePlan> plan;
            {
                py::gil_scoped_release release;
                plan.emplace(catalog_plan_issue(catalog, asset, output_pattern, options, per_task));
            }
            std::vector<std::pair<std::string, std::string>> tasks;
            for (const CatalogCopyTask& task : plan->tasks)
            {
                tasks.emplace_back(task.to_json().dump(), task.name());
            }
            return std::make_pair(to_json(*plan).dump(), tasks);
        },
        py::arg("catalog"), py::arg("asset"), py::arg("recipients"), py::arg("output_pattern"),
        py::kw_only(), py::arg("recipients_file") = py::none(), py::arg("lock_timeout") = 60.0,
        py::arg("per_task") = 16,
        "catalog issue's plan (every new name recorded): (the plan's JSON, the tasks' (JSON, "
        "name)).");
    m.def(
        "_catalog_make_copies",
        [](const std::string& task_json, int threads)
        {
            const CatalogCopyTask task = parse_copy_task(parsed(task_json, "a copy task"));
            std::optional<CatalogMadeCopies> made;
            {
                py::gil_scoped_release release;
                made.emplace(catalog_make_copies(task, threads));
            }
            std::vector<std::pair<std::string, py::bytes>> files;
            for (auto& [path, bytes] : made->files)
            {
                files.emplace_back(path.string(), py::bytes(bytes));
            }
            return std::make_pair(made->to_json().dump(), std::move(files));
        },
        py::arg("task"), py::arg("threads") = 1,
        "A worker's copies of one task: (their JSON, [(path, bytes)]).");
    m.def(
        "_catalog_deliver",
        [](Catalog& catalog, const std::string& task_json, const std::string& made_json,
           const std::vector<std::pair<std::string, py::bytes>>& files)
        {
            const CatalogCopyTask task = parse_copy_task(parsed(task_json, "a copy task"));
            CatalogMadeCopies made = parse_made_copies(parsed(made_json, "made copies"));
            for (const auto& [path, bytes] : files)
            {
                made.files.emplace_back(path, std::string(bytes));
            }
            py::gil_scoped_release release;
            catalog_deliver(catalog, task, made);
        },
        py::arg("catalog"), py::arg("task"), py::arg("made"), py::arg("files"),
        "The coordinator's delivery of a task's copies: written, then recorded delivered.");
    m.def(
        "_catalog_issue_report",
        [](const Catalog& catalog, const std::string& asset, const std::string& plan_json,
           const std::vector<std::string>& made_json, double seconds) -> Report
        {
            const CatalogIssuePlan plan = parse_issue_plan(parsed(plan_json, "an issue plan"));
            std::vector<CatalogMadeCopies> made;
            for (const std::string& text : made_json)
            {
                made.push_back(parse_made_copies(parsed(text, "made copies")));
            }
            return to_python(catalog_issue_json(catalog, asset, plan, made, seconds));
        },
        py::arg("catalog"), py::arg("asset"), py::arg("plan"), py::arg("made"), py::arg("seconds"),
        "catalog issue --json's report of a plan and its made copies.");
}

}  // namespace meshmark::python
