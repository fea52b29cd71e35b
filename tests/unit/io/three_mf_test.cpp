// SPDX-License-Identifier: MIT
// 3MF: mesh objects in the build's world frame, welded; the preserving writer rewrites only the
// x/y/z values of moved vertices. Packages as slicers write them (PrusaSlicer with its config
// and a thumbnail relationship whose part is missing, Bambu/Orca style production-extension
// parts) are zipped with libzip from hand-written XML (three_mf_test_support.h) and compared
// entry by entry and byte by byte; lib3mf 1.8 writes one more fixture and reads meshmark's
// output independently.
#include <cmath>
#include <memory>
#include <regex>

#include <Model/COM/NMR_DLLInterfaces.h>
#include <gtest/gtest.h>
#include <zip.h>

#include "io_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "three_mf_test_support.h"

// lib3mf 1.8 leaks a few libzip allocations (~480 bytes) on every package it reads, also in
// a plain C program; LeakSanitizer builds of this test ignore them (the hook is only read by
// the sanitizer runtime).
extern "C" const char* __lsan_default_suppressions()
{
    return "leak:libzip.so\n";
}

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::box_object;
using test::box_vertices;
using test::entries_of;
using test::Entry;
using test::kBoxTriangles;
using test::kContentTypes;
using test::kProductionRoot;
using test::kPrusaConfig;
using test::kPrusaRels;
using test::make_zip;
using test::mask_vertex_values;
using test::Masked;
using test::Parts;
using test::patch_declared_size;
using test::production_objects;
using test::production_parts;
using test::prusa_model;
using test::prusa_parts;
using test::read_error;

struct Release
{
    void operator()(NMR::PLib3MFBase* p) const { NMR::lib3mf_release(p); }
};
using Ptr = std::unique_ptr<NMR::PLib3MFBase, Release>;

template <typename F>
Ptr make(F&& create)
{
    NMR::PLib3MFBase* p = nullptr;
    EXPECT_EQ(create(&p), 0);
    return Ptr(p);
}

NMR::MODELTRANSFORM transform(float scale, float tx, float ty, float tz)
{
    NMR::MODELTRANSFORM t{};
    for (int r = 0; r < 3; ++r)
    {
        for (int c = 0; c < 3; ++c)
        {
            t.m_fFields[r][c] = r == c ? scale : 0.0f;
        }
    }
    t.m_fFields[0][3] = tx;
    t.m_fFields[1][3] = ty;
    t.m_fFields[2][3] = tz;
    return t;
}

