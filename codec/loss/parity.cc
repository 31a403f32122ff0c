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
  p.row = h.offset;
  const uint32_t k = h.count;  // 1 <= k < rows <= 256 (DatagramHeader::Parse)
  ByteReader r(d.payload(), d.payload_size());
  MS_ASSIGN_OR_RETURN(uint64_t runs, r.Varint("parity: runs", k));
  if (runs == 0) return InvalidInput("parity: no runs of members");
  p.members.reserve(k);
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
    MS_ASSIGN_OR_RETURN(uint64_t length, r.Varint("parity: run length", k));
    if (length == 0 || p.members.size() + length > k) {
      return InvalidInput("parity: run " + std::to_string(i) + " of " + std::to_string(length) + " members after " +
                          std::to_string(p.members.size()) + " of " + std::to_string(k));
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
  if (p.members.size() != k) {
    return InvalidInput("parity: runs name " + std::to_string(p.members.size()) + " members, the header " +
                        std::to_string(k));
  }
  size_t longest = 0;
  for (ParityMember& m : p.members) {
    MS_ASSIGN_OR_RETURN(uint16_t length, r.U16("parity: member length"));
    if (length == 0 || length > kMaxPacketBytes) {
      return InvalidInput("parity: member length " + std::to_string(length) + " (1 to 65507)");
    }
    m.length = length;
    longest = std::max<size_t>(longest, length);
  }
  if (r.remaining() != longest) {
    return InvalidInput("parity: symbol of " + std::to_string(r.remaining()) + " bytes, the longest member has " +
                        std::to_string(longest));
  }
  p.symbol = d.payload() + r.position();
  p.symbol_size = longest;
  return p;
}

std::vector<uint8_t> SerializeParity(uint8_t version, uint32_t stream, uint32_t rows, uint32_t row,
                                     const std::vector<ParityMember>& members, const uint8_t* symbol) {
  DatagramHeader h;
  h.version = version;
  h.kind = DatagramKind::kParity;
  h.stream = stream;
  h.refinement = members.empty() ? 0 : members.front().refinement;
  h.stride = rows;
  h.offset = row;
  h.count = static_cast<uint32_t>(members.size());
  ByteWriter w;
  h.Serialize(w);
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
  size_t longest = 0;
  for (const ParityMember& m : members) {
    w.U16(static_cast<uint16_t>(m.length));
    longest = std::max<size_t>(longest, m.length);
  }
  std::vector<uint8_t> out = std::move(w.bytes());
  out.insert(out.end(), symbol, symbol + longest);
  return out;
}

StatusOr<std::vector<std::vector<uint8_t>>> EncodeParity(ErasureCode& code, uint32_t stream,
                                                         const std::vector<const std::vector<uint8_t>*>& datagrams,
                                                         uint32_t rows, uint32_t first_row, uint32_t count) {
  const size_t k = datagrams.size();
  if (k == 0 || k >= kParityMaxRows || rows > kParityMaxRows || first_row < k || first_row + count > rows) {
    return InvalidArgument("parity: rows [" + std::to_string(first_row) + ", " + std::to_string(first_row + count) +
                           ") of a block of " + std::to_string(k) + " members in " + std::to_string(rows) + " rows");
  }
  struct Entry {
    ParityMember member;
    const std::vector<uint8_t>* bytes;
  };
  std::vector<Entry> entries;
  uint8_t version = kStreamVersion;
  for (const std::vector<uint8_t>* bytes : datagrams) {
    MS_ASSIGN_OR_RETURN(ParsedDatagram d, ParsedDatagram::Parse(bytes->data(), bytes->size()));
    const DatagramHeader& h = d.header();
    if (h.kind == DatagramKind::kEnd || h.kind == DatagramKind::kParity || h.stream != stream ||
        bytes->size() > kMaxPacketBytes) {
      return InvalidArgument("parity: a member is not a data datagram of stream " + std::to_string(stream));
    }
    version = h.version;
    entries.push_back({ParityMember{h.refinement, h.kind, h.offset, static_cast<uint32_t>(bytes->size())}, bytes});
  }
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return MemberBefore(a.member, b.member); });
  size_t longest = 0;
  std::vector<ParityMember> members;
  for (size_t i = 0; i < k; ++i) {
    if (i > 0 && !MemberBefore(entries[i - 1].member, entries[i].member)) {
      return InvalidArgument("parity: two members name datagram (" + std::to_string(entries[i].member.refinement) +
                             ", " + std::to_string(static_cast<int>(entries[i].member.kind)) + ", " +
                             std::to_string(entries[i].member.offset) + ")");
    }
    members.push_back(entries[i].member);
    longest = std::max(longest, entries[i].bytes->size());
  }
  if (members.back().refinement - members.front().refinement >= kMaxRefinements) {
    return InvalidArgument("parity: members span too many refinements");
  }
  // Symbols: each datagram zero-padded to the longest.
  std::vector<std::vector<uint8_t>> padded(k, std::vector<uint8_t>(longest, 0));
  std::vector<const uint8_t*> in(k);
  for (size_t i = 0; i < k; ++i) {
    std::copy(entries[i].bytes->begin(), entries[i].bytes->end(), padded[i].begin());
    in[i] = padded[i].data();
  }
  std::vector<std::vector<uint8_t>> symbols(count, std::vector<uint8_t>(longest));
  std::vector<uint8_t*> out(count);
  std::vector<uint32_t> row_ids(count);
  for (uint32_t j = 0; j < count; ++j) {
    out[j] = symbols[j].data();
    row_ids[j] = first_row + j;
  }
  MS_RETURN_IF_ERROR(code.Encode(k, longest, in.data(), row_ids.data(), count, out.data()));
  std::vector<std::vector<uint8_t>> parity;
  parity.reserve(count);
  for (uint32_t j = 0; j < count; ++j) {
    parity.push_back(SerializeParity(version, stream, rows, first_row + j, members, symbols[j].data()));
  }
  return parity;
}

}  // namespace meshstream
