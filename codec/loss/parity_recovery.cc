#include "codec/loss/parity_recovery.h"

#include <algorithm>
#include <cstring>

namespace meshstream {
namespace {

constexpr size_t kEntryOverhead = 64;

bool SameMembers(const std::vector<ParityMember>& a, const std::vector<ParityMember>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].refinement != b[i].refinement || a[i].kind != b[i].kind || a[i].offset != b[i].offset ||
        a[i].length != b[i].length) {
      return false;
    }
  }
  return true;
}

}  // namespace

const ParityRecovery::Copy* ParityRecovery::Find(const ParityMember& m) const {
  auto it = copies_.find(m.refinement);
  if (it == copies_.end()) return nullptr;
  for (const Copy& c : it->second) {
    if (c.kind == m.kind && c.offset == m.offset && c.bytes.size() == m.length) return &c;
  }
  return nullptr;
}

bool ParityRecovery::Keep(uint32_t refinement, DatagramKind kind, uint32_t offset, const uint8_t* data,
                          size_t size) {
  if (refinement < first_) return false;
  std::vector<Copy>& list = copies_[refinement];
  for (const Copy& c : list) {
    if (c.kind == kind && c.offset == offset && c.bytes.size() == size) return false;  // kept already
  }
  const size_t cost = size + kEntryOverhead;
  if (held_ > max_bytes_ || cost > max_bytes_ - held_) {
    ++stats_.overflow;
    return false;
  }
  list.push_back(Copy{kind, offset, std::vector<uint8_t>(data, data + size)});
  held_ += cost;
  return true;
}

void ParityRecovery::OnData(const ParsedDatagram& d, std::vector<std::vector<uint8_t>>* rebuilt) {
  const DatagramHeader& h = d.header();
  if (!Keep(h.refinement, h.kind, h.offset, d.data(), d.size())) return;
  for (size_t i = 0; i < blocks_.size();) {
    Block& b = blocks_[i];
    const bool member = h.refinement >= b.members.front().refinement && h.refinement <= b.members.back().refinement &&
                        std::any_of(b.members.begin(), b.members.end(),
                                    [&](const ParityMember& m) { return m.SameDatagram(h, d.size()); });
    if (member && TryRebuild(b, rebuilt)) {
      DropBlock(i);
    } else {
      ++i;
    }
  }
}

void ParityRecovery::OnParity(const ParsedDatagram& d, std::vector<std::vector<uint8_t>>* rebuilt) {
  ++stats_.parity;
  auto parsed = ParityDatagram::Parse(d);
  if (!parsed.ok() || parsed->stream != stream_) {
    ++stats_.rejected;
    return;
  }
  ParityDatagram& p = parsed.value();
  if (!p.members.empty()) newest_first_ = std::max(newest_first_.value_or(0), p.first_refinement());
  if (p.last_refinement() < first_) {
    ++stats_.late;
    return;
  }
  size_t i = 0;
  while (i < blocks_.size() && !(blocks_[i].symbol_size == p.symbol_size && SameMembers(blocks_[i].members, p.members))) {
    ++i;
  }
  if (i == blocks_.size()) {
    // A block whose members are all kept needs no parity.
    if (std::all_of(p.members.begin(), p.members.end(), [&](const ParityMember& m) { return Find(m) != nullptr; })) {
      ++stats_.late;
      return;
    }
    blocks_.push_back(Block{std::move(p.members), p.k, p.symbol_size, {}});
  }
  Block& b = blocks_[i];
  for (uint32_t j = 0; j < p.count; ++j) {
    const uint32_t row = p.first_row + j;
    if (b.parity.count(row) != 0) continue;  // a copy
    const size_t cost = p.symbol_size + kEntryOverhead;
    if (held_ > max_bytes_ || cost > max_bytes_ - held_) {
      ++stats_.overflow;
      break;
    }
    const uint8_t* at = p.symbols + size_t(j) * p.symbol_size;
    b.parity.emplace(row, std::vector<uint8_t>(at, at + p.symbol_size));
    held_ += cost;
  }
  if (b.parity.empty()) {
    DropBlock(i);
    return;
  }
  if (TryRebuild(b, rebuilt)) DropBlock(i);
}

