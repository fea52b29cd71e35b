// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB: world-frame welded reading, and the preserving writer (only position bytes
// and POSITION min/max change; the result stays a valid asset for tinygltf): data URIs, external
// buffers and images, sparse and quantized positions, the generic writer.
#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include "gltf_test_fixture.h"
#include "gltf_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::Glb;
using test::GltfBuilder;
using test::GltfTest;
using test::Json;
using test::split;
using test::two_boxes;

Positions displaced(const Positions& V)
{
    Positions result = V;
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        result(i, 0) += 0.01 * std::sin(3.0 * V(i, 1));
        result(i, 1) += 0.02 * std::cos(2.0 * V(i, 2));
        result(i, 2) += 0.015 * std::sin(V(i, 0));
    }
    return result;
}

// Byte ranges of every POSITION element of the plain accessors in a GLB JSON.
std::vector<bool> position_bytes(const Json& doc, std::size_t size)
{
    std::vector<bool> mask(size, false);
    std::set<int> position_accessors;
    for (const auto& mesh : doc["meshes"])
    {
        for (const auto& prim : mesh["primitives"])
        {
            position_accessors.insert(prim["attributes"]["POSITION"].get<int>());
        }
    }
    for (const int a : position_accessors)
    {
        const auto& acc = doc["accessors"][static_cast<std::size_t>(a)];
        const auto& view = doc["bufferViews"][acc["bufferView"].get<std::size_t>()];
        const std::size_t stride = view.value("byteStride", std::size_t{12});
        const std::size_t first =
            view.value("byteOffset", std::size_t{0}) + acc.value("byteOffset", std::size_t{0});
        for (std::size_t e = 0; e < acc["count"].get<std::size_t>(); ++e)
        {
            for (std::size_t k = 0; k < 12; ++k)
            {
                mask[first + e * stride + k] = true;
            }
        }
    }
    return mask;
}

Json without_position_bounds(Json doc)
{
    for (const auto& mesh : doc["meshes"])
    {
        for (const auto& prim : mesh["primitives"])
        {
            auto& acc = doc["accessors"][prim["attributes"]["POSITION"].get<std::size_t>()];
            acc.erase("min");
            acc.erase("max");
        }
    }
    return doc;
}

bool tinygltf_reads(const fs::path& path)
{
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err;
    std::string warn;
    const bool ok = path.extension() == ".glb"
                        ? loader.LoadBinaryFromFile(&model, &err, &warn, path.string())
                        : loader.LoadASCIIFromFile(&model, &err, &warn, path.string());
    EXPECT_TRUE(err.empty()) << err;
    return ok;
}

TEST_F(GltfTest, reads_world_positions_and_welds_seams_and_touching_parts)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "boxes.glb", t.builder.glb());
    const MeshFile file = read_mesh_file(dir / "boxes.glb");
    EXPECT_EQ(file.format, MeshFormat::Glb);
    // 8 corners of A + 4 new corners of B: the 3 seam copies of each corner and the 4 shared
    // corners of the touching face (a few float32 ulps apart in world space) are welded.
    EXPECT_EQ(file.mesh.V.rows(), 12);
    EXPECT_EQ(file.mesh.F.rows(), 24);
    EXPECT_NEAR(file.mesh.V.col(0).minCoeff(), 1.0, 1e-6);
    EXPECT_NEAR(file.mesh.V.col(0).maxCoeff(), 5.0, 1e-6);
    EXPECT_NEAR(file.mesh.V.col(1).maxCoeff(), 2.0, 1e-6);
    for (Eigen::Index f = 0; f < file.mesh.F.rows(); ++f)
    {
        EXPECT_NE(file.mesh.F(f, 0), file.mesh.F(f, 1));
        EXPECT_NE(file.mesh.F(f, 1), file.mesh.F(f, 2));
    }
}

TEST_F(GltfTest, unchanged_positions_reproduce_glb_and_gltf_byte_for_byte)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "in.glb", t.builder.glb());
    test::put_bytes(dir / "in.gltf", t.builder.gltf());
    for (const char* name : {"in.glb", "in.gltf"})
    {
        const MeshFile file = read_mesh_file(dir / name);
        const fs::path out = dir / (std::string("out") + fs::path(name).extension().string());
        write_mesh_file(out, file, file.mesh.V);
        EXPECT_EQ(test::file_bytes(out), test::file_bytes(dir / name)) << name;
    }
}

