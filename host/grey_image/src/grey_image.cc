#include "mlp/grey_image/grey_image.h"

#include "mlp/base/files.h"

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
  double sum = 0;
  for (int i = -r; i <= r; ++i)
    sum += k[static_cast<size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (double& x : k) x /= sum;
  std::vector<double> tmp(img->size());
  const auto at = [&](const std::vector<double>& a, int x, int y) {
    return a[static_cast<size_t>(std::clamp(y, 0, h - 1) * w + std::clamp(x, 0, w - 1))];
  };
  // Along rows, then down columns; away from the borders without the clamping.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      if (x >= r && x < w - r) {
        const double* row = img->data() + static_cast<size_t>(y * w + x - r);
        for (int i = 0; i <= 2 * r; ++i) s += k[static_cast<size_t>(i)] * row[i];
      } else {
        for (int i = -r; i <= r; ++i) s += k[static_cast<size_t>(i + r)] * at(*img, x + i, y);
      }
      tmp[static_cast<size_t>(y * w + x)] = s;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      if (y >= r && y < h - r) {
        const double* col = tmp.data() + static_cast<size_t>((y - r) * w + x);
        for (int i = 0; i <= 2 * r; ++i)
          s += k[static_cast<size_t>(i)] * col[static_cast<size_t>(i * w)];
      } else {
        for (int i = -r; i <= r; ++i) s += k[static_cast<size_t>(i + r)] * at(tmp, x, y + i);
      }
      (*img)[static_cast<size_t>(y * w + x)] = s;
    }
}

void WritePgm(const std::string& path, int w, int h, const std::vector<std::uint8_t>& px) {
  base::WriteFileAtomically(path, [&](std::ostream& out) {
    out << "P5\n" << w << " " << h << "\n255\n";
    out.write(reinterpret_cast<const char*>(px.data()), static_cast<std::streamsize>(px.size()));
  });
}

}  // namespace mlp::grey_image
