// Structure metrics of a Multi-Triangulation.
//
// Papers: E. Puppo, "Variable resolution triangulations", Comput. Geom. 11 (1998) — expressive power,
// depth, growth; L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000), section 3.3 (the criteria)
// and section 7.2, eq. 4 (fronts of a semi-regular 4-8 structure, one level at a time).
#include "multitri/mt_metrics.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

BigUint::BigUint(std::uint64_t value) {
  if (value != 0) limbs_.push_back(value);
}

BigUint BigUint::pow2(std::size_t k) {
  BigUint r;
  r.limbs_.assign(k / 64 + 1, 0);
  r.limbs_.back() = std::uint64_t(1) << (k % 64);
  return r;
}

BigUint BigUint::from_limbs(std::span<const std::uint64_t> limbs) {
  BigUint r;
  r.limbs_.assign(limbs.begin(), limbs.end());
  r.trim();
  return r;
}

void BigUint::trim() noexcept {
  while (!limbs_.empty() && limbs_.back() == 0) limbs_.pop_back();
}

BigUint& BigUint::operator+=(const BigUint& other) {
  if (other.limbs_.size() > limbs_.size()) limbs_.resize(other.limbs_.size(), 0);
  std::uint64_t carry = 0;
  for (std::size_t i = 0; i < limbs_.size(); ++i) {
    const std::uint64_t b = i < other.limbs_.size() ? other.limbs_[i] : 0;
    if (b == 0 && carry == 0 && i >= other.limbs_.size()) break;
    const std::uint64_t s = limbs_[i] + b;
    const std::uint64_t c1 = s < b ? 1 : 0;
    limbs_[i] = s + carry;
    const std::uint64_t c2 = limbs_[i] < carry ? 1 : 0;
    carry = c1 + c2;
  }
  if (carry != 0) limbs_.push_back(carry);
  return *this;
}

BigUint& BigUint::operator-=(std::uint64_t value) {
  // No leading zero limb: a value of two or more limbs is at least 2^64 > value.
  if (limbs_.size() <= 1 && low_u64() < value)
    throw InvalidInput("BigUint: subtracting " + std::to_string(value) + " from " + std::to_string(low_u64()) +
                       " would go below zero");
  std::uint64_t borrow = value;
  for (std::size_t i = 0; i < limbs_.size() && borrow != 0; ++i) {
    const std::uint64_t old = limbs_[i];
    limbs_[i] = old - borrow;
    borrow = old < borrow ? 1 : 0;
  }
  trim();
  return *this;
}

BigUint& BigUint::operator*=(const BigUint& other) {
  if (is_zero() || other.is_zero()) {
    limbs_.clear();
    return *this;
  }
  std::vector<std::uint64_t> r(limbs_.size() + other.limbs_.size(), 0);
  for (std::size_t i = 0; i < limbs_.size(); ++i) {
    unsigned __int128 carry = 0;
    for (std::size_t j = 0; j < other.limbs_.size(); ++j) {
      const unsigned __int128 t =
          static_cast<unsigned __int128>(limbs_[i]) * other.limbs_[j] + r[i + j] + carry;
      r[i + j] = static_cast<std::uint64_t>(t);
      carry = t >> 64;
    }
    r[i + other.limbs_.size()] = static_cast<std::uint64_t>(carry);
  }
  limbs_ = std::move(r);
  trim();
  return *this;
}

std::strong_ordering operator<=>(const BigUint& a, const BigUint& b) noexcept {
  if (a.limbs_.size() != b.limbs_.size()) return a.limbs_.size() <=> b.limbs_.size();
  for (std::size_t i = a.limbs_.size(); i-- > 0;)
    if (a.limbs_[i] != b.limbs_[i]) return a.limbs_[i] <=> b.limbs_[i];
  return std::strong_ordering::equal;
}

std::size_t BigUint::bit_width() const noexcept {
  if (limbs_.empty()) return 0;
  return 64 * (limbs_.size() - 1) + static_cast<std::size_t>(std::bit_width(limbs_.back()));
}

double BigUint::log2() const noexcept {
  const std::size_t bits = bit_width();
  if (bits == 0) return -std::numeric_limits<double>::infinity();
  if (bits <= 64) return std::log2(static_cast<double>(limbs_[0]));
  // The top 64 bits carry all a double can hold.
  const std::size_t shift = bits - 64;
  const std::size_t limb = shift / 64, bit = shift % 64;
  std::uint64_t top = limbs_[limb] >> bit;
  if (bit != 0 && limb + 1 < limbs_.size()) top |= limbs_[limb + 1] << (64 - bit);
  return std::log2(static_cast<double>(top)) + static_cast<double>(shift);
}

