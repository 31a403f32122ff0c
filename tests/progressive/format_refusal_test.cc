// Every reserved or out-of-range value of the progressive format is refused
// with an error naming the field (docs/spec/progressive-format.md): each test takes
// the valid test vector (tests/data/vector/), patches one field, and expects
// the error text to name it. The unpatched vector is accepted by each path.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "codec/progressive/encoder.h"
#include "importers/draco_base_coder.h"
#include "tests/common/test_vector.h"

namespace meshstream {
namespace {

using Bytes = std::vector<uint8_t>;

// The vector's stream, rebuilt in memory with its Draco base.
struct Vector {
  ProgressiveEncoded encoded;
  QuantizationParams quantization;
  StreamWriteOptions write;
  ProgressiveStream stream;
  QuantizedMesh base;  // as Draco decodes it
};

const Vector& TheVector() {
  static const Vector v = [] {
    Vector out;
    auto scene = ImportFile(test_util::VectorPath("octahedron.obj"));
    EXPECT_TRUE(scene.ok());
    const ProgressiveGlbOptions o = test_util::VectorOptions();
    DracoAttributeIds ids;
    auto enc = EncodeProgressive(scene->meshes[0].primitives[0], o.encode, [&](const QuantizedMesh& base, int method) {
      return EncodeDracoBase(base, method, o.draco_compression_level, &ids);
    });
    EXPECT_TRUE(enc.ok());
    out.encoded = enc.value();
    out.quantization = o.encode.quantization;
    out.write = o.stream;
    out.stream = WriteStream(out.encoded, out.quantization, out.write).value();
    auto header = StreamHeader::Parse(out.stream.header.data(), out.stream.header.size());
    EXPECT_TRUE(header.ok());
    out.base = DecodeDracoBase(out.encoded.base_bytes.data(), out.encoded.base_bytes.size(), ids, header->grids).value();
    return out;
  }();
  return v;
}

std::string HeaderError(const Bytes& header) {
  auto h = StreamHeader::Parse(header.data(), header.size());
  if (!h.ok()) return h.status().message();
  Status s = h->DecodeFixups();
  return s.ok() ? "accepted" : s.message();
}

// Header offsets of the vector (version 4: the profile byte, two tool
// bytes; positions only, one-byte varints).
constexpr size_t kPacking = 1, kProfile = 2, kTools = 3, kQp = 5, kOrigin = 9, kRange = 21, kHasNormals = 25,
                 kSets = 26, kHasColors = 27, kBaseMethod = 30, kSplitCount = 32, kPositionFix = 33;

Bytes Patched(Bytes b, size_t at, uint8_t value) {
  b.at(at) = value;
  return b;
}

TEST(FormatRefusal, TheVectorIsTheBlobStoredInTestData) {
  EXPECT_EQ(TheVector().stream.Serialize(), test_util::ReadBytes(test_util::VectorPath("octahedron-qp8-bundled.msps")));
  const Bytes& h = TheVector().stream.header;
  EXPECT_EQ(HeaderError(h), "accepted");
  EXPECT_EQ(h[kBaseMethod], 0);
  EXPECT_EQ(h[kSplitCount], 3);
  EXPECT_EQ(h[kPositionFix], 6);
}

TEST(FormatRefusal, StreamHeaderFields) {
  const Bytes& h = TheVector().stream.header;
  EXPECT_EQ(HeaderError(Patched(h, 0, 5)), "stream header: version 5 is not 1, 2, 3 or 4");
  EXPECT_EQ(HeaderError(Patched(h, 0, 0)), "stream header: version 0 is not 1, 2, 3 or 4");
  // The profile byte (version 4): 0 loss-tolerant, 1 reliable, the rest reserved.
  EXPECT_EQ(h[kProfile], 0);
  EXPECT_EQ(HeaderError(Patched(h, kProfile, 2)), "stream header: profile 2 is reserved");
  EXPECT_EQ(HeaderError(Patched(h, kProfile, 255)), "stream header: profile 255 is reserved");
  // The vector is bundled: the reliable profile has no datagrams, its packing is 0.
  EXPECT_EQ(HeaderError(Patched(h, kProfile, 1)), "stream header: packing 1 in the reliable profile (must be 0)");
  // ... and codes split bits and models its own way: tool bits 6 and 7 are refused.
  EXPECT_EQ(HeaderError(Patched(Patched(h, kProfile, 1), kPacking, 0)),
            "stream header: tools 463: bits 6 and 7 are the loss-tolerant profile's");
  EXPECT_EQ(HeaderError(Patched(Patched(Patched(h, kProfile, 1), kPacking, 0), kTools, 0x0F)), "accepted");
  // Version 3 is version 4's loss-tolerant profile without the profile byte.
  Bytes v3 = Patched(h, 0, 3);
  v3.erase(v3.begin() + kProfile);
  EXPECT_EQ(HeaderError(v3), "accepted");
  // ... and bit 9 (crossings) is version 4's: version 3 reserves it.
  EXPECT_EQ(HeaderError(Patched(v3, kTools, 0x03)), "stream header: tools 975 has bits set that version 3 reserves");
  // Tools: two bytes, little-endian; bits 10-15 reserved.
  EXPECT_EQ(h[kTools], 0xCF);
  EXPECT_EQ(h[kTools + 1], 0x01);
  EXPECT_EQ(HeaderError(Patched(h, kTools + 1, 0x05)), "stream header: tools 1487 has bits set that version 4 reserves");
  // Bit 9 (crossings) orders the ranks of bit 2: accepted with it, refused without.
  EXPECT_EQ(HeaderError(Patched(h, kTools + 1, 0x03)), "accepted");
  EXPECT_EQ(HeaderError(Patched(Patched(h, kTools + 1, 0x03), kTools, 0xCB)),
            "stream header: tools 971: the crossings tool orders the rank tool's ranks");
  EXPECT_EQ(HeaderError(Patched(h, kTools + 1, 0x81)), "stream header: tools 33231 has bits set that version 4 reserves");
  // Bit 8 (the ring predictor) needs bits 0 and 1; without bit 8 the header is version 3 as stop 34 wrote it.
  EXPECT_EQ(HeaderError(Patched(h, kTools, 0xCE)),
            "stream header: tools 462: the predictor tool needs the geometry and frame tools");
  EXPECT_EQ(HeaderError(Patched(h, kTools, 0xCD)),
            "stream header: tools 461: the predictor tool needs the geometry and frame tools");
  EXPECT_EQ(HeaderError(Patched(h, kTools + 1, 0x00)), "accepted");
  // Bit 5 (seams) announces the seam twins after the fix-ups, which this header does not have.
  EXPECT_EQ(HeaderError(Patched(h, kTools, 0xEF)), "stream header: seam twin count: truncated at byte " +
                                                       std::to_string(h.size()));
  // Bit 4 without texture coordinates or colours is accepted (it predicts nothing).
  EXPECT_EQ(HeaderError(Patched(h, kTools, 0xDF)), "accepted");
  // Bits 6 and 7 are version 3's: a version 2 header (one tool byte, no profile byte) refuses them.
  Bytes v2 = Patched(h, 0, 2);
  v2.erase(v2.begin() + kTools + 1);
  v2.erase(v2.begin() + kProfile);
  EXPECT_EQ(HeaderError(v2), "stream header: tools 207 has bits set that version 2 reserves");
  EXPECT_EQ(HeaderError(Patched(v2, kTools - 1, 0x8F)), "stream header: tools 143 has bits set that version 2 reserves");
  EXPECT_EQ(HeaderError(Patched(v2, kTools - 1, 0x0F)), "accepted");
  EXPECT_EQ(HeaderError(Patched(h, kPacking, 2)), "stream header: packing 2 is reserved");
  EXPECT_EQ(HeaderError(Patched(h, kPacking, 255)), "stream header: packing 255 is reserved");
  const char* names[4] = {"qp", "qn", "qt", "qc"};
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(HeaderError(Patched(h, kQp + k, 0)), std::string("stream header: ") + names[k] + " 0 is out of range (1..30)");
    EXPECT_EQ(HeaderError(Patched(h, kQp + k, 31)), std::string("stream header: ") + names[k] + " 31 is out of range (1..30)");
  }
  EXPECT_EQ(HeaderError(Patched(h, kHasNormals, 2)), "stream header: has_normals 2 is not 0 or 1");
  EXPECT_EQ(HeaderError(Patched(h, kSets, 9)), "stream header: texcoord_sets 9 is out of range (0..8)");
  EXPECT_EQ(HeaderError(Patched(h, kHasColors, 2)), "stream header: has_colors 2 is not 0 or 1");
  // Range 0.0f and NaN (the f32's high byte).
  Bytes zero = h;
  for (int i = 0; i < 4; ++i) zero[kRange + i] = 0;
  EXPECT_EQ(HeaderError(zero), "stream header: position grid: range is not positive");
  EXPECT_EQ(HeaderError(Patched(Patched(h, kRange + 3, 0x7F), kRange + 2, 0xC0)),
            "stream header: position grid: range is not positive");
  EXPECT_EQ(HeaderError(Patched(h, kOrigin + 3, 0x7F)).rfind("stream header: position grid", 0), 0u);  // origin x = NaN/inf
  for (int m = 2; m < 256; ++m) {
    EXPECT_EQ(HeaderError(Patched(h, kBaseMethod, static_cast<uint8_t>(m))),
              "stream header: base_method " + std::to_string(m) + " is reserved");
  }
  EXPECT_EQ(HeaderError(Patched(h, kSplitCount, 16)),
            "stream header: split count 16 of refinement 0 exceeds its 15 vertices");
  Bytes stray = h;
  stray.push_back(0);
  EXPECT_EQ(HeaderError(stray), "stream header: 1 stray bytes after the attribute fix-ups");
}

TEST(FormatRefusal, FixupBlocks) {
  const Bytes& h = TheVector().stream.header;
  // One byte more inside the position fix-ups: the range coder ends before it.
  Bytes longer(h.begin(), h.begin() + kPositionFix);
  longer.push_back(static_cast<uint8_t>(h[kPositionFix] + 1));
  longer.insert(longer.end(), h.begin() + kPositionFix + 1, h.begin() + kPositionFix + 1 + h[kPositionFix]);
  longer.push_back(0);
  longer.insert(longer.end(), h.begin() + kPositionFix + 1 + h[kPositionFix], h.end());
  EXPECT_EQ(HeaderError(longer), "stream header: position fix-ups: the block's 7 bytes do not end with its 45 values");
  // One byte less: 45 values need more than the block holds.
  Bytes shorter(h.begin(), h.begin() + kPositionFix);
  shorter.push_back(static_cast<uint8_t>(h[kPositionFix] - 1));
  shorter.insert(shorter.end(), h.begin() + kPositionFix + 1, h.begin() + kPositionFix + h[kPositionFix]);
  shorter.insert(shorter.end(), h.begin() + kPositionFix + 1 + h[kPositionFix], h.end());
  EXPECT_EQ(HeaderError(shorter).rfind("stream header: position fix-ups: ", 0), 0u) << HeaderError(shorter);

  // A fix-up that takes a coordinate past 32 bits.
  const Vector& v = TheVector();
  ProgressiveEncoded e = v.encoded;
  size_t at = 0;
  while (v.base.positions[at / 3][at % 3] <= 0) ++at;
  e.base_position_fix[at] = INT32_MAX;
  auto s = WriteStream(e, v.quantization, v.write);
  ASSERT_TRUE(s.ok());
  auto reader = StreamReader::Create(s->header.data(), s->header.size());
  ASSERT_TRUE(reader.ok());
  EXPECT_EQ(reader->SetBase(v.base).message(),
            "stream header: position fix-up of base vertex " + std::to_string(at / 3) + " overflows 32 bits");
  auto good = StreamReader::Create(v.stream.header.data(), v.stream.header.size());
  EXPECT_TRUE(good->SetBase(v.base).ok());
}

TEST(FormatRefusal, StreamBlob) {
  const Bytes blob = TheVector().stream.Serialize();
  auto error = [](const Bytes& b) {
    auto s = ProgressiveStream::Parse(b.data(), b.size());
    return s.ok() ? std::string("accepted") : s.status().message();
  };
  EXPECT_EQ(error(blob), "accepted");
  EXPECT_EQ(error(Patched(blob, 0, 'X')), "stream blob: magic is not MSPS (not a meshstream progressive stream)");
  EXPECT_EQ(error(Patched(blob, 4, 5)), "stream blob: version 5 is not 1, 2, 3 or 4");
  EXPECT_EQ(error(Patched(blob, 4, 2)), "stream blob: version 2 differs from its header's 4");
  Bytes stray = blob;
  stray.push_back(0);
  EXPECT_EQ(error(stray), "stream blob: 1 stray bytes after the last refinement");
}

// A blob whose header counts other refinements than it holds is refused
// where the header is read (every reader of blobs goes through ParseHeader).
TEST(FormatRefusal, StreamBlobRefinementsMatchItsHeader) {
  ProgressiveStream stream = TheVector().stream;
  auto header = stream.ParseHeader();
  ASSERT_TRUE(header.ok()) << header.status().ToString();
  EXPECT_EQ(header->split_counts.size(), stream.control.size());
  stream.control.pop_back();
  stream.datagrams.pop_back();
  auto short_one = stream.ParseHeader();
  ASSERT_FALSE(short_one.ok());
  EXPECT_EQ(short_one.status().message(), "the stream has " + std::to_string(stream.control.size()) +
                                              " refinements, its header says " +
                                              std::to_string(header->split_counts.size()));
}

// The control block of refinement 0 cut into its parts: the split-bit block
// (with its length), per model slot its mode and what follows it (a table or
// a parameter), and what follows the slots (the alpha byte of the geometry
// prediction).
struct ControlParts {
  Bytes split_bits;
  std::vector<Bytes> slots;
  Bytes tail;
  Bytes Join() const {
    Bytes out = split_bits;
    for (const Bytes& s : slots) out.insert(out.end(), s.begin(), s.end());
    out.insert(out.end(), tail.begin(), tail.end());
    return out;
  }
};

ControlParts Cut(const Bytes& control) {
  ControlParts parts;
  ByteReader r(control.data(), control.size());
  size_t length = 0;
  r.Block("split bits", &length).value();
  parts.split_bits.assign(control.begin(), control.begin() + r.position());
  for (int k = 0; k < 5; ++k) {
    const size_t start = r.position();
    const uint8_t mode = r.U8("mode").value();
    if (mode == static_cast<uint8_t>(ModelMode::kParametric)) r.U8("parameter").value();
    else StaticModel::Parse(r).value();
    parts.slots.emplace_back(control.begin() + start, control.begin() + r.position());
  }
  parts.tail.assign(control.begin() + r.position(), control.end());
  return parts;
}

std::string ControlError(const Bytes& control) {
  const Vector& v = TheVector();
  auto reader = StreamReader::Create(v.stream.header.data(), v.stream.header.size());
  EXPECT_TRUE(reader.ok());
  EXPECT_TRUE(reader->SetBase(v.base).ok());
  Status s = reader->BeginRefinement(control.data(), control.size());
  return s.ok() ? "accepted" : s.message();
}

TEST(FormatRefusal, ControlBlock) {
  const Bytes& control = TheVector().stream.control[0];
  const ControlParts parts = Cut(control);
  ASSERT_EQ(parts.Join(), control);
  EXPECT_EQ(ControlError(control), "accepted");

  // Split bits: a stray byte inside the block, a byte short, a bit count the header does not say.
  ControlParts p = parts;
  p.split_bits[0] += 1;
  p.split_bits.push_back(0);
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: split bits: the block's " + std::to_string(p.split_bits.size() - 1) +
                                        " bytes do not end with its 15 bits");
  p = parts;
  p.split_bits[0] -= 1;
  p.split_bits.pop_back();
  EXPECT_NE(ControlError(p.Join()).find("refinement 0: split bits"), std::string::npos) << ControlError(p.Join());

