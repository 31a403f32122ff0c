// libFuzzer target for a client's view on the server
// (codec/progressive/view_order.h, reached through the protobuf translation
// of services/streaming/session_messages.h, the session plan and the session
// core, services/streaming/session_sender.h): the view comes from the
// client, so whatever its bytes the server refuses it with INVALID_ARGUMENT
// naming a field of `view`, or orders the session by it, and the session
// still sends every refinement of its plan once, each primitive's in its own
// order, with level lists that fit (non-decreasing, the last all of the
// primitive's refinements, the levels already begun unchanged); never a
// crash or a hang.
//
// Input: byte 0 shapes the plan (1-4 primitives, their boxes spread along
// x, y or z), byte 1 its refinements (0-6 per primitive, errors halving
// from a size set by the byte), byte 2 how many control blocks go before
// the view arrives mid-session; the rest is used twice:
//   1. as the bytes of a v1::ClientMessage (its `view`, when it has one);
//   2. structured: 19 doubles (camera, matrix) and two 16-bit viewport sides
//      copied from the bytes as they are (NaN, infinities, zeros included).
// Each view is checked by FromProto; a good one orders the plan at the open
// (ViewPlan) and mid-session (SessionSender::OnView).
// Any violation prints what went wrong and stops the fuzzer (__builtin_trap).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "codec/core/status.h"
#include "meshstream/v1/stream.pb.h"
#include "services/streaming/session_messages.h"
#include "services/streaming/session_plan.h"
#include "services/streaming/session_sender.h"
#include "tests/fuzz/fuzz_service_util.h"