TEST_F(GltfTest, changed_positions_change_only_position_bytes_and_bounds)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "in.glb", t.builder.glb());
    const MeshFile file = read_mesh_file(dir / "in.glb");
    const Positions moved = displaced(file.mesh.V);
    write_mesh_file(dir / "out.glb", file, moved);
    EXPECT_TRUE(tinygltf_reads(dir / "out.glb"));

    const Glb before = split(test::file_bytes(dir / "in.glb"));
    const Glb after = split(test::file_bytes(dir / "out.glb"));
    // JSON: equal once the POSITION bounds are left out; the extension/extras survive.
    EXPECT_EQ(without_position_bounds(after.json), without_position_bounds(before.json));
    EXPECT_NE(after.json["accessors"][0]["max"], before.json["accessors"][0]["max"]);
    // Binary: every byte outside the position elements is identical (normals, UVs,
    // indices, padding); some position bytes changed.
    ASSERT_EQ(after.bin.size(), before.bin.size());
    const auto mask = position_bytes(before.json, before.bin.size());
    std::size_t changed_position_bytes = 0;
    for (std::size_t k = 0; k < before.bin.size(); ++k)
    {
        if (!mask[k])
        {
            ASSERT_EQ(after.bin[k], before.bin[k]) << "byte " << k;
        }
        else if (after.bin[k] != before.bin[k])
        {
            ++changed_position_bytes;
        }
    }
    EXPECT_GT(changed_position_bytes, 0U);

    // Read back: same welded structure (no cracks at seams or between the parts) and the
    // new positions to float32 precision.
    const MeshFile again = read_mesh_file(dir / "out.glb");
    ASSERT_EQ(again.mesh.V.rows(), file.mesh.V.rows());
    EXPECT_EQ(again.mesh.F, file.mesh.F);
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);

    // Bounds are those of the stored floats.
    for (const int a : {0, 4})
    {
        const auto& acc = after.json["accessors"][static_cast<std::size_t>(a)];
        ASSERT_EQ(acc["type"], "VEC3");
        const auto& view = after.json["bufferViews"][acc["bufferView"].get<std::size_t>()];
        const std::size_t stride = view.value("byteStride", std::size_t{12});
        const std::size_t first = view.value("byteOffset", std::size_t{0});
        for (std::size_t d = 0; d < 3; ++d)
        {
            float lo = 1e30f;
            float hi = -1e30f;
            for (std::size_t e = 0; e < acc["count"].get<std::size_t>(); ++e)
            {
                const float v = test::float_at(after.bin, first + e * stride + 4 * d);
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
            EXPECT_EQ(static_cast<float>(acc["min"][d].get<double>()), lo);
            EXPECT_EQ(static_cast<float>(acc["max"][d].get<double>()), hi);
        }
    }
}

