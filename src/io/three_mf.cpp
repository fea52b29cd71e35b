// SPDX-License-Identifier: MIT
// 3MF through lib3mf 1.x (Debian lib3mf-dev): every mesh object in the world frame of the
// build (build item and component transforms), welded like glTF parts; written back by
// loading the original package again, setting the moved vertices and letting lib3mf write it.
#include <cmath>
#include <cstring>
#include <map>

#include <Eigen/Core>
#include <Eigen/LU>
#include <Model/COM/NMR_DLLInterfaces.h>
#include <unistd.h>

#include "io/detail/formats.h"
#include "io/detail/support.h"
#include "io/detail/weld.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {
namespace {

namespace fs = std::filesystem;

// Component nesting deeper than this (or more object visits) is refused: lib3mf does not
// reject reference cycles, and a DAG of components can expand exponentially.
constexpr int kMaxComponentDepth = 64;
constexpr std::size_t kMaxObjectVisits = 1U << 20U;

// Owns one lib3mf instance (model, reader, writer, iterator, resource handle).
class Handle
{
public:
    Handle() = default;
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    ~Handle()
    {
        if (p_ != nullptr)
        {
            NMR::lib3mf_release(p_);
        }
    }
    NMR::PLib3MFBase** out() { return &p_; }
    [[nodiscard]] NMR::PLib3MFBase* get() const { return p_; }

private:
    NMR::PLib3MFBase* p_ = nullptr;
};

// The last error of a lib3mf instance as text.
std::string last_error(NMR::PLib3MFBase* instance)
{
    DWORD code = 0;
    LPCSTR message = nullptr;
    if (instance != nullptr && NMR::lib3mf_getlasterror(instance, &code, &message) == 0 &&
        message != nullptr && *message != '\0')
    {
        return message;
    }
    return "lib3mf error code " + std::to_string(code);
}

void check(const fs::path& path, LIB3MFRESULT result, NMR::PLib3MFBase* instance,
           const std::string& what)
{
    if (result != 0)
    {
        fail_io(path, what + ": " + last_error(instance));
    }
}

Eigen::Matrix4d to_matrix(const NMR::MODELTRANSFORM& t)
{
    // lib3mf stores the 3x4 affine matrix for column vectors: p' = F[:, 0:3] p + F[:, 3].
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r)
    {
        for (int c = 0; c < 4; ++c)
        {
            m(r, c) = static_cast<double>(t.m_fFields[r][c]);
        }
    }
    return m;
}

NMR::MODELTRANSFORM identity_transform()
{
    NMR::MODELTRANSFORM t{};
    for (int r = 0; r < 3; ++r)
    {
        for (int c = 0; c < 4; ++c)
        {
            t.m_fFields[r][c] = r == c ? 1.0f : 0.0f;
        }
    }
    return t;
}

void load_model(const fs::path& path, const std::string& bytes, Handle& model)
{
    check(path, NMR::lib3mf_createmodel(model.out()), nullptr, "cannot create a 3MF model");
    Handle reader;
    check(path, NMR::lib3mf_model_queryreader(model.get(), "3mf", reader.out()), model.get(),
          "cannot create a 3MF reader");
    // lib3mf's reader takes a non-const buffer; it only reads it.
    std::string copy = bytes;
    check(path,
          NMR::lib3mf_reader_readfrombuffer(reader.get(), reinterpret_cast<BYTE*>(copy.data()),
                                            copy.size()),
          reader.get(), "not a valid 3MF package");
}

class Reader
{
public:
    Reader(const fs::path& path, NMR::PLib3MFBase* model, ThreeMfLayout& layout)
        : path_(path), model_(model), layout_(layout)
    {
    }

