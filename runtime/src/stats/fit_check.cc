// stats/fit_check.cc — FitProblem (vlt/gum.h): whether an adjustment's residuals are what its
// model and the stated uncertainties make likely (docs/calibration.md "Fit", docs/network.md N-8).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "vlt/gum.h"

namespace vlt {

std::string FitProblem(double chi2, int dof, double largest_w, int tested) {
  // Chi-square test of the whole fit (upper tail): the residuals are larger than the stated
  // uncertainties make likely.
  const double p = dof > 0 ? std::clamp(1.0 - ChiSquareCdf(chi2, dof), 0.0, 1.0) : 1.0;
  char text[256];
  if (dof > 0 && p < kFitProblemP) {
    std::snprintf(text, sizeof text,
                  "the data do not fit the model: chi2 = %.4g for %d degrees of freedom (Birge ratio %.2f, "
                  "p = %.2g < %g)",
                  chi2, dof, std::sqrt(chi2 / dof), p, kFitProblemP);
    return text;
  }
  // One observation beyond what chance gives over all n tested (Bonferroni, family-wise alpha):
  // a single 3.3-sigma w among a thousand is expected, one beyond this limit is not.
  if (tested > 0) {
    const double limit = NormalCoverageFactor(1.0 - kFitProblemAlphaW / tested);
    if (std::abs(largest_w) > limit) {
      std::snprintf(text, sizeof text,
                    "an observation does not fit: |w| = %.2f above %.2f, the limit that %d good observations "
                    "exceed with probability %g",
                    std::abs(largest_w), limit, tested, kFitProblemAlphaW);
      return text;
    }
  }
  return "";
}

}  // namespace vlt