TEST_F(GltfTest, data_uri_gltf_round_trip_keeps_json_and_rewrites_only_the_buffer)
{
    const auto t = two_boxes();
    test::put_bytes(dir / "in.gltf", t.builder.gltf());
    const MeshFile file = read_mesh_file(dir / "in.gltf");
    EXPECT_EQ(file.mesh.V.rows(), 12);
    const Positions moved = displaced(file.mesh.V);
    write_mesh_file(dir / "out.gltf", file, moved);
    EXPECT_TRUE(tinygltf_reads(dir / "out.gltf"));
    auto before = Json::parse(test::file_bytes(dir / "in.gltf"));
    auto after = Json::parse(test::file_bytes(dir / "out.gltf"));
    EXPECT_NE(after["buffers"][0]["uri"], before["buffers"][0]["uri"]);
    EXPECT_EQ(after["buffers"][0]["uri"].get<std::string>().rfind(
                  "data:application/octet-stream;base64,", 0),
              0U);
    after["buffers"][0].erase("uri");
    before["buffers"][0].erase("uri");
    EXPECT_EQ(without_position_bounds(after), without_position_bounds(before));
    const MeshFile again = read_mesh_file(dir / "out.gltf");
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(GltfTest, external_buffer_is_written_beside_the_output_and_the_input_is_untouched)
{
    const auto t = two_boxes();
    fs::create_directories(dir / "src");
    fs::create_directories(dir / "dst");
    test::put_bytes(dir / "src" / "scene.gltf", t.builder.gltf("scene data.bin"));
    test::put_bytes(dir / "src" / "scene data.bin", t.builder.bin);
    const MeshFile file = read_mesh_file(dir / "src" / "scene.gltf");
    const Positions moved = displaced(file.mesh.V);
    write_mesh_file(dir / "dst" / "marked.gltf", file, moved);
    EXPECT_EQ(test::file_bytes(dir / "src" / "scene data.bin"), t.builder.bin);
    ASSERT_TRUE(fs::exists(dir / "dst" / "marked.bin"));
    const auto out = Json::parse(test::file_bytes(dir / "dst" / "marked.gltf"));
    EXPECT_EQ(out["buffers"][0]["uri"], "marked.bin");
    EXPECT_TRUE(tinygltf_reads(dir / "dst" / "marked.gltf"));
    const MeshFile again = read_mesh_file(dir / "dst" / "marked.gltf");
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);

    // In place: the new buffer gets a name that is not the source's buffer file.
    test::put_bytes(dir / "src" / "scene.bin", t.builder.bin);
    test::put_bytes(dir / "src" / "s2.gltf", t.builder.gltf("scene.bin"));
    const MeshFile second = read_mesh_file(dir / "src" / "s2.gltf");
    write_mesh_file(dir / "src" / "scene.gltf", second, displaced(second.mesh.V));
    EXPECT_EQ(test::file_bytes(dir / "src" / "scene.bin"), t.builder.bin);
    EXPECT_EQ(Json::parse(test::file_bytes(dir / "src" / "scene.gltf"))["buffers"][0]["uri"],
              "scene_wm.bin");
}

// Images with relative URIs: written to another folder, the marked asset must still show its
// textures. Each image is copied beside the output (same relative path), unless the same bytes
// are there already; one whose path leaves the output's folder or whose place holds another
// file is reached from the output instead; a missing image, a data: URI and an output in the
// source's folder change nothing; a failed write leaves no image or folder behind.
TEST_F(GltfTest, images_are_copied_beside_an_output_in_another_folder_or_reached_from_it)
{
    auto t = two_boxes();
    t.builder.doc["images"] = Json::array({{{"uri", "tex/a%20b.png"}},
                                           {{"uri", "../shared.png"}},
                                           {{"uri", "clash.png"}},
                                           {{"uri", "same.png"}},
                                           {{"uri", "missing.png"}},
                                           {{"uri", "data:image/png;base64,AAAA"}}});
    fs::create_directories(dir / "src" / "tex");
    fs::create_directories(dir / "out" / "dst");
    test::put_bytes(dir / "src" / "scene.gltf", t.builder.gltf());
    test::put_bytes(dir / "src" / "tex" / "a b.png", "A");
    test::put_bytes(dir / "shared.png", "S");
    test::put_bytes(dir / "src" / "clash.png", "C");
    test::put_bytes(dir / "src" / "same.png", "M");
    test::put_bytes(dir / "out" / "dst" / "clash.png", "another file");
    test::put_bytes(dir / "out" / "dst" / "same.png", "M");
    const std::string source = test::file_bytes(dir / "src" / "scene.gltf");
    const MeshFile file = read_mesh_file(dir / "src" / "scene.gltf");
    const Positions moved = displaced(file.mesh.V);

    write_mesh_file(dir / "out" / "dst" / "marked.gltf", file, moved);
    const Json images =
        Json::parse(test::file_bytes(dir / "out" / "dst" / "marked.gltf"))["images"];
    EXPECT_EQ(images[0]["uri"], "tex/a%20b.png");
    EXPECT_EQ(test::file_bytes(dir / "out" / "dst" / "tex" / "a b.png"), "A");
    EXPECT_EQ(images[1]["uri"], "../../shared.png");
    EXPECT_EQ(images[2]["uri"], "../../src/clash.png");
    EXPECT_EQ(test::file_bytes(dir / "out" / "dst" / "clash.png"), "another file");
    EXPECT_EQ(images[3]["uri"], "same.png");
    EXPECT_EQ(images[4]["uri"], "missing.png");
    EXPECT_FALSE(fs::exists(dir / "out" / "dst" / "missing.png"));
    EXPECT_EQ(images[5]["uri"], "data:image/png;base64,AAAA");
    EXPECT_FALSE(fs::exists(dir / "out" / "dst" / "shared.png"));
    EXPECT_EQ(test::file_bytes(dir / "src" / "scene.gltf"), source);
    EXPECT_LT(
        (read_mesh_file(dir / "out" / "dst" / "marked.gltf").mesh.V - moved).cwiseAbs().maxCoeff(),
        1e-6);

    // In the source's folder every URI already resolves: the images are left as they are.
    write_mesh_file(dir / "src" / "marked.gltf", file, moved);
    EXPECT_EQ(Json::parse(test::file_bytes(dir / "src" / "marked.gltf"))["images"],
              t.builder.doc["images"]);

    // The asset cannot be written (its name is a folder): no image and no folder are left.
    fs::create_directories(dir / "fail" / "m.gltf");
    EXPECT_THROW(write_mesh_file(dir / "fail" / "m.gltf", file, moved), Error);
    EXPECT_FALSE(fs::exists(dir / "fail" / "tex"));
    EXPECT_FALSE(fs::exists(dir / "fail" / "same.png"));
}