namespace {

using namespace meshstream;

constexpr char kTarget[] = "fuzz_service_view";
[[noreturn]] void Bug(const std::string& what) { fuzz::FuzzBug(kTarget, what); }

struct Session {
  std::vector<uint8_t> artifact;
  SessionPlan plan;
};

// Refinements level by level (refinement 0 of every primitive, then 1 ...),
// one level per refinement of the largest; every datagram one byte.
Session MakeSession(uint8_t shape, uint8_t sizes) {
  Session s;
  const uint32_t primitives = shape % 4 + 1;
  const int axis = (shape / 4) % 3;
  uint64_t next = 1;
  uint32_t most = 0;
  for (uint32_t p = 0; p < primitives; ++p) {
    PlannedPrimitive pp;
    pp.stream = p;
    pp.header = {0, 1};
    pp.refinements = (sizes >> (2 * p)) % 4 + ((shape >> 6) & 1) * (p % 3);
    most = std::max(most, pp.refinements);
    double e = 1.0 + ((sizes >> p) & 3);
    for (uint32_t r = 0; r < pp.refinements; ++r, e /= 2) pp.residual_error.push_back(e);
    pp.residual_error.push_back(0);
    pp.has_bounds = true;
    pp.bounds.lo = {-1, -1, -1};
    pp.bounds.hi = {1, 1, 1};
    pp.bounds.lo[axis] = 2.0 * p - 1;
    pp.bounds.hi[axis] = 2.0 * p + 1;
    s.plan.primitives.push_back(pp);
  }
  s.plan.levels = most;
  for (uint32_t level = 1; level <= most; ++level) {
    for (uint32_t p = 0; p < primitives; ++p) {
      PlannedPrimitive& pp = s.plan.primitives[p];
      pp.level_refinements.push_back(std::min(level, pp.refinements));
      if (level > pp.refinements) continue;
      PlannedRefinement pr;
      pr.primitive = p;
      pr.refinement = level - 1;
      pr.level = level;
      pr.control = {next++, 1};
      pr.datagrams.push_back({next++, 1});
      s.plan.refinements.push_back(pr);
    }
  }
  s.artifact.assign(next, 0);
  s.artifact[0] = 1;
  return s;
}

// A plan's order and levels fit the refinements of `s`.
void CheckPlan(const Session& s, const SessionPlan& plan, const char* what) {
  std::set<std::pair<uint32_t, uint32_t>> want, got;
  for (const PlannedRefinement& r : s.plan.refinements) want.insert({r.primitive, r.refinement});
  std::vector<int64_t> last(plan.primitives.size(), -1);
  for (const PlannedRefinement& r : plan.refinements) {
    if (r.primitive >= plan.primitives.size()) Bug(std::string(what) + ": a refinement of no primitive");
    if (static_cast<int64_t>(r.refinement) != last[r.primitive] + 1) Bug(std::string(what) + ": out of its primitive's order");
    last[r.primitive] = r.refinement;
    if (!got.insert({r.primitive, r.refinement}).second) Bug(std::string(what) + ": a refinement twice");
  }
  if (got != want) Bug(std::string(what) + ": not the plan's refinements");
  for (const PlannedPrimitive& p : plan.primitives) {
    if (p.level_refinements.size() != plan.levels) Bug(std::string(what) + ": a level list of another length");
    for (size_t l = 0; l < p.level_refinements.size(); ++l) {
      if (l > 0 && p.level_refinements[l] < p.level_refinements[l - 1]) Bug(std::string(what) + ": a level list decreases");
    }
    if (!p.level_refinements.empty() && p.level_refinements.back() != p.refinements) {
      Bug(std::string(what) + ": the last level is not every refinement");
    }
  }
}

void Check(const Session& s, const StatusOr<View>& view, uint8_t begun_before) {
  if (!view.ok()) {
    if (view.status().code() != StatusCode::kInvalidArgument) Bug("not INVALID_ARGUMENT: " + view.status().ToString());
    if (view.status().message().rfind("view.", 0) != 0) Bug("does not name a field of view: " + view.status().message());
    return;
  }
  CheckPlan(s, ViewPlan(s.plan, view.value(), -1), "ViewPlan");
  const SessionPlan cut = ViewPlan(s.plan, view.value(), 1);
  if (cut.levels > 1) Bug("ViewPlan at level 1 has more levels");

  // Mid-session: the view after `begun_before` control blocks.
  SessionSenderOptions options;
  options.idle_timeout_us = 0;
  SessionSender sender(s.plan, s.artifact, -1, options, 0);
  uint64_t now = 0;
  std::vector<std::pair<uint32_t, uint32_t>> sent;
  const size_t view_at = begun_before % (s.plan.refinements.size() + 1);
  bool viewed = false;
  std::vector<std::vector<uint32_t>> before;
  for (const PlannedPrimitive& p : s.plan.primitives) before.push_back(p.level_refinements);
  for (int step = 0; step < 100000; ++step) {
    if (!viewed && sent.size() == view_at) {
      sender.OnView(now, view.value());
      viewed = true;
    }
    SenderAction a = sender.Next(now);
    switch (a.kind) {
      case SenderAction::kWait:
        if (a.due_us == SenderAction::kNever) Bug("the session waits for nothing");
        now = a.due_us;
        break;
      case SenderAction::kControl:
        sent.push_back({a.refinement->primitive, a.refinement->refinement});
        break;
      case SenderAction::kLevels: {
        if (a.first_changed_level == 0 || a.first_changed_level > s.plan.levels) Bug("a first changed level out of range");
        const SessionPlan& now_plan = sender.plan();
        CheckPlan(s, now_plan, "the reordered plan");
        for (size_t p = 0; p < before.size(); ++p) {
          for (uint32_t l = 1; l < a.first_changed_level; ++l) {
            if (now_plan.primitives[p].level_refinements[l - 1] != before[p][l - 1]) Bug("a level before the first changed one moved");
          }
        }
        for (size_t k = 0; k < sent.size(); ++k) {
          if (now_plan.refinements[k].primitive != sent[k].first || now_plan.refinements[k].refinement != sent[k].second) {
            Bug("a refinement already begun moved");
          }
        }
        const v1::ServerMessage m = LevelPlanMessage(now_plan, a.first_changed_level);
        if (static_cast<size_t>(m.levels().primitives_size()) != s.plan.primitives.size()) Bug("a LevelPlan of other primitives");
        break;
      }
      case SenderAction::kFinish: {
        if (!a.status.ok()) Bug("the session ended " + a.status.ToString());
        std::set<std::pair<uint32_t, uint32_t>> want, got(sent.begin(), sent.end());
        for (const PlannedRefinement& r : s.plan.refinements) want.insert({r.primitive, r.refinement});
        if (got != want || sent.size() != want.size()) Bug("the session did not send every refinement once");
        return;
      }
      case SenderAction::kEnd:
        sender.OnClientClosed(now, false);
        break;
      default:
        break;
    }
  }
  Bug("the session never finished");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  const Session s = MakeSession(data[0], data[1]);
  const uint8_t begun = data[2];
  const uint8_t* rest = data + 3;
  const size_t left = size - 3;

  v1::ClientMessage message;
  if (message.ParseFromArray(rest, static_cast<int>(left)) && message.has_view()) {
    Check(s, FromProto(message.view()), begun);
  }
  if (left >= 19 * sizeof(double) + 4) {
    v1::View v;
    double d[19];
    std::memcpy(d, rest, sizeof d);
    for (int i = 0; i < 3; ++i) v.add_camera_position(d[i]);
    for (int i = 3; i < 19; ++i) v.add_view_projection(d[i]);
    uint16_t w, h;
    std::memcpy(&w, rest + sizeof d, 2);
    std::memcpy(&h, rest + sizeof d + 2, 2);
    v.set_viewport_width(w);
    v.set_viewport_height(h);
    Check(s, FromProto(v), begun);
  }
  return 0;
}
