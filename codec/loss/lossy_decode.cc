#include "codec/loss/lossy_decode.h"

#include <algorithm>
#include <utility>

namespace meshstream {

StatusOr<StreamReader> DecodeStreamLossy(const ProgressiveStream& stream, uint32_t stream_id, QuantizedMesh base,
                                         const LossyDecodeOptions& options, LossyDecodeReport* report) {
  ReconstructorOptions reconstructor = options.reconstructor;
  if (reconstructor.erasure == nullptr) reconstructor.erasure = options.parity.code;
  // With parity, room to hold a refinement until its block's parity is in
  // (ReconstructorOptions::parity_hold_us): a block spans up to max_span
  // refinements and its parity follows the next one.
  if (reconstructor.erasure != nullptr) {
    reconstructor.window = std::max(reconstructor.window, options.parity.plan.max_span + 2);
  }
  MS_ASSIGN_OR_RETURN(StreamReconstructor rec, StreamReconstructor::Create(stream.header.data(), stream.header.size(),
                                                                           stream_id, reconstructor));
  // Refinements the reconstructor will decode; the simulator sends only those.
  const size_t refinements = std::min(stream.control.size(), rec.limit());
  MS_ASSIGN_OR_RETURN(Transmission sent,
                      SimulateTransmission(stream, stream_id, refinements, options.loss, options.timing,
                                           options.reliable, &options.parity));
  MS_RETURN_IF_ERROR(rec.SetBase(std::move(base)));

  // One refinement at a time, so that on_level sees every level, not only
  // the last of several that became ready together.
  auto drain = [&](uint64_t now_us, bool flushing) -> Status {
    for (;;) {
      MS_ASSIGN_OR_RETURN(bool did, rec.DecodeNext(now_us, flushing));
      if (!did) return Status::Ok();
      if (options.on_level) options.on_level(rec.applied(), rec.reader());
    }
  };
  for (const ChannelEvent& e : sent.events) {
    if (e.kind == ChannelEvent::Kind::kControl) {
      MS_RETURN_IF_ERROR(rec.OnControl(e.data, e.size, e.time_us));
      if (e.parity_follows) rec.ExpectParity(e.refinement);
    } else {
      rec.OnDatagram(e.data, e.size, e.time_us);
    }
    MS_RETURN_IF_ERROR(drain(e.time_us, false));
  }
  MS_RETURN_IF_ERROR(drain(0, true));  // the session is over: Flush, level by level

  if (report) {
    report->transmission = sent.stats;
    report->reconstructor = rec.stats();
    report->recovery = rec.reader().recovery_stats();
    report->levels_applied = rec.applied();
  }
  return std::move(rec.reader_);
}

}  // namespace meshstream