// The unit box with 8 vertices and 12 triangles.
void set_box(NMR::PLib3MFBase* mesh)
{
    std::vector<NMR::MODELMESHVERTEX> v(8);
    for (int i = 0; i < 8; ++i)
    {
        v[static_cast<std::size_t>(i)].m_fPosition[0] = static_cast<float>(i & 1);
        v[static_cast<std::size_t>(i)].m_fPosition[1] = static_cast<float>((i >> 1) & 1);
        v[static_cast<std::size_t>(i)].m_fPosition[2] = static_cast<float>((i >> 2) & 1);
    }
    const DWORD tri[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                              {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    std::vector<NMR::MODELMESHTRIANGLE> t(12);
    for (std::size_t f = 0; f < 12; ++f)
    {
        for (std::size_t c = 0; c < 3; ++c)
        {
            t[f].m_nIndices[c] = tri[f][c];
        }
    }
    ASSERT_EQ(NMR::lib3mf_meshobject_setgeometry(mesh, v.data(), 8, t.data(), 12), 0);
}

// Box A (build item: scale 2, at x = 1) and box B reached through a components object
// (build item at x = 3, component scale 2): the world boxes [1,3]^3-ish and [3,5] share the
// face x = 3. A has base materials per triangle; the model has metadata.
std::string two_box_package()
{
    auto model = make([](NMR::PLib3MFBase** p) { return NMR::lib3mf_createmodel(p); });
    auto materials = make([&](NMR::PLib3MFBase** p)
                          { return NMR::lib3mf_model_addbasematerialgroup(model.get(), p); });
    DWORD red = 0;
    DWORD blue = 0;
    EXPECT_EQ(NMR::lib3mf_basematerial_addmaterialutf8(materials.get(), "red", 255, 0, 0, &red), 0);
    EXPECT_EQ(NMR::lib3mf_basematerial_addmaterialutf8(materials.get(), "blue", 0, 0, 255, &blue),
              0);
    DWORD group = 0;
    EXPECT_EQ(NMR::lib3mf_resource_getresourceid(materials.get(), &group), 0);

    auto a =
        make([&](NMR::PLib3MFBase** p) { return NMR::lib3mf_model_addmeshobject(model.get(), p); });
    set_box(a.get());
    EXPECT_EQ(NMR::lib3mf_object_setnameutf8(a.get(), "box A"), 0);
    auto handler = make([&](NMR::PLib3MFBase** p)
                        { return NMR::lib3mf_meshobject_createpropertyhandler(a.get(), p); });
    for (DWORD f = 0; f < 12; ++f)
    {
        EXPECT_EQ(NMR::lib3mf_propertyhandler_setbasematerial(handler.get(), f, group,
                                                              f % 2 == 0 ? red : blue),
                  0);
    }
    // lib3mf refuses to write triangle properties without an object default property.
    auto defaults = make([&](NMR::PLib3MFBase** p)
                         { return NMR::lib3mf_object_createdefaultpropertyhandler(a.get(), p); });
    EXPECT_EQ(NMR::lib3mf_defaultpropertyhandler_setbasematerial(defaults.get(), group, red), 0);
    auto b =
        make([&](NMR::PLib3MFBase** p) { return NMR::lib3mf_model_addmeshobject(model.get(), p); });
    set_box(b.get());
    EXPECT_EQ(NMR::lib3mf_object_setnameutf8(b.get(), "box B"), 0);
    auto parts = make([&](NMR::PLib3MFBase** p)
                      { return NMR::lib3mf_model_addcomponentsobject(model.get(), p); });
    NMR::MODELTRANSFORM scale2 = transform(2.0f, 0.0f, 0.0f, 0.0f);
    auto component = make(
        [&](NMR::PLib3MFBase** p)
        { return NMR::lib3mf_componentsobject_addcomponent(parts.get(), b.get(), &scale2, p); });

    NMR::MODELTRANSFORM ta = transform(2.0f, 1.0f, 0.0f, 0.0f);
    auto item_a = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_addbuilditem(model.get(), a.get(), &ta, p); });
    NMR::MODELTRANSFORM tb = transform(1.0f, 3.0f, 0.0f, 0.0f);
    auto item_b =
        make([&](NMR::PLib3MFBase** p)
             { return NMR::lib3mf_model_addbuilditem(model.get(), parts.get(), &tb, p); });
    EXPECT_EQ(NMR::lib3mf_model_addmetadatautf8(model.get(), "Title", "two boxes"), 0);
    EXPECT_EQ(NMR::lib3mf_model_addmetadatautf8(model.get(), "Designer", "meshmark tests"), 0);

    // Debian's lib3mf 1.8 cannot write to a buffer: write a file and read it.
    auto writer = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_querywriter(model.get(), "3mf", p); });
    const fs::path file = test::temp_dir("three_mf_fixture") / "fixture.3mf";
    EXPECT_EQ(NMR::lib3mf_writer_writetofileutf8(writer.get(), file.string().c_str()), 0);
    return test::file_bytes(file);
}

// Everything lib3mf exposes about a package except vertex coordinates, as text.
struct Summary
{
    std::string structure;
    std::vector<std::vector<float>> vertices;  // per mesh object
};

