#pragma once
/// @file Laser speckle with a grain: the coherent image of a rough surface (Goodman, "Speckle
/// Phenomena in Optics", Roberts 2007, ch. 4-5). The surface gives each scatterer an independent
/// phase, uniform over 2 pi (roughness beyond the wavelength); the lens is a circular pupil, so
/// the image field is the object field convolved with the Airy amplitude 2 J1(v) / v; the pixel
/// integrates |field|^2 over its area. The grain then comes from the aperture: the intensity's
/// correlation first falls to zero at the Airy radius 1.22 lambda N (the image-side f-number),
/// and the stripe centre's scatter is that of Dorsch, Haeusler and Herrmann (Appl. Opt. 33(7),
/// 1994). The phases belong to the surface: fixed while the mirror sweeps, so the speckle of one
/// pixel changes only as the sheet moves over the scatterers around it, as on a real part.
///
/// Partly developed speckle (contrast C < 1: polarisation and wavelength diversity, a laser whose
/// coherence length is short against the roughness depth) is a fraction C of the light adding
/// coherently and 1 - C adding in intensity: the mixture has contrast C.
///
/// Hand-written: OpenCV's filters are real-valued and need the whole image; this is a sparse
/// complex convolution over the few sub-samples the sheet lights.

#include <complex>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace mlp::sim {

class SpeckleImager {
 public:
  /// airy_radius_px: first dark ring of the intensity PSF on the sensor, 1.22 lambda N / pitch;
  /// contrast in [0, 1]; seed: the surface's phases.
  SpeckleImager(
      int width_px, int height_px, double airy_radius_px, double contrast, std::uint64_t seed);

  /// Sub-samples per pixel along each axis (the field is sampled finer than its Nyquist limit).
  int Oversampling() const { return q_; }
  /// The object irradiance [e-, as a pixel would collect it] at the sub-samples, row-major,
  /// width_px q x height_px q, sub-sample (a, b) of pixel (x, y) at (x - 1/2 + (a + 1/2) / q, ...).
  /// Fill it (zero where no light falls), then call Image.
  std::vector<float>& Irradiance() { return irradiance_; }
  /// Mean electrons per pixel (row-major width_px x height_px) of the speckled image of the
  /// irradiance; clears the irradiance for the next frame.
  void Image(std::vector<double>* pixel_e);

 private:
  /// (re, im, incoherent, unused): a sub-sample's field and light, or a tap's weights of them.
  using Cell = Eigen::Array4f;
  struct KernelRow {
    int dy = 0, dx0 = 0;     ///< the row's offset and its first tap's
    std::vector<Cell> taps;  ///< (amplitude, amplitude, amplitude^2, 0), contiguous in dx
  };
  void Scatter(int x, int y, std::complex<float> a, float e);

  int w_, h_, q_, reach_ = 0;
  double contrast_;
  std::vector<KernelRow> kernel_;
  std::vector<std::complex<float>> phase_;  ///< per sub-sample, the surface's
  std::vector<float> irradiance_;
  /// The image field (real, imaginary) and the incoherent light per sub-sample, side by side
  /// (one vector operation per tap), with a margin of reach_ all round so the kernel needs no
  /// bounds test.
  std::vector<Cell> field_;
  std::vector<int> lit_lo_, lit_hi_;  ///< lit sub-columns per sub-row of this frame
};

}  // namespace mlp::sim
