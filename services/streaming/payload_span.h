// A run of datagram payloads, each (bytes, length), viewed and not owned:
// what SessionSender hands out in a kDatagrams action (session_sender.h, a
// view into the sender) and what UdpEndpoint::Session::SendData seals.
//
// Contract: valid as long as the storage it views; it never copies.
// Thread safety: as the viewed storage.
#ifndef MESHSTREAM_SERVICES_STREAMING_PAYLOAD_SPAN_H_
#define MESHSTREAM_SERVICES_STREAMING_PAYLOAD_SPAN_H_

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace meshstream {

using DatagramPayload = std::pair<const uint8_t*, size_t>;

class PayloadSpan {
 public:
  PayloadSpan() = default;
  PayloadSpan(const DatagramPayload* data, size_t size) : data_(data), size_(size) {}
  // Implicit: a view of the whole vector.
  PayloadSpan(const std::vector<DatagramPayload>& v) : data_(v.data()), size_(v.size()) {}  // NOLINT

  const DatagramPayload* begin() const { return data_; }
  const DatagramPayload* end() const { return data_ + size_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const DatagramPayload& operator[](size_t i) const { return data_[i]; }

 private:
  const DatagramPayload* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_STREAMING_PAYLOAD_SPAN_H_