  // Model modes (version 3's model modes tool): every slot of the vector is
  // adaptive from a parameter (mode 2); 4 and above are reserved; 0 (reuse)
  // in refinement 0 names no model; a parameter names one of 160 members.
  for (const Bytes& slot : parts.slots) {
    ASSERT_EQ(slot.size(), 2u);
    EXPECT_EQ(slot[0], 2);
  }
  for (uint8_t mode : {4, 5, 255}) {
    p = parts;
    p.slots[3][0] = mode;
    EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 3 (position, second tangential): model mode " +
                                          std::to_string(mode) + " is not 0, 1, 2 or 3");
  }
  p = parts;
  p.slots[1] = {0};
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 1 (cut rank, high digit): model mode 0 reuses a model that was never sent");
  p = parts;
  p.slots[2][1] = 159;
  EXPECT_EQ(ControlError(p.Join()), "accepted");
  p.slots[2][1] = 160;
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 2 (position, first tangential): model parameter 160 is out of range (0..159)");
  const Bytes no_parameter(control.begin(), control.end() - 2);  // slot 4's parameter and the predictor record cut off
  EXPECT_EQ(ControlError(no_parameter).rfind("refinement 0: model slot 4 (position, normal): model parameter: truncated", 0), 0u)
      << ControlError(no_parameter);
  // Mode 3: adaptive from a table, parsed as a table.
  p = parts;
  p.slots[4] = {3, 3, 0x1F, 0x01};
  EXPECT_EQ(ControlError(p.Join()), "accepted");
  p.slots[4] = {3, 73, 0x01};
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 4 (position, normal): model alphabet size 73 is out of range (1..72)");

  // Alphabets: 0 is reserved, wings have at most 16 symbols, signed values 72.
  auto model = [](uint8_t n, uint8_t fill) {
    Bytes m = {1, n};
    for (int s = 0; s < (n + 1) / 2; ++s) m.push_back(fill);
    return m;
  };
  p = parts;
  p.slots[0] = model(16, 0x11);
  EXPECT_EQ(ControlError(p.Join()), "accepted");  // a wing model may name every valence-16 index
  p.slots[0] = model(17, 0x01);
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 0 (cut rank, low digit): model alphabet size 17 is out of range (1..16)");
  p = parts;
  p.slots[1] = model(0, 0);
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 1 (cut rank, high digit): model alphabet size 0 is out of range (1..16)");
  for (uint8_t n : {73, 96, 255}) {
    p = parts;
    p.slots[2] = model(n, 0x01);
    EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 2 (position, first tangential): model alphabet size " + std::to_string(n) +
                                          " is out of range (1..72)");
  }
  p = parts;
  p.slots[4] = model(3, 0x00);
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 4 (position, normal): model codes: no symbol is present");
  p = parts;
  p.slots[4] = model(3, 0x11);  // the high nibble after symbol 2 must be 0
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 4 (position, normal): model codes have a stray nibble");
  p = parts;
  p.slots[4] = {1, 5};
  EXPECT_EQ(ControlError(p.Join()), "refinement 0: model slot 4 (position, normal): model codes: truncated at byte " +
                                        std::to_string(p.Join().size()));
  Bytes stray = control;
  stray.push_back(0);
  EXPECT_EQ(ControlError(stray), "refinement 0: control block: 1 stray bytes after the models");
  // The ring predictor (version 3, tool bit 8): its record ends the block,
  // 0 (keep) or 1 and six zigzag varints of at most 2^16.
  ASSERT_EQ(parts.tail, Bytes{0});
  EXPECT_EQ(ControlError(Bytes(control.begin(), control.end() - 1)).rfind("refinement 0: control block: predictor record", 0), 0u)
      << ControlError(Bytes(control.begin(), control.end() - 1));
  auto with_tail = [&](const Bytes& tail) {
    ControlParts q = parts;
    q.tail = tail;
    return ControlError(q.Join());
  };
  for (uint8_t record : {2, 3, 255}) {
    EXPECT_EQ(with_tail({record}), "refinement 0: control block: predictor record " + std::to_string(record) + " is not 0 or 1");
  }
  EXPECT_EQ(with_tail({1, 0x80, 0x04, 0, 0, 0x80, 0x04, 0, 0}), "accepted");  // (256, 0, 0) twice, as zigzag 512
  EXPECT_EQ(with_tail({1, 0x80, 0x80, 0x04, 0, 0, 0, 0, 0}), "accepted");    // the largest: zigzag 2^16, a weight of 2^15
  EXPECT_EQ(with_tail({1, 0x81, 0x80, 0x04, 0, 0, 0, 0, 0}),
            "refinement 0: control block: tangential Laplacian weight: predictor weight = 65537 exceeds 65536");
  EXPECT_EQ(with_tail({1, 0, 0, 0, 0, 0}).rfind("refinement 0: control block: normal ring weight: predictor weight: truncated", 0), 0u)
      << with_tail({1, 0, 0, 0, 0, 0});
  EXPECT_EQ(with_tail({1, 0, 0, 0, 0, 0, 0, 0}), "refinement 0: control block: 1 stray bytes after the models");
}

