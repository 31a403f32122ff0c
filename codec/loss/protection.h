// Protection by harm per byte (docs/design/loss-protection.md): per refinement of a
// stream, what its datagrams' loss would do to the final mesh (its largest
// single-loss Hausdorff distance, datagram_harm.h) decides how it travels:
//   - on the reliable cut (reliable_cut.h): it cannot be lost;
//   - nothing: its loss stays within kHarmTarget of the diagonal, a distance
//     nobody can tell from the loss-free mesh (the median target);
//   - parity: within kHarmWorst (the worst run's bound), blocks whose parity
//     may fail now and then (ParityPlanOptions::block_failure);
//   - strong parity: beyond kHarmWorst, blocks sized to fail far more rarely
//     (ParityPlanOptions::strong_failure).
// The choice is the encoder's and is stored with the version (the delivery
// record's "parity" and "harm"); a session sizes the parity of each block for
// the loss its client reports (parity_plan.h).
//
// Contract: pure functions; any input (sizes that do not agree: a harm
// missing counts as above kHarmWorst, so nothing goes unprotected for lack of
// a measurement).
#ifndef MESHSTREAM_CODEC_LOSS_PROTECTION_H_
#define MESHSTREAM_CODEC_LOSS_PROTECTION_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshstream {

constexpr double kHarmTarget = 0.001;  // 0.1 % of the diagonal
constexpr double kHarmWorst = 0.0025;  // 0.25 %

// Values of a refinement's entry in a protection vector (PlanParityBlocks).
enum ProtectionTier : uint8_t { kUnprotected = 0, kParity = 1, kStrongParity = 2 };

// The refinements to protect with parity: those not on `reliable` whose harm
// exceeds kHarmTarget, ascending. `harm` per refinement (a share of the
// diagonal); refinements [0, refinements).
std::vector<uint32_t> ChooseParity(const std::vector<double>& harm, const std::vector<uint32_t>& reliable,
                                   size_t refinements);

// Per refinement [0, refinements): its tier, from the record's parity list
// and harm (a refinement named by `parity` whose harm exceeds kHarmWorst, or
// is unknown, is strong; one not named is unprotected).
std::vector<uint8_t> ProtectionTiers(const std::vector<uint32_t>& parity, const std::vector<double>& harm,
                                     size_t refinements);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_LOSS_PROTECTION_H_
