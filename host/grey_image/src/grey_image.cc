#include "mlp/grey_image/grey_image.h"

#include "mlp/base/files.h"
#include "mlp/base/raster.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace mlp::grey_image {

void GaussianBlur(std::vector<double>* img, int w, int h, double sigma) {
  if (sigma <= 0) return;
  const int r = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> k(static_cast<size_t>(2 * r + 1));
  double* const centre = k.data() + r;  // centre[i], i in [-r, r]
  double sum = 0;
  for (int i = -r; i <= r; ++i) sum += centre[i] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (double& x : k) x /= sum;
  std::vector<double> tmp(img->size());
  const auto at = [&](const std::vector<double>& a, int x, int y) {
    return a[base::RasterIndex(std::clamp(x, 0, w - 1), std::clamp(y, 0, h - 1), w)];
  };
  // Along rows, then down columns; away from the borders without the clamping.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      if (x >= r && x < w - r) {
        const double* row = img->data() + base::RasterIndex(x - r, y, w);
        for (int i = 0; i <= 2 * r; ++i) s += k[static_cast<size_t>(i)] * row[i];
      } else {
        for (int i = -r; i <= r; ++i) s += centre[i] * at(*img, x + i, y);
      }
      tmp[base::RasterIndex(x, y, w)] = s;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      if (y >= r && y < h - r) {
        const double* col = tmp.data() + base::RasterIndex(x, y - r, w);
        for (int i = 0; i <= 2 * r; ++i)
          s += k[static_cast<size_t>(i)] * col[base::RasterIndex(0, i, w)];
      } else {
        for (int i = -r; i <= r; ++i) s += centre[i] * at(tmp, x, y + i);
      }
      (*img)[base::RasterIndex(x, y, w)] = s;
    }
}

void WritePgm(const std::string& path, int w, int h, const std::vector<std::uint8_t>& px) {
  base::WriteFileAtomically(path, [&](std::ostream& out) {
    out << "P5\n" << w << " " << h << "\n255\n";
    out.write(reinterpret_cast<const char*>(px.data()), static_cast<std::streamsize>(px.size()));
  });
}

}  // namespace mlp::grey_image