std::string DatagramError(const Bytes& d) {
  ByteReader r(d.data(), d.size());
  auto h = DatagramHeader::Parse(r);
  return h.ok() ? "accepted" : h.status().message();
}

TEST(FormatRefusal, DatagramHeader) {
  const Bytes& d = TheVector().stream.datagrams[0][0];
  // 4D 04 00 | stream 0 | refinement 0 | stride 1 | offset 0 | count 3 | payload.
  ASSERT_EQ(Bytes(d.begin(), d.begin() + 8), (Bytes{0x4D, 4, 0, 0, 0, 1, 0, 3}));
  EXPECT_EQ(DatagramError(d), "accepted");
  EXPECT_EQ(DatagramError(Patched(d, 0, 0x4E)), "datagram: magic 78 is not 0x4D");
  EXPECT_EQ(DatagramError(Patched(d, 1, 5)), "datagram: version 5 is not 1, 2, 3 or 4");
  EXPECT_EQ(DatagramError(Patched(d, 1, 0)), "datagram: version 0 is not 1, 2, 3 or 4");
  // Kind 4 is a parity datagram (section 6.1): this header's rows, row and
  // count do not make one.
  EXPECT_EQ(DatagramError(Patched(d, 2, 4)), "datagram: parity of 3 members in 1 rows (1 to rows - 1)");
  EXPECT_EQ(DatagramError(Bytes{0x4D, 3, 4, 0, 0, 0x81, 0x02, 0, 1}), "datagram: parity of 257 rows (at most 256)");
  EXPECT_EQ(DatagramError(Bytes{0x4D, 3, 4, 0, 0, 4, 1, 2}), "datagram: parity row 1 is not in [2, 4)");
  for (int k = 5; k < 256; ++k) {
    EXPECT_EQ(DatagramError(Patched(d, 2, static_cast<uint8_t>(k))), "datagram: kind " + std::to_string(k) + " is reserved");
  }
  EXPECT_EQ(DatagramError(Bytes{0x4D, 1, 0, 0, 0xFF, 0x01, 1, 0, 3}), "datagram: refinement = 255 exceeds 254");
  EXPECT_EQ(DatagramError(Patched(d, 5, 0)), "datagram: stride 0 is not allowed");
  EXPECT_EQ(DatagramError(Patched(d, 6, 1)), "datagram: offset 1 is not below stride 1");
  EXPECT_EQ(DatagramError(Patched(d, 7, 0)), "datagram: count 0 is not allowed");
  EXPECT_EQ(DatagramError(Bytes{0x4D, 1, 0, 0, 0, 1, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0x7F}).rfind("datagram: count", 0), 0u);
  // END: stride 1, offset 0, no payload.
  EXPECT_EQ(DatagramError(MakeEndDatagram(0, 0, 1)), "accepted");
  EXPECT_EQ(DatagramError(Bytes{0x4D, 1, 3, 0, 0, 2, 0, 1}), "datagram: END has stride 2, not 1");
  EXPECT_EQ(DatagramError(Bytes{0x4D, 1, 3, 0, 0, 1, 1, 1}), "datagram: END has offset 1, not 0");
  EXPECT_EQ(DatagramError(Bytes{0x4D, 1, 3, 0, 0, 1, 0, 1, 0}), "datagram: END has 1 payload bytes");
}

