// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/verdict.h"

#include <array>
#include <cmath>
#include <cstdio>

#include "meshmark/core/plain_numbers.h"

namespace meshmark
{

Verdict verdict_of(const DetectReport& report, double max_false_positive)
{
    Verdict v;
    v.max_false_positive_probability = max_false_positive;
    v.traced = report.recipients_traced > 0;
    if (!v.traced)
    {
        v.claimed = report.decision.is_present;
        v.false_positive_probability = report.decision.false_positive_probability;
        return v;
    }
    for (const RecipientScore& r : report.accused)
    {
        v.accused.push_back(r.name);
    }
    v.claimed = report.detected();
    v.false_positive_probability = report.accused.empty()
                                       ? report.owner_false_positive_probability
                                       : report.accused.front().false_positive_probability;
    return v;
}

std::string headline(const Verdict& verdict)
{
    std::array<char, 32> p{};
    std::snprintf(p.data(), p.size(), "%.2g", verdict.false_positive_probability);
    std::string out;
    if (verdict.claimed)
    {
        out = "Claimed: a copy of the original";
        if (!verdict.accused.empty())
        {
            out += verdict.accused.size() == 1 ? ", made from the copy issued to "
                                               : ", made from the copies issued to ";
            for (std::size_t i = 0; i < verdict.accused.size(); ++i)
            {
                if (i > 0)
                {
                    out.append(i + 1 == verdict.accused.size() ? " and " : ", ");
                }
                out.append(verdict.accused[i]);
            }
        }
        else if (verdict.traced)
        {
            out += " (no recipient's copy named: none of their codes reads strongly enough)";
        }
        out += ". The chance that a mesh without this mark gives this result is at most " +
               one_in(verdict.false_positive_probability) + " (" + p.data() + ").";
        return out;
    }
    std::array<char, 32> bound{};
    std::snprintf(bound.data(), bound.size(), "%.2g", verdict.max_false_positive_probability);
    const std::string how_often = verdict.false_positive_probability < 1.0
                                      ? one_in(verdict.false_positive_probability) + " times"
                                      : std::string("every time");
    out =
        "Not shown: the mark is not read strongly enough to claim this copy. Chance alone gives a "
        "reading this "
        "strong " +
        how_often + " (" + p.data() + "); a claim needs at most " +
        one_in(verdict.max_false_positive_probability) + " (" + bound.data() + ").";
    return out;
}

}  // namespace meshmark
