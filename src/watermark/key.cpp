// SPDX-License-Identifier: MIT
#include "meshmark/watermark/key.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <type_traits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/named_choice.h"
#include "meshmark/core/rng.h"

namespace meshmark {
namespace {

using Json = nlohmann::json;

constexpr const char* kKeyFormat = "meshmark-key";
// A key is a few hundred bytes, a family key about 50 more per recipient; anything far larger
// is not a key (and is not parsed).
constexpr std::uintmax_t kMaxKeyBytes = 16U << 20U;
constexpr std::size_t kMaxRecipientName = 100;
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

std::uint64_t parse_hex64(const std::string& text, const std::string& field, const std::string& source)
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
            throw IoError(source + ": key field '" + field + "' has a character that is not a "
                          "lower-case hex digit.");
        }
        value = (value << 4U) | static_cast<std::uint64_t>(digit);
    }
    return value;
}

// n bits, each the lowest bit of one draw (the documented payload/mask mapping).
std::vector<std::uint8_t> low_bits(Rng& rng, int n)
{
    std::vector<std::uint8_t> bits(static_cast<std::size_t>(n));
    for (auto& b : bits)
    {
        b = static_cast<std::uint8_t>(rng.bits() & 1U);
    }
    return bits;
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
    j["embedding"] = {{"rule", to_string(key.options.rule)},
                      {"basis_size", key.options.basis_size},
                      {"coefficients", key.options.coefficients},
                      {"repetitions", key.options.repetitions},
                      {"first_mode", key.options.first_mode},
                      {"strength", key.options.resolved_strength()},
                      {"sigma_factor", key.options.sigma_factor},
                      {"centers", to_string(key.options.centers)},
                      {"basis", to_string(key.options.basis)},
                      {"gram_rows", key.options.gram_rows}};
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
const Json& member(const Json& object, const char* name, const std::string& where, const std::string& source)
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
            const bool fits = it->is_number_unsigned()
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

const char* to_string(EmbeddingRule rule) noexcept
{
    return rule == EmbeddingRule::Paper ? "paper" : "additive";
}

EmbeddingRule parse_embedding_rule(const std::string& name)
{
    return parse_named_choice<EmbeddingRule>(name, "embedding rule",
                                             {{"additive", EmbeddingRule::Additive}, {"paper", EmbeddingRule::Paper}});
}

const char* to_string(BasisType basis) noexcept
{
    return basis == BasisType::Laplacian ? "laplacian" : "rbf";
}

const char* to_string(CenterSelection centers) noexcept
{
    return centers == CenterSelection::Decimate ? "decimate" : "random";
}

BasisType parse_basis_type(const std::string& name)
{
    return parse_named_choice<BasisType>(name, "basis", {{"rbf", BasisType::Rbf}, {"laplacian", BasisType::Laplacian}});
}

CenterSelection parse_center_selection(const std::string& name)
{
    return parse_named_choice<CenterSelection>(name, "center selection",
                                               {{"random", CenterSelection::Random}, {"decimate", CenterSelection::Decimate}});
}

const char* to_string(StrengthMeasure measure) noexcept
{
    return measure == StrengthMeasure::Vertex ? "vertex" : "surface";
}

StrengthMeasure parse_strength_measure(const std::string& name)
{
    return parse_named_choice<StrengthMeasure>(name, "strength measure",
                                               {{"surface", StrengthMeasure::Surface}, {"vertex", StrengthMeasure::Vertex}});
}

double default_strength(EmbeddingRule rule, StrengthMeasure measure) noexcept
{
    // Additive, surface: an RMS surface distance of 0.059% of the diagonal. The sampled MRMS
    // reads within 0.3% of the first-order measure, so this keeps it below 0.06%, the largest
    // the robustness targets allow (docs/algorithms/embedding.md, "Strength"). Vertex: 0.1%
    // of the diagonal, which gives an MRMS of 0.051-0.079% depending on the sampling.
    // Paper: rho = 0.01 [Wu & Kobbelt 2005, Sec. 6].
    if (rule == EmbeddingRule::Paper)
    {
        return 0.01;
    }
    return measure == StrengthMeasure::Surface ? 5.9e-4 : 1e-3;
}

const Recipient* RecipientCodes::find(const std::string& name) const noexcept
{
    for (const Recipient& r : recipients)
    {
        if (r.name == name)
        {
            return &r;
        }
    }
    return nullptr;
}

void RecipientCodes::validate(const EmbedOptions& options) const
{
    const int used = options.first_mode + modulated_modes(options);
    if (modes < 1 || used + modes > options.basis_size)
    {
        throw InvalidOption("recipient modes (--recipient-modes) must be in 1.." +
                            std::to_string(std::max(1, options.basis_size - used)) +
                            " (the basis size minus the owner's first mode and modes), got " +
                            std::to_string(modes) + ".");
    }
    if (!std::isfinite(energy_share) || energy_share <= 0.0 || energy_share >= 1.0)
    {
        throw InvalidOption("the recipients' energy share (--recipient-share) must be in (0, 1), got " +
                            std::to_string(energy_share) + ".");
    }
}

void check_recipient_name(const std::string& name)
{
    if (name.empty() || name.size() > kMaxRecipientName)
    {
        throw InvalidOption("a recipient name must have 1 to " + std::to_string(kMaxRecipientName) +
                            " characters, got " + std::to_string(name.size()) + ".");
    }
    if (name.front() == '.')
    {
        throw InvalidOption("recipient name '" + name + "' starts with '.'; names become part of file names.");
    }
    for (const char c : name)
    {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20U || u == 0x7FU || c == '/' || c == '\\' || c == '"')
        {
            throw InvalidOption("recipient name '" + name +
                                "' has a control character, a quote or a path separator; names become part "
                                "of file names.");
        }
    }
}

