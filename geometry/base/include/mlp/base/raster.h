#pragma once
/// @file Indexing a row-major raster (an image, a mask, a block map).

#include <cstddef>

namespace mlp::base {

/// Index of pixel (x, y) in a row-major raster `width` pixels wide. Computed in size_t: in int,
/// y * width would overflow before the widening, on a raster over 2^31 pixels
/// (clang-tidy bugprone-misplaced-widening-cast). Callers check x, y >= 0.
constexpr std::size_t RasterIndex(int x, int y, int width) {
  return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(x);
}

/// Number of pixels in a raster of width x height, in size_t.
constexpr std::size_t RasterSize(int width, int height) {
  return static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
}

}  // namespace mlp::base