std::string BigUint::to_string() const {
  if (limbs_.empty()) return "0";
  constexpr std::uint64_t kChunk = 10000000000000000000ull;  // 10^19 < 2^64
  std::vector<std::uint64_t> n = limbs_;
  std::vector<std::uint64_t> chunks;
  while (!n.empty()) {
    unsigned __int128 rem = 0;
    for (std::size_t i = n.size(); i-- > 0;) {
      const unsigned __int128 cur = (rem << 64) | n[i];
      n[i] = static_cast<std::uint64_t>(cur / kChunk);
      rem = cur % kChunk;
    }
    chunks.push_back(static_cast<std::uint64_t>(rem));
    while (!n.empty() && n.back() == 0) n.pop_back();
  }
  std::string s = std::to_string(chunks.back());
  for (std::size_t i = chunks.size() - 1; i-- > 0;) {
    const std::string part = std::to_string(chunks[i]);
    s.append(19 - part.size(), '0');
    s += part;
  }
  return s;
}

std::vector<Index> compute_node_levels(const Mt& mt) {
  // Parents precede children (mt.hpp), so one forward pass is a longest-path computation.
  std::vector<Index> level(mt.num_nodes(), 0);
  for (NodeId n = 1; n < mt.num_nodes(); ++n) {
    Index l = 0;
    for (NodeId p : mt.parents(n)) l = std::max(l, level[p]);
    level[n] = l + 1;
  }
  return level;
}

namespace {

std::vector<std::size_t> level_histogram(const std::vector<Index>& level) {
  Index depth = 0;
  for (Index l : level) depth = std::max(depth, l);
  std::vector<std::size_t> count(static_cast<std::size_t>(depth) + 1, 0);
  for (Index l : level) ++count[l];
  return count;
}

}  // namespace

MtMetrics compute_metrics(const Mt& mt) {
  MtMetrics m;
  m.nodes = mt.num_nodes() == 0 ? 0 : mt.num_nodes() - 1;
  m.faces = mt.num_faces();
  if (mt.num_nodes() == 0) return m;
  m.coarsest_faces = mt.image_size(Mt::source());
  for (FaceId f = 0; f < mt.num_faces(); ++f)
    if (mt.destroyer(f) == kInvalid) ++m.finest_faces;
  m.nodes_per_level = level_histogram(compute_node_levels(mt));
  m.depth = m.nodes_per_level.size() - 1;
  m.memory_bytes = mt.memory_bytes();
  if (m.finest_faces != 0) {
    m.growth_rate = static_cast<double>(m.faces) / static_cast<double>(m.finest_faces);
    m.bytes_per_face = static_cast<double>(m.memory_bytes) / static_cast<double>(m.finest_faces);
  }
  return m;
}

ChainGrowth chain_growth(const Mt& mt, std::size_t max_nodes) {
  ChainGrowth g;
  const std::size_t nn = mt.num_nodes();
  if (nn == 0 || nn - 1 > max_nodes) return g;
  g.computed = true;
  const double base = static_cast<double>(mt.image_size(Mt::source()));
  // Longest-image chain into each node (parents first: node ids are a topological order).
  std::vector<double> chain(nn, 0.0);
  std::vector<std::size_t> length(nn, 0);
  for (NodeId v = 1; v < nn; ++v) {
    double best = 0.0;
    std::size_t best_len = 0;
    for (NodeId p : mt.parents(v))
      if (p != Mt::source() && (chain[p] > best || (chain[p] == best && length[p] > best_len)))
        best = chain[p], best_len = length[p];
    chain[v] = best + static_cast<double>(mt.image_size(v));
    length[v] = best_len + 1;
  }
  // The closure of each end node, by a stamped walk up its ancestors.
  std::vector<std::uint32_t> seen(nn, 0);
  std::vector<NodeId> stack;
  for (NodeId v = 1; v < nn; ++v) {
    const auto stamp = static_cast<std::uint32_t>(v);
    double net = 0.0;
    std::size_t closure = 0;
    stack.assign(1, v);
    seen[v] = stamp;
    while (!stack.empty()) {
      const NodeId u = stack.back();
      stack.pop_back();
      ++closure;
      net += static_cast<double>(mt.image_size(u)) - static_cast<double>(mt.pre_image(u).size());
      for (NodeId p : mt.parents(u))
        if (p != Mt::source() && seen[p] != stamp) seen[p] = stamp, stack.push_back(p);
    }
    const double growth = (base + chain[v]) / (base + net);
    if (growth > g.max_growth) g.max_growth = growth, g.argmax_end = v, g.argmax_length = length[v], g.argmax_closure = closure;
  }
  return g;
}