std::vector<std::uint8_t> recipient_code(std::uint64_t seed, std::uint32_t index, int n)
{
    Rng rng(derive_seed(derive_seed(seed, "recipient-code"), std::to_string(index)));
    return low_bits(rng, n);
}

void EmbedOptions::validate() const
{
    if (basis_size < 4 || basis_size > 5000)
    {
        throw InvalidOption("basis size (--basis-size) must be in 4..5000, got " +
                            std::to_string(basis_size) + ".");
    }
    if (coefficients < 1 || coefficients > basis_size)
    {
        throw InvalidOption("modulated coefficients (--coefficients) must be in 1.." +
                            std::to_string(basis_size) + " (the basis size), got " +
                            std::to_string(coefficients) + ".");
    }
    if (repetitions != kAutoRepetitions &&
        (repetitions < 1 || static_cast<long long>(repetitions) * coefficients > basis_size))
    {
        throw InvalidOption("repetitions (--repetitions) must be auto or at least 1 and at most the basis size "
                            "divided by the coefficients (" + std::to_string(basis_size) + " / " +
                            std::to_string(coefficients) + "), got " + std::to_string(repetitions) + ".");
    }
    // The automatic choice needs room for one repetition at least.
    const int r = repetitions == kAutoRepetitions ? 1 : repetitions;
    if (first_mode < 0 || static_cast<long long>(r) * coefficients + first_mode > basis_size)
    {
        throw InvalidOption("the first modulated mode (--first-mode) must be in 0.." +
                            std::to_string(std::max(0, basis_size - r * coefficients)) +
                            " (basis size minus coefficients times repetitions), got " +
                            std::to_string(first_mode) + ".");
    }
    const double s = resolved_strength();
    if (!std::isfinite(s) || s < 0.0 || s > 0.5)
    {
        throw InvalidOption("strength (--strength) must be in 0..0.5, got " + std::to_string(s) + ".");
    }
    if (vertex_strength >= 0.0 && !(std::isfinite(vertex_strength) && vertex_strength <= 1.0))
    {
        throw InvalidOption("the calibrated vertex strength must be in 0..1, got " +
                            std::to_string(vertex_strength) + ".");
    }
    if (!std::isfinite(sigma_factor) || sigma_factor <= 0.0 || sigma_factor > 100.0)
    {
        throw InvalidOption("sigma factor must be in (0, 100], got " + std::to_string(sigma_factor) + ".");
    }
    const std::int64_t min_gram_rows = std::int64_t{kMinGramRowsPerCenter} * basis_size;
    if (gram_rows != 0 && gram_rows < min_gram_rows)
    {
        throw InvalidOption("Gram rows (--gram-rows) must be 0 (every row) or at least " +
                            std::to_string(kMinGramRowsPerCenter) + " times the basis size (" +
                            std::to_string(min_gram_rows) + "), got " + std::to_string(gram_rows) + ".");
    }
}

