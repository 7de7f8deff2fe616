#pragma once
/// @file Grey images for the virtual cameras (host/toolcam, host/grind): the optics' blur and
/// the frames written as a camera would leave them. Hand-written: OpenCV would bring its
/// libraries into every library that renders, for two loops.

#include <cstdint>
#include <string>
#include <vector>

namespace mlp::grey_image {

/// Separable Gaussian blur (the optics' point spread), kernel to 3 sigma, edges clamped;
/// sigma <= 0 leaves the image as it is.
void GaussianBlur(std::vector<double>* image, int width, int height, double sigma);

/// Writes an 8-bit binary PGM (P5) whole or not at all (a temporary file, then rename);
/// throws std::runtime_error naming the file.
void WritePgm(const std::string& path, int width, int height, const std::vector<std::uint8_t>& px);

}  // namespace mlp::grey_image
