#pragma once
/// @file Where the actual contour meets the line from the wheel-nose centre C through the
/// cutting point Mi (seed 001, Fig. 3): Mr.
///
/// The seed sorts the contour by image column and starts from the columns of C and Mi
/// (yC, yMi), in one of six cases by which side yC lies of yMi and where the contour meets
/// the line: beyond C (1: yC > yMi, from yC towards larger y; 4: yC < yMi, towards smaller),
/// between C and Mi (2 and 5: every point between the two columns), beyond Mi (3: from yMi
/// towards smaller y; 6: towards larger). A directed search stops once the distance to the
/// line grows while its least is under a pixel. yC = yMi: the contour point in that column.
/// Where the contour lies is read off the contour points in the columns yC and yMi: their
/// offsets from the line differ in sign when it crosses between them, else it crosses on the
/// side of the smaller offset (the contour runs across the line, its offset nearly linear).
///
/// Generalised in one way: when C-Mi lies nearer the image's rows than its columns (the
/// contour steeper than 45 deg, which the seed's column sort cannot follow), the rows play the
/// columns' part. The sort presumes the contour is a graph over that axis near Mi.
///
/// Mr to sub-pixel: a line through the contour points within 3 px of the point found,
/// intersected with C-Mi.

#include "mlp/geometry/types.h"

#include <cstddef>
#include <vector>

namespace mlp::grind {

struct LineCrossing {
  double t_mm = 0.0;     ///< from C along (Mi - C) / |Mi - C|: Mr = C + t u
  int seed_case = 0;     ///< the seed's case 1..6 (Fig. 3); 0 when C and Mi share a column
  bool by_rows = false;  ///< the rows played the columns' part (a steep contour)
};

/// `contour`: the actual contour's points (mm, y up), any order; `px_mm` the pixel on the
/// object. Throws GrindError when the contour does not come within 3 px of the line.
LineCrossing FindContourOnLine(const std::vector<geometry::Vec2>& contour,
                               const geometry::Vec2& c_mm,
                               const geometry::Vec2& mi_mm,
                               double px_mm);

}  // namespace mlp::grind
