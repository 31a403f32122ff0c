#include "codec/loss/link_model.h"

#include <cmath>
#include <string>

namespace meshstream {

namespace {

Status CheckProbability(double p, const char* field) {
  if (p >= 0.0 && p <= 1.0) return Status::Ok();
  return InvalidArgument(std::string("link model: ") + field + " = " + std::to_string(p) + " is not in [0, 1]");
}

}  // namespace

LinkModel LinkModel::Loss(double p, uint64_t seed) {
  LinkModel m;
  m.loss = p;
  m.seed = seed;
  return m;
}

LinkModel LinkModel::Bursts(double mean, double burst, uint64_t seed) {
  if (burst <= 1.0 || mean <= 0.0 || mean >= 1.0) return Loss(mean, seed);
  LinkModel m;
  m.p_good = 1.0 / burst;
  m.p_bad = mean * m.p_good / (1.0 - mean);
  m.loss_good = 0;
  m.loss_bad = 1;
  m.seed = seed;
  return m;
}

double LinkModel::mean_loss() const {
  if (p_bad <= 0) return loss;
  return (p_good * loss_good + p_bad * loss_bad) / (p_bad + p_good);
}

Status LinkModel::Validate() const {
  MS_RETURN_IF_ERROR(CheckProbability(loss, "loss"));
  MS_RETURN_IF_ERROR(CheckProbability(p_bad, "p_bad"));
  MS_RETURN_IF_ERROR(CheckProbability(p_good, "p_good"));
  MS_RETURN_IF_ERROR(CheckProbability(loss_good, "loss_good"));
  MS_RETURN_IF_ERROR(CheckProbability(loss_bad, "loss_bad"));
  MS_RETURN_IF_ERROR(CheckProbability(reorder, "reorder"));
  MS_RETURN_IF_ERROR(CheckProbability(duplicate, "duplicate"));
  if (p_bad > 0 && p_good <= 0) return InvalidArgument("link model: p_good must be > 0 when p_bad > 0");
  return Status::Ok();
}

DatagramFate SimulatedLink::Next() {
  DatagramFate fate;
  bool lost;
  if (model_.p_bad > 0) {
    bad_ = bad_ ? Uniform() >= model_.p_good : Uniform() < model_.p_bad;
    lost = Uniform() < (bad_ ? model_.loss_bad : model_.loss_good);
  } else {
    lost = model_.loss > 0 && Uniform() < model_.loss;
  }
  if (lost) {
    fate.copies = 0;
    return fate;
  }
  fate.copies = model_.duplicate > 0 && Uniform() < model_.duplicate ? 2 : 1;
  for (int c = 0; c < fate.copies; ++c) {
    uint64_t delay = model_.delay_us;
    if (model_.jitter_us > 0) delay += static_cast<uint64_t>(Uniform() * static_cast<double>(model_.jitter_us));
    if (model_.reorder > 0 && Uniform() < model_.reorder) delay += model_.reorder_us;
    fate.delay_us[c] = delay;
  }
  return fate;
}

}  // namespace meshstream