Summary summarize(const fs::path& path)
{
    Summary s;
    auto model = make([](NMR::PLib3MFBase** p) { return NMR::lib3mf_createmodel(p); });
    auto reader = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_queryreader(model.get(), "3mf", p); });
    EXPECT_EQ(NMR::lib3mf_reader_readfromfileutf8(reader.get(), path.string().c_str()), 0);
    DWORD count = 0;
    EXPECT_EQ(NMR::lib3mf_model_getmetadatacount(model.get(), &count), 0);
    for (DWORD m = 0; m < count; ++m)
    {
        char key[256] = {};
        char value[256] = {};
        ULONG needed = 0;
        NMR::lib3mf_model_getmetadatakeyutf8(model.get(), m, key, sizeof(key), &needed);
        NMR::lib3mf_model_getmetadatavalueutf8(model.get(), m, value, sizeof(value), &needed);
        s.structure += std::string("meta ") + key + "=" + value + "\n";
    }
    auto meshes = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_getmeshobjects(model.get(), p); });
    BOOL has = 0;
    while (NMR::lib3mf_resourceiterator_movenext(meshes.get(), &has) == 0 && has != 0)
    {
        auto mesh = make([&](NMR::PLib3MFBase** p)
                         { return NMR::lib3mf_resourceiterator_getcurrent(meshes.get(), p); });
        DWORD id = 0;
        DWORD nv = 0;
        DWORD nt = 0;
        char name[256] = {};
        ULONG needed = 0;
        NMR::lib3mf_resource_getresourceid(mesh.get(), &id);
        NMR::lib3mf_object_getnameutf8(mesh.get(), name, sizeof(name), &needed);
        NMR::lib3mf_meshobject_getvertexcount(mesh.get(), &nv);
        NMR::lib3mf_meshobject_gettrianglecount(mesh.get(), &nt);
        s.structure += "mesh " + std::to_string(id) + " '" + name + "' " + std::to_string(nv) +
                       " " + std::to_string(nt) + "\n";
        std::vector<NMR::MODELMESHTRIANGLE> t(nt);
        NMR::lib3mf_meshobject_gettriangleindices(mesh.get(), t.data(), nt, nullptr);
        auto handler =
            make([&](NMR::PLib3MFBase** p)
                 { return NMR::lib3mf_meshobject_createpropertyhandler(mesh.get(), p); });
        for (DWORD f = 0; f < nt; ++f)
        {
            DWORD g = 0;
            DWORD i = 0;
            NMR::lib3mf_propertyhandler_getbasematerial(handler.get(), f, &g, &i);
            s.structure += " t " + std::to_string(t[f].m_nIndices[0]) + " " +
                           std::to_string(t[f].m_nIndices[1]) + " " +
                           std::to_string(t[f].m_nIndices[2]) + " m " + std::to_string(g) + ":" +
                           std::to_string(i) + "\n";
        }
        std::vector<NMR::MODELMESHVERTEX> v(nv);
        NMR::lib3mf_meshobject_getvertices(mesh.get(), v.data(), nv, nullptr);
        s.vertices.emplace_back();
        for (const auto& x : v)
        {
            s.vertices.back().insert(s.vertices.back().end(),
                                     {x.m_fPosition[0], x.m_fPosition[1], x.m_fPosition[2]});
        }
    }
    auto items =
        make([&](NMR::PLib3MFBase** p) { return NMR::lib3mf_model_getbuilditems(model.get(), p); });
    while (NMR::lib3mf_builditemiterator_movenext(items.get(), &has) == 0 && has != 0)
    {
        auto item = make([&](NMR::PLib3MFBase** p)
                         { return NMR::lib3mf_builditemiterator_getcurrent(items.get(), p); });
        DWORD id = 0;
        NMR::MODELTRANSFORM t{};
        NMR::lib3mf_builditem_getobjectresourceid(item.get(), &id);
        NMR::lib3mf_builditem_getobjecttransform(item.get(), &t);
        s.structure += "item " + std::to_string(id);
        for (const auto& row : t.m_fFields)
        {
            for (const float x : row)
            {
                s.structure += " " + std::to_string(x);
            }
        }
        s.structure += "\n";
    }
    return s;
}

class ThreeMfTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("three_mf_test");
};

TEST_F(ThreeMfTest, reads_objects_in_the_build_frame_welded)
{
    test::put_bytes(dir / "boxes.3mf", two_box_package());
    const MeshFile file = read_mesh_file(dir / "boxes.3mf");
    EXPECT_EQ(file.format, MeshFormat::ThreeMf);
    // 8 + 8 corners, 4 shared on the face x = 3.
    EXPECT_EQ(file.mesh.V.rows(), 12);
    EXPECT_EQ(file.mesh.F.rows(), 24);
    EXPECT_DOUBLE_EQ(file.mesh.V.col(0).minCoeff(), 1.0);
    EXPECT_DOUBLE_EQ(file.mesh.V.col(0).maxCoeff(), 5.0);
    EXPECT_DOUBLE_EQ(file.mesh.V.col(2).maxCoeff(), 2.0);
}

TEST_F(ThreeMfTest, round_trip_changes_only_vertex_coordinates)
{
    const std::string package = two_box_package();
    test::put_bytes(dir / "in.3mf", package);
    const MeshFile file = read_mesh_file(dir / "in.3mf");
    write_mesh_file(dir / "same.3mf", file, file.mesh.V);
    EXPECT_EQ(test::file_bytes(dir / "same.3mf"), package);

    Positions moved = file.mesh.V;
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        moved(i, 1) += 0.01 * static_cast<double>(i + 1);
    }
    write_mesh_file(dir / "out.3mf", file, moved);
    // Entry by entry: the model part differs only inside x/y/z values, the rest not at all.
    const auto in_entries = entries_of(package);
    const auto out_entries = entries_of(test::file_bytes(dir / "out.3mf"));
    ASSERT_EQ(out_entries.size(), in_entries.size());
    for (std::size_t i = 0; i < in_entries.size(); ++i)
    {
        EXPECT_EQ(out_entries[i].name, in_entries[i].name);
        if (in_entries[i].name == "3D/3dmodel.model")
        {
            EXPECT_EQ(mask_vertex_values(out_entries[i].content).text,
                      mask_vertex_values(in_entries[i].content).text);
            EXPECT_NE(out_entries[i].content, in_entries[i].content);
        }
        else
        {
            EXPECT_EQ(out_entries[i].raw, in_entries[i].raw) << in_entries[i].name;
        }
    }
    const Summary before = summarize(dir / "in.3mf");
    const Summary after = summarize(dir / "out.3mf");
    EXPECT_EQ(after.structure, before.structure);
    ASSERT_EQ(after.vertices.size(), 2U);
    EXPECT_NE(after.vertices, before.vertices);

    const MeshFile again = read_mesh_file(dir / "out.3mf");
    ASSERT_EQ(again.mesh.V.rows(), moved.rows());
    EXPECT_EQ(again.mesh.F, file.mesh.F);
    // lib3mf wrote the coordinates with 6 decimals (<= 9 digits): moved ones are rewritten as
    // the shortest float text, exact to float32 rounding in local units times the scale 2.
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(ThreeMfTest, generic_writer_and_bad_packages)
{
    TriangleMesh mesh;
    mesh.V.resize(4, 3);
    mesh.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    mesh.F.resize(4, 3);
    mesh.F << 0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3;
    write_mesh(dir / "w.3mf", mesh);
    const TriangleMesh again = read_mesh(dir / "w.3mf");
    EXPECT_EQ(again.F, mesh.F);
    EXPECT_EQ(again.V, mesh.V);
    // An independent reader sees the same object.
    const Summary summary = summarize(dir / "w.3mf");
    ASSERT_EQ(summary.vertices.size(), 1U);
    EXPECT_EQ(summary.vertices[0], std::vector<float>({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}));
    EXPECT_NE(summary.structure.find("t 0 2 1"), std::string::npos) << summary.structure;

    const std::string package = two_box_package();
    test::put_bytes(dir / "cut.3mf", package.substr(0, package.size() / 2));
    try
    {
        static_cast<void>(read_mesh_file(dir / "cut.3mf"));
        FAIL() << "accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("cut.3mf"), std::string::npos) << e.what();
    }
}

