// SPDX-License-Identifier: MIT
// Behaviour unchanged (issue 51): the built `meshmark` program on a fixed corpus, compared
// exactly with saved expectations (tests/data/expectations/detect/<group>.json).
//
// Each group embeds a mesh with a fixed --seed, attacks the marked copy with fixed seeds
// (noise, crop, simplify, remesh, similarity, reorder, a mirrored copy, a copy split at seams,
// a copy of an animated asset in another pose, copies of a family key's recipients, a copy whose
// registration does not converge, a Draco-compressed and an instanced glTF) and runs
// `detect --json` on each (`--verdict bits` for a few). Every field of the JSON but `seconds`
// (scores, z, the false-positive probabilities, the verdict, the accused, the registration's
// method, RMS and transform, the bit counts...) must print exactly as saved, and so must the
// SHA-256 of every file embed and attack wrote and the exit code of detect. A failure names the
// group, the case and the field, with the saved and the found value.
//
// The basis runs its portable kernels (MESHMARK_BASIS_KERNEL=portable), so the figures do not
// depend on the processor's SIMD (src/basis/rbf_kernels.cpp). The "shared" group uses the shared
// meshes (MESHMARK_MESH_DIR or ../shared/data/meshes) and is skipped without them.
//
// Regenerating the expectations (only when a change of behaviour is intended, and said so in the
// commit): build the program, then
//     MESHMARK_UPDATE_EXPECTATIONS=1 ctest --test-dir build -L regression
// rewrites tests/data/expectations/detect/*.json in the source tree (docs/reliability.md).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gltf_test_support.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/io/mesh_io.h"
#include "support/cli_run.h"
#include "support/test_paths.h"
#include "support/test_shapes.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

bool is_updating()
{
    const char* env = std::getenv("MESHMARK_UPDATE_EXPECTATIONS");
    return env != nullptr && *env != '\0' && std::string(env) != "0";
}

std::string quoted(const fs::path& path)
{
    return "\"" + path.string() + "\"";
}

// Where JSON \p found differs from \p saved: one line per field ("registration.method: saved
// "x", found "y""), numbers compared as printed.
void differences(const Json& saved, const Json& found, const std::string& at,
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

// The marked copy's triangles on the side x > 0 get vertices of their own where they meet the
// other side, as a writer splits a mesh at its UV seams (Blender's PLY and OBJ writers).
TriangleMesh split_at_seam(const TriangleMesh& mesh)
{
    TriangleMesh out = mesh;
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    std::vector<int> side(n, 0);  // bit 1: used by a face on x <= 0, bit 2: on x > 0
    std::vector<bool> right(static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const double x =
            mesh.V(mesh.F(f, 0), 0) + mesh.V(mesh.F(f, 1), 0) + mesh.V(mesh.F(f, 2), 0);
        right[static_cast<std::size_t>(f)] = x > 0.0;
        for (int c = 0; c < 3; ++c)
        {
            side[static_cast<std::size_t>(mesh.F(f, c))] |= x > 0.0 ? 2 : 1;
        }
    }
    std::vector<std::int32_t> copy(n, -1);
    std::vector<Eigen::Index> added;
    for (std::size_t v = 0; v < n; ++v)
    {
        if (side[v] == 3)
        {
            copy[v] = static_cast<std::int32_t>(n + added.size());
            added.push_back(static_cast<Eigen::Index>(v));
        }
    }
    out.V.conservativeResize(static_cast<Eigen::Index>(n + added.size()), 3);
    for (std::size_t k = 0; k < added.size(); ++k)
    {
        out.V.row(static_cast<Eigen::Index>(n + k)) = mesh.V.row(added[k]);
    }
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            const auto v = static_cast<std::size_t>(mesh.F(f, c));
            if (right[static_cast<std::size_t>(f)] && copy[v] >= 0)
            {
                out.F(f, c) = copy[v];
            }
        }
    }
    return out;
}

