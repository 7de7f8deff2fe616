#pragma once

#include "mlp/probe_fw/stripe.h"

#include <cstddef>
#include <vector>

namespace mlp::probe_fw {

/// Takes the along-stripe blur's shift out of stripe centres
/// (StripeOptions::along_stripe_sigma_px).
///
/// Why: a Gaussian along the stripe averages each line's profile with its neighbours', each
/// weighted by its own light. Where the stripe is evenly lit the neighbours cancel; where its
/// light changes along it (a speckle grain, a sphere's limb, a trace's end) the centre is that of
/// lines M1 away on average [lines, light-weighted], and a stripe crossing its lines at a slope
/// moves by slope * M1 (the curvature's share, curvature/2 times the mean square offset, is a
/// hundredth of a pixel and left in). The scan measures M1 per centre from the unsmoothed lines
/// (StripePoint::blur_m1_lines); this fits the slope along the stripe from the neighbouring
/// centres of the same frame and scan (a few Jacobi steps, because the neighbours carry the
/// shift too) and subtracts it. Found by the verify run at C 0.3 (P_Size.Sph.1x25 +33.8 um with
/// the smoothing alone, +10.2 with this; docs/ACCURACY.md). No library models this: it is the
/// centroid's linearity written out.
///
/// `points[begin, end())`: one frame's centres of one scan, ascending by line. A centre without
/// enough neighbours to fit (fewer than 3 lines) keeps its value (a trace that short is refused
/// later as isolated, epipolar.h). Weak: past a stripe's end the smoothing still shows light for
/// ~2 sigma lines with none of the line's own; the linear model leaves those centres up to
/// 0.3 px off (2.4 px uncorrected). Refusing them (or any shift over 0.5 px) was tried and
/// lost: the gaps it leaves in the traces let reflections through the sweep's rules (outside
/// renderer, sphere 9320: 8,801 -> 7,358 points, 46 beyond 50 um either way, RMS 13 -> 86 um).
void UndoAlongBlur(std::vector<StripePoint>* points, std::size_t begin, double sigma_px);

}  // namespace mlp::probe_fw