bool ParityRecovery::TryRebuild(Block& b, std::vector<std::vector<uint8_t>>* rebuilt) {
  const uint32_t k = b.k, S = b.symbol_size;
  // Data rows of present members (their bytes cut into S-byte symbols, the
  // last zero-padded) and the rows of missing ones.
  std::vector<uint8_t> present_bytes;
  std::vector<uint32_t> rows, wanted, missing;  // missing: member indices
  std::vector<size_t> present_at;               // offsets into present_bytes, per row in `rows`
  uint32_t row = 0;
  for (uint32_t i = 0; i < b.members.size(); ++i) {
    const ParityMember& m = b.members[i];
    const uint32_t n = static_cast<uint32_t>(SymbolsOf(m.length, S));
    const Copy* c = Find(m);
    if (c == nullptr) {
      missing.push_back(i);
      for (uint32_t j = 0; j < n; ++j) wanted.push_back(row + j);
    } else {
      const size_t at = present_bytes.size();
      present_bytes.resize(at + size_t(n) * S, 0);
      std::memcpy(&present_bytes[at], c->bytes.data(), c->bytes.size());
      for (uint32_t j = 0; j < n; ++j) {
        rows.push_back(row + j);
        present_at.push_back(at + size_t(j) * S);
      }
    }
    row += n;
  }
  if (missing.empty()) return true;                     // whole
  if (rows.size() + b.parity.size() < k) return false;  // not yet
  std::vector<const uint8_t*> symbols;
  for (size_t j = 0; j < rows.size() && j < k; ++j) symbols.push_back(&present_bytes[present_at[j]]);
  rows.resize(std::min<size_t>(rows.size(), k));
  for (const auto& [parity_row, symbol] : b.parity) {
    if (rows.size() == k) break;
    rows.push_back(parity_row);
    symbols.push_back(symbol.data());
  }
  std::vector<uint8_t> out(wanted.size() * size_t(S));
  std::vector<uint8_t*> out_ptrs(wanted.size());
  for (size_t j = 0; j < wanted.size(); ++j) out_ptrs[j] = &out[j * S];
  if (!code_->Rebuild(k, S, rows.data(), symbols.data(), wanted.data(), wanted.size(), out_ptrs.data()).ok()) {
    ++stats_.inconsistent;
    return true;
  }
  // Each rebuilt datagram must name the member it was rebuilt as; one that
  // does not means a parity (or a member) was not the sender's. The missing
  // members' rows are consecutive in `out`, in member order.
  std::vector<std::vector<uint8_t>> made;
  size_t at = 0;
  for (uint32_t i : missing) {
    const ParityMember& m = b.members[i];
    std::vector<uint8_t> bytes(out.begin() + at, out.begin() + at + m.length);
    at += SymbolsOf(m.length, S) * S;
    auto d = ParsedDatagram::Parse(bytes.data(), bytes.size());
    if (!d.ok() || !m.SameDatagram(d->header(), m.length) || d->header().stream != stream_) {
      ++stats_.inconsistent;
      return true;
    }
    made.push_back(std::move(bytes));
  }
  for (size_t j = 0; j < missing.size(); ++j) {
    const ParityMember& m = b.members[missing[j]];
    Keep(m.refinement, m.kind, m.offset, made[j].data(), made[j].size());
    ++stats_.recovered;
    rebuilt->push_back(std::move(made[j]));
  }
  return true;
}

void ParityRecovery::DropBlock(size_t i) {
  for (const auto& [row, symbol] : blocks_[i].parity) held_ -= symbol.size() + kEntryOverhead;
  blocks_.erase(blocks_.begin() + static_cast<std::ptrdiff_t>(i));
}

std::vector<const std::vector<uint8_t>*> ParityRecovery::Kept(uint32_t r) const {
  std::vector<const std::vector<uint8_t>*> out;
  auto it = copies_.find(r);
  if (it == copies_.end()) return out;
  for (const Copy& c : it->second) out.push_back(&c.bytes);
  return out;
}

bool ParityRecovery::MayStillCover(uint32_t r) const {
  if (!newest_first_ || *newest_first_ <= r) return true;
  return std::any_of(blocks_.begin(), blocks_.end(), [r](const Block& b) {
    return b.members.front().refinement <= r && r <= b.members.back().refinement;
  });
}

void ParityRecovery::Release(uint32_t first) {
  if (first <= first_) return;
  first_ = first;
  while (!copies_.empty() && copies_.begin()->first < first) {
    for (const Copy& c : copies_.begin()->second) held_ -= c.bytes.size() + kEntryOverhead;
    copies_.erase(copies_.begin());
  }
  for (size_t i = 0; i < blocks_.size();) {
    if (blocks_[i].members.back().refinement < first) {
      DropBlock(i);
    } else {
      ++i;
    }
  }
}

}  // namespace meshstream
