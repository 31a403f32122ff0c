#include "codec/loss/parity.h"

#include <algorithm>
#include <string>
#include <tuple>

#include "codec/core/byte_io.h"

namespace meshstream {

bool MemberBefore(const ParityMember& a, const ParityMember& b) {
  return std::make_tuple(a.refinement, static_cast<uint8_t>(a.kind), a.offset) <
         std::make_tuple(b.refinement, static_cast<uint8_t>(b.kind), b.offset);
}

StatusOr<ParityDatagram> ParityDatagram::Parse(const ParsedDatagram& d) {
  const DatagramHeader& h = d.header();
  if (h.kind != DatagramKind::kParity) return InvalidArgument("parity: not a parity datagram");
  ParityDatagram p;
  p.version = h.version;
  p.stream = h.stream;
  p.rows = h.stride;
  p.first_row = h.offset;
  p.k = h.count;  // 1 <= k <= offset < rows <= 256 (DatagramHeader::Parse)
  ByteReader r(d.payload(), d.payload_size());
  MS_ASSIGN_OR_RETURN(uint64_t symbol, r.Varint("parity: symbol size", kMaxPacketBytes));
  if (symbol == 0) return InvalidInput("parity: symbol size 0");
  p.symbol_size = static_cast<uint32_t>(symbol);
  MS_ASSIGN_OR_RETURN(uint64_t count, r.Varint("parity: rows carried", kParityMaxRows));
  if (count == 0 || p.first_row + count > p.rows) {
    return InvalidInput("parity: " + std::to_string(count) + " rows from row " + std::to_string(p.first_row) +
                        " in a block of " + std::to_string(p.rows));
  }
  p.count = static_cast<uint32_t>(count);
  MS_ASSIGN_OR_RETURN(uint64_t runs, r.Varint("parity: runs", p.k));
  if (runs == 0) return InvalidInput("parity: no runs of members");
  uint64_t refinement = h.refinement;
  for (uint64_t i = 0; i < runs; ++i) {
    MS_ASSIGN_OR_RETURN(uint64_t delta, r.Varint("parity: refinement delta", kMaxRefinements - 1));
    if (i == 0 && delta != 0) {
      return InvalidInput("parity: the first run's refinement delta is " + std::to_string(delta) + ", not 0");
    }
    refinement += delta;
    if (refinement >= kMaxRefinements) {
      return InvalidInput("parity: run " + std::to_string(i) + " names refinement " + std::to_string(refinement));
    }
    MS_ASSIGN_OR_RETURN(uint8_t kind, r.U8("parity: member kind"));
    if (kind > static_cast<uint8_t>(DatagramKind::kGeometry)) {
      return InvalidInput("parity: run " + std::to_string(i) + " has kind " + std::to_string(kind) + " (0, 1 or 2)");
    }
    MS_ASSIGN_OR_RETURN(uint64_t first, r.Varint("parity: first offset", kMaxStreamVertices));
    // Every member is at least one data row: at most k members in all.
    MS_ASSIGN_OR_RETURN(uint64_t length, r.Varint("parity: run length", p.k));
    if (length == 0 || p.members.size() + length > p.k) {
      return InvalidInput("parity: run " + std::to_string(i) + " of " + std::to_string(length) + " members after " +
                          std::to_string(p.members.size()) + ", more than the " + std::to_string(p.k) + " data rows");
    }
    for (uint64_t j = 0; j < length; ++j) {
      ParityMember m;
      m.refinement = static_cast<uint32_t>(refinement);
      m.kind = static_cast<DatagramKind>(kind);
      m.offset = static_cast<uint32_t>(first + j);
      if (!p.members.empty() && !MemberBefore(p.members.back(), m)) {
        return InvalidInput("parity: member " + std::to_string(p.members.size()) + " is not after the one before");
      }
      p.members.push_back(m);
    }
  }
  uint64_t data_rows = 0;
  for (ParityMember& m : p.members) {
    MS_ASSIGN_OR_RETURN(uint16_t length, r.U16("parity: member length"));
    if (length == 0 || length > kMaxPacketBytes) {
      return InvalidInput("parity: member length " + std::to_string(length) + " (1 to 65507)");
    }
    m.length = length;
    data_rows += SymbolsOf(length, p.symbol_size);
  }
  if (data_rows != p.k) {
    return InvalidInput("parity: members make " + std::to_string(data_rows) + " data rows of " +
                        std::to_string(p.symbol_size) + " bytes, the header says " + std::to_string(p.k));
  }
  if (r.remaining() != uint64_t(p.count) * p.symbol_size) {
    return InvalidInput("parity: " + std::to_string(r.remaining()) + " bytes of rows, " + std::to_string(p.count) +
                        " rows of " + std::to_string(p.symbol_size) + " need " +
                        std::to_string(uint64_t(p.count) * p.symbol_size));
  }
  p.symbols = d.payload() + r.position();
  return p;
}

uint32_t SymbolSizeFor(const std::vector<uint32_t>& lengths, uint32_t max_k) {
  uint32_t longest = 0;
  for (uint32_t l : lengths) longest = std::max(longest, l);
  if (longest == 0 || max_k == 0) return std::max<uint32_t>(1, longest);
  auto rows = [&](uint32_t s) {
    uint64_t k = 0;
    for (uint32_t l : lengths) k += SymbolsOf(l, s);
    return k;
  };
  if (rows(longest) > max_k) return longest;  // more members than rows: one row each is the least
  uint32_t lo = 1, hi = longest;  // rows(hi) <= max_k
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (rows(mid) <= max_k) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return lo;
}

uint32_t RowsPerDatagram(uint32_t symbol_size, size_t members, uint32_t packet_bytes) {
  // Header (at most 3 + 5 x 4 bytes), S and c, runs (at most 12 bytes each,
  // one per member at worst) and 2 bytes per member length.
  const uint64_t overhead = 23 + 8 + 14 * uint64_t(members);
  if (symbol_size == 0 || packet_bytes <= overhead) return 1;
  return static_cast<uint32_t>(std::max<uint64_t>(1, (packet_bytes - overhead) / symbol_size));
}

namespace {

std::vector<uint8_t> SerializeParity(uint8_t version, uint32_t stream, uint32_t rows, uint32_t first_row,
                                     uint32_t count, uint32_t k, uint32_t symbol_size,
                                     const std::vector<ParityMember>& members, const uint8_t* symbols) {
  DatagramHeader h;
  h.version = version;
  h.kind = DatagramKind::kParity;
  h.stream = stream;
  h.refinement = members.empty() ? 0 : members.front().refinement;
  h.stride = rows;
  h.offset = first_row;
  h.count = k;
  ByteWriter w;
  h.Serialize(w);
  w.Varint(symbol_size);
  w.Varint(count);
  // Runs: members of one refinement and kind with consecutive offsets.
  std::vector<std::pair<size_t, size_t>> runs;  // first member, length
  for (size_t i = 0; i < members.size(); ++i) {
    const bool continues = i > 0 && members[i].refinement == members[i - 1].refinement &&
                           members[i].kind == members[i - 1].kind && members[i].offset == members[i - 1].offset + 1;
    if (continues) {
      ++runs.back().second;
    } else {
      runs.push_back({i, 1});
    }
  }
  w.Varint(runs.size());
  uint32_t refinement = h.refinement;
  for (const auto& [first, length] : runs) {
    const ParityMember& m = members[first];
    w.Varint(m.refinement - refinement);
    refinement = m.refinement;
    w.U8(static_cast<uint8_t>(m.kind));
    w.Varint(m.offset);
    w.Varint(length);
  }
  for (const ParityMember& m : members) w.U16(static_cast<uint16_t>(m.length));
  std::vector<uint8_t> out = std::move(w.bytes());
  out.insert(out.end(), symbols, symbols + size_t(count) * symbol_size);
  return out;
}

}  // namespace

StatusOr<std::vector<std::vector<uint8_t>>> EncodeParity(ErasureCode& code, uint32_t stream,
                                                         const std::vector<const std::vector<uint8_t>*>& datagrams,
                                                         const ParityShape& shape) {
  const uint32_t S = shape.symbol_size;
  if (datagrams.empty() || S == 0 || S > kMaxPacketBytes || shape.m == 0 || shape.per_datagram == 0 ||
      uint64_t(shape.k) + shape.m > kParityMaxRows) {
    return InvalidArgument("parity: a block of " + std::to_string(datagrams.size()) + " members, " +
                           std::to_string(shape.k) + " + " + std::to_string(shape.m) + " rows of " +
                           std::to_string(S) + " bytes");
  }
  struct Entry {
    ParityMember member;
    const std::vector<uint8_t>* bytes;
  };
  std::vector<Entry> entries;
  uint8_t version = kStreamVersion;
  uint64_t rows = 0;
  for (const std::vector<uint8_t>* bytes : datagrams) {
    MS_ASSIGN_OR_RETURN(ParsedDatagram d, ParsedDatagram::Parse(bytes->data(), bytes->size()));
    const DatagramHeader& h = d.header();
    if (h.kind == DatagramKind::kEnd || h.kind == DatagramKind::kParity || h.stream != stream ||
        bytes->size() > kMaxPacketBytes) {
      return InvalidArgument("parity: a member is not a data datagram of stream " + std::to_string(stream));
    }
    version = h.version;
    rows += SymbolsOf(bytes->size(), S);
    entries.push_back({ParityMember{h.refinement, h.kind, h.offset, static_cast<uint32_t>(bytes->size())}, bytes});
  }
  if (rows != shape.k) {
    return InvalidArgument("parity: the members make " + std::to_string(rows) + " data rows, not " +
                           std::to_string(shape.k));
  }
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return MemberBefore(a.member, b.member); });
  std::vector<ParityMember> members;
  for (size_t i = 0; i < entries.size(); ++i) {
    if (i > 0 && !MemberBefore(entries[i - 1].member, entries[i].member)) {
      return InvalidArgument("parity: two members name datagram (" + std::to_string(entries[i].member.refinement) +
                             ", " + std::to_string(static_cast<int>(entries[i].member.kind)) + ", " +
                             std::to_string(entries[i].member.offset) + ")");
    }
    members.push_back(entries[i].member);
  }
  // Data rows: each member cut into S-byte symbols, the last zero-padded.
  std::vector<uint8_t> data(size_t(shape.k) * S, 0);
  std::vector<const uint8_t*> in(shape.k);
  size_t row = 0;
  for (const Entry& e : entries) {
    std::copy(e.bytes->begin(), e.bytes->end(), data.begin() + row * S);
    const size_t n = SymbolsOf(e.bytes->size(), S);
    for (size_t j = 0; j < n; ++j, ++row) in[row] = &data[row * S];
  }
  std::vector<uint8_t> parity(size_t(shape.m) * S);
  std::vector<uint8_t*> out(shape.m);
  std::vector<uint32_t> row_ids(shape.m);
  for (uint32_t j = 0; j < shape.m; ++j) {
    out[j] = &parity[size_t(j) * S];
    row_ids[j] = shape.k + j;
  }
  MS_RETURN_IF_ERROR(code.Encode(shape.k, S, in.data(), row_ids.data(), shape.m, out.data()));
  std::vector<std::vector<uint8_t>> datagrams_out;
  for (uint32_t first = 0; first < shape.m; first += shape.per_datagram) {
    const uint32_t count = std::min(shape.per_datagram, shape.m - first);
    datagrams_out.push_back(SerializeParity(version, stream, shape.k + shape.m, shape.k + first, count, shape.k, S,
                                            members, &parity[size_t(first) * S]));
  }
  return datagrams_out;
}

}  // namespace meshstream
