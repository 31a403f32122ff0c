// One primitive's stream decoded as a client would receive it: the loss
// simulator (loss_simulator.h) delivers the control blocks and datagrams,
// the stream reconstructor (stream_reconstructor.h) orders them and hands
// each refinement to the reader's recovery. A loss-free model takes exactly
// the same path, so decoding times compare fairly.
//
// Contract: pure (simulated time only); safe on hostile streams (errors, never
// crashes); the same inputs and seed give the same mesh. Thread safety: none
// needed.
#ifndef MESHSTREAM_CODEC_LOSS_LOSSY_DECODE_H_
#define MESHSTREAM_CODEC_LOSS_LOSSY_DECODE_H_

#include <cstdint>
#include <functional>
#include <vector>

#include "codec/loss/simulator.h"
#include "codec/bitstream/format.h"
#include "codec/loss/reconstructor.h"

namespace meshstream {

struct LossyDecodeOptions {
  LossModel loss;
  LinkTiming timing;
  ReconstructorOptions reconstructor;  // recovery and lod live here
  // The refinements whose datagrams travel reliably (reliable_cut.h; the
  // progressive .glb records them); empty: the paper's scheme.
  std::vector<uint32_t> reliable;
  // Parity datagrams (simulator.h); with a code, the reconstructor gets it
  // too unless reconstructor.erasure names one.
  SimulatedParity parity;
  // Called after each decoded level (1 = after the first refinement).
  std::function<void(size_t level, const StreamReader& reader)> on_level;
};

struct LossyDecodeReport {
  TransmissionStats transmission;
  ReconstructorStats reconstructor;
  RecoveryStats recovery;      // summed over refinements (stream_reader.h)
  uint64_t levels_applied = 0;
};

// `base` is the single-rate decoder's output (before fix-ups), as for
// StreamReader::SetBase. Returns the reader after the last decoded level.
StatusOr<StreamReader> DecodeStreamLossy(const ProgressiveStream& stream, uint32_t stream_id, QuantizedMesh base,
                                         const LossyDecodeOptions& options, LossyDecodeReport* report);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_LOSSY_DECODE_H_
