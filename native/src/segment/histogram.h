// Mean-curvature histogram analysis of Chen & Feng, "Automatic prismatic feature segmentation of
// scanning-derived meshes utilizing mean curvature histograms", Virtual and Physical Prototyping
// 9(1), 2014 (thesis ch. 3.2.1.1–3.2.1.3): build, condition by peak/valley-preserving smoothing,
// and find the valleys that separate features.
#pragma once

#include <vector>

namespace idealize {

struct HistogramOptions {
  int bins = 150;               // thesis: any count in 100–500 gives the same result after conditioning
  int smoothing_passes = 100;   // thesis: the conditioning converges after about 100 passes
};

struct Histogram {
  double low = 0.0, high = 0.0;  // value range spanned by the bins
  std::vector<double> counts;    // raw counts per bin
  std::vector<double> smoothed;  // after conditioning

  double bin_width() const { return (high - low) / static_cast<double>(counts.size()); }
  double bin_center(int bin) const { return low + (bin + 0.5) * bin_width(); }
};

// The histogram read as consecutive value ranges, one per surviving peak.
struct HistogramRanges {
  Histogram histogram;
  std::vector<int> peak_bins;    // one per range, ascending
  std::vector<int> valley_bins;  // #peaks − 1 separators, ascending
  std::vector<double> valleys;   // value at each separator (bin centre)

  int num_ranges() const { return static_cast<int>(peak_bins.size()); }
  // Range index of a value: the number of separators at or below it.
  int range_of(double value) const;
  // Value bounds [lower, upper) of range r (±infinity at the ends).
  double range_lower(int r) const;
  double range_upper(int r) const;
};

// Histogram of `values` restricted to entries where `mask` is non-zero (all when mask is empty),
// conditioned, with low-amplitude valleys discarded as the thesis describes.
HistogramRanges histogram_ranges(const std::vector<double>& values, const std::vector<char>& mask,
                                 const HistogramOptions& options = {});

}  // namespace idealize
