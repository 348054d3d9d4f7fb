// Whether one fit explains its points about as well as another: the one comparison every stage of
// the feature identification makes when it weighs a candidate surface against a reference (a merge
// of two patches against each part's own fit, a shared axis against a feature's free fit, a retyped
// surface against the original).
#pragma once

namespace idealize {

// The largest residual still accepted against `reference`: `ratio` × `reference` + `slack`.
//
//   reference  the reference fit's residual (an RMS, a spread, a normal spread)
//   ratio      how much worse a fit may be and still count as about as good: the stage's
//              `residual_ratio` (1.5 by default, see FeatureOptions), or 1 where it must not be worse
//   slack      an absolute allowance that keeps exact fits comparable, whose residuals are near
//              zero: the distance tolerance, the noise or the normal floor, as the stage says
inline double accepted_residual(double reference, double ratio, double slack = 0.0) {
  return ratio * reference + slack;
}

// True when `candidate` is within the accepted residual of `reference` (see accepted_residual).
inline bool fits_as_well(double candidate, double reference, double ratio, double slack = 0.0) {
  return candidate <= accepted_residual(reference, ratio, slack);
}

}  // namespace idealize
