#include "segment/histogram.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace idealize {

namespace {

// Eq. (1): mean absolute difference between neighbouring bins.
double average_fluctuation(const std::vector<double>& h) {
  if (h.size() < 2) return 0.0;
  double sum = 0.0;
  for (size_t i = 0; i + 1 < h.size(); ++i) sum += std::abs(h[i] - h[i + 1]);
  return sum / static_cast<double>(h.size());
}

// A bin that is a local peak or valley and differs from both neighbours by less than the average
// fluctuation is replaced by the mean of itself and its neighbours. Monotone runs and large jumps
// stay, so peak and valley positions do not move.
void condition(std::vector<double>& h, int passes) {
  std::vector<double> next;
  for (int pass = 0; pass < passes; ++pass) {
    const double average = average_fluctuation(h);
    next = h;
    bool changed = false;
    for (size_t i = 1; i + 1 < h.size(); ++i) {
      const double left = h[i] - h[i - 1], right = h[i] - h[i + 1];
      const bool extremum = (left > 0 && right > 0) || (left < 0 && right < 0);
      if (extremum && std::abs(left) < average && std::abs(right) < average) {
        next[i] = (h[i - 1] + h[i] + h[i + 1]) / 3.0;
        changed = true;
      }
    }
    h.swap(next);
    if (!changed) break;
  }
}

struct Extremum {
  int bin;      // middle of the plateau
  double height;
  bool peak;
};

// Alternating peaks and valleys, plateaus counted once; outside the histogram counts as lower,
// so the sequence starts and ends with a peak.
std::vector<Extremum> extrema(const std::vector<double>& h) {
  std::vector<Extremum> out;
  const int n = static_cast<int>(h.size());
  const double outside = -std::numeric_limits<double>::infinity();
  for (int start = 0; start < n;) {
    int end = start;
    while (end + 1 < n && h[end + 1] == h[start]) ++end;
    const double before = start > 0 ? h[start - 1] : outside;
    const double after = end + 1 < n ? h[end + 1] : outside;
    const int middle = (start + end) / 2;
    if (h[start] > before && h[start] > after) out.push_back({middle, h[start], true});
    if (h[start] < before && h[start] < after) out.push_back({middle, h[start], false});
    start = end + 1;
  }
  return out;
}

}  // namespace

int HistogramRanges::range_of(double value) const {
  return static_cast<int>(std::upper_bound(valleys.begin(), valleys.end(), value) - valleys.begin());
}

double HistogramRanges::range_lower(int r) const {
  // Bounds-checked: with no values at all there are no ranges and no valleys (found by fuzz_segment).
  return r <= 0 || r > static_cast<int>(valleys.size()) ? -std::numeric_limits<double>::infinity()
                                                         : valleys[r - 1];
}

double HistogramRanges::range_upper(int r) const {
  return r < 0 || r >= static_cast<int>(valleys.size()) ? std::numeric_limits<double>::infinity()
                                                          : valleys[r];
}

HistogramRanges histogram_ranges(const std::vector<double>& values, const std::vector<char>& mask,
                                 const HistogramOptions& options) {
  HistogramRanges out;
  Histogram& hist = out.histogram;
  const bool all = mask.empty();
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (size_t i = 0; i < values.size(); ++i)
    if (all || mask[i]) {
      low = std::min(low, values[i]);
      high = std::max(high, values[i]);
    }
  hist.counts.assign(options.bins, 0.0);
  if (!(low <= high)) {  // nothing selected
    hist.smoothed = hist.counts;
    return out;
  }
  if (high == low) high = low + 1.0;  // a single value: one peak, no valley
  hist.low = low;
  hist.high = high;
  for (size_t i = 0; i < values.size(); ++i)
    if (all || mask[i]) {
      const int bin = std::min(options.bins - 1, static_cast<int>((values[i] - low) / hist.bin_width()));
      hist.counts[bin] += 1.0;
    }
  hist.smoothed = hist.counts;
  condition(hist.smoothed, options.smoothing_passes);

  // Eq. (2) decides which valleys are ripples (noise, undulation, real defects), with three
  // refinements measured on noisy parts (see BENCHMARKS.md):
  // - heights are compared as square roots of counts: counting noise is Poisson, and the square
  //   root gives it the same spread (1/2) in every bin, so one threshold fits tall and low peaks;
  // - the threshold is the median, not the mean, of the peak-to-valley differences, so that the
  //   one tall peak of the planes does not make every other valley look like a ripple; and never
  //   less than three standard deviations of counting noise (1.5);
  // - ripples are removed shallowest first, merging their two peaks, so that a ripple on the
  //   flank of a tall peak is judged against that peak once its smaller neighbours are gone
  //   (persistence simplification).
  std::vector<Extremum> ext = extrema(hist.smoothed);
  for (Extremum& e : ext) e.height = std::sqrt(std::max(e.height, 0.0));
  constexpr double kCountingNoise = 1.5;  // 3 σ of sqrt(Poisson counts)
  double threshold = kCountingNoise;
  if (ext.size() > 1) {
    std::vector<double> differences;
    for (size_t i = 0; i + 1 < ext.size(); ++i) differences.push_back(std::abs(ext[i].height - ext[i + 1].height));
    auto middle = differences.begin() + differences.size() / 2;
    std::nth_element(differences.begin(), middle, differences.end());
    threshold = std::max(threshold, *middle);
  }
  while (ext.size() >= 3) {
    size_t shallowest = 0;
    double depth = std::numeric_limits<double>::infinity();
    for (size_t i = 1; i + 1 < ext.size(); i += 2) {  // valleys sit at odd positions
      const double d = std::min(ext[i - 1].height, ext[i + 1].height) - ext[i].height;
      if (d < depth) {
        depth = d;
        shallowest = i;
      }
    }
    if (depth >= threshold) break;
    // Drop the valley and the lower of its two peaks.
    const size_t lower = ext[shallowest - 1].height < ext[shallowest + 1].height ? shallowest - 1 : shallowest + 1;
    ext.erase(ext.begin() + std::max(lower, shallowest));
    ext.erase(ext.begin() + std::min(lower, shallowest));
  }
  std::vector<int> kept_valleys;
  for (size_t i = 1; i < ext.size(); i += 2) kept_valleys.push_back(ext[i].bin);
  // Each range between kept valleys is represented by its highest bin.
  int begin = 0;
  for (size_t r = 0; r <= kept_valleys.size(); ++r) {
    const int end = r < kept_valleys.size() ? kept_valleys[r] : options.bins;
    const int peak = static_cast<int>(
        std::max_element(hist.smoothed.begin() + begin, hist.smoothed.begin() + end) - hist.smoothed.begin());
    out.peak_bins.push_back(peak);
    begin = end;
  }
  out.valley_bins = kept_valleys;
  for (int bin : kept_valleys) out.valleys.push_back(hist.bin_center(bin));
  return out;
}

}  // namespace idealize