LevelFrontCount count_level_fronts(const Mt& mt) {
  if (mt.num_nodes() == 0) throw InvalidInput("count_level_fronts: the Mt is empty (no source)");
  LevelFrontCount r;
  const std::vector<Index> level = compute_node_levels(mt);
  // Independence of one level given the lower ones: no node has a parent on its own level or above.
  for (NodeId n = 1; n < mt.num_nodes(); ++n)
    for (NodeId p : mt.parents(n))
      if (level[p] >= level[n])
        throw InvalidInput("count_level_fronts: node " + std::to_string(n) + " has a parent on its level or above", n);
  r.nodes_per_level = level_histogram(level);
  const std::size_t depth = r.nodes_per_level.size() - 1;
  for (std::size_t j = 1; j <= depth; ++j) r.total += BigUint::pow2(r.nodes_per_level[j]);
  if (depth == 0) {
    r.distinct = BigUint(1);
  } else {
    r.distinct = r.total;
    r.distinct -= depth - 1;
  }
  return r;
}

namespace {

// A topological order of the non-source nodes that keeps the DP frontier small. Greedy: among the ready
// nodes, take the one that retires the most live parents (parents whose last unvisited child it is), minus
// one if it becomes live itself; ties go to the most recently readied node, which keeps the sweep local.
std::vector<NodeId> frontier_order(const Mt& mt, std::size_t& width) {
  const std::size_t nn = mt.num_nodes();
  std::vector<Index> missing(nn, 0), remaining(nn, 0);
  for (NodeId n = 1; n < nn; ++n) {
    for (NodeId p : mt.parents(n))
      if (p != Mt::source()) ++missing[n];
    remaining[n] = static_cast<Index>(mt.children(n).size());
  }
  std::vector<NodeId> ready, order;
  order.reserve(nn);
  for (NodeId n = 1; n < nn; ++n)
    if (missing[n] == 0) ready.push_back(n);
  std::size_t live = 0;
  width = 0;
  while (!ready.empty()) {
    std::size_t best = 0;
    long best_score = std::numeric_limits<long>::min();
    for (std::size_t i = 0; i < ready.size(); ++i) {
      const NodeId v = ready[i];
      long score = mt.children(v).empty() ? 0 : -1;
      for (NodeId p : mt.parents(v))
        if (p != Mt::source() && remaining[p] == 1) ++score;
      if (score >= best_score) {
        best_score = score;
        best = i;
      }
    }
    const NodeId v = ready[best];
    ready.erase(ready.begin() + static_cast<std::ptrdiff_t>(best));
    order.push_back(v);
    for (NodeId p : mt.parents(v))
      if (p != Mt::source() && --remaining[p] == 0) --live;
    if (!mt.children(v).empty()) ++live;
    width = std::max(width, live);
    for (NodeId c : mt.children(v))
      if (--missing[c] == 0) ready.push_back(c);
  }
  return order;
}

// Multi-limb counters stored flat, `limbs` words per state; sums never overflow because the caller sizes
// `limbs` for 2^(number of nodes).
void add_into(std::uint64_t* dst, const std::uint64_t* src, std::size_t limbs) noexcept {
  std::uint64_t carry = 0;
  for (std::size_t i = 0; i < limbs; ++i) {
    const std::uint64_t s = dst[i] + src[i];
    const std::uint64_t c1 = s < src[i] ? 1 : 0;
    dst[i] = s + carry;
    const std::uint64_t c2 = dst[i] < carry ? 1 : 0;
    carry = c1 + c2;
  }
}

}  // namespace