// Two vertices a float32 step apart (a CAD model's repeated corners) moved alike must stay two:
// written as float32 their new coordinates would round to the same floats, and the reader
// would weld them (an IFC building lost 182 of its 16,942 vertices so, and its marked copy was
// no longer read vertex for vertex). The writer moves the later one on by float32 steps.
TEST_F(GltfTest, vertices_a_float_step_apart_stay_apart_when_moved_alike)
{
    const float a = 0.3F;
    const float b = std::nextafter(a, 1.0F);
    GltfBuilder g;
    const int pos = g.positions({a, 0, 0, b, 0, 0, 0, 1, 0, 0, 0, 1});
    g.node({{"mesh", g.mesh(Json::array({{{"attributes", {{"POSITION", pos}}},
                                          {"indices", g.indices({0, 2, 3, 1, 3, 2})}}}))}});
    test::put_bytes(dir / "close.glb", g.glb());
    const MeshFile file = read_mesh_file(dir / "close.glb");
    ASSERT_EQ(file.mesh.V.rows(), 4);
    Positions moved = file.mesh.V;
    moved.col(0).array() += 0.3;  // both land on 0.6000000238 in float32
    ASSERT_EQ(static_cast<float>(moved(0, 0)), static_cast<float>(moved(1, 0)));
    write_mesh_file(dir / "close_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "close_out.glb");
    ASSERT_EQ(again.mesh.V.rows(), 4);
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_NE(again.mesh.V(0, 0), again.mesh.V(1, 0));
}

TEST_F(GltfTest, sparse_accessor_positions_are_read_and_written_through)
{
    // Base positions in a view; the sparse part replaces elements 1 and 2.
    GltfBuilder b;
    const std::vector<float> base{0, 0, 0, 9, 9, 9, 9, 9, 9, 0, 1, 0};
    const std::vector<float> values{1, 0, 0, 1, 1, 0};
    const std::vector<std::uint16_t> which{1, 2};
    const int base_view = b.view(GltfBuilder::raw(base));
    const int index_view = b.view(GltfBuilder::raw(which));
    const int value_view = b.view(GltfBuilder::raw(values));
    const int pos = b.accessor(base_view, 0, 5126, 4, "VEC3");
    b.doc["accessors"][static_cast<std::size_t>(pos)]["sparse"] = {
        {"count", 2},
        {"indices", {{"bufferView", index_view}, {"componentType", 5123}}},
        {"values", {{"bufferView", value_view}}}};
    b.set_bounds(pos, {0, 0, 0, 1, 1, 0});
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices({0, 1, 2, 0, 2, 3})}}}));
    b.node({{"mesh", mesh}});
    test::put_bytes(dir / "sparse.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "sparse.glb");
    ASSERT_EQ(file.mesh.V.rows(), 4);
    EXPECT_EQ(file.mesh.V(1, 0), 1.0);
    EXPECT_EQ(file.mesh.V(2, 1), 1.0);
    Positions moved = file.mesh.V;
    moved(1, 2) = 0.5;   // a sparse element
    moved(3, 2) = -0.5;  // a base element
    write_mesh_file(dir / "sparse_out.glb", file, moved);
    const Glb after = split(test::file_bytes(dir / "sparse_out.glb"));
    const Glb before = split(test::file_bytes(dir / "sparse.glb"));
    // The overridden base element 1 is untouched; the sparse value and base element 3 moved.
    const auto& views = after.json["bufferViews"];
    const std::size_t base_at = views[static_cast<std::size_t>(base_view)]["byteOffset"];
    const std::size_t value_at = views[static_cast<std::size_t>(value_view)]["byteOffset"];
    EXPECT_EQ(test::float_at(after.bin, base_at + 12 + 8), 9.0f);
    EXPECT_EQ(test::float_at(after.bin, value_at + 8), 0.5f);
    EXPECT_EQ(test::float_at(after.bin, base_at + 36 + 8), -0.5f);
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["min"][2], -0.5);
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["max"][2], 0.5);
    const MeshFile again = read_mesh_file(dir / "sparse_out.glb");
    EXPECT_EQ(again.mesh.V, moved);
    EXPECT_TRUE(tinygltf_reads(dir / "sparse_out.glb"));
    static_cast<void>(before);
}

