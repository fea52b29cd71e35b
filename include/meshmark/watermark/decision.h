// SPDX-License-Identifier: MIT
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace meshmark
{

/// What an extraction read from a suspect.
struct Extraction
{
    /// Signed coefficient change of each modulated coefficient divided by its modulation
    /// (3 m r values, coefficient c = 3 * mode + axis carries payload bit c mod 3m): +1 where
    /// the embedded sign b'_c was +1, -1 where it was -1, ~0 where nothing was embedded.
    std::vector<double> normalized_change;
    /// Weight of each coefficient in the correlation (3 m r values, >= 0): the inverse of its
    /// estimated noise variance where the extraction estimates it (joint least squares), else 1;
    /// 0 for a coefficient the suspect cannot determine (its change is then 0 as well). Never
    /// depends on the embedded signs, so the verdict's false-positive bound still holds.
    std::vector<double> weights;
    /// Per payload bit (3m values): the mean over its r coefficients of the change with the key
    /// mask undone, weighted by `weights`: +1 for an embedded 1 and -1 for a 0 (soft decision).
    std::vector<double> bit_values;
    std::vector<std::uint8_t> bits_found;  ///< Payload bits: 0, 1, or 2 for undecided.
    /// Further readings of the owner's 3 m r coefficients, each one more statistic of the
    /// verdict with uniform weights a = 1 (docs/statistics.md): the damped least-squares
    /// readings, one per damping level ("Damped readings"), normalized as normalized_change,
    /// and for a resampled suspect the reading against the original's vertices
    /// (add_further_reading). Empty where none is computed. Never depends on the embedded signs.
    std::vector<std::vector<double>> further_changes;
    /// Further readings (indices into `further_changes`) that are another reading's three
    /// weightings rather than damped readings (add_further_reading records them), so that
    /// `damped_only` can leave them out.
    std::vector<std::size_t> further_weightings;
    /// The owner's verdict scores the damped readings alone (`further_changes` but
    /// `further_weightings`): neither computed nor paid for are the three weightings of the
    /// least-squares reading. Set for a suspect resampled at the original's vertices, where the
    /// normal sampling couples the modulated columns and the damped readings are the ones
    /// that read (docs/statistics.md, "Resampled suspects score their damped readings"). A
    /// fixed rule of the suspect's kind, never of its signs, so the bound holds. The trace
    /// (a family key's code) is not affected.
    bool damped_only = false;
    /// Statistics the verdict pays for in its union bound without computing them: a
    /// detection that stopped before a further reading because the score alone was already
    /// conclusive at the price of all of them (detect_file, resampled suspects).
    int unread_statistics = 0;
    /// Family keys: the recipient code's 3M coefficients of the same further readings (empty
    /// where the code is not read with the owner's mark, or no further reading is computed).
    std::vector<std::vector<double>> further_recipient_changes;
    /// Family keys: the recipient code's 3M coefficients (coefficient c = 3 * mode + axis of
    /// the M modes after the owner's), normalized and weighted as above; empty otherwise.
    std::vector<double> recipient_change;
    std::vector<double> recipient_weights;
    /// Family keys, resampled suspects read with the code: how the resampling sees the code,
    /// a 3M x 3M symmetric matrix K (row-major; coefficient c = 3 * mode + axis in the mark's
    /// canonical axes). A code field with coefficients y (modulation times normalized change)
    /// that keeps only its normal components at the rows, weighted as the extraction's rows,
    /// projects back on the code's modes as K y. Detector::region_changes() undoes it (a
    /// resampled region otherwise reads the code through the normals alone). Computed from the
    /// original's normals and the rows' weights, never from the signs; empty where not computed.
    std::vector<double> code_sampling;
    /// Family keys, for spliced suspects: per region of the original (Detector::region_changes),
    /// the recipient code's 3M coefficients of the suspect's change confined to that region,
    /// normalized; empty when not computed.
    std::vector<std::vector<double>> region_changes;
};

/// \brief Join \p other, another reading of the same suspect's coefficients for the same key,
/// to \p primary as further readings, so the verdict scores every statistic of both and pays
/// for each in its union bound: \p other's changes under the three weightings (each passed as
/// a x, scored with a = 1) and its own further readings, the owner's to `further_changes` and,
/// when \p primary pairs those with a family code's, the code's to `further_recipient_changes`
/// (zeros where \p other did not read the code).
/// When both readings bring the same number k >= 1 of damped readings of their own (and no
/// weightings yet), the two are also joined (joined_reading_count): each pair at the same
/// damping level, and for k >= 2 all 2k together, as the sum of the readings each scaled to
/// unit norm, one further statistic each. The two readings of a resampled suspect see
/// different errors of the attack (their noise correlates by 0.0-0.3 after a coarse
/// decimation) and the same mark, so their sum scores higher than either (docs/statistics.md,
/// "The two readings joined"). Fixed functions of the suspect, so the bound holds.
/// \throws InvalidOption if the two readings do not have the same number of coefficients.
void add_further_reading(Extraction& primary, const Extraction& other);

/// The further statistics add_further_reading joins for two readings of \p damped damped
/// readings each: one per damping level, plus one of all of them where \p damped >= 2.
[[nodiscard]] int joined_reading_count(int damped) noexcept;

/// \brief The tail of a weighted sum of random signs, computed for the weights at hand:
/// P(sum_i s_i a_i >= z |a|) for independent uniform signs s_i and fixed weights a_i.
///
/// The formula bound (rademacher_tail_bound) holds for every weight vector and so pays for the
/// worst one, up to 4.46 times the normal tail; the distribution of the sum for *these*
/// weights is known exactly up to rounding. Each |a_i| / |a| is rounded to the nearest
/// multiple q_i h of a step h, the distribution of sum_i s_i q_i is counted exactly (a
/// subset-sum recursion, O(n Q) for Q = sum_i q_i), and the rounding is paid for whole: the
/// sum can exceed h sum_i s_i q_i by at most e = sum_i |a_i / |a| - q_i h|, so
/// P(sum_i s_i a_i >= z |a|) <= P(sum_i s_i q_i >= (z - e) / h). The result is never below the
/// exact tail, and at most the exact tail at z - resolution (e <= resolution by the choice of
/// h). Weights so many that the counting would cost more than kMaxWork are not counted: the
/// tail is then 1 and the formula bound stands alone where the two are combined.
/// (Written here: a convolution of n two-point distributions, not something a library offers.)
class RademacherTail
{
public:
    /// The most counting work (about n Q / 2 additions, Q the table's size) spent on one tail:
    /// about 470 equal weights at the default resolution, 20-30 ms.
    static constexpr double kMaxWork = 6e7;
    /// \param weights any real weights (signs and zeros allowed); \param resolution the largest
    /// shift in z the rounding may cost (> 0).
    explicit RademacherTail(const std::vector<double>& weights, double resolution = 0.02);
    /// No weights: every tail is 1 (what the formula bound alone gives).
    RademacherTail() = default;
    /// Upper bound on P(sum_i s_i a_i >= z |a|): 1 for z <= 0, where every weight is 0 and
    /// where the weights were too many to count.
    [[nodiscard]] double operator()(double z) const;
    /// Whether the distribution was counted (some weight is not 0 and the work was within
    /// kMaxWork).
    [[nodiscard]] bool is_counted() const noexcept { return !at_least_.empty(); }
    /// The rounding's largest shift e in z (in units of |a|).
    [[nodiscard]] double slack() const noexcept { return slack_; }

private:
    double inverse_step_ = 0.0;  // 1 / h, h in units of |a|
    double slack_ = 0.0;         // e
    std::size_t total_ = 0;      // Q = sum_i q_i
    std::size_t first_ = 0;      // Q / 2: the first sum kept below
    // at_least_[k - first_] = P(sum over the positive signs of q_i >= k), k = first_ .. Q + 1
    std::vector<double> at_least_;
};

/// One score of a SoftCorrelation: the best statistic's z and the smallest tail.
struct SoftScore
{
    double z = 0.0;  ///< The largest of the statistics' scores.
    /// The smallest over the statistics of P(a suspect without these signs scores at least
    /// that statistic's score), each bounded by min(rademacher_tail_bound, RademacherTail):
    /// may be another statistic's than z's, where that one's weights make its score rarer.
    double tail = 1.0;
    /// min(1, statistic count x tail): the union bound over the statistics.
    double probability = 1.0;
};

/// \brief The soft correlation of a set of normalized coefficients with a sign vector, over the
/// three weightings a = w^0, w^(1/2), w^1 (docs/statistics.md) and over any further readings of
/// the same coefficients with uniform weights (the damped readings): the weighted values and
/// each statistic's tail (RademacherTail: they depend on the weights, not on the signs) are
/// computed once, so scoring many sign vectors (every recipient of a family key) is one dot
/// product and one table lookup per statistic each.
class SoftCorrelation
{
public:
    /// \param x normalized changes; \param w their weights (>= 0), same size; \param extra
    /// further readings of the same coefficients, each of that size (else InvalidOption).
    /// \param with_weightings false: only the further readings are statistics (x and w give
    /// the size alone). \param threads counts the statistics' tails on that many threads
    /// (resolve_threads; 1 by default): the same tables for any value.
    SoftCorrelation(const std::vector<double>& x, const std::vector<double>& w,
                    const std::vector<std::vector<double>>& extra = {}, bool with_weightings = true,
                    int threads = 1);
    /// The statistics' best z for signs sign(c) in {-1, +1}, their smallest tail and the
    /// union bound over them on P(a suspect without these signs scores so).
    template <class Sign>
    [[nodiscard]] SoftScore score(Sign sign) const;
    [[nodiscard]] std::size_t size() const noexcept { return size_; }
    /// 3 weightings (unless left out) plus one per extra reading: the union bound's factor.
    [[nodiscard]] int statistic_count() const noexcept
    {
        return static_cast<int>(weighted_.size());
    }

private:
    std::size_t size_ = 0;
    std::vector<std::vector<double>> weighted_;  // per statistic, the weighted values
    std::vector<double> norm_;                   // per statistic, their squared norm
    std::vector<RademacherTail> tails_;          // per statistic, the tail of its weights
};

/// How one recipient of a family key scores on a suspect.
struct RecipientScore
{
    std::string name;
    std::uint32_t index = 0;
    double score = 0.0;  ///< z of the recipient code's soft correlation.
    /// The largest z over the regions of Extraction::region_changes (0 without them).
    double region_score = 0.0;
    /// Bound on P(some innocent recipient of the key scores this high), a union bound over the
    /// key's R recipients: R S t without regions, with them
    /// R min(2 S t, 2 K rademacher_tail_bound(region_score)) for K regions
    /// (docs/fingerprinting.md), where S is the number of statistics of the score (3
    /// weightings, plus one per damped reading) and t their smallest tail (SoftScore::tail);
    /// at most 1.
    double false_positive_probability = 1.0;
    bool is_accused = false;  ///< false_positive_probability <= DetectOptions::max_false_positive.
    /// z of the owner's coefficients and this recipient's code read as one mark: the soft
    /// correlation over both with the owner's signs and this recipient's (0 without a
    /// whole-model reading of the code). Evidence of ownership when nobody can be accused.
    double joint_score = 0.0;
    /// Bound on P(an unmarked suspect gives some recipient this joint score): R S t, with S
    /// and t the joint statistics' count and smallest tail as above, at most 1.
    double joint_false_positive_probability = 1.0;
};

/// How the verdict is reached (docs/statistics.md).
enum class VerdictRule
{
    /// Default: the soft correlation of Correlation and the count of payload bits read back
    /// of Bits, two tests of the same extraction joined by a weighted union bound: the
    /// false-positive probability is min(1, 16/15 score_false_positive_probability,
    /// 16 bits_false_positive_probability), ownership when it is at most
    /// DetectOptions::max_false_positive. A perfect read of 24 bits is claimed at 1e-6 even
    /// when the magnitudes of its coefficients are uneven.
    Combined,
    /// Soft-decision correlation of all 3 m r coefficients with the embedded signs,
    /// z = sum_c b'_c x_c / |x|; ownership when the bound on P(an unmarked mesh scores z) is
    /// at most DetectOptions::max_false_positive.
    Correlation,
    /// [Wu & Kobbelt 2005]: R = fraction of payload bits read back, ownership when
    /// R >= DetectOptions::threshold; reported false-positive probability P(X >= matches),
    /// X ~ Bin(3m, 1/2) (Decision::bits_false_positive_probability).
    Bits,
};

/// The factor by which \p rule's verdict multiplies the score's false-positive probability
/// before comparing it with the level: 16/15 for Combined (its share of the level), 1 for
/// Correlation; 0 for Bits, whose verdict does not use the score.
[[nodiscard]] double score_level_factor(VerdictRule rule) noexcept;

/// Name used on the command line and in --json: "combined", "correlation" or "bits".
[[nodiscard]] const char* to_string(VerdictRule rule) noexcept;
/// \throws InvalidOption for any other name.
[[nodiscard]] VerdictRule parse_verdict_rule(const std::string& name);

/// Options of the decision (docs/algorithms/detection.md, docs/statistics.md).
struct DetectOptions
{
    VerdictRule verdict = VerdictRule::Combined;
    /// Combined and correlation rules: ownership is claimed when the false-positive bound is at
    /// most this.
    double max_false_positive = 1e-6;
    /// Bits rule: ownership is claimed when R >= threshold (Wu & Kobbelt's value).
    double threshold = 0.75;
    /// Undecided band of a payload bit, as a fraction of the modulation (chosen by hand; no
    /// study on record).
    double epsilon = 0.1;
    /// Remove the attack's predictable part before deciding: the changes of a similarity
    /// motion and of Laplacian smoothing are fitted on the unmodulated modes (which carry no
    /// watermark) and subtracted from the modulated ones. See docs/algorithms/detection.md.
    bool remove_nuisance = true;
    /// \throws InvalidOption unless threshold is in (0, 1], epsilon in [0, 1) and
    /// max_false_positive in (0, 1].
    void validate() const;
};

/// The verdict on a suspect.
struct Decision
{
    /// The verdict of the rule in use: false-positive bound at most
    /// DetectOptions::max_false_positive (combined, correlation) or R >= DetectOptions::threshold
    /// (bits).
    bool is_present = false;
    VerdictRule verdict = VerdictRule::Combined;  ///< The rule in use.
    /// R: fraction of payload bits read back correctly (an undecided bit counts as wrong).
    double correlation = 0.0;
    int matches = 0;
    int bit_count = 0;
    /// z = sum_c a_c b'_c x_c / sqrt(sum_c a_c^2 x_c^2) over the 3 m r modulated coefficients,
    /// the largest over the weightings a = w^0, w^(1/2), w^1 (w: Extraction::weights) and over
    /// the damped readings x of Extraction::further_changes (a = 1): about sqrt(3 m r) for an
    /// intact mark; for an unmarked mesh, for each statistic, a sum of independent random signs
    /// (the key mask) with fixed weights, of mean 0 and variance 1.
    double score = 0.0;
    int coefficient_count = 0;  ///< 3 m r.
    /// The number of statistics z is the best of: 3, plus one per damped reading (plus the
    /// statistics paid for unread, Extraction::unread_statistics).
    int statistic_count = 3;
    /// Bound on P(an unmarked mesh scores so): statistic_count x score_tail (union bound over
    /// the statistics), at most 1.
    double score_false_positive_probability = 1.0;
    /// The smallest over the statistics of the tail of its score (SoftScore::tail): for each,
    /// P(a sum of random signs with its weights reaches its score), bounded by
    /// min(rademacher_tail_bound, RademacherTail).
    double score_tail = 1.0;
    /// P(X >= matches), X ~ Bin(3m, 1/2): each decided bit of an unrelated mesh matches the
    /// key-masked payload with probability 1/2 and an undecided one never does.
    double bits_false_positive_probability = 1.0;
    /// The false-positive probability of the rule in use: one of the two above, or for the
    /// combined rule min(1, 16/15 score_false_positive_probability, 16
    /// bits_false_positive_probability).
    double false_positive_probability = 1.0;
    std::string bits_expected;  ///< '0'/'1'.
    std::string bits_found;     ///< '0'/'1'/'?'.
};

/// \brief Upper bound on P(sum_i s_i a_i >= z |a|) for independent uniform random signs s_i
/// and any real weights a_i: min(exp(-z^2/2), (2 e^3 / 9) (1 - Phi(z))) for z > 0, else 1
/// [Hoeffding 1963; Pinelis 1994, Ann. Statist. 22(1)]. Never optimistic whatever the a_i.
[[nodiscard]] double rademacher_tail_bound(double z);

/// \brief P(X >= k) for X ~ Binomial(n, 1/2), exact.
[[nodiscard]] double binomial_tail_half(int n, int k);

template <class Sign>
SoftScore SoftCorrelation::score(Sign sign) const
{
    SoftScore result;
    for (std::size_t p = 0; p < weighted_.size(); ++p)
    {
        double dot = 0.0;
        for (std::size_t c = 0; c < size_; ++c)
        {
            dot += sign(c) * weighted_[p][c];
        }
        const double z = norm_[p] > 0.0 ? dot / std::sqrt(norm_[p]) : 0.0;
        const double tail = std::min(rademacher_tail_bound(z), tails_[p](z));
        result.z = p == 0 ? z : std::max(result.z, z);
        result.tail = std::min(result.tail, tail);
    }
    result.probability = std::min(1.0, static_cast<double>(weighted_.size()) * result.tail);
    return result;
}

}  // namespace meshmark