    TriangleMesh run()
    {
        // Build items first (their transforms), then mesh objects no build item reaches.
        Handle items;
        check(path_, NMR::lib3mf_model_getbuilditems(model_, items.out()), model_,
              "cannot list the build items");
        BOOL has_next = 0;
        while (NMR::lib3mf_builditemiterator_movenext(items.get(), &has_next) == 0 && has_next != 0)
        {
            Handle item;
            check(path_, NMR::lib3mf_builditemiterator_getcurrent(items.get(), item.out()),
                  items.get(), "cannot read a build item");
            NMR::MODELTRANSFORM t = identity_transform();
            check(path_, NMR::lib3mf_builditem_getobjecttransform(item.get(), &t), item.get(),
                  "cannot read a build item transform");
            DWORD id = 0;
            check(path_, NMR::lib3mf_builditem_getobjectresourceid(item.get(), &id), item.get(),
                  "cannot read a build item's object");
            visit(id, to_matrix(t), 0);
        }
        Handle meshes;
        check(path_, NMR::lib3mf_model_getmeshobjects(model_, meshes.out()), model_,
              "cannot list the mesh objects");
        while (NMR::lib3mf_resourceiterator_movenext(meshes.get(), &has_next) == 0 && has_next != 0)
        {
            Handle resource;
            check(path_, NMR::lib3mf_resourceiterator_getcurrent(meshes.get(), resource.out()),
                  meshes.get(), "cannot read a mesh object");
            DWORD id = 0;
            check(path_, NMR::lib3mf_resource_getresourceid(resource.get(), &id), resource.get(),
                  "cannot read a resource id");
            if (slot_.count(id) == 0)
            {
                add_mesh(id, Eigen::Matrix4d::Identity());
            }
        }
        return weld();
    }

private:
    void visit(DWORD id, const Eigen::Matrix4d& to_world, int depth)
    {
        if (depth > kMaxComponentDepth || ++visits_ > kMaxObjectVisits)
        {
            fail_io(path_, "the components of object " + std::to_string(id) +
                               " nest too deeply (a reference cycle?)");
        }
        if (!to_world.allFinite())
        {
            fail_io(path_, "object " + std::to_string(id) + " has a non-finite transform");
        }
        Handle mesh;
        if (NMR::lib3mf_model_getmeshobjectbyid(model_, id, mesh.out()) == 0 &&
            mesh.get() != nullptr)
        {
            add_mesh(id, to_world);
            return;
        }
        Handle components;
        if (NMR::lib3mf_model_getcomponentsobjectbyid(model_, id, components.out()) != 0 ||
            components.get() == nullptr)
        {
            fail_io(path_, "the build refers to object " + std::to_string(id) +
                               ", which is neither a mesh nor a components object");
        }
        DWORD count = 0;
        check(path_, NMR::lib3mf_componentsobject_getcomponentcount(components.get(), &count),
              components.get(), "cannot read the components of object " + std::to_string(id));
        for (DWORD c = 0; c < count; ++c)
        {
            Handle component;
            check(path_,
                  NMR::lib3mf_componentsobject_getcomponent(components.get(), c, component.out()),
                  components.get(), "cannot read a component of object " + std::to_string(id));
            NMR::MODELTRANSFORM t = identity_transform();
            check(path_, NMR::lib3mf_component_gettransform(component.get(), &t), component.get(),
                  "cannot read a component transform");
            DWORD child = 0;
            check(path_, NMR::lib3mf_component_getobjectresourceid(component.get(), &child),
                  component.get(), "cannot read a component's object");
            visit(child, to_world * to_matrix(t), depth + 1);
        }
    }

    void add_mesh(DWORD id, const Eigen::Matrix4d& to_world)
    {
        if (const auto found = slot_.find(id); found != slot_.end())
        {
            // Another instance: one set of vertices, one displacement (see glTF instancing).
            static_cast<void>(found);
            return;
        }
        if (std::abs(to_world.topLeftCorner<3, 3>().determinant()) == 0.0)
        {
            return;  // a singular transform: nothing visible to mark
        }
        Handle mesh;
        check(path_, NMR::lib3mf_model_getmeshobjectbyid(model_, id, mesh.out()), model_,
              "cannot open mesh object " + std::to_string(id));
        DWORD vertex_count = 0;
        DWORD triangle_count = 0;
        check(path_, NMR::lib3mf_meshobject_getvertexcount(mesh.get(), &vertex_count), mesh.get(),
              "cannot read mesh object " + std::to_string(id));
        check(path_, NMR::lib3mf_meshobject_gettrianglecount(mesh.get(), &triangle_count),
              mesh.get(), "cannot read mesh object " + std::to_string(id));
        std::vector<NMR::MODELMESHVERTEX> vertices(vertex_count);
        std::vector<NMR::MODELMESHTRIANGLE> triangles(triangle_count);
        if (vertex_count > 0)
        {
            check(path_,
                  NMR::lib3mf_meshobject_getvertices(mesh.get(), vertices.data(), vertex_count,
                                                     nullptr),
                  mesh.get(), "cannot read the vertices of mesh object " + std::to_string(id));
        }
        if (triangle_count > 0)
        {
            check(path_,
                  NMR::lib3mf_meshobject_gettriangleindices(mesh.get(), triangles.data(),
                                                            triangle_count, nullptr),
                  mesh.get(), "cannot read the triangles of mesh object " + std::to_string(id));
        }
        slot_[id] = layout_.objects.size();
        ThreeMfObject object;
        object.resource_id = id;
        object.to_world = to_world;
        object.welded.resize(vertex_count);
        layout_.objects.push_back(std::move(object));
        const std::size_t base = group_.size();
        base_.push_back(base);
        const auto group = group_of(to_world);
        for (const auto& v : vertices)
        {
            const Eigen::Vector4d local(v.m_fPosition[0], v.m_fPosition[1], v.m_fPosition[2], 1.0);
            if (!local.allFinite())
            {
                fail_mesh(path_, "mesh object " + std::to_string(id) + " has a non-finite vertex");
            }
            const Eigen::Vector4d w = to_world * local;
            world_.insert(world_.end(), {w.x(), w.y(), w.z()});
            group_.push_back(group);
        }
        for (const auto& t : triangles)
        {
            for (const auto i : t.m_nIndices)
            {
                if (i >= vertex_count)
                {
                    fail_mesh(path_, "mesh object " + std::to_string(id) + " has vertex index " +
                                         std::to_string(i) + " " + index_range(vertex_count));
                }
                corners_.push_back(base + i);
            }
        }
    }