TEST_F(GltfTest, quantized_positions_are_dequantized_and_requantized)
{
    // KHR_mesh_quantization: normalized int16 positions under a scaling node.
    GltfBuilder b;
    const std::vector<std::int16_t> q{0, 0, 0, 32767, 0, 0, 32767, 32767, 0, 0, 32767, 0};
    const int view = b.view(GltfBuilder::raw(q));
    const int pos = b.accessor(view, 0, 5122, 4, "VEC3", true);
    b.doc["accessors"][static_cast<std::size_t>(pos)]["min"] = {0, 0, 0};
    b.doc["accessors"][static_cast<std::size_t>(pos)]["max"] = {32767, 32767, 0};
    const int mesh = b.mesh(Json::array(
        {{{"attributes", {{"POSITION", pos}}}, {"indices", b.indices({0, 1, 2, 0, 2, 3})}}}));
    b.node({{"mesh", mesh}, {"scale", {4.0, 4.0, 4.0}}});
    b.doc["extensionsUsed"] = {"KHR_mesh_quantization"};
    b.doc["extensionsRequired"] = {"KHR_mesh_quantization"};
    test::put_bytes(dir / "q.glb", b.glb());
    const MeshFile file = read_mesh_file(dir / "q.glb");
    ASSERT_EQ(file.mesh.V.rows(), 4);
    EXPECT_DOUBLE_EQ(file.mesh.V(2, 0), 4.0);
    Positions moved = file.mesh.V;
    moved(2, 0) = 2.0;
    moved(0, 2) = -1.0;
    write_mesh_file(dir / "q_out.glb", file, moved);
    const MeshFile again = read_mesh_file(dir / "q_out.glb");
    // One int16 step of a 4-unit normalized range is 4 / 32767.
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 4.0 / 32767.0);
    const Glb after = split(test::file_bytes(dir / "q_out.glb"));
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["min"][2], -8192);
    EXPECT_EQ(after.json["accessors"][static_cast<std::size_t>(pos)]["max"][0], 32767);
}

TEST_F(GltfTest, generic_writer_makes_valid_glb_and_gltf)
{
    TriangleMesh mesh;
    mesh.V.resize(4, 3);
    mesh.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0.1, 0.2, 1.0 / 3.0;
    mesh.F.resize(4, 3);
    mesh.F << 0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3;
    for (const char* name : {"w.glb", "w.gltf"})
    {
        write_mesh(dir / name, mesh);
        EXPECT_TRUE(tinygltf_reads(dir / name));
        const TriangleMesh again = read_mesh(dir / name);
        EXPECT_EQ(again.F, mesh.F);
        EXPECT_LT((again.V - mesh.V).cwiseAbs().maxCoeff(), 1e-7);
    }
}

// glTF 1.0 assets (2015-2016: collections keyed by name, a "version" string or number) are
// either refused by tinygltf with an unrelated reason or read as an empty scene; both are
// refused naming the version and the upgrade.
}  // namespace
}  // namespace meshmark
