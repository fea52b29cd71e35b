// SPDX-License-Identifier: MIT
// Keys: options and their defaults, recipients' names and codes, payloads, the original's
// fingerprint and make_key (the key file's JSON: key_json.cpp).
#include "meshmark/watermark/key.h"

#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/core/named_choice.h"
#include "meshmark/core/rng.h"

namespace meshmark
{
namespace
{

// Longest recipient name: a person's or a company's name fits; a key stays small (a family key
// stores every name). Chosen by hand; no study on record.
constexpr std::size_t kMaxRecipientName = 100;

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

}  // namespace

const char* to_string(EmbeddingRule rule) noexcept
{
    return rule == EmbeddingRule::Paper ? "paper" : "additive";
}

EmbeddingRule parse_embedding_rule(const std::string& name)
{
    return parse_named_choice<EmbeddingRule>(
        name, "embedding rule",
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
    return parse_named_choice<BasisType>(
        name, "basis", {{"rbf", BasisType::Rbf}, {"laplacian", BasisType::Laplacian}});
}

CenterSelection parse_center_selection(const std::string& name)
{
    return parse_named_choice<CenterSelection>(
        name, "center selection",
        {{"random", CenterSelection::Random}, {"decimate", CenterSelection::Decimate}});
}

const char* to_string(StrengthMeasure measure) noexcept
{
    return measure == StrengthMeasure::Vertex ? "vertex" : "surface";
}

StrengthMeasure parse_strength_measure(const std::string& name)
{
    return parse_named_choice<StrengthMeasure>(
        name, "strength measure",
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
        throw InvalidOption(
            "the recipients' energy share (--recipient-share) must be in (0, 1), got " +
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
        throw InvalidOption("recipient name '" + name +
                            "' starts with '.'; names become part of file names.");
    }
    for (const char c : name)
    {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20U || u == 0x7FU || c == '/' || c == '\\' || c == '"')
        {
            throw InvalidOption(
                "recipient name '" + name +
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
    // The ranges below (basis size 4..5000, strength 0..0.5) were chosen by hand; no study on
    // record.
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
        throw InvalidOption(
            "repetitions (--repetitions) must be auto or at least 1 and at most the basis size "
            "divided by the coefficients (" +
            std::to_string(basis_size) + " / " + std::to_string(coefficients) + "), got " +
            std::to_string(repetitions) + ".");
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
        throw InvalidOption("strength (--strength) must be in 0..0.5, got " + std::to_string(s) +
                            ".");
    }
    if (vertex_strength >= 0.0 && !(std::isfinite(vertex_strength) && vertex_strength <= 1.0))
    {
        throw InvalidOption("the calibrated vertex strength must be in 0..1, got " +
                            std::to_string(vertex_strength) + ".");
    }
    if (!std::isfinite(sigma_factor) || sigma_factor <= 0.0 || sigma_factor > 100.0)
    {
        throw InvalidOption("sigma factor must be in (0, 100], got " +
                            std::to_string(sigma_factor) + ".");
    }
    const std::int64_t min_gram_rows = std::int64_t{kMinGramRowsPerCenter} * basis_size;
    if (gram_rows != 0 && gram_rows < min_gram_rows)
    {
        throw InvalidOption("Gram rows (--gram-rows) must be 0 (every row) or at least " +
                            std::to_string(kMinGramRowsPerCenter) + " times the basis size (" +
                            std::to_string(min_gram_rows) + "), got " + std::to_string(gram_rows) +
                            ".");
    }
}

double EmbedOptions::resolved_strength() const noexcept
{
    return strength < 0.0 ? default_strength(rule, measure) : strength;
}

bool EmbedOptions::needs_calibration() const noexcept
{
    return rule == EmbeddingRule::Additive && measure == StrengthMeasure::Surface &&
           vertex_strength < 0.0;
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
    fp.position_hash =
        hash_bytes(mesh.V.data(), static_cast<std::size_t>(mesh.V.size()) * sizeof(double));
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
                            std::to_string(n) + " payload bits, got " + std::to_string(hex.size()) +
                            ".");
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
            bits.push_back(static_cast<std::uint8_t>(
                (static_cast<unsigned>(value) >> static_cast<unsigned>(b)) & 1U));
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

Key make_key(const EmbedOptions& options, std::uint64_t seed,
             const std::optional<std::string>& message, const std::optional<std::string>& bits_hex)
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

}  // namespace meshmark