// A generated lumpy ellipsoid (2,562 vertices): the copies that keep the vertex order, the
// renumbered ones, the registered and resampled ones, a mirrored copy, a copy split at seams,
// and the unmarked original.
TEST(DetectRegression, generated_ellipsoid)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("ellipsoid");
    write_mesh(g.at("original.ply"), lumpy_ellipsoid(4));
    g.embed("marked", g.at("original.ply"), "marked.ply", "key.json", 101);
    g.detect("marked", "marked.ply", g.at("original.ply"), "key.json");
    g.detect("unmarked", "original.ply", g.at("original.ply"), "key.json");
    struct Attack
    {
        const char* label;
        const char* spec;
        std::uint64_t seed;
    };
    for (const Attack& a :
         {Attack{"noise", "noise=0.001", 1}, Attack{"reorder", "reorder", 2},
          Attack{"similarity_reorder", "similarity,reorder", 3},
          Attack{"simplify", "simplify=0.5", 4}, Attack{"crop", "crop=0.7", 5},
          Attack{"remesh", "remesh=0.25", 6}, Attack{"mirrored", "similarity:mirror=x", 7},
          Attack{"quantize", "quantize=9", 8},
          Attack{"smooth_similarity", "smooth=5,similarity", 9}})
    {
        const std::string file = std::string(a.label) + ".ply";
        g.attack("marked.ply", a.spec, a.seed, file);
        g.detect(a.label, file, g.at("original.ply"), "key.json");
    }
    // The unmarked original through the registration and resampling: not claimed.
    g.attack("original.ply", "similarity,simplify=0.5", 10, "unmarked_simplified.ply");
    g.detect("unmarked_simplified", "unmarked_simplified.ply", g.at("original.ply"), "key.json");
    write_mesh(g.at("seams.ply"), split_at_seam(read_mesh(g.at("marked.ply"))));
    g.detect("seams", "seams.ply", g.at("original.ply"), "key.json");
    g.finish();
}

// Generated assets whose detection takes the situational paths: a nearly mirror-symmetric
// vehicle (the poses of its symmetries under the union bound), a CAD plate whose vertices crowd
// on its outline (renumbered by its triangles' constraints), and a rigged arm that bends (a copy
// in the pose Blender shows is read through the animation's frame).
TEST(DetectRegression, generated_assets)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("assets");
    write_mesh(g.at("vehicle.ply"), test::vehicle(true));
    g.embed("vehicle", g.at("vehicle.ply"), "vehicle_marked.ply", "vehicle_key.json", 202);
    g.attack("vehicle_marked.ply", "similarity:mirror=x", 1, "vehicle_mirrored.ply");
    g.detect("vehicle_mirrored", "vehicle_mirrored.ply", g.at("vehicle.ply"), "vehicle_key.json");
    g.attack("vehicle_marked.ply", "similarity,reorder", 2, "vehicle_moved.ply");
    g.detect("vehicle_moved", "vehicle_moved.ply", g.at("vehicle.ply"), "vehicle_key.json");
    g.attack("vehicle_marked.ply", "similarity:mirror=y,reorder", 3,
             "vehicle_mirrored_reordered.ply");
    g.detect("vehicle_mirrored_reordered", "vehicle_mirrored_reordered.ply", g.at("vehicle.ply"),
             "vehicle_key.json");

    write_mesh(g.at("plate.ply"), test::outline_plate());
    g.embed("plate", g.at("plate.ply"), "plate_marked.ply", "plate_key.json", 303);
    g.attack("plate_marked.ply", "reorder", 4, "plate_reordered.ply");
    g.detect("plate_reordered", "plate_reordered.ply", g.at("plate.ply"), "plate_key.json");

    // The arm (test::BendingArm over a long lumpy ellipsoid), and the marked copy as Blender
    // shows it after import (the first animation at frame 1), its vertices in reverse order.
    TriangleMesh shape = lumpy_ellipsoid(4);
    shape.V.col(0) *= 2.0;
    std::vector<float> xyz;
    std::vector<std::uint16_t> idx;
    for (Eigen::Index v = 0; v < shape.V.rows(); ++v)
    {
        for (int c = 0; c < 3; ++c)
        {
            xyz.push_back(static_cast<float>(shape.V(v, c)));
        }
    }
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            idx.push_back(static_cast<std::uint16_t>(shape.F(f, c)));
        }
    }
    const test::BendingArm arm;
    test::put_bytes(g.at("arm.glb"), arm.glb(xyz, idx));
    g.embed("arm", g.at("arm.glb"), "arm_marked.glb", "arm_key.json", 404);
    const TriangleMesh stored = read_mesh(g.at("arm_marked.glb"));
    const Eigen::Index n = stored.V.rows();
    TriangleMesh posed;
    posed.V.resize(n, 3);
    for (Eigen::Index v = 0; v < n; ++v)
    {
        posed.V.row(n - 1 - v) =
            arm.shown(stored.V.row(v).transpose(), arm.weight(xyz[static_cast<std::size_t>(3 * v)]))
                .transpose();
    }
    posed.F = (n - 1) - stored.F.array();
    write_mesh(g.at("arm_posed.ply"), posed);
    g.detect("arm_posed", "arm_posed.ply", g.at("arm.glb"), "arm_key.json");
    g.finish();
}

