// libFuzzer target for the UDP packet layer (net/): arbitrary bytes as a
// received datagram, and the same bytes as a script of packets to seal.
//
// 1. The whole input is a datagram: ParseHeader, then OpenPacket under fixed
//    session keys for both directions, then, for one that opens, the HELLO or
//    HELLO_ACK parser and a ReplayWindow.
// 2. The input read as records (type, 8-byte packet number, 1-byte length,
//    that many payload bytes) is sealed, opened and fed to a ReplayWindow.
//
// Invariants (a violation stops the fuzzer with __builtin_trap):
//   - a datagram that opens re-seals, from its parsed header and plaintext
//     under the same key, to exactly the input bytes (nothing is accepted that
//     did not authenticate as it stands);
//   - a datagram never opens under the other direction's key nor for the
//     other direction; a refusal leaves the output untouched;
//   - OpenPacket agrees with ParseHeader on every header reason;
//   - what SealPacket makes opens to the same header and payload;
//   - a ReplayWindow never accepts one number twice, and refuses only what is
//     a duplicate or at least kWindow below the highest accepted.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <set>
#include <vector>

#include "net/drop_reason.h"
#include "net/hello.h"
#include "net/packet_crypto.h"
#include "net/packet_header.h"
#include "net/replay_window.h"

namespace {

using namespace meshstream;

PacketKey Key(uint8_t first) {
  PacketKey k;
  for (size_t i = 0; i < k.size(); ++i) k[i] = static_cast<uint8_t>(first + i);
  return k;
}

// The keys of the committed seeds (tests/fuzz/corpus/net_packet/).
const SessionKeys& Keys() {
  static const SessionKeys keys{Key(0x20), Key(0x00)};
  return keys;
}

void Check(bool ok) {
  if (!ok) __builtin_trap();
}

class ModelWindow {
 public:
  void Feed(uint64_t n) {
    const DropReason r = window_.Accept(n);
    const bool seen = accepted_.count(n) != 0;
    if (r == DropReason::kNone) {
      Check(!seen);
      accepted_.insert(n);
      if (accepted_.size() == 1 || n > highest_) highest_ = n;
    } else if (r == DropReason::kReplayed) {
      Check(seen);
    } else {
      Check(r == DropReason::kTooOld && !accepted_.empty() && highest_ - n >= ReplayWindow::kWindow);
    }
  }

 private:
  ReplayWindow window_;
  std::set<uint64_t> accepted_;
  uint64_t highest_ = 0;
};

void AsDatagram(const uint8_t* data, size_t size) {
  PacketHeader header;
  const DropReason parsed = ParseHeader(data, size, &header);
  for (Direction incoming : {Direction::kClientToServer, Direction::kServerToClient}) {
    for (const PacketKey* key : {&Keys().client_to_server, &Keys().server_to_client}) {
      OpenedPacket out;
      out.payload = {0xAB};
      const DropReason r = OpenPacket(data, size, incoming, *key, &out);
      if (parsed != DropReason::kNone) Check(r == parsed);
      if (r != DropReason::kNone) {
        Check(out.payload.size() == 1 && out.payload[0] == 0xAB);
        continue;
      }
      Check(parsed == DropReason::kNone && DirectionOf(header.type) == incoming && key == &KeyFor(Keys(), header.type));
      Check(out.header.type == header.type && out.header.session_id == header.session_id &&
            out.header.packet_number == header.packet_number);
      const auto resealed = SealPacket(header.type, header.session_id, header.packet_number, *key,
                                       out.payload.data(), out.payload.size());
      Check(resealed.ok() && resealed->size() == size && std::equal(resealed->begin(), resealed->end(), data));
      if (header.type == PacketType::kHello) {
        const auto echo = ParseHelloPayload(out.payload);
        Check(echo.ok() == (out.payload.size() == kHelloPayloadBytes &&
                            std::all_of(out.payload.begin() + kChallengeBytes, out.payload.end(),
                                        [](uint8_t b) { return b == 0; })));
      } else if (header.type == PacketType::kHelloAck) {
        Check(ParseHelloAckPayload(out.payload).ok() == (out.payload.size() == kHelloAckPayloadBytes));
      }
      ModelWindow window;
      window.Feed(header.packet_number);
      window.Feed(header.packet_number);
    }
  }
}

void AsScript(const uint8_t* data, size_t size) {
  ModelWindow window;
  size_t pos = 0;
  while (size - pos >= 10) {
    const PacketType type = static_cast<PacketType>(1 + data[pos] % 3);
    uint64_t pn = 0;
    for (int i = 0; i < 8; ++i) pn |= static_cast<uint64_t>(data[pos + 1 + i]) << (8 * i);
    size_t length = data[pos + 9];
    pos += 10;
    if (length > size - pos) length = size - pos;
    const auto sealed = SealPacket(type, 0x0123456789ABCDEFull, pn, KeyFor(Keys(), type), data + pos, length);
    pos += length;
    Check(sealed.ok() && sealed->size() == length + kPacketOverheadBytes);
    OpenedPacket out;
    Check(OpenPacket(sealed->data(), sealed->size(), DirectionOf(type), KeyFor(Keys(), type), &out) ==
          DropReason::kNone);
    Check(out.header.type == type && out.header.packet_number == pn && out.payload.size() == length &&
          std::equal(out.payload.begin(), out.payload.end(), data + pos - length));
    window.Feed(pn);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  AsDatagram(data, size);
  AsScript(data, size);
  return 0;
}
