// What losing one datagram alone does to the final mesh (docs/loss-
// protection.md, "Harm per byte"): for every data datagram of a stream, the
// stream is decoded with that datagram lost and everything else arrived
// (recovery by prediction, as a client does), and the final level is
// compared with the loss-free one by the symmetric point-to-surface
// Hausdorff distance (codec/metrics/hausdorff.h), relative to the loss-free
// final level's bounding-box diagonal: the metric the loss targets use, as a
// maximum, not a sum of importances.
//
// The distance is measured on the part that changed: the faces of either
// mesh around every vertex whose position or faces differ, two rings wide
// (the rest of the two surfaces is the same). That is the full distance
// whenever the closest points lie within the two rings, and never below it
// otherwise (a missing far face can only make a point look farther).
//
// Cost: one decode of the refinements from the lost one on, plus a local
// distance, per datagram; the reader before each refinement is kept once.
// The runner (when given, with more than one worker) takes the datagrams in
// parallel.
//
// Contract: pure; safe on any stream the reader accepts (its errors are
// returned). Thread safety: none needed.
#ifndef MESHSTREAM_CODEC_LOSS_DATAGRAM_HARM_H_
#define MESHSTREAM_CODEC_LOSS_DATAGRAM_HARM_H_

#include <cstdint>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/status.h"
#include "codec/core/task_runner.h"
#include "codec/mesh/quantized_mesh.h"

namespace meshstream {

// harm[i][d]: the single-loss distance of stream.datagrams[i][d], a share of
// the diagonal (0: the final mesh is the loss-free one).
struct DatagramHarm {
  std::vector<std::vector<double>> harm;
  double diagonal = 0;  // the loss-free final level's, in model units
  // The largest harm of refinement i's datagrams.
  double RefinementMax(size_t i) const;
};

// What the encoder measures by default, in a fraction of the time: a
// refinement deals its splits round-robin to its datagrams, so they harm
// alike (docs/design/loss-protection.md has the measurements); one datagram per
// refinement (its largest) is measured, finest refinement first, and once
// `stop_after` refinements in a row harm more than `stop_above` the coarser
// ones (which harm more still) are not measured but given the largest value
// measured: a lower bound, which is all the choice of protection needs.
struct HarmOptions {
  bool every_datagram = false;
  double stop_above = 0.0025;
  int stop_after = 2;
  // EstimateDatagramHarm: a refinement with finer ones after it counts
  // this many times its local distance (< 0: kSpreadMargin).
  double spread_margin = -1;
};

// `base` is the single-rate decoder's output (StreamReader::SetBase).
// With every_datagram, harm[i][d] for every datagram; otherwise harm[i] has
// one entry per refinement (empty for a refinement without datagrams).
StatusOr<DatagramHarm> MeasureDatagramHarm(const ProgressiveStream& stream, const QuantizedMesh& base,
                                           TaskRunner* runner = nullptr, const HarmOptions& options = {});

// The encoder's estimate of the same (docs/design/loss-protection.md, "The harm
// estimate"), at about the cost of two decodes instead of one decode per
// refinement: for each refinement, the refinement alone is decoded again
// from the loss-free state before it, without the datagrams measured, and
// recovered by prediction as a client does; a split's local distance is the
// largest distance of its two vertices (w and the new one) as predicted
// from the fans (the triangles of both) as coded, and of the coded ones from
// the predicted fans. A datagram's harm is the largest local distance of the
// splits whose units it carries (a seam pair's secondary counts where its
// own ordinal is), a share of the final level's bounding-box diagonal.
// By default, as MeasureDatagramHarm's default, a refinement's datagrams are
// taken to harm alike (round-robin over the refinement): its largest
// structure and its largest geometry datagram are measured (lost together
// when they carry different splits) and harm[i] has one entry, the larger;
// with every_datagram, harm[i] has one per datagram (all structure
// datagrams lost in one decode, all geometry ones in another: under the
// batch rule a refinement's splits do not touch each other's rings, so each
// split is predicted as its own datagram's loss would predict it).
// What the local distance leaves out is the spread to finer refinements (a
// ring a prediction changed makes later splits on it predicted too), which
// the measure includes: on the shared models the local distance of a
// refinement with finer ones after it is 0.37-1.0 of the measure (median
// about 0.65; at the finest refinement 1.0), so such a refinement's harm is
// kSpreadMargin times it. With it, the tiers (protection.h) of the five
// shared models are those the measure gives but for two of the bunny's
// refinements, which get strong parity where the measure says parity
// (docs/design/loss-protection.md, "The harm estimate"; the loss bench's
// `datagram_harm_estimate` beside `datagram_harm`).
// Contract: as MeasureDatagramHarm (stop_above and stop_after unused).
constexpr double kSpreadMargin = 1.5;
StatusOr<DatagramHarm> EstimateDatagramHarm(const ProgressiveStream& stream, const QuantizedMesh& base,
                                            TaskRunner* runner = nullptr, const HarmOptions& options = {});

// The distance between two final levels of one stream decoded in canonical
// order (same vertex count), measured on what differs, as above; a share of
// `diagonal` (model units). 0 when nothing differs.
StatusOr<double> LocalHausdorff(const QuantizedMesh& a, const QuantizedMesh& b, double diagonal);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_DATAGRAM_HARM_H_