// A family key with three recipients: bob's copy as issued, with noise, simplified and cropped
// (traced to bob), and the owner's unmarked original.
TEST(DetectRegression, family_key)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("family");
    write_mesh(g.at("original.ply"), lumpy_ellipsoid(4));
    g.embed("family", g.at("original.ply"), "copy_{recipient}.ply", "family.json", 505,
            "--recipient alice --recipient bob --recipient carol",
            {"copy_alice.ply", "copy_bob.ply", "copy_carol.ply", "family.json"});
    g.detect("bob", "copy_bob.ply", g.at("original.ply"), "family.json");
    g.attack("copy_bob.ply", "noise=0.001", 1, "bob_noise.ply");
    g.detect("bob_noise", "bob_noise.ply", g.at("original.ply"), "family.json");
    g.attack("copy_bob.ply", "similarity,simplify=0.5", 2, "bob_simplified.ply");
    g.detect("bob_simplified", "bob_simplified.ply", g.at("original.ply"), "family.json");
    g.attack("copy_bob.ply", "crop=0.7", 3, "bob_cropped.ply");
    g.detect("bob_cropped", "bob_cropped.ply", g.at("original.ply"), "family.json");
    g.detect("unmarked", "original.ply", g.at("original.ply"), "family.json");
    g.finish();
}

// The lumpy ellipsoid's positions (float) and triangles (uint16), as a glTF stores them.
void gltf_arrays(const TriangleMesh& shape, std::vector<float>& xyz,
                 std::vector<std::uint16_t>& idx)
{
    for (Eigen::Index v = 0; v < shape.V.rows(); ++v)
    {
        for (int c = 0; c < 3; ++c)
        {
            xyz.push_back(static_cast<float>(shape.V(v, c)));
        }
    }
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            idx.push_back(static_cast<std::uint16_t>(shape.F(f, c)));
        }
    }
}

// A GLB whose one primitive is \p shape Draco-compressed (KHR_draco_mesh_compression:
// edgebreaker, 14-bit positions, Draco's defaults), under one node.
std::string draco_glb(const TriangleMesh& shape)
{
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(static_cast<int>(shape.F.rows()));
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    for (Eigen::Index f = 0; f < shape.F.rows(); ++f)
    {
        std::array<std::array<float, 3>, 3> p{};
        for (int c = 0; c < 3; ++c)
        {
            for (int k = 0; k < 3; ++k)
            {
                p[static_cast<std::size_t>(c)][static_cast<std::size_t>(k)] =
                    static_cast<float>(shape.V(shape.F(f, c), k));
            }
        }
        builder.SetAttributeValuesForFace(pos, draco::FaceIndex(static_cast<std::uint32_t>(f)),
                                          p[0].data(), p[1].data(), p[2].data());
    }
    const std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
    encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
    draco::EncoderBuffer out;
    EXPECT_TRUE(encoder.EncodeMeshToBuffer(*mesh, &out).ok());

    test::GltfBuilder b;
    const int view = b.view(std::string(out.data(), out.size()));
    const auto position = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5126},
         {"count", mesh->num_points()},
         {"type", "VEC3"},
         {"min", {shape.V.col(0).minCoeff(), shape.V.col(1).minCoeff(), shape.V.col(2).minCoeff()}},
         {"max",
          {shape.V.col(0).maxCoeff(), shape.V.col(1).maxCoeff(), shape.V.col(2).maxCoeff()}}});
    const auto indices = static_cast<int>(b.doc["accessors"].size());
    b.doc["accessors"].push_back(
        {{"componentType", 5125}, {"count", 3 * mesh->num_faces()}, {"type", "SCALAR"}});
    const int gltf_mesh = b.mesh(test::Json::array(
        {{{"attributes", {{"POSITION", position}}},
          {"indices", indices},
          {"material", 0},
          {"extensions",
           {{"KHR_draco_mesh_compression",
             {{"bufferView", view},
              {"attributes", {{"POSITION", mesh->attribute(pos)->unique_id()}}}}}}}}}));
    b.node({{"mesh", gltf_mesh}});
    b.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    b.doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    return b.glb();
}

