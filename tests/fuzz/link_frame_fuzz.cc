// libFuzzer target: arbitrary bytes from the network into the link's frame parser and every
// payload decoder behind it (hello, auth, cloud, capture request, status, error, ack, session).
// Only typed LinkErrors may come out; anything else (a crash, an ASan/UBSan report, another
// exception) is a finding. Built and run by scripts/fuzz-link.sh.

#include "mlp/link/auth.h"
#include "mlp/link/cloud_codec.h"
#include "mlp/link/messages.h"
#include "mlp/link/wire.h"

#include <cstddef>
#include <cstdint>

using namespace mlp::link;

namespace {

// What a host does with a frame; a LinkError is the expected answer to garbage.
void Dispatch(HostHandshake& host, Session& session, const Frame& f) {
  try {
    switch (f.type) {
      case MessageType::kHello:
        host.OnHello(f);
        break;
      case MessageType::kAuth:
        host.OnAuth(f);
        break;
      case MessageType::kCloud:
        DecodeCloud(f.payload);
        break;
      case MessageType::kCaptureRequest:
        DecodeCaptureRequest(f.payload);
        break;
      case MessageType::kStatus:
        DecodeStatus(f.payload);
        break;
      case MessageType::kError:
        DecodeError(f.payload);
        break;
      case MessageType::kAck:
        DecodeAck(f.payload);
        break;
      default:
        session.Open(f);
        break;
    }
  } catch (const LinkError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // The first byte sets how the stream is cut into reads, as TCP would.
  const std::size_t piece = 1 + data[0] % 64;
  Parser parser;
  HostHandshake host([](const std::string&) -> std::optional<Key> { return Key{Bytes(32, 1)}; });
  Session session(Bytes(32, 2), Bytes(32, 3));
  try {
    for (std::size_t at = 1; at < size; at += piece) {
      parser.Feed(data + at, std::min(piece, size - at));
      Frame f;
      while (parser.Next(&f)) Dispatch(host, session, f);
    }
  } catch (const LinkError&) {
  }
  // Random bytes rarely carry a valid CRC: also hand them to every payload decoder directly.
  Frame direct;
  direct.type = static_cast<MessageType>(1 + data[0] % 9);
  direct.payload.assign(data + 1, data + size);
  Dispatch(host, session, direct);
  return 0;
}
