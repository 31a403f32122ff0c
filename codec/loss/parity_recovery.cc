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
  if (p.last_refinement() < first_) {
    ++stats_.late;
    return;
  }
  size_t i = 0;
  while (i < blocks_.size() && !SameMembers(blocks_[i].members, p.members)) ++i;
  if (i == blocks_.size()) {
    // A block whose members are all kept needs no parity.
    if (std::all_of(p.members.begin(), p.members.end(), [&](const ParityMember& m) { return Find(m) != nullptr; })) {
      ++stats_.late;
      return;
    }
    blocks_.push_back(Block{std::move(p.members), {}});
  }
  Block& b = blocks_[i];
  if (b.parity.count(p.row) != 0) return;  // a copy
  const size_t cost = p.symbol_size + kEntryOverhead;
  if (held_ > max_bytes_ || cost > max_bytes_ - held_) {
    ++stats_.overflow;
    if (b.parity.empty()) DropBlock(i);
    return;
  }
  b.parity.emplace(p.row, std::vector<uint8_t>(p.symbol, p.symbol + p.symbol_size));
  held_ += cost;
  if (TryRebuild(b, rebuilt)) DropBlock(i);
}

bool ParityRecovery::TryRebuild(Block& b, std::vector<std::vector<uint8_t>>* rebuilt) {
  const size_t k = b.members.size();
  std::vector<uint32_t> rows, wanted;
  std::vector<const uint8_t*> symbols;
  size_t longest = 0;
  for (const ParityMember& m : b.members) longest = std::max<size_t>(longest, m.length);
  std::vector<std::vector<uint8_t>> padded;  // present members, zero-padded
  padded.reserve(k);
  for (uint32_t i = 0; i < k; ++i) {
    const Copy* c = Find(b.members[i]);
    if (c == nullptr) {
      wanted.push_back(i);
      continue;
    }
    padded.emplace_back(longest, 0);
    std::memcpy(padded.back().data(), c->bytes.data(), c->bytes.size());
    rows.push_back(i);
    symbols.push_back(padded.back().data());
  }
  if (wanted.empty()) return true;                          // whole
  if (rows.size() + b.parity.size() < k) return false;      // not yet
  for (const auto& [row, symbol] : b.parity) {
    if (rows.size() == k) break;
    rows.push_back(row);
    symbols.push_back(symbol.data());
  }
  std::vector<std::vector<uint8_t>> out(wanted.size(), std::vector<uint8_t>(longest));
  std::vector<uint8_t*> out_ptrs;
  for (auto& o : out) out_ptrs.push_back(o.data());
  if (!code_->Rebuild(k, longest, rows.data(), symbols.data(), wanted.data(), wanted.size(), out_ptrs.data()).ok()) {
    ++stats_.inconsistent;
    return true;
  }
  // Each rebuilt datagram must name the member it was rebuilt as; one that
  // does not means a parity (or a member) was not the sender's.
  for (size_t j = 0; j < wanted.size(); ++j) {
    const ParityMember& m = b.members[wanted[j]];
    auto d = ParsedDatagram::Parse(out[j].data(), m.length);
    if (!d.ok() || !m.SameDatagram(d->header(), m.length) || d->header().stream != stream_) {
      ++stats_.inconsistent;
      return true;
    }
  }
  for (size_t j = 0; j < wanted.size(); ++j) {
    const ParityMember& m = b.members[wanted[j]];
    out[j].resize(m.length);
    Keep(m.refinement, m.kind, m.offset, out[j].data(), out[j].size());
    ++stats_.recovered;
    rebuilt->push_back(std::move(out[j]));
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