    std::int32_t group_of(const Eigen::Matrix4d& to_world)
    {
        for (std::size_t g = 0; g < groups_.size(); ++g)
        {
            if (groups_[g] == to_world)
            {
                return static_cast<std::int32_t>(g);
            }
        }
        groups_.push_back(to_world);
        return static_cast<std::int32_t>(groups_.size() - 1);
    }

    TriangleMesh weld()
    {
        if (group_.size() > kMaxVertices)
        {
            fail_io(path_, "the model has more than " + std::to_string(kMaxVertices) + " vertices");
        }
        std::vector<double> xyz;
        const auto welded =
            weld_world_positions(world_, group_, groups_.size(), kCrossTransformWeldRel, xyz);
        for (std::size_t s = 0; s < layout_.objects.size(); ++s)
        {
            auto& object = layout_.objects[s];
            std::copy(welded.begin() + static_cast<std::ptrdiff_t>(base_[s]),
                      welded.begin() + static_cast<std::ptrdiff_t>(base_[s] + object.welded.size()),
                      object.welded.begin());
        }
        TriangleBuffer triangles;
        triangles.reserve(corners_.size() / 3);
        for (std::size_t t = 0; t + 2 < corners_.size(); t += 3)
        {
            triangles.push(welded[corners_[t]], welded[corners_[t + 1]], welded[corners_[t + 2]]);
        }
        return make_mesh(xyz, triangles);
    }

    const fs::path& path_;
    NMR::PLib3MFBase* model_;
    ThreeMfLayout& layout_;
    std::size_t visits_ = 0;
    std::map<DWORD, std::size_t> slot_;
    std::vector<std::size_t> base_;
    std::vector<Eigen::Matrix4d> groups_;
    std::vector<double> world_;
    std::vector<std::int32_t> group_;
    std::vector<std::size_t> corners_;
};

// The package lib3mf writes for \p model. Debian's lib3mf 1.8 cannot write to memory (its
// stream size query returns 0 and callback streams cannot seek), so it writes a temporary file
// next to \p path, which is read back and removed; the caller then writes atomically.
std::string model_bytes(const fs::path& path, NMR::PLib3MFBase* model)
{
    Handle writer;
    check(path, NMR::lib3mf_model_querywriter(model, "3mf", writer.out()), model,
          "cannot create a 3MF writer");
    const fs::path directory = path.has_parent_path() ? path.parent_path() : fs::path(".");
    // Appended piecewise: GCC 12 at -O3 gives a false -Wrestrict on a + chain (bug 105329).
    std::string name = ".";
    name += path.filename().string();
    name += ".lib3mf-";
    name += std::to_string(::getpid());
    name += ".tmp";
    const fs::path temporary = directory / name;
    std::string bytes;
    try
    {
        check(path, NMR::lib3mf_writer_writetofileutf8(writer.get(), temporary.string().c_str()),
              writer.get(), "cannot write the 3MF package");
        bytes = read_file_bytes(temporary);
    }
    catch (...)
    {
        std::error_code ignored;
        fs::remove(temporary, ignored);
        throw;
    }
    std::error_code ignored;
    fs::remove(temporary, ignored);
    return bytes;
}

std::string moved_package(const fs::path& path, const FileLayout& layout, const Positions& original,
                          const Positions& positions);
std::string new_package(const fs::path& path, const TriangleMesh& mesh);

