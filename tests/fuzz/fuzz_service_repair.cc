// libFuzzer target for a client's RepairRequest on the server
// (services/streaming/repair_request.h, reached through the protobuf
// translation of services/streaming/session_messages.h and the session core,
// services/streaming/session_sender.h): the request comes from the client,
// so whatever its bytes the server answers with the datagrams it names,
// each once, or INVALID_ARGUMENT naming the first item that does not fit
// (or the item count, beyond one per refinement of the plan); never a
// crash, never a datagram of another session, never more than the plan
// holds.
//
// Input: byte 0 shapes the session's plan (1-3 primitives with wire stream
// ids 0, 5 and 2^31 + 7), byte 1 its refinements (0-4 per primitive) and
// datagrams (0-5 per refinement); the rest is used twice:
//   1. as the bytes of a v1::RepairRequest (what arrives on the stream);
//   2. structured, to reach deep items without protobuf framing: per item a
//      byte picking the stream (an id of the plan, or a raw one), a byte of
//      refinement, a byte of count and that many ordinal bytes.
// Each request is judged by RepairDatagrams against an oracle written here
// independently, and then handed to a SessionSender opened with repair,
// which must send exactly those datagrams on the stream and a RepairEnd
// that counts them, or end the call with the same INVALID_ARGUMENT.
// Any violation prints what went wrong and stops the fuzzer (__builtin_trap).
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "codec/core/status.h"
#include "meshstream/v1/stream.pb.h"
#include "services/streaming/session_messages.h"
#include "services/streaming/repair_request.h"
#include "services/streaming/session_sender.h"
#include "tests/fuzz/fuzz_service_util.h"