// Whether the GLB at \p path still stores its geometry Draco-compressed.
bool is_draco(const fs::path& path)
{
    const test::Json doc = test::glb_json(test::slurp(path));
    return doc.contains("extensionsUsed") &&
           doc.at("extensionsUsed").dump().find("KHR_draco_mesh_compression") != std::string::npos;
}

// Situational paths of detection on the generated ellipsoid (embedded as in the "ellipsoid"
// group): a copy under noise of 20% of the diagonal, renumbered, whose registration does not
// converge (its trimmed RMS error is above RegistrationOptions::max_rms_rel), and the bits
// verdict (--verdict bits: R against --threshold) on the marked copy and on a moved, renumbered
// one (registered without the symmetry search, which the bits verdict skips).
TEST(DetectRegression, generated_paths)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("paths");
    write_mesh(g.at("original.ply"), lumpy_ellipsoid(4));
    g.embed("marked", g.at("original.ply"), "marked.ply", "key.json", 101);
    g.attack("marked.ply", "noise=0.2,reorder", 11, "not_converged.ply");
    g.detect("not_converged", "not_converged.ply", g.at("original.ply"), "key.json");
    EXPECT_EQ(g.report("not_converged")["registration"]["method"], "registration (not converged)")
        << "the case no longer takes the path it is there for";
    g.detect("marked_bits", "marked.ply", g.at("original.ply"), "key.json", "--verdict bits");
    g.attack("marked.ply", "similarity,reorder", 3, "similarity_reorder.ply");
    g.detect("similarity_reorder_bits", "similarity_reorder.ply", g.at("original.ply"), "key.json",
             "--verdict bits");
    for (const char* label : {"marked_bits", "similarity_reorder_bits"})
    {
        EXPECT_EQ(g.report(label)["verdict"], "bits") << label;
    }
    g.finish();
}

// A Draco-compressed glTF (edgebreaker, 14-bit positions): embed re-encodes the marked
// positions into Draco data (its points renumbered by edgebreaker's traversal), read back where
// they stand; the marked copy moved and renumbered, and the unmarked original.
TEST(DetectRegression, gltf_draco)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("draco");
    test::put_bytes(g.at("original.glb"), draco_glb(lumpy_ellipsoid(4)));
    g.embed("marked", g.at("original.glb"), "marked.glb", "key.json", 909);
    EXPECT_TRUE(is_draco(g.at("marked.glb"))) << "embed no longer writes Draco data";
    g.detect("marked", "marked.glb", g.at("original.glb"), "key.json");
    g.attack("marked.glb", "similarity,reorder", 1, "similarity_reorder.ply");
    g.detect("similarity_reorder", "similarity_reorder.ply", g.at("original.glb"), "key.json");
    g.detect("unmarked", "original.glb", g.at("original.glb"), "key.json");
    g.finish();
}