TEST(FormatRefusal, DatagramPayloadMustEndWithItsLastSplit) {
  const Vector& v = TheVector();
  auto offer = [&v](const Bytes& d) {
    auto reader = StreamReader::Create(v.stream.header.data(), v.stream.header.size());
    EXPECT_TRUE(reader->SetBase(v.base).ok());
    EXPECT_TRUE(reader->BeginRefinement(v.stream.control[0].data(), v.stream.control[0].size()).ok());
    const bool accepted = reader->OfferDatagram(d.data(), d.size());
    EXPECT_EQ(reader->stats().rejected, accepted ? 0u : 1u);
    return accepted;
  };
  const Bytes& d = v.stream.datagrams[0][0];
  EXPECT_TRUE(offer(d));
  Bytes stray = d;
  stray.push_back(0);
  EXPECT_FALSE(offer(stray));
  EXPECT_FALSE(offer(Bytes(d.begin(), d.end() - 1)));
  EXPECT_FALSE(offer(Patched(d, 2, 1)));  // a structure datagram in a bundled stream
  EXPECT_FALSE(offer(Patched(d, 1, 1)));  // a version 1 datagram in a version 3 stream
  EXPECT_FALSE(offer(Patched(d, 1, 2)));  // a version 2 datagram in a version 3 stream
}

