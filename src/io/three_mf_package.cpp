// SPDX-License-Identifier: MIT
// The 3MF package: the zip archive (zip_archive.cpp), the root model part named by the 3D
// model relationship in _rels/.rels, and the model parts, each inflated (within size bounds
// against zip bombs) and parsed in place on first use, with their objects by id.
#include <utility>

#include "io/detail/three_mf.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

constexpr std::string_view kModelRelationship =
    "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel";
// Where the 3MF specification puts the root model part; used when _rels/.rels names none.
constexpr std::string_view kDefaultModelPart = "3D/3dmodel.model";

// Zip entries are inflated into memory only up to these declared sizes (zip bombs): one model
// part (~6 million vertices with their triangles as slicers write them), all model parts of a
// package together, and the package relationships.
constexpr std::uint64_t kMaxModelPartBytes = 1ULL << 30U;
constexpr std::uint64_t kMaxModelBytes = 2ULL << 30U;
constexpr std::uint64_t kMaxRelationshipBytes = 16ULL << 20U;

std::unique_ptr<ModelPart> parse_model_part(const fs::path& path, std::string name,
                                            std::string text)
{
    auto part = std::make_unique<ModelPart>();
    part->name = std::move(name);
    part->text = std::move(text);
    part->buffer = part->text;
    const auto result = part->document.load_buffer_inplace(
        part->buffer.data(), part->buffer.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!result)
    {
        fail_io(path, "the model part " + part->name + " is not well-formed XML: " +
                          result.description() + " at byte " + std::to_string(result.offset));
    }
    part->model = part->document.document_element();
    if (!is_element(part->model, kCoreNamespace, "model"))
    {
        fail_io(path, "the model part " + part->name + " has no 3MF <model> root element");
    }
    ChildFilter is_resources(part->model, kCoreNamespace, "resources");
    for (const auto resources : part->model.children())
    {
        if (!is_resources(resources))
        {
            continue;
        }
        ChildFilter is_object(resources, kCoreNamespace, "object");
        for (const auto object : resources.children())
        {
            if (!is_object(object))
            {
                continue;
            }
            std::uint32_t id = 0;
            if (!parse_id(object.attribute("id").value(), id))
            {
                fail_io(path, "an object in " + part->name + " has a bad id " +
                                  quoted(object.attribute("id").value()));
            }
            if (!part->objects.emplace(id, object).second)
            {
                fail_io(path, describe(*part, id) + " is defined twice");
            }
            part->object_order.push_back(id);
        }
    }
    return part;
}

}  // namespace

std::string part_entry_name(std::string_view target, std::string_view source_name)
{
    if (target.starts_with('/'))
    {
        return std::string(target.substr(1));
    }
    const auto slash = source_name.rfind('/');
    std::string name(slash == std::string_view::npos ? std::string_view()
                                                     : source_name.substr(0, slash + 1));
    name += target;
    return name;
}

std::string describe(const ModelPart& part, std::uint32_t id)
{
    return "object " + std::to_string(id) + " in " + part.name;
}

ModelPart& Package::root()
{
    std::string name;
    if (const auto rels = zip_.find("_rels/.rels"))
    {
        const std::string text = zip_.read(*rels, kMaxRelationshipBytes);
        pugi::xml_document document;
        const auto result = document.load_buffer(text.data(), text.size(), pugi::parse_default,
                                                 pugi::encoding_utf8);
        if (!result)
        {
            fail_io(path_, std::string("_rels/.rels is not well-formed XML: ") +
                               result.description() + " at byte " + std::to_string(result.offset));
        }
        for (const auto relationship : document.document_element().children())
        {
            if (local_name(relationship.name()) == "Relationship" &&
                trimmed(relationship.attribute("Type").value()) == kModelRelationship)
            {
                name = part_entry_name(trimmed(relationship.attribute("Target").value()), "");
                break;
            }
        }
    }
    if (name.empty())
    {
        if (!zip_.find(std::string(kDefaultModelPart)))
        {
            fail_io(path_, "not a valid 3MF package: _rels/.rels names no 3D model part");
        }
        name = kDefaultModelPart;
    }
    return part(name, "_rels/.rels");
}

ModelPart& Package::part(const std::string& name, const std::string& referrer)
{
    const auto index = zip_.find(name);
    if (!index)
    {
        fail_io(path_,
                referrer + " refers to the model part /" + name + ", which is not in the package");
    }
    const std::string entry = zip_.name(*index);
    for (const auto& part : parts_)
    {
        if (part->name == entry)
        {
            return *part;
        }
    }
    const std::uint64_t size = zip_.size(*index);
    if (size <= kMaxModelPartBytes && size > kMaxModelBytes - model_bytes_)
    {
        fail_io(path_, "the model parts declare more than " + std::to_string(kMaxModelBytes) +
                           " uncompressed bytes together");
    }
    model_bytes_ += size;
    parts_.push_back(parse_model_part(path_, entry, zip_.read(*index, kMaxModelPartBytes)));
    return *parts_.back();
}

}  // namespace meshmark::detail