TEST_F(ThreeMfTest, prusa_package_with_a_missing_thumbnail_is_read_in_the_build_frame)
{
    const std::string package = make_zip(dir, prusa_parts(prusa_model(box_object("1", "20"))));
    test::put_bytes(dir / "prusa.3mf", package);
    const MeshFile file = read_mesh_file(dir / "prusa.3mf");
    EXPECT_EQ(file.mesh.V.rows(), 8);
    EXPECT_EQ(file.mesh.F.rows(), 12);
    EXPECT_EQ(file.mesh.V.colwise().minCoeff(), Eigen::RowVector3d(100, 100, 10));
    EXPECT_EQ(file.mesh.V.colwise().maxCoeff(), Eigen::RowVector3d(120, 120, 30));

    // Unchanged positions: the package byte for byte.
    write_mesh_file(dir / "same.3mf", file, file.mesh.V);
    EXPECT_EQ(test::file_bytes(dir / "same.3mf"), package);
}

TEST_F(ThreeMfTest, a_second_build_item_of_an_object_is_kept_aside_as_an_instance)
{
    // Two build items place one box object: the first is the watermarked mesh, the second is
    // returned as MeshFile::instances (world frame) and follows the first's displacement.
    std::string model = prusa_model(box_object("1", "20"));
    const std::string item =
        "  <item objectid=\"1\" transform=\"1 0 0 0 1 0 0 0 1 100 100 10\" printable=\"1\"/>\n";
    const auto at = model.find(item);
    ASSERT_NE(at, std::string::npos);
    model.insert(
        at + item.size(),
        "  <item objectid=\"1\" transform=\"1 0 0 0 1 0 0 0 1 200 100 10\" printable=\"1\"/>\n");
    test::put_bytes(dir / "two.3mf", make_zip(dir, prusa_parts(model)));
    const MeshFile file = read_mesh_file(dir / "two.3mf");
    ASSERT_EQ(file.mesh.V.rows(), 8);
    ASSERT_EQ(file.instances.V.rows(), 8);
    EXPECT_EQ(file.instances.F.rows(), 12);
    EXPECT_EQ(file.instances.V.colwise().minCoeff(), Eigen::RowVector3d(200, 100, 10));
    Positions moved = file.mesh.V;
    moved(0, 2) += 0.5;
    write_mesh_file(dir / "two_out.3mf", file, moved);
    const MeshFile again = read_mesh_file(dir / "two_out.3mf");
    EXPECT_EQ(again.mesh.V, moved);
    const Positions shift = again.instances.V - file.instances.V;
    EXPECT_EQ(shift.col(2).maxCoeff(), 0.5);
    EXPECT_EQ(shift.leftCols(2).cwiseAbs().maxCoeff(), 0.0);
}