// lib3mf reports most failures as result codes but lets some C++ exceptions escape its C
// interface; both become one IoError naming the file.
template <typename F>
auto guarded(const fs::path& path, F&& body)
{
    try
    {
        return body();
    }
    catch (const Error&)
    {
        throw;
    }
    catch (const std::exception& e)
    {
        fail_io(path, std::string("not a valid 3MF package: ") + e.what());
    }
}

}  // namespace

TriangleMesh read_3mf(const fs::path& path, FileLayout& layout)
{
    return guarded(path,
                   [&]
                   {
                       Handle model;
                       load_model(path, layout.bytes, model);
                       auto& objects = layout.positions.emplace<ThreeMfLayout>();
                       Reader reader(path, model.get(), objects);
                       return reader.run();
                   });
}

std::string preserved_3mf_bytes(const fs::path& path, const FileLayout& layout,
                                const Positions& original, const Positions& positions)
{
    return guarded(path, [&] { return moved_package(path, layout, original, positions); });
}

std::string three_mf_bytes(const fs::path& path, const TriangleMesh& mesh)
{
    return guarded(path, [&] { return new_package(path, mesh); });
}

namespace {

std::string moved_package(const fs::path& path, const FileLayout& layout, const Positions& original,
                          const Positions& positions)
{
    const auto& objects = std::get<ThreeMfLayout>(layout.positions);
    Handle model;
    load_model(path, layout.bytes, model);
    bool is_any_changed = false;
    for (const auto& object : objects.objects)
    {
        Handle mesh;
        check(path,
              NMR::lib3mf_model_getmeshobjectbyid(model.get(), object.resource_id, mesh.out()),
              model.get(), "cannot open mesh object " + std::to_string(object.resource_id));
        const Eigen::Matrix4d to_local = object.to_world.inverse();
        for (std::size_t i = 0; i < object.welded.size(); ++i)
        {
            const auto w = object.welded[i];
            if (std::memcmp(original.row(w).data(), positions.row(w).data(), 3 * sizeof(double)) ==
                0)
            {
                continue;
            }
            const Eigen::Vector4d local =
                to_local * Eigen::Vector4d(positions(w, 0), positions(w, 1), positions(w, 2), 1.0);
            NMR::MODELMESHVERTEX v{};
            for (int d = 0; d < 3; ++d)
            {
                v.m_fPosition[d] = static_cast<float>(local[d]);
                if (!std::isfinite(v.m_fPosition[d]))
                {
                    fail_io(path,
                            "vertex " + std::to_string(w) + " does not fit a float32 coordinate");
                }
            }
            check(path, NMR::lib3mf_meshobject_setvertex(mesh.get(), static_cast<DWORD>(i), &v),
                  mesh.get(),
                  "cannot set a vertex of mesh object " + std::to_string(object.resource_id));
            is_any_changed = true;
        }
    }
    // Unchanged positions: the package as it was, byte for byte.
    return is_any_changed ? model_bytes(path, model.get()) : layout.bytes;
}

std::string new_package(const fs::path& path, const TriangleMesh& mesh)
{
    Handle model;
    check(path, NMR::lib3mf_createmodel(model.out()), nullptr, "cannot create a 3MF model");
    Handle object;
    check(path, NMR::lib3mf_model_addmeshobject(model.get(), object.out()), model.get(),
          "cannot add a mesh object");
    std::vector<NMR::MODELMESHVERTEX> vertices(static_cast<std::size_t>(mesh.V.rows()));
    for (std::size_t i = 0; i < vertices.size(); ++i)
    {
        for (int d = 0; d < 3; ++d)
        {
            vertices[i].m_fPosition[d] =
                static_cast<float>(mesh.V(static_cast<Eigen::Index>(i), d));
        }
    }
    std::vector<NMR::MODELMESHTRIANGLE> triangles(static_cast<std::size_t>(mesh.F.rows()));
    for (std::size_t f = 0; f < triangles.size(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            triangles[f].m_nIndices[c] =
                static_cast<DWORD>(mesh.F(static_cast<Eigen::Index>(f), c));
        }
    }
    check(path,
          NMR::lib3mf_meshobject_setgeometry(object.get(), vertices.data(),
                                             static_cast<DWORD>(vertices.size()), triangles.data(),
                                             static_cast<DWORD>(triangles.size())),
          object.get(), "cannot set the mesh geometry");
    Handle item;
    check(path, NMR::lib3mf_model_addbuilditem(model.get(), object.get(), nullptr, item.out()),
          model.get(), "cannot add a build item");
    return model_bytes(path, model.get());
}

}  // namespace

}  // namespace meshmark::detail