namespace {

using namespace meshstream;

constexpr char kTarget[] = "fuzz_service_repair";
[[noreturn]] void Bug(const std::string& what) { fuzz::FuzzBug(kTarget, what); }

constexpr uint32_t kStreams[] = {0, 5, 0x80000007u};

struct Session {
  std::vector<uint8_t> artifact;
  SessionPlan plan;
};

// Every datagram of the plan its own range (offset = its index), so a
// range names its datagram.
Session MakeSession(uint8_t shape, uint8_t sizes) {
  Session s;
  const uint32_t primitives = shape % 3 + 1;
  uint64_t next = 1;  // byte 0: the stream version
  for (uint32_t p = 0; p < primitives; ++p) {
    PlannedPrimitive pp;
    pp.stream = kStreams[p];
    pp.header = {0, 1};
    const uint32_t refinements = (sizes >> (2 * p)) % 5;
    pp.refinements = refinements;
    s.plan.primitives.push_back(pp);
    for (uint32_t r = 0; r < refinements; ++r) {
      PlannedRefinement pr;
      pr.primitive = p;
      pr.refinement = r;
      const uint32_t datagrams = (shape / 3 + r + p) % 6;
      for (uint32_t k = 0; k < datagrams; ++k) pr.datagrams.push_back({next++, 1});
      s.plan.refinements.push_back(pr);
    }
  }
  s.artifact.assign(next, 0);
  s.artifact[0] = 1;
  return s;
}

// The oracle: (offsets of the datagrams named, each once, in first-named
// order), or too many items, or the index of the first item that does not fit.
struct Expected {
  bool ok = true;
  bool too_many = false;
  size_t bad_item = 0;
  std::vector<uint64_t> offsets;
};

Expected Judge(const Session& s, const std::vector<RepairItem>& items) {
  Expected e;
  if (items.size() > s.plan.refinements.size()) return Expected{false, true, 0, {}};
  std::set<std::tuple<uint32_t, uint32_t, uint32_t>> seen;
  for (size_t i = 0; i < items.size(); ++i) {
    const PlannedRefinement* found = nullptr;
    for (const PlannedRefinement& r : s.plan.refinements) {
      if (s.plan.primitives[r.primitive].stream == items[i].stream && r.refinement == items[i].refinement) found = &r;
    }
    if (found == nullptr) return Expected{false, false, i, {}};
    for (uint32_t k : items[i].datagrams) {
      if (k >= found->datagrams.size()) return Expected{false, false, i, {}};
      if (seen.insert({items[i].stream, items[i].refinement, k}).second) e.offsets.push_back(found->datagrams[k].offset);
    }
  }
  return e;
}

void Check(const Session& s, const std::vector<RepairItem>& items) {
  const Expected want = Judge(s, items);
  auto got = RepairDatagrams(s.plan, items);
  size_t total = 0;
  for (const PlannedRefinement& r : s.plan.refinements) total += r.datagrams.size();
  if (want.ok) {
    if (!got.ok()) Bug("refused a fitting request: " + got.status().ToString());
    if (got->size() > total) Bug("more datagrams than the plan holds");
    std::vector<uint64_t> offsets;
    for (const ByteRange& r : got.value()) offsets.push_back(r.offset);
    if (offsets != want.offsets) Bug("not the datagrams named, once each, in order");
  } else {
    if (got.ok()) Bug("accepted a request that does not fit");
    if (got.status().code() != StatusCode::kInvalidArgument) Bug("not INVALID_ARGUMENT: " + got.status().ToString());
    const std::string where =
        want.too_many ? "repair: " + std::to_string(items.size()) + " items, more than the " +
                            std::to_string(s.plan.refinements.size()) + " refinements"
                      : "repair.items[" + std::to_string(want.bad_item) + "]";
    if (got.status().message().rfind(where, 0) != 0) Bug("does not name " + where + ": " + got.status().message());
  }

  // The session core with repair: the same datagrams on the stream, then RepairEnd.
  SessionSenderOptions options;
  options.repair = true;
  options.idle_timeout_us = 0;
  SessionSender sender(s.plan, s.artifact, -1, options, 0);
  uint64_t now = 0;
  bool ended = false;
  std::vector<uint64_t> sent;
  for (int step = 0; step < 100000; ++step) {
    SenderAction a = sender.Next(now);
    if (a.kind == SenderAction::kWait) {
      if (a.due_us == SenderAction::kNever) Bug("the session waits for nothing");
      now = a.due_us;
      continue;
    }
    if (a.kind == SenderAction::kEnd) {
      ended = true;
      sender.OnRepair(now, items);
      continue;
    }
    if (a.kind == SenderAction::kDatagrams && ended) {
      for (const auto& d : a.datagrams) {
        if (d.first < s.artifact.data() || d.first + d.second > s.artifact.data() + s.artifact.size()) {
          Bug("a repaired datagram outside the artifact");
        }
        sent.push_back(static_cast<uint64_t>(d.first - s.artifact.data()));
      }
    }
    if (a.kind == SenderAction::kRepairEnd) {
      if (!want.ok) Bug("RepairEnd for a refused request");
      if (a.count != sent.size() || sent != want.offsets) Bug("the session repaired other datagrams");
    }
    if (a.kind == SenderAction::kFinish) {
      if (want.ok != a.status.ok()) Bug("the session ended " + a.status.ToString());
      return;
    }
  }
  Bug("the session never finished");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const Session s = MakeSession(data[0], data[1]);
  const uint8_t* rest = data + 2;
  const size_t left = size - 2;

  v1::RepairRequest request;
  if (request.ParseFromArray(rest, static_cast<int>(left))) Check(s, FromProto(request));

  std::vector<RepairItem> items;
  size_t at = 0;
  while (at + 3 <= left && items.size() < 64) {
    RepairItem item;
    const uint8_t pick = rest[at];
    item.stream = pick < 192 ? kStreams[pick % 3] : pick;
    item.refinement = rest[at + 1] % 8;
    const size_t count = rest[at + 2] % 16;
    at += 3;
    for (size_t i = 0; i < count && at < left; ++i) item.datagrams.push_back(rest[at++] % 8);
    items.push_back(item);
  }
  Check(s, items);
  return 0;
}