// An instanced glTF: one mesh (the lumpy ellipsoid) shown by three nodes (moved, turned,
// scaled). Embed marks the stored positions once (every instance shows the mark); detection reads
// the marked file, and a flattened copy that shows every instance as geometry of its own
// (as gltf-transform's join leaves it), renumbered, registered against all the instances.
TEST(DetectRegression, gltf_instanced)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    Group g("instanced");
    std::vector<float> xyz;
    std::vector<std::uint16_t> idx;
    gltf_arrays(lumpy_ellipsoid(4), xyz, idx);
    test::GltfBuilder b;
    const int mesh = b.mesh(test::Json::array(
        {{{"attributes", {{"POSITION", b.positions(xyz)}}}, {"indices", b.indices(idx)}}}));
    b.node({{"mesh", mesh}, {"translation", {3.0, 0.0, 0.0}}});
    b.node({{"mesh", mesh}, {"translation", {-3.0, 0.0, 0.0}}, {"rotation", {0.0, 0.0, 0.6, 0.8}}});
    b.node({{"mesh", mesh}, {"translation", {0.0, 3.0, 1.0}}, {"scale", {0.5, 0.5, 0.5}}});
    test::put_bytes(g.at("original.glb"), b.glb());
    g.embed("marked", g.at("original.glb"), "marked.glb", "key.json", 1010);
    const MeshFile marked = read_mesh_file(g.at("marked.glb"));
    ASSERT_EQ(marked.instances.V.rows(), 2 * static_cast<Eigen::Index>(xyz.size() / 3))
        << "the marked file no longer shows its mesh through three nodes";
    g.detect("marked", "marked.glb", g.at("original.glb"), "key.json");
    TriangleMesh flat;
    const Eigen::Index n = marked.mesh.V.rows();
    flat.V.resize(n + marked.instances.V.rows(), 3);
    flat.V << marked.mesh.V, marked.instances.V;
    flat.F.resize(marked.mesh.F.rows() + marked.instances.F.rows(), 3);
    flat.F << marked.mesh.F, (marked.instances.F.array() + static_cast<std::int32_t>(n)).matrix();
    write_mesh(g.at("flattened.ply"), flat);
    g.attack("flattened.ply", "reorder", 1, "flattened_reordered.ply");
    g.detect("flattened_reordered", "flattened_reordered.ply", g.at("original.glb"), "key.json");
    g.finish();
}

// Real meshes (skipped without the shared folder): a scan, a CAD part and a symmetric teapot.
TEST(DetectRegression, shared_meshes)
{
    ASSERT_FALSE(test::cli_path().empty()) << "the meshmark program is not built";
    const fs::path meshes = test::mesh_dir();
    for (const char* name : {"bunny.off", "fandisk.obj", "teapot.obj"})
    {
        if (!fs::exists(meshes / name))
        {
            GTEST_SKIP() << "no shared meshes in " << meshes << " (" << name << ")";
        }
    }
    Group g("shared");
    struct Attack
    {
        const char* label;
        const char* spec;
        std::uint64_t seed;
    };
    const auto mesh_cases = [&](const char* name, const char* stem, std::uint64_t seed,
                                std::initializer_list<Attack> attacks)
    {
        const fs::path original = meshes / name;
        const std::string ext = fs::path(name).extension().string();
        const std::string marked = std::string(stem) + "_marked" + ext;
        const std::string key = std::string(stem) + "_key.json";
        g.embed(stem, original, marked, key, seed);
        for (const Attack& a : attacks)
        {
            const std::string file = std::string(stem) + "_" + a.label + ".ply";
            g.attack(marked, a.spec, a.seed, file);
            g.detect(std::string(stem) + "_" + a.label, file, original, key);
        }
    };
    mesh_cases(
        "bunny.off", "bunny", 606,
        {Attack{"noise", "noise=0.002", 1}, Attack{"similarity_reorder", "similarity,reorder", 2},
         Attack{"simplify", "similarity,simplify=0.3", 3}, Attack{"crop", "crop=0.5", 4}});
    mesh_cases("fandisk.obj", "fandisk", 707,
               {Attack{"crop", "crop=0.5", 5}, Attack{"remesh", "remesh=0.25", 6}});
    mesh_cases("teapot.obj", "teapot", 808, {Attack{"mirrored", "similarity:mirror=y", 7}});
    g.finish();
}

}  // namespace
}  // namespace meshmark
