// Tolerant decoding of Velodyne data packets: what real firmware and real networks send besides
// clean packets. The ROS velodyne driver and nebula take a block's azimuth modulo 36000 (real
// firmware emits 36000 at the wrap) and the ROS driver stops at a block whose header is no bank
// id instead of refusing the packet; we do the same per block, and also drop blocks that break
// the packet's azimuth order (a corrupt block would otherwise smear its points over the circle
// and cut the scan twice). Every case is counted in DecoderQuirks and warned once.
#include <fmt/format.h>

#include "sources/velodyne_decoder.hpp"

namespace hazmap::velodyne_detail {

namespace {

/// Blocks (of `candidates`, in packet order) to keep: the most that turn less than once around
/// in order. A block slightly behind its predecessor looks like a turn of almost 360°, while a
/// sensor with a restricted field of view legitimately jumps forward by up to 360° − its view
/// (the VLP-32C recording here jumps 180°), so "backwards" cannot be a threshold on one step.
/// Chains are tried from each first block, azimuths measured forward from it; n ≤ 12.
std::vector<int> inOrder(const std::vector<int>& candidates, const std::uint8_t* p) {
  const int n = static_cast<int>(candidates.size());
  const auto azimuth = [&](int i) { return static_cast<int>(u16(p + candidates[static_cast<std::size_t>(i)] * kBlockBytes + 2)); };
  const auto forward = [&](int from, int to) { return (azimuth(to) - azimuth(from) + kCentiDegrees) % kCentiDegrees; };
  int turn = 0;  // the usual case first: all in order, less than a turn in total
  for (int i = 1; i < n && turn < kCentiDegrees; ++i) turn += forward(i - 1, i);
  if (turn < kCentiDegrees) return candidates;
  std::vector<int> best;
  for (int s = 0; s + static_cast<int>(best.size()) < n; ++s) {
    std::vector<int> length(n, 0), previous(n, -1);
    length[s] = 1;
    int end = s;
    for (int i = s + 1; i < n; ++i) {
      for (int j = s; j < i; ++j)
        if (length[j] > 0 && forward(s, j) <= forward(s, i) && length[j] + 1 > length[i])
          length[i] = length[j] + 1, previous[i] = j;
      if (length[i] > length[end]) end = i;
    }
    if (length[end] <= static_cast<int>(best.size())) continue;
    best.clear();
    for (int i = end; i >= 0; i = previous[i]) best.insert(best.begin(), candidates[static_cast<std::size_t>(i)]);
  }
  return best;
}

void putAzimuth(std::uint8_t* p, int block, std::uint16_t azimuth) {
  p[block * kBlockBytes + 2] = static_cast<std::uint8_t>(azimuth & 0xff);
  p[block * kBlockBytes + 3] = static_cast<std::uint8_t>(azimuth >> 8);
}

}  // namespace

/// Wraps azimuth 36000 to 0 and marks the blocks not to decode (impossible azimuth, no bank id,
/// out of order) in skip_; a skipped block takes its neighbour's azimuth so that the others'
/// azimuth steps stay sane. False when no block of the packet is left.
bool VelodyneDecoder::repairBlocks(std::uint8_t mode, const std::string& where) {
  std::uint8_t* p = packet_.data();
  const bool vls = *model_ == VelodyneModel::VLS128;
  const int used = vls && mode == kModeDual ? 8 : kBlocks;
  std::vector<int> candidates;
  bool odd[kBlocks] = {};  // skipped for what it holds (its azimuth is replaced below)
  for (int b = 0; b < kBlocks; ++b) {
    skip_[b] = true;
    const std::uint16_t header = u16(p + b * kBlockBytes), azimuth = u16(p + b * kBlockBytes + 2);
    if (azimuth == kCentiDegrees) {
      putAzimuth(p, b, 0);
      quirks_.note("Velodyne block azimuths of 36000 wrapped to 0", where);
    } else if (azimuth > kCentiDegrees) {
      quirks_.note("Velodyne blocks with an azimuth above 36000 skipped", where);
      odd[b] = true;
      continue;
    }
    odd[b] = true;            // until it proves in order below
    if (b >= used) {          // VLS-128 dual return padding: never decoded, its azimuth kept
      odd[b] = false;
      continue;
    }
    if (!(vls ? bankOf(header) >= 0 : header == kBankIds[0])) {
      quirks_.note(fmt::format("Velodyne blocks whose header is no {} bank id skipped", velodyneModelName(*model_)),
                   where);
      continue;
    }
    candidates.push_back(b);
  }
  const std::vector<int> kept = inOrder(candidates, p);
  if (kept.size() < candidates.size())
    quirks_.note("Velodyne blocks out of azimuth order skipped", where, candidates.size() - kept.size());
  for (int b : kept) skip_[b] = false, odd[b] = false;
  if (kept.empty()) return false;
  std::uint16_t last = u16(p + kept.front() * kBlockBytes + 2);
  for (int b = 0; b < kBlocks; ++b) {
    if (odd[b]) putAzimuth(p, b, last);
    last = u16(p + b * kBlockBytes + 2);
  }
  return true;
}

}  // namespace hazmap::velodyne_detail