double EmbedOptions::resolved_strength() const noexcept
{
    return strength < 0.0 ? default_strength(rule, measure) : strength;
}

bool EmbedOptions::needs_calibration() const noexcept
{
    return rule == EmbeddingRule::Additive && measure == StrengthMeasure::Surface && vertex_strength < 0.0;
}

double EmbedOptions::modulation_strength() const noexcept
{
    if (rule != EmbeddingRule::Additive || measure == StrengthMeasure::Vertex)
    {
        return resolved_strength();
    }
    return vertex_strength >= 0.0 ? vertex_strength : std::sqrt(3.0) * resolved_strength();
}

MeshFingerprint fingerprint(const TriangleMesh& mesh)
{
    MeshFingerprint fp;
    fp.vertex_count = mesh.V.rows();
    fp.face_count = mesh.F.rows();
    fp.position_hash = hash_bytes(mesh.V.data(), static_cast<std::size_t>(mesh.V.size()) * sizeof(double));
    return fp;
}

std::vector<std::uint8_t> payload_from_message(const std::string& message, int n)
{
    Rng rng(hash_bytes(message.data(), message.size(), 0x6D7367U));
    return low_bits(rng, n);
}

std::vector<std::uint8_t> payload_from_hex(const std::string& hex, int n)
{
    const auto digits = static_cast<std::size_t>((n + 3) / 4);
    if (hex.size() != digits)
    {
        throw InvalidOption("--bits needs exactly " + std::to_string(digits) + " hex digits for " +
                            std::to_string(n) + " payload bits, got " + std::to_string(hex.size()) + ".");
    }
    std::vector<std::uint8_t> bits;
    bits.reserve(digits * 4);
    for (const char c : hex)
    {
        const char lower = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        int value = -1;
        if (lower >= '0' && lower <= '9')
        {
            value = lower - '0';
        }
        else if (lower >= 'a' && lower <= 'f')
        {
            value = lower - 'a' + 10;
        }
        if (value < 0)
        {
            throw InvalidOption("--bits must be hex digits, got '" + hex + "'.");
        }
        for (int b = 3; b >= 0; --b)
        {
            bits.push_back(static_cast<std::uint8_t>((static_cast<unsigned>(value) >> static_cast<unsigned>(b)) & 1U));
        }
    }
    for (std::size_t i = static_cast<std::size_t>(n); i < bits.size(); ++i)
    {
        if (bits[i] != 0)
        {
            throw InvalidOption("--bits encodes more than " + std::to_string(n) +
                                " bits: the unused low bits of the last digit must be 0.");
        }
    }
    bits.resize(static_cast<std::size_t>(n));
    return bits;
}

std::vector<std::uint8_t> random_payload(std::uint64_t seed, int n)
{
    Rng rng(derive_seed(seed, "payload"));
    return low_bits(rng, n);
}