TEST_F(ThreeMfTest, writer_changes_only_moved_vertex_values)
{
    const std::string model = prusa_model(box_object("1", "20"));
    const std::string package = make_zip(dir, prusa_parts(model));
    test::put_bytes(dir / "in.3mf", package);
    const MeshFile file = read_mesh_file(dir / "in.3mf");
    // Move vertices 0..3 (world z = 10): 0 and 1 in x only, 2 and 3 in all axes.
    Positions moved = file.mesh.V;
    moved(0, 0) += 0.125;
    moved(1, 0) -= 0.001;
    moved.row(2) += Eigen::RowVector3d(0.01, 0.02, 0.03);
    moved.row(3) += Eigen::RowVector3d(-0.01, 1e-4, 0.5);
    write_mesh_file(dir / "out.3mf", file, moved);
    const std::string written = test::file_bytes(dir / "out.3mf");

    const auto before = entries_of(package);
    const auto after = entries_of(written);
    ASSERT_EQ(after.size(), before.size());
    for (std::size_t i = 0; i < before.size(); ++i)
    {
        EXPECT_EQ(after[i].name, before[i].name);
        EXPECT_EQ(after[i].method, before[i].method) << before[i].name;
        if (before[i].name != "3D/3dmodel.model")
        {
            EXPECT_EQ(after[i].content, before[i].content) << before[i].name;
            EXPECT_EQ(after[i].raw, before[i].raw) << before[i].name << " was recompressed";
        }
    }
    ASSERT_EQ(before[2].name, "3D/3dmodel.model");
    const Masked in = mask_vertex_values(before[2].content);
    const Masked out = mask_vertex_values(after[2].content);
    ASSERT_EQ(in.values.size(), 24U);
    EXPECT_EQ(out.text, in.text);  // every byte outside x/y/z values
    ASSERT_EQ(out.values.size(), in.values.size());
    // Attribute order in the file: vertex 2 is written z, y, x.
    const std::vector<std::string> expected_moved = {
        "0.125",  "0",     "0",  // vertex 0: x only; y and z keep their text
        "19.999", "0",     "0",  // vertex 1
        "0.03",   "20.02", "0.01", "19.99", "20.0001", "0.5"};
    for (std::size_t k = 0; k < in.values.size(); ++k)
    {
        if (k < expected_moved.size())
        {
            EXPECT_EQ(out.values[k], expected_moved[k]) << "value " << k;
        }
        else
        {
            EXPECT_EQ(out.values[k], in.values[k]) << "value " << k;  // unmoved: same bytes
        }
    }
    const MeshFile again = read_mesh_file(dir / "out.3mf");
    EXPECT_EQ(again.mesh.F, file.mesh.F);
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-5);
}

TEST_F(ThreeMfTest, production_components_are_marked_in_the_world_frame)
{
    const Parts parts = production_parts();
    const std::string package = make_zip(dir, parts, ZIP_CM_STORE);
    test::put_bytes(dir / "bambu.3mf", package);
    const MeshFile file = read_mesh_file(dir / "bambu.3mf");
    ASSERT_EQ(file.mesh.V.rows(), 16);
    EXPECT_EQ(file.mesh.F.rows(), 24);
    // Box 1 at the item's (128, 128, 5); box 3 scaled by 2 and moved by 30 in x on top of that.
    EXPECT_EQ(file.mesh.V.colwise().minCoeff(), Eigen::RowVector3d(128, 128, 5));
    EXPECT_NEAR(file.mesh.V.col(0).maxCoeff(), 178.0, 1e-5);
    EXPECT_NEAR(file.mesh.V.col(2).maxCoeff(), 25.0, 1e-5);
    write_mesh_file(dir / "same.3mf", file, file.mesh.V);
    EXPECT_EQ(test::file_bytes(dir / "same.3mf"), package);

    Positions moved = file.mesh.V;
    moved.col(0).array() += 0.01;
    write_mesh_file(dir / "out.3mf", file, moved);
    const auto before = entries_of(package);
    const auto after = entries_of(test::file_bytes(dir / "out.3mf"));
    ASSERT_EQ(after.size(), before.size());
    for (std::size_t i = 0; i < before.size(); ++i)
    {
        EXPECT_EQ(after[i].name, before[i].name);
        EXPECT_EQ(after[i].method, ZIP_CM_STORE) << before[i].name;
        if (before[i].name != "3D/Objects/object_1.model")
        {
            // The root model too: only the part the components point to is rewritten.
            EXPECT_EQ(after[i].raw, before[i].raw) << before[i].name;
        }
    }
    ASSERT_EQ(before[4].name, "3D/Objects/object_1.model");
    const Masked in = mask_vertex_values(before[4].content);
    const Masked out = mask_vertex_values(after[4].content);
    EXPECT_EQ(out.text, in.text);
    ASSERT_EQ(out.values.size(), 48U);
    // Box 1 (scale 1): x + 0.01; box 3 (scale 2): x + 0.005 in its own frame; y and z as they were.
    EXPECT_EQ(out.values[0], "0.01");
    EXPECT_EQ(out.values[3], "10.01");
    EXPECT_EQ(out.values[24], "0.005");
    EXPECT_EQ(out.values[27], "10.005");
    for (const std::size_t k : {1U, 2U, 4U, 5U, 25U, 26U})
    {
        EXPECT_EQ(out.values[k], in.values[k]) << "value " << k;
    }
    const MeshFile again = read_mesh_file(dir / "out.3mf");
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 1e-5);

    // The part the components point to must be there.
    Parts missing = parts;
    missing.erase(missing.begin() + 4);
    test::put_bytes(dir / "missing.3mf", make_zip(dir, missing));
    const std::string message = read_error<IoError>(dir / "missing.3mf");
    EXPECT_NE(message.find("/3D/Objects/object_1.model, which is not in the package"),
              std::string::npos)
        << message;
}

