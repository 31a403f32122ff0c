#include "codec/bitstream/format.h"

#include <cmath>

#include "codec/entropy/range_coder.h"

namespace meshstream {

namespace {

constexpr uint8_t kBlobMagic[4] = {'M', 'S', 'P', 'S'};

void WriteGrid(ByteWriter& w, const QuantizationGrid& g, int components) {
  for (int c = 0; c < components; ++c) w.F32(g.origin[c]);
  w.F32(g.range);
}

StatusOr<QuantizationGrid> ReadGrid(ByteReader& r, int components, int bits, const char* what) {
  QuantizationGrid g;
  g.bits = bits;
  g.components = components;
  for (int c = 0; c < components; ++c) {
    MS_ASSIGN_OR_RETURN(g.origin[c], r.F32(what));
    if (!std::isfinite(g.origin[c])) return InvalidInput(std::string(what) + ": origin is not finite");
  }
  MS_ASSIGN_OR_RETURN(g.range, r.F32(what));
  if (!std::isfinite(g.range) || !(g.range > 0)) return InvalidInput(std::string(what) + ": range is not positive");
  return g;
}

// Fix-ups: one adaptive "nonzero" bit per value, then zigzag in two raw halves.
std::vector<uint8_t> EncodeFixups(const std::vector<int32_t>& values) {
  RangeEncoder enc;
  BitModel nonzero;
  for (int32_t v : values) {
    enc.EncodeBit(nonzero, v != 0);
    if (v != 0) {
      const uint32_t z = (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
      enc.EncodeRaw(z & 0xFFFF, 16);
      enc.EncodeRaw(z >> 16, 16);
    }
  }
  return enc.Finish();
}

Status DecodeFixupBlock(const std::vector<uint8_t>& block, size_t count, std::vector<int32_t>& out, const char* what) {
  RangeDecoder dec(block.data(), block.size());
  BitModel nonzero;
  // `count` comes from the header: grow with the values the bytes really
  // hold instead of allocating it up front (a lying count fails on overrun).
  out.clear();
  for (size_t i = 0; i < count; ++i) {
    int32_t v = 0;
    if (dec.DecodeBit(nonzero)) {
      const uint32_t lo = dec.DecodeRaw(16);
      const uint32_t z = lo | (dec.DecodeRaw(16) << 16);
      v = static_cast<int32_t>((z >> 1) ^ (~(z & 1) + 1));
    }
    if (dec.overran()) return InvalidInput(std::string(what) + ": truncated");
    out.push_back(v);
  }
  if (!dec.ended_exactly()) {
    return InvalidInput(std::string(what) + ": the block's " + std::to_string(block.size()) +
                        " bytes do not end with its " + std::to_string(count) + " values");
  }
  return Status::Ok();
}

}  // namespace

void StreamHeader::Serialize(ByteWriter& w) const {
  w.U8(version);
  w.U8(static_cast<uint8_t>(packing));
  if (version >= 4) w.U8(static_cast<uint8_t>(profile));
  if (version == 2) w.U8(static_cast<uint8_t>(tools));
  if (version >= 3) w.U16(tools);
  w.U8(static_cast<uint8_t>(quantization.qp));
  w.U8(static_cast<uint8_t>(quantization.qn));
  w.U8(static_cast<uint8_t>(quantization.qt));
  w.U8(static_cast<uint8_t>(quantization.qc));
  WriteGrid(w, grids.position_grid, 3);
  const AttributeLayout& l = grids.layout;
  w.U8(l.has_normals ? 1 : 0);
  w.U8(static_cast<uint8_t>(l.texcoord_sets));
  w.U8(l.has_colors ? 1 : 0);
  for (int t = 0; t < l.texcoord_sets; ++t) WriteGrid(w, l.texcoord_grids[t], 2);
  if (l.has_colors) WriteGrid(w, l.color_grid, 4);
  w.Varint(base_vertices);
  w.Varint(base_faces);
  w.U8(base_method);
  w.Varint(split_counts.size());
  for (uint32_t c : split_counts) w.Varint(c);
  w.Block(EncodeFixups(base_position_fix));
  w.Block(EncodeFixups(base_attribute_fix));
  if (version >= 2 && has(kToolSeams)) {
    w.Varint(seam_twins.size());
    for (const auto& t : seam_twins) {
      w.Varint(t[0]);
      w.Varint(t[1] - t[0]);
    }
  }
}

StatusOr<StreamHeader> StreamHeader::Parse(const uint8_t* data, size_t size) {
  ByteReader r(data, size);
  StreamHeader h;
  auto refuse = [](const std::string& what) { return InvalidInput("stream header: " + what); };
  MS_ASSIGN_OR_RETURN(uint8_t version, r.U8("stream header: version"));
  if (!IsStreamVersion(version)) {
    return Unsupported("stream header: version " + std::to_string(version) + " is not " + kStreamVersionsText);
  }
  h.version = version;
  MS_ASSIGN_OR_RETURN(uint8_t packing, r.U8("stream header: packing"));
  if (packing > 1) return refuse("packing " + std::to_string(packing) + " is reserved");
  h.packing = static_cast<Packing>(packing);
  if (version >= 4) {
    MS_ASSIGN_OR_RETURN(uint8_t profile, r.U8("stream header: profile"));
    if (profile > 1) return refuse("profile " + std::to_string(profile) + " is reserved");
    h.profile = static_cast<Profile>(profile);
    // The reliable profile has no datagrams: its packing byte is 0.
    if (h.reliable() && packing != 0) return refuse("packing " + std::to_string(packing) + " in the reliable profile (must be 0)");
  }
  h.tools = 0;
  if (version == 2) {
    MS_ASSIGN_OR_RETURN(h.tools, r.U8("stream header: tools"));
  } else if (version >= 3) {
    MS_ASSIGN_OR_RETURN(h.tools, r.U16("stream header: tools"));
  }
  if ((h.tools & ~DefinedTools(version)) != 0) {
    return refuse("tools " + std::to_string(h.tools) + " has bits set that version " + std::to_string(version) +
                  " reserves");
  }
  if (h.reliable() && (h.tools & (kToolSplitContexts | kToolModelModes)) != 0) {
    return refuse("tools " + std::to_string(h.tools) + ": bits 6 and 7 are the loss-tolerant profile's");
  }
  if ((h.tools & kToolCutCrossings) != 0 && (h.tools & kToolWingRank) == 0) {
    return refuse("tools " + std::to_string(h.tools) + ": the crossings tool orders the rank tool's ranks");
  }
  if ((h.tools & kToolRingPredictor) != 0 &&
      (h.tools & (kToolGeometryPrediction | kToolLocalFrame)) != (kToolGeometryPrediction | kToolLocalFrame)) {
    return refuse("tools " + std::to_string(h.tools) + ": the predictor tool needs the geometry and frame tools");
  }
  static const char* const kBitsNames[4] = {"qp", "qn", "qt", "qc"};
  uint8_t bits[4];
  for (int k = 0; k < 4; ++k) {
    MS_ASSIGN_OR_RETURN(bits[k], r.U8("stream header: quantization bits"));
    if (bits[k] < kMinQuantizationBits || bits[k] > kMaxQuantizationBits) {
      return refuse(std::string(kBitsNames[k]) + " " + std::to_string(bits[k]) + " is out of range (1..30)");
    }
  }
  h.quantization = {bits[0], bits[1], bits[2], bits[3]};
  MS_ASSIGN_OR_RETURN(h.grids.position_grid, ReadGrid(r, 3, bits[0], "stream header: position grid"));
  AttributeLayout& l = h.grids.layout;
  l.qn = bits[1];
  MS_ASSIGN_OR_RETURN(uint8_t has_normals, r.U8("stream header: has_normals"));
  if (has_normals > 1) return refuse("has_normals " + std::to_string(has_normals) + " is not 0 or 1");
  MS_ASSIGN_OR_RETURN(uint8_t sets, r.U8("stream header: texcoord_sets"));
  if (sets > 8) return refuse("texcoord_sets " + std::to_string(sets) + " is out of range (0..8)");
  MS_ASSIGN_OR_RETURN(uint8_t has_colors, r.U8("stream header: has_colors"));
  if (has_colors > 1) return refuse("has_colors " + std::to_string(has_colors) + " is not 0 or 1");
  l.has_normals = has_normals;
  l.texcoord_sets = sets;
  l.has_colors = has_colors;
  for (int t = 0; t < sets; ++t) {
    MS_ASSIGN_OR_RETURN(QuantizationGrid g, ReadGrid(r, 2, bits[2], "stream header: texture coordinate grid"));
    l.texcoord_grids.push_back(g);
  }
  if (has_colors) {
    MS_ASSIGN_OR_RETURN(l.color_grid, ReadGrid(r, 4, bits[3], "stream header: colour grid"));
  }
  MS_ASSIGN_OR_RETURN(uint64_t bv, r.Varint("stream header: base vertex count", kMaxBaseVertices));
  MS_ASSIGN_OR_RETURN(uint64_t bf, r.Varint("stream header: base triangle count", 2 * kMaxStreamVertices));
  h.base_vertices = static_cast<uint32_t>(bv);
  h.base_faces = static_cast<uint32_t>(bf);
  MS_ASSIGN_OR_RETURN(h.base_method, r.U8("stream header: base_method"));
  if (h.base_method > 1) return refuse("base_method " + std::to_string(h.base_method) + " is reserved");
  MS_ASSIGN_OR_RETURN(uint64_t levels, r.Varint("stream header: refinement count", kMaxRefinements));
  uint64_t total = bv;
  for (uint64_t i = 0; i < levels; ++i) {
    MS_ASSIGN_OR_RETURN(uint64_t c, r.Varint("stream header: split count", kMaxStreamVertices));
    // A refinement splits at most every vertex once.
    if (c > total) {
      return refuse("split count " + std::to_string(c) + " of refinement " + std::to_string(i) +
                    " exceeds its " + std::to_string(total) + " vertices");
    }
    total += c;
    if (total > kMaxStreamVertices) return ResourceExhausted("stream header: the stream has too many vertices");
    h.split_counts.push_back(static_cast<uint32_t>(c));
  }
  size_t length = 0;
  MS_ASSIGN_OR_RETURN(const uint8_t* pos_fix, r.Block("stream header: position fix-ups", &length));
  h.position_fix_block.assign(pos_fix, pos_fix + length);
  MS_ASSIGN_OR_RETURN(const uint8_t* attr_fix, r.Block("stream header: attribute fix-ups", &length));
  h.attribute_fix_block.assign(attr_fix, attr_fix + length);
  if (h.has(kToolSeams)) {
    // Every pair takes at least two bytes: the count cannot claim more than the bytes hold.
    MS_ASSIGN_OR_RETURN(uint64_t twins, r.Varint("stream header: seam twin count", r.remaining() / 2));
    h.seam_twins.reserve(twins);
    for (uint64_t k = 0; k < twins; ++k) {
      MS_ASSIGN_OR_RETURN(uint64_t p, r.Varint("stream header: seam twin", h.base_vertices));
      MS_ASSIGN_OR_RETURN(uint64_t gap, r.Varint("stream header: seam twin", h.base_vertices));
      if (gap == 0 || p + gap >= h.base_vertices) {
        return refuse("seam twin pair " + std::to_string(k) + " (" + std::to_string(p) + ", +" + std::to_string(gap) +
                      ") does not name two base vertices in ascending order");
      }
      h.seam_twins.push_back({static_cast<uint32_t>(p), static_cast<uint32_t>(p + gap)});
    }
  }
  if (r.remaining() != 0) return refuse(std::to_string(r.remaining()) + (h.has(kToolSeams) ? " stray bytes after the seam twins"
                                                                                   : " stray bytes after the attribute fix-ups"));
  return h;
}

Status StreamHeader::DecodeFixups() {
  MS_RETURN_IF_ERROR(DecodeFixupBlock(position_fix_block, size_t{3} * base_vertices, base_position_fix,
                                      "stream header: position fix-ups"));
  return DecodeFixupBlock(attribute_fix_block, size_t(grids.layout.channels()) * base_vertices, base_attribute_fix,
                          "stream header: attribute fix-ups");
}

std::vector<uint32_t> StreamHeader::level_vertices() const {
  std::vector<uint32_t> out = {base_vertices};
  for (uint32_t c : split_counts) out.push_back(out.back() + c);
  return out;
}

size_t ProgressiveStream::reliable_bytes() const {
  size_t n = header.size();
  for (const auto& c : control) n += c.size();
  return n;
}

size_t ProgressiveStream::unreliable_bytes() const {
  size_t n = 0;
  for (const auto& level : datagrams)
    for (const auto& d : level) n += d.size();
  return n;
}

size_t ProgressiveStream::datagram_count() const {
  size_t n = 0;
  for (const auto& level : datagrams) n += level.size();
  return n;
}

std::vector<uint8_t> ProgressiveStream::Serialize() const {
  ByteWriter w;
  for (uint8_t b : kBlobMagic) w.U8(b);
  w.U8(version);
  w.Block(header);
  w.Varint(control.size());
  for (size_t i = 0; i < control.size(); ++i) {
    w.Block(control[i]);
    w.Varint(datagrams[i].size());
    for (const auto& d : datagrams[i]) w.Block(d);
  }
  return std::move(w.bytes());
}

StatusOr<StreamHeader> ProgressiveStream::ParseHeader() const {
  MS_ASSIGN_OR_RETURN(StreamHeader h, StreamHeader::Parse(header.data(), header.size()));
  if (h.split_counts.size() != control.size()) {
    return InvalidInput("the stream has " + std::to_string(control.size()) + " refinements, its header says " +
                        std::to_string(h.split_counts.size()));
  }
  return h;
}

StatusOr<ProgressiveStream> ProgressiveStream::Parse(const uint8_t* data, size_t size) {
  ByteReader r(data, size);
  for (uint8_t b : kBlobMagic) {
    MS_ASSIGN_OR_RETURN(uint8_t got, r.U8("stream blob: magic"));
    if (got != b) return InvalidInput("stream blob: magic is not MSPS (not a meshstream progressive stream)");
  }
  MS_ASSIGN_OR_RETURN(uint8_t version, r.U8("stream blob: version"));
  if (!IsStreamVersion(version)) {
    return Unsupported("stream blob: version " + std::to_string(version) + " is not " + kStreamVersionsText);
  }
  ProgressiveStream s;
  s.version = version;
  size_t length = 0;
  MS_ASSIGN_OR_RETURN(const uint8_t* header, r.Block("stream blob: header", &length));
  s.header.assign(header, header + length);
  if (length > 0 && header[0] != version) {
    return InvalidInput("stream blob: version " + std::to_string(version) + " differs from its header's " +
                        std::to_string(header[0]));
  }
  MS_ASSIGN_OR_RETURN(uint64_t levels, r.Varint("stream blob: refinement count", kMaxRefinements));
  for (uint64_t i = 0; i < levels; ++i) {
    MS_ASSIGN_OR_RETURN(const uint8_t* control, r.Block("stream blob: control block", &length));
    s.control.emplace_back(control, control + length);
    // Every datagram takes at least two bytes (its length and its magic).
    MS_ASSIGN_OR_RETURN(uint64_t count, r.Varint("stream blob: datagram count", r.remaining() / 2));
    s.datagrams.emplace_back();
    for (uint64_t d = 0; d < count; ++d) {
      MS_ASSIGN_OR_RETURN(const uint8_t* dg, r.Block("stream blob: datagram", &length));
      s.datagrams.back().emplace_back(dg, dg + length);
    }
  }
  if (r.remaining() != 0) {
    return InvalidInput("stream blob: " + std::to_string(r.remaining()) + " stray bytes after the last refinement");
  }
  return s;
}

void DatagramHeader::Serialize(ByteWriter& w) const {
  w.U8(kDatagramMagic);
  w.U8(version);
  w.U8(static_cast<uint8_t>(kind));
  w.Varint(stream);
  w.Varint(refinement);
  w.Varint(stride);
  w.Varint(offset);
  w.Varint(count);
}

StatusOr<DatagramHeader> DatagramHeader::Parse(ByteReader& r) {
  DatagramHeader h;
  MS_ASSIGN_OR_RETURN(uint8_t magic, r.U8("datagram: magic"));
  if (magic != kDatagramMagic) return InvalidInput("datagram: magic " + std::to_string(magic) + " is not 0x4D");
  MS_ASSIGN_OR_RETURN(uint8_t version, r.U8("datagram: version"));
  if (!IsStreamVersion(version)) {
    return Unsupported("datagram: version " + std::to_string(version) + " is not " + kStreamVersionsText);
  }
  h.version = version;
  MS_ASSIGN_OR_RETURN(uint8_t kind, r.U8("datagram: kind"));
  if (kind > 4) return InvalidInput("datagram: kind " + std::to_string(kind) + " is reserved");
  h.kind = static_cast<DatagramKind>(kind);
  MS_ASSIGN_OR_RETURN(uint64_t stream, r.Varint("datagram: stream", UINT32_MAX));
  MS_ASSIGN_OR_RETURN(uint64_t refinement, r.Varint("datagram: refinement", kMaxRefinements - 1));
  MS_ASSIGN_OR_RETURN(uint64_t stride, r.Varint("datagram: stride", kMaxStreamVertices));
  MS_ASSIGN_OR_RETURN(uint64_t offset, r.Varint("datagram: offset", kMaxStreamVertices));
  MS_ASSIGN_OR_RETURN(uint64_t count, r.Varint("datagram: count", kMaxStreamVertices));
  if (kind == static_cast<uint8_t>(DatagramKind::kEnd)) {
    if (stride != 1) return InvalidInput("datagram: END has stride " + std::to_string(stride) + ", not 1");
    if (offset != 0) return InvalidInput("datagram: END has offset " + std::to_string(offset) + ", not 0");
    if (r.remaining() != 0) return InvalidInput("datagram: END has " + std::to_string(r.remaining()) + " payload bytes");
  } else if (kind == static_cast<uint8_t>(DatagramKind::kParity)) {
    // stride: the block's rows n = k + m; offset: this parity's row; count: k.
    if (stride > kParityMaxRows) {
      return InvalidInput("datagram: parity of " + std::to_string(stride) + " rows (at most 256)");
    }
    if (count == 0 || count >= stride) {
      return InvalidInput("datagram: parity of " + std::to_string(count) + " members in " + std::to_string(stride) +
                          " rows (1 to rows - 1)");
    }
    if (offset < count || offset >= stride) {
      return InvalidInput("datagram: parity row " + std::to_string(offset) + " is not in [" + std::to_string(count) +
                          ", " + std::to_string(stride) + ")");
    }
  } else if (stride == 0) {
    return InvalidInput("datagram: stride 0 is not allowed");
  } else if (offset >= stride) {
    return InvalidInput("datagram: offset " + std::to_string(offset) + " is not below stride " + std::to_string(stride));
  } else if (count == 0) {
    return InvalidInput("datagram: count 0 is not allowed");
  }
  h.stream = static_cast<uint32_t>(stream);
  h.refinement = static_cast<uint32_t>(refinement);
  h.stride = static_cast<uint32_t>(stride);
  h.offset = static_cast<uint32_t>(offset);
  h.count = static_cast<uint32_t>(count);
  return h;
}

bool DatagramFits(const DatagramHeader& h, const StreamHeader& header) {
  if (h.version != header.version || h.refinement >= header.split_counts.size()) return false;
  if (header.reliable()) return false;  // its refinements carry their data in the control block
  const bool kind_ok = header.packing == Packing::kBundled
                           ? h.kind == DatagramKind::kBundled
                           : h.kind == DatagramKind::kStructure || h.kind == DatagramKind::kGeometry;
  // Parse guarantees count >= 1 and stride, offset, count <= 2^28: no overflow.
  return kind_ok && h.offset + uint64_t(h.count - 1) * h.stride < header.split_counts[h.refinement];
}

std::vector<uint8_t> MakeEndDatagram(uint32_t stream, uint32_t refinement, uint32_t datagrams, uint8_t version) {
  DatagramHeader h;
  h.version = version;
  h.kind = DatagramKind::kEnd;
  h.stream = stream;
  h.refinement = refinement;
  h.stride = 1;
  h.offset = 0;
  h.count = datagrams;
  ByteWriter w;
  h.Serialize(w);
  return std::move(w.bytes());
}

std::vector<uint8_t> MakeStreamEndDatagram(const uint8_t* stream_header, size_t header_size, uint32_t stream,
                                           uint32_t refinement, uint32_t datagrams) {
  const uint8_t version = header_size > 0 ? stream_header[0] : kStreamVersion;
  return MakeEndDatagram(stream, refinement, datagrams, version);
}

StatusOr<ParsedDatagram> ParsedDatagram::Parse(const uint8_t* data, size_t size) {
  ByteReader r(data, size);
  ParsedDatagram d;
  MS_ASSIGN_OR_RETURN(d.header_, DatagramHeader::Parse(r));
  d.data_ = data;
  d.size_ = size;
  d.payload_offset_ = r.position();
  return d;
}

ParsedDatagram ParsedDatagram::Over(const uint8_t* copy) const {
  ParsedDatagram d = *this;
  d.data_ = copy;
  return d;
}

}  // namespace meshstream
