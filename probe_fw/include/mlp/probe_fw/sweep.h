#pragma once
/// @file A capture as the firmware takes it: the camera armed for the request's window and
/// exposure, the LED frame under the LED ring, then one laser frame per projector column with
/// the mirror settled there. Cameras behind one interface: the board's V4L2 sensor, and frames
/// recorded (or rendered) before, which answer what the projector lights now.

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/frame_io.h"
#include "mlp/probe_fw/projector.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace mlp::probe_fw {

/// What one capture asks of the camera and the light.
struct SweepPlan {
  Aoi aoi;                      ///< sensor window [px]
  double exposure_us = 100.0;   ///< per frame
  std::vector<double> columns;  ///< the laser frames' projector columns, in sweep order
};

/// A camera armed for one sweep: one frame per call, exposed while the projector holds still.
class FrameGrabber {
 public:
  virtual ~FrameGrabber() = default;
  /// Throws FrameIoError when the camera fails or delivers nothing.
  virtual void Grab(Frame* frame) = 0;
  /// Frames the sensor delivered that the firmware never read (its buffers were full).
  virtual std::uint64_t Dropped() const { return 0; }
};

/// LED on, the LED frame, LED off; laser on; per column: mirror there, one frame; laser off.
/// The laser and the LEDs are off when this returns, also by an exception. Frames come back
/// tagged with what lit them (laser_column < 0: the LED frame).
std::vector<Frame> TakeSweep(Projector& projector, FrameGrabber& camera, const SweepPlan& plan);

/// A camera that sees recorded frames: each grab returns the recorded frame for what
/// `projector` lights now (the LED frame under the LEDs; under the laser the frame recorded at
/// the mirror's column, to 1e-6 column). Throws FrameIoError when nothing was recorded so lit.
std::unique_ptr<FrameGrabber> MakeRecordedCamera(std::vector<Frame> frames,
                                                 const Projector& projector);

/// The board's camera (V4L2, 8-bit GREY or 16-bit Y16, memory-mapped streaming) armed for the
/// window and exposure. Throws FrameIoError naming the device and the reason when there is no
/// such camera or it cannot deliver the window.
/// Opens `device` and asks whether it is a V4L2 camera that streams (the check a service makes at
/// start, before a request arms it). Throws FrameIoError naming the device and the reason.
void CheckV4l2Camera(const std::string& device);

std::unique_ptr<FrameGrabber> OpenV4l2Camera(const std::string& device,
                                             const SweepPlan& plan,
                                             int bit_depth);

}  // namespace mlp::probe_fw
