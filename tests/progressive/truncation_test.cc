// Truncation and bit flips of a real stream's reliable start: the test
// vector's stream blob (tests/data/vector/) cut at every byte offset of its
// header and first control block, and with every bit of them flipped, must
// give a clean error or a valid decode, never a crash, hang or runaway
// allocation. Each case runs the whole reliable path: blob, header, fix-ups,
// the Draco base, the control block and the datagrams.
#include <chrono>

#include <gtest/gtest.h>

#include "codec/bitstream/reader.h"
#include "tests/common/test_vector.h"

namespace meshstream {
namespace {

// Decodes a (possibly damaged) stream blob on the vector's real base; the
// result only says whether it was refused.
bool DecodeBlob(const std::vector<uint8_t>& blob, const std::vector<uint8_t>& glb) {
  auto stream = ProgressiveStream::Parse(blob.data(), blob.size());
  if (!stream.ok()) return false;
  auto reader = StreamReader::Create(stream->header.data(), stream->header.size());
  if (!reader.ok()) return false;
  // The base as Draco decodes it, on the (possibly damaged) header's grids.
  auto scene = DecodeProgressiveGlb(glb, [] { ProgressiveDecodeOptions o; o.lod = 0; return o; }(), nullptr);
  if (!scene.ok()) return false;
  auto base = QuantizeOnto(scene->meshes[0].primitives[0], reader->header().grids);
  if (!base.ok()) return false;
  if (!reader->SetBase(std::move(base).value()).ok()) return false;
  if (stream->control.size() != reader->refinement_count()) return false;
  for (size_t i = 0; i < stream->control.size(); ++i) {
    if (!reader->BeginRefinement(stream->control[i].data(), stream->control[i].size()).ok()) return false;
    for (const auto& d : stream->datagrams[i]) reader->OfferDatagram(d.data(), d.size());
    if (!reader->FinishRefinement().ok()) return false;
  }
  return reader->Mesh().vertex_count() <= 64;
}

TEST(Truncation, EveryCutAndBitFlipOfTheHeaderAndFirstControlBlock) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<uint8_t> blob = test_util::ReadBytes(test_util::VectorPath("octahedron-qp8-bundled.msps"));
  const std::vector<uint8_t> glb = test_util::ReadBytes(test_util::VectorPath("octahedron-qp8-bundled.glb"));
  ASSERT_TRUE(DecodeBlob(blob, glb));
  // Magic, version, header block, R, then the first control block (both
  // lengths are one-byte varints in the vector).
  ASSERT_LT(blob[5], 128);
  const size_t header_end = 6 + blob[5];
  ASSERT_LT(blob[header_end + 1], 128);
  const size_t reliable_end = header_end + 1 + 1 + blob[header_end + 1];
  size_t refused_cuts = 0, refused_flips = 0, flips = 0;
  for (size_t cut = 0; cut < blob.size(); ++cut) {
    // A cut anywhere makes some block or count run past the end.
    EXPECT_FALSE(DecodeBlob(std::vector<uint8_t>(blob.begin(), blob.begin() + cut), glb)) << "cut at " << cut;
    ++refused_cuts;
  }
  for (size_t at = 0; at < reliable_end; ++at) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> flipped = blob;
      flipped[at] ^= static_cast<uint8_t>(1u << bit);
      refused_flips += DecodeBlob(flipped, glb) ? 0 : 1;
      ++flips;
    }
  }
  // Flips of the magic, the versions and the block lengths are always refused;
  // flips of a grid's origin or a model code often still give a valid stream
  // (other positions, other frequencies). None crashes or hangs.
  for (size_t at : {size_t{0}, size_t{4}, size_t{5}, size_t{6}, header_end + 1}) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> flipped = blob;
      flipped[at] ^= static_cast<uint8_t>(1u << bit);
      EXPECT_FALSE(DecodeBlob(flipped, glb)) << "byte " << at << " bit " << bit;
    }
  }
  EXPECT_GT(refused_flips, flips / 4);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 20.0);
  std::printf("%zu cuts refused, %zu of %zu bit flips refused, %.2f s\n", refused_cuts, refused_flips, flips, seconds);
}

}  // namespace
}  // namespace meshstream