Key make_key(const EmbedOptions& options, std::uint64_t seed, const std::optional<std::string>& message,
             const std::optional<std::string>& bits_hex)
{
    Key key;
    key.seed = seed;
    key.options = options;
    key.options.strength = options.resolved_strength();
    if (key.options.rule != EmbeddingRule::Additive)
    {
        key.options.measure = StrengthMeasure::Vertex;  // rho is not a distance
        key.options.vertex_strength = -1.0;
    }
    const int bits = payload_bit_count(key.options);
    if (message)
    {
        key.payload = payload_from_message(*message, bits);
        key.message = message;
    }
    else if (bits_hex)
    {
        key.payload = payload_from_hex(*bits_hex, bits);
    }
    else
    {
        key.payload = random_payload(key.seed, bits);
    }
    return key;
}

std::vector<std::uint8_t> payload_mask(std::uint64_t seed, int n)
{
    Rng rng(derive_seed(seed, "payload-mask"));
    return low_bits(rng, n);
}

std::string to_bit_string(const std::vector<std::uint8_t>& bits)
{
    std::string s;
    s.reserve(bits.size());
    for (const auto b : bits)
    {
        s.push_back(b != 0 ? '1' : '0');
    }
    return s;
}

std::string to_hex(const std::vector<std::uint8_t>& bits)
{
    static const char* digits = "0123456789abcdef";
    std::string s;
    for (std::size_t i = 0; i < bits.size(); i += 4)
    {
        unsigned value = 0;
        for (std::size_t b = 0; b < 4; ++b)
        {
            value = (value << 1U) | (i + b < bits.size() && bits[i + b] != 0 ? 1U : 0U);
        }
        s.push_back(digits[value]);
    }
    return s;
}

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
        throw IoError(source + ": the key file is not a valid meshmark key (a JSON value is out "
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
        throw IoError(source + ": the key file's checksum does not match its content; it was "
                      "modified or damaged.");
    }

    Key key;
    key.seed = parse_hex64(field<std::string>(j, "seed", "", source), "seed", source);
    const Json& embedding = member(j, "embedding", "", source);
    key.options.rule = parse_embedding_rule(field<std::string>(embedding, "rule", "embedding.", source));
    key.options.basis_size = field<int>(embedding, "basis_size", "embedding.", source);
    key.options.coefficients = field<int>(embedding, "coefficients", "embedding.", source);
    // Absent from keys written before spreading existed: those embedded every bit once.
    key.options.repetitions =
        embedding.contains("repetitions") ? field<int>(embedding, "repetitions", "embedding.", source) : 1;
    if (key.options.repetitions == EmbedOptions::kAutoRepetitions)
    {
        // The embedding records the number it chose; a key without one cannot be trusted to
        // rebuild the same mark if the rule ever changes.
        throw IoError(source + ": the key does not record its repetitions (embedding.repetitions is 0).");
    }
    key.options.first_mode =
        embedding.contains("first_mode") ? field<int>(embedding, "first_mode", "embedding.", source) : 0;
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
            key.options.centers =
                parse_center_selection(field<std::string>(embedding, "centers", "embedding.", source));
        }
        if (embedding.contains("basis"))
        {
            key.options.basis = parse_basis_type(field<std::string>(embedding, "basis", "embedding.", source));
        }
        if (embedding.contains("strength_measure"))
        {
            key.options.measure =
                parse_strength_measure(field<std::string>(embedding, "strength_measure", "embedding.", source));
        }
    }
    catch (const InvalidOption& e)
    {
        throw IoError(source + ": invalid key field: " + e.what());
    }
    if (key.options.rule == EmbeddingRule::Additive && key.options.measure == StrengthMeasure::Surface)
    {
        key.options.vertex_strength = field<double>(embedding, "vertex_strength", "embedding.", source);
        if (!(key.options.vertex_strength >= 0.0))
        {
            throw IoError(source + ": the key's surface strength was never calibrated on the original "
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
                throw IoError(source + ": recipient '" + r.name + "' (index " + std::to_string(r.index) +
                              ") appears twice in the key.");
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
