// Indirect light told from the stripe by the sweep: on one row, two traces of stripe centres that
// cover the same pixels at columns far apart cannot both be direct light; the weaker loses,
// where neither is weaker both do; traces on different pixels (a bore's two walls) both stay.

#include "mlp/probe_fw/ghost.h"

#include <gtest/gtest.h>

namespace mlp::probe_fw {
namespace {

// A trace on row `y`: frames first..last, centre x0 + px_per_frame * (frame - first), lit at
// column 2 * frame + column_offset.
void AddTrace(std::vector<SweepObservation>* obs,
              int y,
              int first,
              int last,
              double x0,
              double px_per_frame,
              double column_offset,
              double amplitude) {
  for (int f = first; f <= last; ++f) {
    SweepObservation o;
    o.stripe.x_px = x0 + px_per_frame * (f - first);
    o.stripe.y_px = y;
    o.stripe.amplitude_dn = amplitude;
    o.column = 2.0 * f + column_offset;
    o.frame = f;
    obs->push_back(o);
  }
}

std::size_t Indirect(const std::vector<SweepObservation>& obs, double amplitude) {
  std::size_t n = 0;
  for (const auto& o : obs) n += o.indirect && o.stripe.amplitude_dn == amplitude;
  return n;
}

TEST(RejectIndirectLight, AWeakerTraceOverTheStripesPixelsIsRejectedWhole) {
  std::vector<SweepObservation> obs;
  for (int y = 0; y < 3; ++y) {
    AddTrace(&obs, y, 0, 99, 100.0, 3.2, 0.0, 120.0);  // the stripe: 3.2 px a frame
    // The ghost: 40 px ahead, drifting 1.2 px a frame more, at half the light. Its last frames
    // are beyond the stripe's pixels: rejected with the rest of its trace.
    AddTrace(&obs, y, 0, 99, 140.0, 4.4, 0.0, 60.0);
  }
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 300u);
  EXPECT_EQ(Indirect(obs, 60.0), 300u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);
}

TEST(RejectIndirectLight, SurfacesOnDifferentPixelsAndOneSurfaceSeenTwiceAllStay) {
  std::vector<SweepObservation> obs;
  // A bore's near and far wall on one row: two traces on separate pixels, different brightness.
  AddTrace(&obs, 5, 0, 49, 100.0, 2.0, 0.0, 150.0);
  AddTrace(&obs, 5, 0, 49, 400.0, 1.5, 0.0, 40.0);
  // A steep face: the stripe barely moves, consecutive frames see the same pixels at nearby
  // columns (within the sheet's reach): one surface, no conflict.
  AddTrace(&obs, 6, 0, 49, 300.0, 0.3, 0.0, 90.0);
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 0u);
}

TEST(RejectIndirectLight, NeitherClearlyWeakerBothGoAndABlipLosesToALongTrace) {
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 0, 0, 59, 100.0, 3.0, 0.0, 100.0);
  AddTrace(&obs, 0, 0, 59, 130.0, 4.0, 0.0, 80.0);  // 0.8 of the light: cannot tell
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 120u);

  obs.clear();
  AddTrace(&obs, 1, 0, 59, 100.0, 3.0, 0.0, 100.0);
  AddTrace(&obs, 1, 40, 41, 200.5, 3.0, 0.0, 110.0);  // a bright 2-frame blip far off the sweep
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 2u);
  EXPECT_EQ(Indirect(obs, 110.0), 2u);
}

TEST(RejectIndirectLight, RowsAreIndependentAndNothingIsAnEmptySweep) {
  std::vector<SweepObservation> none;
  EXPECT_EQ(RejectIndirectLight(&none, {}), 0u);
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 0, 0, 29, 100.0, 3.0, 0.0, 100.0);
  AddTrace(&obs, 1, 0, 29, 130.0, 4.0, 0.0, 50.0);  // another row: no conflict
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 0u);
}

}  // namespace
}  // namespace mlp::probe_fw
