#pragma once
// The board's devices through Linux system calls (private to probe_fw): ioctl retried on EINTR,
// and an error text that names the device, what failed and the system's reason.

#include <cerrno>
#include <cstring>
#include <string>

#include <sys/ioctl.h>

namespace mlp::probe_fw::device_io {

/// ioctl(2), retried while a signal interrupts it (as the V4L2 and spidev examples do).
inline int Ioctl(int fd, unsigned long request, void* arg) {
  int r;
  do r = ioctl(fd, request, arg);
  while (r == -1 && errno == EINTR);
  return r;
}

/// "<prefix><device> <what>: <strerror>", with `if_missing` added when the device is not there.
inline std::string Describe(const std::string& prefix,
                            const std::string& device,
                            const std::string& what,
                            int err,
                            const std::string& if_missing) {
  std::string message = prefix + device + " " + what;
  if (err != 0) message += std::string(": ") + std::strerror(err);
  if (err == ENOENT) message += " (" + if_missing + ")";
  return message;
}

}  // namespace mlp::probe_fw::device_io