FrontCount expressive_power(const Mt& mt, const FrontCountOptions& options) {
  FrontCount result;
  const std::size_t nn = mt.num_nodes();
  if (nn == 0) throw InvalidInput("expressive_power: the Mt is empty (no source)");
  if (nn == 1) {
    result.exact = true;
    result.value = BigUint(1);
    result.log2 = 0.0;
    return result;
  }
  const std::size_t n_real = nn - 1;
  result.log2_upper = static_cast<double>(n_real);
  auto refuse = [&]() {
    result.exact = false;
    result.value = BigUint();
    result.log2 = count_level_fronts(mt).distinct.log2();
    return result;
  };
  if (n_real > options.max_nodes) return refuse();

  std::size_t width = 0;
  const std::vector<NodeId> order = frontier_order(mt, width);
  result.peak_width = width;
  if (width > std::min<std::size_t>(options.max_width, 64)) return refuse();

  // Frontier DP (transfer matrix over `order`). A live node owns a bit slot; a state's mask holds the live
  // nodes in the ideal. Visiting v: "v out" is always allowed, "v in" needs all its parents in; parents
  // visited for the last time drop out of the mask, so states that differ only there merge.
  const std::size_t limbs = n_real / 64 + 1;
  std::vector<Index> remaining(nn, 0);
  for (NodeId n = 1; n < nn; ++n) remaining[n] = static_cast<Index>(mt.children(n).size());
  std::vector<int> slot(nn, -1);
  std::uint64_t used_slots = 0;

  std::vector<std::uint64_t> masks{0}, counts(limbs, 0), next_masks, next_counts;
  counts[0] = 1;
  std::vector<Index> table;
  std::size_t peak = 1;

  for (const NodeId v : order) {
    std::uint64_t need = 0, retire = 0;
    for (NodeId p : mt.parents(v)) {
      if (p == Mt::source()) continue;
      const std::uint64_t bit = std::uint64_t(1) << slot[p];
      need |= bit;
      if (remaining[p] == 1) retire |= bit;
    }
    // Slots are released before v takes one: retired bits are cleared from every new mask first.
    for (NodeId p : mt.parents(v))
      if (p != Mt::source() && --remaining[p] == 0) {
        used_slots &= ~(std::uint64_t(1) << slot[p]);
        slot[p] = -1;
      }
    std::uint64_t vbit = 0;
    if (!mt.children(v).empty()) {
      const int s = std::countr_one(used_slots);  // width <= 64 guarantees a free slot
      slot[v] = s;
      used_slots |= std::uint64_t(1) << s;
      vbit = std::uint64_t(1) << s;
    }

    // Next step: the states, at most twice as many successors, and the table (16 bytes per state).
    const std::size_t step_bytes = masks.size() * (24 * (limbs + 1) + 16);
    if (step_bytes > options.max_memory_bytes) {
      result.peak_states = peak;
      return refuse();
    }
    // Merge equal masks through an open-addressing table (linear probing, Fibonacci hashing): at most two
    // successors per state, so a table of 4x the states stays at most half full.
    next_masks.clear();
    next_counts.clear();
    const std::size_t want = 4 * masks.size();
    const int bits = std::max(4, static_cast<int>(std::bit_width(want - 1)));
    table.assign(std::size_t(1) << bits, kInvalid);
    const std::size_t table_mask = table.size() - 1;
    auto add = [&](std::uint64_t mask, const std::uint64_t* c) {
      std::size_t h = static_cast<std::size_t>((mask * 0x9E3779B97F4A7C15ull) >> (64 - bits));
      while (table[h] != kInvalid) {
        if (next_masks[table[h]] == mask) {
          add_into(next_counts.data() + std::size_t(table[h]) * limbs, c, limbs);
          return;
        }
        h = (h + 1) & table_mask;
      }
      table[h] = static_cast<Index>(next_masks.size());
      next_masks.push_back(mask);
      next_counts.insert(next_counts.end(), c, c + limbs);
    };
    for (std::size_t s = 0; s < masks.size(); ++s) {
      const std::uint64_t mask = masks[s];
      const std::uint64_t* c = counts.data() + s * limbs;
      const std::uint64_t kept = mask & ~retire;
      add(kept, c);
      if ((mask & need) == need) add(kept | vbit, c);
    }
    masks.swap(next_masks);
    counts.swap(next_counts);
    peak = std::max(peak, masks.size());
    if (masks.size() > std::min<std::size_t>(options.max_states, std::size_t(1) << 31)) {
      result.peak_states = peak;
      return refuse();
    }
  }

  std::vector<std::uint64_t> total(limbs, 0);
  for (std::size_t s = 0; s < masks.size(); ++s) add_into(total.data(), counts.data() + s * limbs, limbs);
  result.exact = true;
  result.value = BigUint::from_limbs(total);
  result.log2 = result.value.log2();
  result.peak_states = peak;
  return result;
}

}  // namespace varmesh
