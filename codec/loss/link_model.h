// One direction of a lossy datagram link as a seeded sequence of fates:
// loss (independent, or in bursts by a two-state Gilbert-Elliott chain),
// a one-way delay with jitter (so reordering), extra reordering, and
// duplicates. The one model of a link that the tests' UDP relay
// (testing/udp_relay.h, real sockets) and the session cores' simulated
// network (tests/sessions/) both draw from, so a run of the relay with a
// seed can be replayed in process with the same fates.
//
// Gilbert-Elliott: per datagram the chain moves good -> bad with p_bad and
// bad -> good with p_good, then the datagram is lost with loss_good or
// loss_bad of its state. The stationary share of bad is
// p_bad / (p_bad + p_good), so the mean loss is
// (p_good * loss_good + p_bad * loss_bad) / (p_bad + p_good), and with
// loss_bad 1 and loss_good 0 a bad spell lasts 1 / p_good datagrams on
// average (Bursts()). With p_bad 0 the loss is independent (`loss`).
//
// Contract: pure and deterministic: the same model and seed give the same
// fates in the same order (std::mt19937_64, no global state). The draws per
// datagram are, in order: the chain's step and the loss (two, Gilbert-
// Elliott) or the loss (one, when `loss` > 0); if delivered, the duplicate
// (when `duplicate` > 0); then per copy the jitter (when `jitter_us` > 0)
// and the reorder (when `reorder` > 0). Thread safety: one SimulatedLink
// per thread.
#ifndef MESHSTREAM_CODEC_LOSS_LINK_MODEL_H_
#define MESHSTREAM_CODEC_LOSS_LINK_MODEL_H_

#include <cstdint>
#include <random>

#include "codec/core/status.h"

namespace meshstream {

struct LinkModel {
  double loss = 0;              // independent loss (used when p_bad == 0)
  double p_bad = 0;             // Gilbert-Elliott: good -> bad per datagram
  double p_good = 1;            //                  bad -> good per datagram
  double loss_good = 0, loss_bad = 1;
  uint64_t delay_us = 0;        // every datagram
  uint64_t jitter_us = 0;       // plus uniform [0, jitter)
  double reorder = 0;           // this share is held back another `reorder_us`
  uint64_t reorder_us = 5000;
  double duplicate = 0;         // this share is delivered twice
  uint64_t seed = 1;

  // Independent loss with probability `p`.
  static LinkModel Loss(double p, uint64_t seed = 1);
  // Bursts with mean loss `mean` and mean bad spell `burst` datagrams (loss 1
  // in bad, 0 in good); `burst` <= 1 is independent loss.
  static LinkModel Bursts(double mean, double burst, uint64_t seed = 1);

  // The long-run share of datagrams lost.
  double mean_loss() const;
  // InvalidArgument naming the field out of range (probabilities in [0, 1],
  // p_good > 0 when p_bad > 0).
  Status Validate() const;
};

// What happens to one datagram: `copies` arrive (0: lost, 2: duplicated),
// copy i after delay_us[i].
struct DatagramFate {
  int copies = 1;
  uint64_t delay_us[2] = {0, 0};
};

class SimulatedLink {
 public:
  // The generator seeded with `seed` (a link's two directions pass two).
  SimulatedLink(const LinkModel& model, uint64_t seed) : model_(model), rng_(seed) {}
  explicit SimulatedLink(const LinkModel& model) : SimulatedLink(model, model.seed) {}

  // The fate of the next datagram.
  DatagramFate Next();
  const LinkModel& model() const { return model_; }

 private:
  double Uniform() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_); }

  LinkModel model_;
  std::mt19937_64 rng_;
  bool bad_ = false;
};

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_LINK_MODEL_H_
