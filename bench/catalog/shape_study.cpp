// SPDX-License-Identifier: MIT
// Study of the catalogue's shape index: how often the right asset is among the first K the
// index proposes for attacked copies, and how far apart right and wrong assets lie.
//   meshmark_shape_study LIST [ATTACK_SPEC...]
// LIST: a file of mesh paths, one per line (the catalogue). Each of the first 60 (every
// n-th when there are more) is attacked by every spec (default: the set below) and ranked
// against all. Prints one line per (asset, attack) and a summary per attack. A line: asset,
// attack, its rank, its distance as ranked, the first's, its rank by the index alone, the rank
// of the first asset of its vertex and face counts (a variant of its mesh, or itself), its own
// fit from all its crop views (with MESHMARK_STUDY_FIT), the first's name. Settings through the
// environment: MESHMARK_STUDY_FIT, _FIT_*, _SIBLINGS, _GROUPS, _REFIT, _VERIFY, _ATTACKED,
// _SUSPECTS (each explained where it is read).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "meshmark/attacks/attack_spec.h"
#include "meshmark/attacks/cropping.h"
#include "meshmark/catalog/catalog_scan.h"
#include "meshmark/geometry/shape_signature.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/shape_fit.h"

using namespace meshmark;

int main(int argc, char** argv)
{
    if (argc < 2)
    {
        std::fprintf(stderr, "usage: meshmark_shape_study LIST [SPEC...]\n");
        return 2;
    }
    std::vector<std::string> paths;
    {
        std::ifstream in(argv[1]);
        for (std::string line; std::getline(in, line);)
        {
            if (!line.empty())
            {
                paths.push_back(line);
            }
        }
    }
    std::vector<std::string> specs(argv + 2, argv + argc);
    if (specs.empty())
    {
        specs = {"similarity",
                 "similarity,noise=0.002",
                 "simplify=0.5,similarity",
                 "simplify=0.2",
                 "remesh=0.8",
                 "smooth=5",
                 "crop=0.75,similarity",
                 "crop=0.5,similarity",
                 "reorder,similarity"};
    }
    std::vector<TriangleMesh> meshes;
    std::vector<ShapeSignature> index;
    std::vector<std::string> names;
    for (const std::string& p : paths)
    {
        try
        {
            TriangleMesh mesh = read_mesh(p);
            if (mesh.vertex_count() < 100)
            {
                continue;
            }
            index.push_back(shape_signature(mesh));
            meshes.push_back(std::move(mesh));
            names.push_back(p);
        }
        catch (const std::exception& e)
        {
            std::fprintf(stderr, "skip %s: %s\n", p.c_str(), e.what());
        }
    }
    std::fprintf(stderr, "%zu meshes indexed\n", index.size());
    std::vector<Catalog::IndexEntry> entries;
    for (std::size_t b = 0; b < index.size(); ++b)
    {
        entries.push_back(index_entry(names[b], index[b].to_bytes()));
    }
    std::vector<TriangleMesh> samples(meshes.size());
    for (std::size_t b = 0; b < meshes.size(); ++b)
    {
        samples[b].V = shape_sample(meshes[b], 2048);
    }
    std::vector<Positions> fit_samples(meshes.size());
    std::vector<Positions> fit_normals(meshes.size());
    std::vector<std::unique_ptr<PointKdTree>> fit_trees(meshes.size());
    {
        const char* points_env = std::getenv("MESHMARK_STUDY_FIT_POINTS");
        const int fit_points = points_env ? std::stoi(points_env) : 1024;
        for (std::size_t b = 0; b < meshes.size(); ++b)
        {
            fit_samples[b] = shape_sample(meshes[b], fit_points, &fit_normals[b]);
            fit_trees[b] = std::make_unique<PointKdTree>(fit_samples[b]);
        }
    }
    // MESHMARK_STUDY_ATTACKED=N: attack only the first N meshes of the list (the rest are
    // distractors); otherwise up to 60 spread over the list.
    const char* attacked = std::getenv("MESHMARK_STUDY_ATTACKED");
    const std::size_t first = attacked != nullptr
                                  ? std::min<std::size_t>(meshes.size(), std::stoul(attacked))
                                  : meshes.size();
    const std::size_t step = attacked != nullptr ? 1 : std::max<std::size_t>(1, meshes.size() / 60);
    std::map<std::string, std::vector<int>> ranks;
    double verify_seconds = 0.0;
    // MESHMARK_STUDY_SUSPECTS=FILE: rank the suspects FILE lists instead, a line each:
    // SUSPECT<TAB>ORIGINAL (ORIGINAL as LIST gives it), reported under the attack "file".
    std::vector<std::pair<std::size_t, std::string>> jobs;
    if (const char* listed = std::getenv("MESHMARK_STUDY_SUSPECTS"))
    {
        std::ifstream in(listed);
        for (std::string line; std::getline(in, line);)
        {
            const auto tab = line.find('\t');
            const auto at = std::find(names.begin(), names.end(), line.substr(tab + 1));
            if (tab != std::string::npos && at != names.end())
            {
                jobs.emplace_back(static_cast<std::size_t>(at - names.begin()),
                                  "file:" + line.substr(0, tab));
            }
        }
    }
    else
    {
        for (std::size_t a = 0; a < first; a += step)
        {
            for (const std::string& spec : specs)
            {
                jobs.emplace_back(a, spec);
            }
        }
    }
    for (const auto& [a, spec] : jobs)
    {
        {
            TriangleMesh suspect;
            try
            {
                if (spec.starts_with("file:"))
                {
                    suspect = read_mesh(spec.substr(5));
                }
                else if (spec.starts_with("aligned-crop="))
                {
                    // A crop along the first of the index's directions (0, -1, -phi): no direction
                    // error, only the fraction's.
                    CropOptions crop_options;
                    crop_options.vertex_fraction = std::stod(spec.substr(13));
                    crop_options.direction = -Eigen::Vector3d(
                        std::sqrt(1.0 - (1.0 - 1.0 / 64) * (1.0 - 1.0 / 64)), 0.0, 1.0 - 1.0 / 64);
                    Rng rng(1);
                    suspect = crop(meshes[a], crop_options, rng).mesh;
                }
                else
                {
                    suspect = apply_attacks(meshes[a], parse_attack_spec(spec), 7 + a, 1).mesh;
                }
            }
            catch (const std::exception& e)
            {
                continue;
            }
            // The ranking catalog scan makes (shape_candidates), over every asset.
            std::vector<std::pair<float, std::size_t>> d =
                shape_candidates(entries, shape_features(suspect), entries.size());
            // MESHMARK_STUDY_VERIFY=M: the first M re-ranked by a quick registration of point
            // samples (rms of the fit; a fit that does not converge ranks last).
            if (const char* verify = std::getenv("MESHMARK_STUDY_VERIFY"))
            {
                const std::size_t m = std::min<std::size_t>(d.size(), std::stoul(verify));
                TriangleMesh s_points;
                s_points.V = shape_sample(suspect, 1024);
                RegistrationOptions quick;
                quick.coarse_samples = 32;
                quick.refine_samples = 256;
                quick.fine_samples = 512;
                quick.final_samples = 1024;
                quick.reference_samples = 2048;
                quick.max_iterations = 10;
                quick.tolerance = 1e-6;
                quick.threads = 1;
                const auto t0 = std::chrono::steady_clock::now();
                for (std::size_t k = 0; k < m; ++k)
                {
                    const RegistrationResult fit =
                        register_to_reference(s_points, samples[d[k].second], quick);
                    d[k].first = static_cast<float>(fit.rms_error +
                                                    (fit.overlap_fraction < 0.8 ? 1.0 : 0.0));
                }
                verify_seconds +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                std::sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(m));
            }
            int index_rank = 0;
            while (d[static_cast<std::size_t>(index_rank)].second != a)
            {
                ++index_rank;
            }
            // MESHMARK_STUDY_FIT=M: the first M re-ranked by shape_fit (the suspect's 512
            // points onto the asset's MESHMARK_STUDY_FIT_POINTS, from the whole and the asset's
            // MESHMARK_STUDY_FIT_VIEWS crop views nearest the suspect's features).
            if (const char* fit_env = std::getenv("MESHMARK_STUDY_FIT"))
            {
                const std::size_t m = std::min<std::size_t>(d.size(), std::stoul(fit_env));
                const char* views_env = std::getenv("MESHMARK_STUDY_FIT_VIEWS");
                const std::size_t view_count = views_env ? std::stoul(views_env) : 3;
                const char* sp_env = std::getenv("MESHMARK_STUDY_FIT_SUSPECT");
                const Positions s_points = shape_sample(suspect, sp_env ? std::stoi(sp_env) : 512);
                ShapeFitOptions fit_options;
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_COARSE"))
                {
                    fit_options.coarse_rounds = std::stoi(e);
                }
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_FINE"))
                {
                    fit_options.fine_rounds = std::stoi(e);
                }
                for (const auto& [name, field] :
                     {std::pair{"MESHMARK_STUDY_FIT_START_STRIDE", &ShapeFitOptions::start_stride},
                      std::pair{"MESHMARK_STUDY_FIT_COARSE_POSES", &ShapeFitOptions::coarse_poses},
                      std::pair{"MESHMARK_STUDY_FIT_COARSE_STRIDE",
                                &ShapeFitOptions::coarse_stride},
                      std::pair{"MESHMARK_STUDY_FIT_FINE_STRIDE", &ShapeFitOptions::fine_stride}})
                {
                    if (const char* e = std::getenv(name))
                    {
                        fit_options.*field = std::stoi(e);
                    }
                }
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_BOUND"))
                {
                    fit_options.start_bound = std::stod(e);
                }
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_SETTLED"))
                {
                    fit_options.settled = std::stod(e);
                }
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_ACROSS"))
                {
                    fit_options.across = std::stoi(e) != 0;
                }
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_POINT"))
                {
                    fit_options.to_plane = std::stoi(e) == 0;
                }
                if (const char* e = std::getenv("MESHMARK_STUDY_FIT_POSES"))
                {
                    fit_options.fine_poses = std::stoi(e);
                }
                const ShapeFeatures features = shape_features(suspect);
                // MESHMARK_STUDY_GROUPS=1: the m fitted are the first of m distinct vertex and
                // face counts (one variant of a mesh stands for all until the fit ranks it).
                if (std::getenv("MESHMARK_STUDY_GROUPS") != nullptr)
                {
                    std::vector<std::pair<float, std::size_t>> front;
                    std::vector<std::pair<float, std::size_t>> rest;
                    std::set<std::pair<Eigen::Index, Eigen::Index>> seen;
                    for (const auto& entry : d)
                    {
                        const TriangleMesh& mesh = meshes[entry.second];
                        if (front.size() < m && seen.insert({mesh.V.rows(), mesh.F.rows()}).second)
                        {
                            front.push_back(entry);
                        }
                        else
                        {
                            rest.push_back(entry);
                        }
                    }
                    front.insert(front.end(), rest.begin(), rest.end());
                    d = std::move(front);
                }
                // Asset b's fit from its whole and its \p views_kept crop views nearest the
                // suspect's features.
                const auto fit_of = [&](std::size_t b, std::size_t views_kept)
                {
                    std::vector<std::pair<float, int>> by_view;
                    for (int v = 1; v < static_cast<int>(index[b].views.size()); ++v)
                    {
                        by_view.emplace_back(
                            shape_distance(features, index[b].views[static_cast<std::size_t>(v)]),
                            v);
                    }
                    const std::size_t kept = std::min(views_kept, by_view.size());
                    std::partial_sort(by_view.begin(),
                                      by_view.begin() + static_cast<std::ptrdiff_t>(kept),
                                      by_view.end());
                    std::vector<int> views;
                    for (std::size_t v = 0; v < kept; ++v)
                    {
                        views.push_back(by_view[v].second);
                    }
                    return static_cast<float>(shape_fit(s_points, fit_samples[b], fit_normals[b],
                                                        *fit_trees[b], views, fit_options));
                };
                const auto t0 = std::chrono::steady_clock::now();
                for (std::size_t k = 0; k < m; ++k)
                {
                    d[k].first = fit_of(d[k].second, view_count);
                }
                std::stable_sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(m));
                // MESHMARK_STUDY_SIBLINGS=K: the assets of the vertex and face counts of any of
                // the fit's first K (same connectivity: variants of one mesh) fitted as well.
                if (const char* sib = std::getenv("MESHMARK_STUDY_SIBLINGS"))
                {
                    const std::size_t kk = std::min<std::size_t>(m, std::stoul(sib));
                    std::vector<std::pair<float, std::size_t>> front(
                        d.begin(), d.begin() + static_cast<std::ptrdiff_t>(m));
                    std::vector<std::pair<float, std::size_t>> rest;
                    for (std::size_t k = m; k < d.size(); ++k)
                    {
                        const std::size_t b = d[k].second;
                        bool sibling = false;
                        for (std::size_t j = 0; j < kk && !sibling; ++j)
                        {
                            const std::size_t c = d[j].second;
                            sibling = meshes[b].V.rows() == meshes[c].V.rows() &&
                                      meshes[b].F.rows() == meshes[c].F.rows();
                        }
                        if (!sibling)
                        {
                            rest.push_back(d[k]);
                            continue;
                        }
                        front.emplace_back(fit_of(b, view_count), b);
                    }
                    std::stable_sort(front.begin(), front.end());
                    front.insert(front.end(), rest.begin(), rest.end());
                    d = std::move(front);
                }
                // MESHMARK_STUDY_REFIT=M,V: the first M of that ranking fitted again from their V
                // crop views nearest the suspect's features (the better of the two fits kept).
                if (const char* refit = std::getenv("MESHMARK_STUDY_REFIT"))
                {
                    const std::string spec_refit(refit);
                    const std::size_t comma = spec_refit.find(',');
                    const std::size_t mm =
                        std::min<std::size_t>(d.size(), std::stoul(spec_refit.substr(0, comma)));
                    const std::size_t vv = std::stoul(spec_refit.substr(comma + 1));
                    for (std::size_t k = 0; k < mm; ++k)
                    {
                        const std::size_t b = d[k].second;
                        d[k].first = std::min(d[k].first, fit_of(b, vv));
                    }
                    std::stable_sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(mm));
                }
                verify_seconds +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            }
            int rank = 0;
            while (d[static_cast<std::size_t>(rank)].second != a)
            {
                ++rank;
            }
            ranks[spec].push_back(rank);
            // The first of the same vertex and face counts (a variant of the same mesh, or itself).
            int family_rank = 0;
            while (meshes[d[static_cast<std::size_t>(family_rank)].second].V.rows() !=
                       meshes[a].V.rows() ||
                   meshes[d[static_cast<std::size_t>(family_rank)].second].F.rows() !=
                       meshes[a].F.rows())
            {
                ++family_rank;
            }
            // The right asset's own fit, from every crop view (whether or not it was fitted).
            double own_fit = 0.0;
            if (std::getenv("MESHMARK_STUDY_FIT") != nullptr)
            {
                std::vector<int> all_views;
                for (int v = 1; v < static_cast<int>(index[a].views.size()); ++v)
                {
                    all_views.push_back(v);
                }
                own_fit = shape_fit(shape_sample(suspect, 512), fit_samples[a], fit_normals[a],
                                    *fit_trees[a], all_views);
            }
            std::printf("%s\t%s\t%d\t%.4f\t%.4f\t%d\t%d\t%.4f\t%s\n", names[a].c_str(),
                        spec.c_str(), rank,
                        static_cast<double>(d[static_cast<std::size_t>(rank)].first),
                        static_cast<double>(d[0].first), index_rank, family_rank, own_fit,
                        names[d[0].second].c_str());
        }
    }
    std::fprintf(stderr, "verification: %.1f s in all\n", verify_seconds);
    std::fflush(stdout);
    for (const auto& [spec, r] : ranks)
    {
        const auto within = [&](int k)
        { return std::count_if(r.begin(), r.end(), [&](int x) { return x < k; }); };
        std::fprintf(stderr, "%-28s n=%3zu top1 %3ld top4 %3ld top8 %3ld top32 %3ld max %d\n",
                     spec.c_str(), r.size(), within(1), within(4), within(8), within(32),
                     *std::max_element(r.begin(), r.end()));
    }
    return 0;
}