std::string GlbError(const nlohmann::json& doc) {
  const Bytes glb = test_util::ReadBytes(test_util::VectorPath("octahedron-qp8-bundled.glb"));
  auto scene = DecodeProgressiveGlb(test_util::WithGlbJson(glb, doc), {}, nullptr);
  return scene.ok() ? "accepted" : scene.status().message();
}

TEST(FormatRefusal, ExtensionJson) {
  const Bytes glb = test_util::ReadBytes(test_util::VectorPath("octahedron-qp8-bundled.glb"));
  const nlohmann::json doc = test_util::GlbJson(glb);
  EXPECT_EQ(GlbError(doc), "accepted");
  auto with = [&doc](const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json d = doc;
    edit(d["meshes"][0]["primitives"][0]["extensions"][kProgressiveExtension]);
    return GlbError(d);
  };
  const std::string where = "meshes[0].primitives[0]: MESHSTREAM_progressive.";
  EXPECT_EQ(with([](nlohmann::json& e) { e["extras"] = {{"note", 1}}; }), "accepted");
  EXPECT_EQ(with([](nlohmann::json& e) { e["version"] = 5; }), where + "version 5 is not 1, 2, 3 or 4");
  EXPECT_EQ(with([](nlohmann::json& e) { e["version"] = 0; }), where + "version 0 is not 1, 2, 3 or 4");
  EXPECT_EQ(with([](nlohmann::json& e) { e["version"] = "4"; }), where + "version \"4\" is not 1, 2, 3 or 4");
  EXPECT_EQ(with([](nlohmann::json& e) { e["version"] = 1.5; }), where + "version 1.5 is not 1, 2, 3 or 4");
  // "reliable" (version 4): a bufferView index naming the reliable profile's stream.
  EXPECT_EQ(with([](nlohmann::json& e) { e["reliable"] = "x"; }), where + "reliable is not an unsigned integer");
  EXPECT_EQ(with([](nlohmann::json& e) { e["reliable"] = 999; }), where + "reliable does not exist");
  EXPECT_EQ(with([](nlohmann::json& e) { e["reliable"] = e["bufferView"]; }),
            where + "reliable names a stream of the loss-tolerant profile");
  // The extension's version must be the stream's.
  EXPECT_NE(with([](nlohmann::json& e) { e["version"] = 2; }).find("differ"), std::string::npos);
  EXPECT_EQ(with([](nlohmann::json& e) { e.erase("version"); }), where + "version is missing");
  EXPECT_EQ(with([](nlohmann::json& e) { e["bufferView"] = -1; }), where + "bufferView is missing or not an unsigned integer");
  EXPECT_EQ(with([](nlohmann::json& e) { e["levels"] = 3; }), where + "levels is not defined by version 4");
}

}  // namespace
}  // namespace meshstream
