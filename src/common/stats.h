#pragma once
/// Order statistics over plain samples: the one quantile and median of TwoCam's metrics and
/// timing summaries.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace twocam {

/// The q-quantile (q in [0, 1]) of the samples by the nearest rank: the element of rank
/// round(q (n - 1)) in ascending order (no interpolation, so the result is a sample). NaN when
/// there are no samples. Takes a copy (nth_element reorders it).
[[nodiscard]] inline double quantile(std::vector<double> samples, double q) {
  if (samples.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double last = static_cast<double>(samples.size() - 1);
  const double rank = std::floor(std::clamp(q, 0.0, 1.0) * last + 0.5);
  const size_t k = std::min(samples.size() - 1, static_cast<size_t>(rank));
  std::nth_element(
      samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(k), samples.end());
  return samples[k];
}

/// quantile(samples, 0.5): the upper median for an even count.
[[nodiscard]] inline double median(std::vector<double> samples) {
  return quantile(std::move(samples), 0.5);
}

}  // namespace twocam
