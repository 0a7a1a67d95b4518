// Segments: independent records concatenated along the sample axis (contract §1.1).
#pragma once

#include "checked.hpp"
#include "errors.hpp"

#include <algorithm>
#include <initializer_list>
#include <string>
#include <vector>

namespace dynval {

/// `segments=` of the contract: lengths or starts (empty: one segment). With `starts_only`
/// (the kernels' int64 starts) the lengths form is not accepted.
struct segment_spec {
    std::vector<long long> values;
    bool starts_only = false;
    segment_spec() = default;
    segment_spec(std::vector<long long> v, bool only_starts = false)  // NOLINT: implicit on purpose
        : values(std::move(v)), starts_only(only_starts) {}
    segment_spec(std::initializer_list<long long> v) : values(v) {}
};

/// Segment starts (first element 0) from the contract's two forms: lengths summing to N, or
/// strictly increasing starts beginning at 0 and below N. Empty means one segment.
inline std::vector<Index> segment_starts(const segment_spec& spec, Index n) {
    const std::vector<long long>& segments = spec.values;
    if (segments.empty() && !spec.starts_only) return {0};
    const auto fail = [&]() {
        detail::throw_parameter("segments",
                                "positive lengths summing to N=" + std::to_string(n) +
                                    ", or increasing starts beginning at 0 and below N=" + std::to_string(n),
                                value_text(segments));
    };
    std::vector<Index> starts;
    if (segments.empty()) fail();
    if (segments.front() == 0) {
        for (std::size_t i = 0; i < segments.size(); ++i) {
            if ((i > 0 && segments[i] <= segments[i - 1]) || segments[i] >= n) fail();
            starts.push_back(static_cast<Index>(segments[i]));
        }
        return starts;
    }
    if (spec.starts_only) fail();
    long long total = 0;
    for (long long len : segments) {
        if (len <= 0) fail();
        starts.push_back(static_cast<Index>(total));
        // A sum that wraps could land on N and pass for valid lengths: refuse it at the overflow.
        const auto next = detail::checked_add(total, len);
        if (!next || *next > n) fail();
        total = *next;
    }
    if (total != n) fail();
    return starts;
}

/// Lengths of the segments that begin at `starts` over n samples.
inline std::vector<Index> segment_lengths(const std::vector<Index>& starts, Index n) {
    std::vector<Index> lengths(starts.size());
    for (std::size_t s = 0; s < starts.size(); ++s) lengths[s] = (s + 1 < starts.size() ? starts[s + 1] : n) - starts[s];
    return lengths;
}

/// Number of lag-ℓ products: Σ_s max(n_s − ℓ, 0).
inline Index lag_products(const std::vector<Index>& lengths, Index lag) {
    Index total = 0;
    for (Index len : lengths) total += std::max<Index>(len - lag, 0);
    return total;
}

}  // namespace dynval
