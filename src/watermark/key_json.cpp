// SPDX-License-Identifier: MIT
// Key files: the versioned JSON a key is stored as (with a checksum over its content), and its
// hardened reader (size, nesting, every field's type and range checked before use).
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/watermark/key.h"

namespace meshmark
{
namespace
{

using Json = nlohmann::json;

constexpr const char* kKeyFormat = "meshmark-key";
// A key is a few hundred bytes, a family key about 50 more per recipient; anything far larger
// is not a key (and is not parsed).
constexpr std::uintmax_t kMaxKeyBytes = 16U << 20U;
constexpr int kMaxKeyDepth = 16;  // A key nests 3 levels deep.

std::string hex64(std::uint64_t value)
{
    static const char* digits = "0123456789abcdef";
    std::string s(16, '0');
    for (int i = 15; i >= 0; --i)
    {
        s[static_cast<std::size_t>(i)] = digits[value & 0xFU];
        value >>= 4U;
    }
    return s;
}

std::uint64_t parse_hex64(const std::string& text, const std::string& field,
                          const std::string& source)
{
    if (text.empty() || text.size() > 16)
    {
        throw IoError(source + ": key field '" + field + "' must be 1 to 16 hex digits.");
    }
    std::uint64_t value = 0;
    for (const char c : text)
    {
        const int digit = std::isdigit(static_cast<unsigned char>(c)) ? c - '0'
                          : (c >= 'a' && c <= 'f')                    ? c - 'a' + 10
                                                                      : -1;
        if (digit < 0)
        {
            throw IoError(source + ": key field '" + field +
                          "' has a character that is not a "
                          "lower-case hex digit.");
        }
        value = (value << 4U) | static_cast<std::uint64_t>(digit);
    }
    return value;
}

std::uint64_t checksum_of(const Json& content)
{
    const std::string text = content.dump();
    return hash_bytes(text.data(), text.size(), 0x6B6579U);
}

Json content_json(const Key& key)
{
    Json j;
    j["format"] = kKeyFormat;
    j["version"] = Key::kVersion;
    j["seed"] = hex64(key.seed);
    j["embedding"] = {
        {"rule", to_string(key.options.rule)},      {"basis_size", key.options.basis_size},
        {"coefficients", key.options.coefficients}, {"repetitions", key.options.repetitions},
        {"first_mode", key.options.first_mode},     {"strength", key.options.resolved_strength()},
        {"sigma_factor", key.options.sigma_factor}, {"centers", to_string(key.options.centers)},
        {"basis", to_string(key.options.basis)},    {"gram_rows", key.options.gram_rows}};
    if (key.options.rule == EmbeddingRule::Additive)
    {
        // The paper's rho is not a distance: its keys have no measure.
        j["embedding"]["strength_measure"] = to_string(key.options.measure);
        if (key.options.measure == StrengthMeasure::Surface)
        {
            j["embedding"]["vertex_strength"] = key.options.vertex_strength;
        }
    }
    j["payload"] = {{"bits", to_bit_string(key.payload)}};
    if (key.message)
    {
        j["payload"]["message"] = *key.message;
    }
    j["original"] = {{"vertex_count", key.original.vertex_count},
                     {"face_count", key.original.face_count},
                     {"position_hash", hex64(key.original.position_hash)}};
    if (key.recipients)
    {
        Json issued = Json::array();
        for (const Recipient& r : key.recipients->recipients)
        {
            issued.push_back({{"name", r.name}, {"index", r.index}});
        }
        j["recipients"] = {{"modes", key.recipients->modes},
                           {"energy_share", key.recipients->energy_share},
                           {"issued", std::move(issued)}};
    }
    return j;
}

// The deepest nesting of arrays and objects in JSON \p text (brackets inside strings do not
// count); malformed text is left to the parser.
int nesting_depth(const std::string& text)
{
    int depth = 0;
    int deepest = 0;
    bool is_in_string = false;
    for (std::size_t i = 0; i < text.size(); ++i)
    {
        const char c = text[i];
        if (is_in_string)
        {
            if (c == '\\')
            {
                ++i;  // the escaped character
            }
            else if (c == '"')
            {
                is_in_string = false;
            }
        }
        else if (c == '"')
        {
            is_in_string = true;
        }
        else if (c == '[' || c == '{')
        {
            deepest = std::max(deepest, ++depth);
        }
        else if (c == ']' || c == '}')
        {
            --depth;
        }
    }
    return deepest;
}

// The member \p name of \p object, by reference (a family key's list of recipients is large
// enough that copying it showed in a detection's time).
const Json& member(const Json& object, const char* name, const std::string& where,
                   const std::string& source)
{
    const auto it = object.find(name);
    if (it == object.end())
    {
        throw IoError(source + ": key is missing the field '" + where + name + "'.");
    }
    return *it;
}

template <class T>
T field(const Json& object, const char* name, const std::string& where, const std::string& source)
{
    const auto it = object.find(name);
    if (it == object.end())
    {
        throw IoError(source + ": key is missing the field '" + where + name + "'.");
    }
    try
    {
        if constexpr (std::is_integral_v<T>)
        {
            // get<int> from a float or an out-of-range integer would convert silently (or, for
            // floats out of range, with undefined behaviour): accept only integers that fit.
            if (!it->is_number_integer())
            {
                throw IoError(source + ": key field '" + where + name + "' must be an integer.");
            }
            const bool fits =
                it->is_number_unsigned()
                    ? it->template get<std::uint64_t>() <=
                          static_cast<std::uint64_t>(std::numeric_limits<T>::max())
                    : it->template get<std::int64_t>() >= std::numeric_limits<T>::min() &&
                          it->template get<std::int64_t>() <= std::numeric_limits<T>::max();
            if (!fits)
            {
                throw IoError(source + ": key field '" + where + name + "' is out of range.");
            }
        }
        return it->template get<T>();
    }
    catch (const Json::exception&)
    {
        throw IoError(source + ": key field '" + where + name + "' has the wrong type.");
    }
}

}  // namespace

std::string to_json(const Key& key)
{
    Json j = content_json(key);
    j["checksum"] = hex64(checksum_of(j));
    return j.dump(2) + "\n";
}

Key parse_key(const std::string& text, const std::string& source)
{
    if (text.size() > kMaxKeyBytes)
    {
        throw IoError(source + ": the key text is " + std::to_string(text.size()) +
                      " bytes, far too large to be a meshmark key.");
    }
    Json j;
    try
    {
        // A key nests 3 levels deep; refuse deeper input before parsing so that hostile
        // nesting costs neither time nor memory. (A scan of the text, rather than nlohmann's
        // parser callback, which made parsing a key of 10,000 recipients 3x slower.)
        if (nesting_depth(text) > kMaxKeyDepth)
        {
            throw Json::other_error::create(0, "nesting too deep", nullptr);
        }
        j = Json::parse(text);
    }
    catch (const Json::parse_error& e)
    {
        throw IoError(source + ": the key file is not valid JSON (byte " + std::to_string(e.byte) +
                      "); is it truncated?");
    }
    catch (const Json::other_error&)
    {
        throw IoError(source + ": the key file nests JSON values more than " +
                      std::to_string(kMaxKeyDepth) + " levels deep; it is not a meshmark key.");
    }
    catch (const Json::exception&)
    {
        // E.g. out_of_range for a number that overflows a double ("1e1111").
        throw IoError(source +
                      ": the key file is not a valid meshmark key (a JSON value is out "
                      "of range).");
    }
    const auto format = j.is_object() ? j.find("format") : j.end();
    if (format == j.end() || !format->is_string() || format->get<std::string>() != kKeyFormat)
    {
        throw IoError(source + ": not a meshmark key file (missing \"format\": \"meshmark-key\").");
    }
    const int version = field<int>(j, "version", "", source);
    if (version != Key::kVersion)
    {
        throw IoError(source + ": key file version " + std::to_string(version) +
                      " is not supported (this meshmark reads version " +
                      std::to_string(Key::kVersion) + ").");
    }
    const std::string checksum = field<std::string>(j, "checksum", "", source);
    j.erase("checksum");  // the checksum covers the rest
    if (parse_hex64(checksum, "checksum", source) != checksum_of(j))
    {
        throw IoError(source +
                      ": the key file's checksum does not match its content; it was "
                      "modified or damaged.");
    }

    Key key;
    key.seed = parse_hex64(field<std::string>(j, "seed", "", source), "seed", source);
    const Json& embedding = member(j, "embedding", "", source);
    key.options.rule =
        parse_embedding_rule(field<std::string>(embedding, "rule", "embedding.", source));
    key.options.basis_size = field<int>(embedding, "basis_size", "embedding.", source);
    key.options.coefficients = field<int>(embedding, "coefficients", "embedding.", source);
    // Absent from keys written before spreading existed: those embedded every bit once.
    key.options.repetitions = embedding.contains("repetitions")
                                  ? field<int>(embedding, "repetitions", "embedding.", source)
                                  : 1;
    if (key.options.repetitions == EmbedOptions::kAutoRepetitions)
    {
        // The embedding records the number it chose; a key without one cannot be trusted to
        // rebuild the same mark if the rule ever changes.
        throw IoError(source +
                      ": the key does not record its repetitions (embedding.repetitions is 0).");
    }
    key.options.first_mode = embedding.contains("first_mode")
                                 ? field<int>(embedding, "first_mode", "embedding.", source)
                                 : 0;
    key.options.strength = field<double>(embedding, "strength", "embedding.", source);
    // Absent from keys written before the surface measure existed: those meant the vertex RMS.
    key.options.measure = StrengthMeasure::Vertex;
    key.options.sigma_factor = field<double>(embedding, "sigma_factor", "embedding.", source);
    // Absent from keys written before the sampled Gram matrix existed: those used every row.
    key.options.gram_rows = embedding.contains("gram_rows")
                                ? field<std::int64_t>(embedding, "gram_rows", "embedding.", source)
                                : 0;
    // Absent from keys written before the Laplacian basis and decimated centers existed.
    try
    {
        if (embedding.contains("centers"))
        {
            key.options.centers = parse_center_selection(
                field<std::string>(embedding, "centers", "embedding.", source));
        }
        if (embedding.contains("basis"))
        {
            key.options.basis =
                parse_basis_type(field<std::string>(embedding, "basis", "embedding.", source));
        }
        if (embedding.contains("strength_measure"))
        {
            key.options.measure = parse_strength_measure(
                field<std::string>(embedding, "strength_measure", "embedding.", source));
        }
    }
    catch (const InvalidOption& e)
    {
        throw IoError(source + ": invalid key field: " + e.what());
    }
    if (key.options.rule == EmbeddingRule::Additive &&
        key.options.measure == StrengthMeasure::Surface)
    {
        key.options.vertex_strength =
            field<double>(embedding, "vertex_strength", "embedding.", source);
        if (!(key.options.vertex_strength >= 0.0))
        {
            throw IoError(source +
                          ": the key's surface strength was never calibrated on the original "
                          "(embedding.vertex_strength is negative).");
        }
    }
    try
    {
        key.options.validate();
    }
    catch (const InvalidOption& e)
    {
        throw IoError(source + ": invalid key parameters: " + e.what());
    }
    const Json& payload = member(j, "payload", "", source);
    const std::string bits = field<std::string>(payload, "bits", "payload.", source);
    if (bits.size() != static_cast<std::size_t>(payload_bit_count(key.options)) ||
        bits.find_first_not_of("01") != std::string::npos)
    {
        throw IoError(source + ": key field 'payload.bits' must hold " +
                      std::to_string(payload_bit_count(key.options)) + " characters 0 or 1.");
    }
    for (const char c : bits)
    {
        key.payload.push_back(c == '1' ? 1 : 0);
    }
    if (payload.contains("message"))
    {
        key.message = field<std::string>(payload, "message", "payload.", source);
    }
    const Json& original = member(j, "original", "", source);
    key.original.vertex_count = field<std::int64_t>(original, "vertex_count", "original.", source);
    key.original.face_count = field<std::int64_t>(original, "face_count", "original.", source);
    key.original.position_hash =
        parse_hex64(field<std::string>(original, "position_hash", "original.", source),
                    "original.position_hash", source);
    if (j.contains("recipients"))
    {
        const Json& family = member(j, "recipients", "", source);
        RecipientCodes codes;
        codes.modes = field<int>(family, "modes", "recipients.", source);
        codes.energy_share = field<double>(family, "energy_share", "recipients.", source);
        const Json& issued = member(family, "issued", "recipients.", source);
        if (!issued.is_array())
        {
            throw IoError(source + ": key field 'recipients.issued' must be a list.");
        }
        std::set<std::uint32_t> indices;
        std::set<std::string> names;
        for (const Json& entry : issued)
        {
            Recipient r;
            r.name = field<std::string>(entry, "name", "recipients.issued[].", source);
            r.index = field<std::uint32_t>(entry, "index", "recipients.issued[].", source);
            try
            {
                check_recipient_name(r.name);
            }
            catch (const InvalidOption& e)
            {
                throw IoError(source + ": invalid key field: " + e.what());
            }
            if (!names.insert(r.name).second || !indices.insert(r.index).second)
            {
                throw IoError(source + ": recipient '" + r.name + "' (index " +
                              std::to_string(r.index) + ") appears twice in the key.");
            }
            codes.recipients.push_back(std::move(r));
        }
        try
        {
            codes.validate(key.options);
        }
        catch (const InvalidOption& e)
        {
            throw IoError(source + ": invalid key parameters: " + e.what());
        }
        key.recipients = std::move(codes);
    }
    return key;
}

void write_key(const std::filesystem::path& path, const Key& key)
{
    const std::string text = to_json(key);
    write_file_atomically(path, [&](std::ostream& out) { out << text; }, {.permissions = 0600});
}

Key read_key(const std::filesystem::path& path)
{
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (ec)
    {
        throw IoError(path.string() + ": cannot read the key file (" + ec.message() + ").");
    }
    if (size > kMaxKeyBytes)
    {
        throw IoError(path.string() + ": the file is " + std::to_string(size) +
                      " bytes, far too large to be a meshmark key.");
    }
    std::ifstream in(path, std::ios::binary);
    if (!in)
    {
        throw IoError(path.string() + ": cannot open the key file.");
    }
    std::stringstream buffer;
    buffer << in.rdbuf();
    return parse_key(buffer.str(), path.string());
}

}  // namespace meshmark
