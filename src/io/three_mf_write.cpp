// SPDX-License-Identifier: MIT
// The 3MF writers. The preserving writer rewrites only the x/y/z attribute values of moved
// vertices in the model parts' text (each new value in the precision of the token it
// replaces) and replaces those parts in the zip; every other entry, and every other byte of
// the model parts, stays as it was. The generic writer makes a one-object package.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <Eigen/LU>

#include "io/detail/formats.h"
#include "io/detail/numbers.h"
#include "io/detail/three_mf.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// A replacement of text[offset, end) by text.
struct Edit
{
    std::size_t offset = 0;
    std::size_t end = 0;
    std::string text;
};

// [offset, end) of the raw value of \p attribute in part.text: where pugixml's in-place value
// starts, up to the closing quote (an attribute value never holds its own quote character).
std::pair<std::size_t, std::size_t> value_span(const fs::path& path, const ModelPart& part,
                                               pugi::xml_attribute attribute)
{
    const char* value = attribute.value();
    const char* begin = part.buffer.data();
    if (value <= begin || value > begin + part.buffer.size())
    {
        fail_io(path, "cannot locate a coordinate in " + part.name);  // not in the buffer
    }
    const auto offset = static_cast<std::size_t>(value - begin);
    const char quote = part.text[offset - 1];
    const auto end =
        (quote == '"' || quote == '\'') ? part.text.find(quote, offset) : std::string::npos;
    if (end == std::string::npos)
    {
        fail_io(path, "cannot locate a coordinate in " + part.name);
    }
    return {offset, end};
}

// The text of \p part with the moved vertices of \p objects rewritten ("" when none moved).
std::string moved_part_text(const fs::path& path, const ModelPart& part,
                            const std::vector<const ThreeMfObject*>& objects,
                            const Positions& original, const Positions& positions)
{
    std::vector<Edit> edits;
    for (const auto* object : objects)
    {
        const std::string object_name = describe(part, object->resource_id);
        const auto found = part.objects.find(object->resource_id);
        const auto mesh =
            found == part.objects.end() ? pugi::xml_node() : first_child(found->second, "mesh");
        if (!mesh)
        {
            fail_io(path, "the source package no longer has " + object_name);
        }
        const Eigen::Matrix4d to_local = object->to_world.inverse();
        for_each_vertex(
            mesh,
            [&](std::size_t i, pugi::xml_node vertex)
            {
                if (i >= object->welded.size())
                {
                    fail_io(path, "the source package has changed: " + object_name +
                                      " has more vertices");
                }
                const auto w = object->welded[i];
                if (std::memcmp(original.row(w).data(), positions.row(w).data(),
                                3 * sizeof(double)) == 0)
                {
                    return;
                }
                const Eigen::Vector4d local =
                    to_local *
                    Eigen::Vector4d(positions(w, 0), positions(w, 1), positions(w, 2), 1.0);
                for (int d = 0; d < 3; ++d)
                {
                    const double before = parse_coordinate(path, vertex, d, i, object_name);
                    if (std::memcmp(&before, &local[d], sizeof(double)) == 0)
                    {
                        continue;  // this coordinate keeps its text
                    }
                    const auto [offset, end] = value_span(
                        path, part, vertex.attribute(kAxes[static_cast<std::size_t>(d)]));
                    const std::string_view token(part.text.data() + offset, end - offset);
                    // Float digits when the original token had float precision, else double
                    // (see append_like_token); either must be a finite number.
                    const bool is_float = significant_digits(token) <= 9;
                    if (!std::isfinite(local[d]) ||
                        (is_float && !std::isfinite(static_cast<float>(local[d]))))
                    {
                        fail_io(path, "vertex " + std::to_string(i) + " of " + object_name +
                                          " does not fit a " + (is_float ? "float32" : "float64") +
                                          " coordinate");
                    }
                    Edit edit{offset, end, {}};
                    append_like_token(edit.text, token, local[d]);
                    edits.push_back(std::move(edit));
                }
            });
    }
    if (edits.empty())
    {
        return {};
    }
    std::sort(edits.begin(), edits.end(),
              [](const Edit& a, const Edit& b) { return a.offset < b.offset; });
    std::string text;
    text.reserve(part.text.size() + edits.size() * 4);
    std::size_t at = 0;
    for (const auto& edit : edits)
    {
        text.append(part.text, at, edit.offset - at);
        text += edit.text;
        at = edit.end;
    }
    text.append(part.text, at, std::string::npos);
    return text;
}