TEST_F(ThreeMfTest, hostile_packages_fail_with_one_sentence)
{
    const auto expect_error = [&](const std::string& name, const Parts& parts,
                                  const std::string& expected, bool is_mesh_error = false)
    {
        test::put_bytes(dir / name, make_zip(dir, parts));
        const std::string message =
            is_mesh_error ? read_error<InvalidMesh>(dir / name) : read_error<IoError>(dir / name);
        EXPECT_NE(message.find(name + ": "), std::string::npos) << message;
        EXPECT_NE(message.find(expected), std::string::npos) << message;
    };
    const std::string box = box_object("1", "20");
    std::string model = prusa_model(box);
    expect_error("cut.3mf", prusa_parts(model.substr(0, model.size() - 20)),
                 "the model part 3D/3dmodel.model is not well-formed XML");
    std::string bad_index = box;
    bad_index.replace(bad_index.find("v3=\"1\""), 6, "v3=\"8\"");
    expect_error("index.3mf", prusa_parts(prusa_model(bad_index)),
                 "triangle 0 of object 1 in 3D/3dmodel.model uses vertex index 8 outside 0..7",
                 true);
    std::string bad_coordinate = box;
    bad_coordinate.replace(bad_coordinate.find("x=\"0\""), 5, "x=\"1,5\"");
    expect_error("coordinate.3mf", prusa_parts(prusa_model(bad_coordinate)),
                 "vertex 0 of object 1 in 3D/3dmodel.model has a bad x coordinate '1,5'");
    expect_error(
        "cycle.3mf",
        prusa_parts(prusa_model(
            "  <object id=\"1\"><components><component objectid=\"5\"/></components></object>\n"
            "  <object id=\"5\"><components><component objectid=\"1\"/></components></object>\n")),
        "nest too deeply");
    expect_error("no_model.3mf", {{"[Content_Types].xml", kContentTypes}},
                 "_rels/.rels names no 3D model part");
    test::put_bytes(dir / "not_a_zip.3mf", model);
    EXPECT_NE(read_error<IoError>(dir / "not_a_zip.3mf").find("not a zip archive"),
              std::string::npos);

    // A zip bomb: the model part claims 4 GB; refused before anything is inflated.
    std::string bomb = make_zip(dir, prusa_parts(model));
    patch_declared_size(bomb, "3D/3dmodel.model", 0xfffffff0U);
    test::put_bytes(dir / "bomb.3mf", bomb);
    const std::string message = read_error<IoError>(dir / "bomb.3mf");
    EXPECT_NE(message.find("declares 4294967280 uncompressed bytes, more than the limit"),
              std::string::npos)
        << message;
    // A size smaller than the data: the data do not fit the declared size.
    std::string short_size = make_zip(dir, prusa_parts(model));
    patch_declared_size(short_size, "3D/3dmodel.model", 100U);
    test::put_bytes(dir / "short.3mf", short_size);
    EXPECT_NE(read_error<IoError>(dir / "short.3mf").find("cannot decompress zip entry"),
              std::string::npos);
}

}  // namespace
}  // namespace meshmark