std::string moved_package(const fs::path& path, const FileLayout& layout, const Positions& original,
                          const Positions& positions)
{
    const auto& objects = std::get<ThreeMfLayout>(layout.positions);
    // The objects with a moved vertex, by model part (in the order parts were read).
    std::vector<std::pair<std::string, std::vector<const ThreeMfObject*>>> moved;
    for (const auto& object : objects.objects)
    {
        const bool is_moved =
            std::any_of(object.welded.begin(), object.welded.end(),
                        [&](std::int32_t w) {
                            return std::memcmp(original.row(w).data(), positions.row(w).data(),
                                               3 * sizeof(double)) != 0;
                        });
        if (!is_moved)
        {
            continue;
        }
        auto at = std::find_if(moved.begin(), moved.end(),
                               [&](const auto& entry) { return entry.first == object.part; });
        if (at == moved.end())
        {
            moved.emplace_back(object.part, std::vector<const ThreeMfObject*>{});
            at = moved.end() - 1;
        }
        at->second.push_back(&object);
    }
    if (moved.empty())
    {
        return layout.bytes;  // unchanged positions: the package as it was, byte for byte
    }
    std::vector<std::pair<std::string, std::string>> replaced;
    {
        Package package(path, layout.bytes);
        for (const auto& [name, part_objects] : moved)
        {
            const ModelPart& part = package.part(name, "the source layout");
            std::string text = moved_part_text(path, part, part_objects, original, positions);
            if (!text.empty())
            {
                replaced.emplace_back(part.name, std::move(text));
            }
        }
    }
    if (replaced.empty())
    {
        return layout.bytes;
    }
    return replace_zip_entries(path, layout.bytes, replaced);
}

// ---------------------------------------------------------------------------------------
// The generic writer: hand-written XML (one object, one build item) in a new zip.

std::string new_package(const fs::path& path, const TriangleMesh& mesh)
{
    std::string model =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<model unit=\"millimeter\" xml:lang=\"en-US\" "
        "xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\">\n"
        " <resources>\n"
        "  <object id=\"1\" type=\"model\">\n"
        "   <mesh>\n"
        "    <vertices>\n";
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        model += "     <vertex";
        for (int d = 0; d < 3; ++d)
        {
            const auto value = static_cast<float>(mesh.V(i, d));
            if (!std::isfinite(value))
            {
                fail_io(path, "vertex " + std::to_string(i) + " does not fit a float32 coordinate");
            }
            model += ' ';
            model += kAxes[static_cast<std::size_t>(d)];
            model += "=\"";
            append_shortest(model, value);
            model += '"';
        }
        model += "/>\n";
    }
    model += "    </vertices>\n    <triangles>\n";
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        model += "     <triangle v1=\"" + std::to_string(mesh.F(f, 0)) + "\" v2=\"" +
                 std::to_string(mesh.F(f, 1)) + "\" v3=\"" + std::to_string(mesh.F(f, 2)) +
                 "\"/>\n";
    }
    model +=
        "    </triangles>\n"
        "   </mesh>\n"
        "  </object>\n"
        " </resources>\n"
        " <build>\n"
        "  <item objectid=\"1\"/>\n"
        " </build>\n"
        "</model>\n";
    const std::string content_types =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\n"
        " <Default Extension=\"rels\" "
        "ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\n"
        " <Default Extension=\"model\" "
        "ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>\n"
        "</Types>\n";
    const std::string relationships =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n"
        " <Relationship Target=\"/3D/3dmodel.model\" Id=\"rel0\" "
        "Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/>\n"
        "</Relationships>\n";
    return new_zip(path, {{"[Content_Types].xml", content_types},
                          {"_rels/.rels", relationships},
                          {"3D/3dmodel.model", model}});
}

}  // namespace

std::string preserved_3mf_bytes(const fs::path& path, const FileLayout& layout,
                                const Positions& original, const Positions& positions)
{
    return guarded(path, [&] { return moved_package(path, layout, original, positions); });
}

std::string three_mf_bytes(const fs::path& path, const TriangleMesh& mesh)
{
    return guarded(path, [&] { return new_package(path, mesh); });
}

}  // namespace meshmark::detail
