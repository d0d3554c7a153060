#pragma once
/// Indexed min-heap of candidate edges for the QEM analysis (internal to qem_analysis.cpp).
///
/// Items are small integer ids (edge slots) with a cost and a 64-bit tie key; the order is (cost, tie), a
/// total order when tie keys are distinct, so the pop sequence does not depend on insertion order. The heap
/// keeps each id's position, so an edge that dies is erased at once (mostly near the leaves, hence cheap)
/// instead of lingering as a stale entry that a later pop must sift through the whole depth of the heap.
/// An entry is 8 bytes: the cost rounded to float and the id. Rounding is monotone, so unequal float keys
/// order like the double costs; equal keys fall back to the exact (cost, tie) kept per id, and the order is
/// the same as on (double cost, tie). kArity children share one 64-byte line (the array is offset so that
/// the first child of every node starts a line).
/// Invariant (checked by validate()): pos_[h_[i].id] == i for every i, and no entry is less than its parent.
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "multitri/types.hpp"

namespace varmesh::detail {

class EdgeHeap {
 public:
  static constexpr std::size_t kArity = 8;

  EdgeHeap() = default;
  EdgeHeap(const EdgeHeap&) = delete;  // h_ points into store_
  EdgeHeap& operator=(const EdgeHeap&) = delete;

  /// Ids must be < the largest value ever given to grow_ids(); the heap holds at most that many entries.
  void grow_ids(std::size_t n) {
    if (pos_.size() < n) {
      pos_.resize(n, kInvalid);
      cost_.resize(n, 0.0);
      tie_.resize(n, 0);
    }
    if (cap_ < n) grow(n);
  }
  bool empty() const noexcept { return size_ == 0; }
  std::size_t size() const noexcept { return size_; }
  bool contains(Index id) const noexcept { return pos_[id] != kInvalid; }
  /// Where `id` sits (kInvalid when absent); a caller may read it early to bring the line in.
  Index position(Index id) const noexcept { return pos_[id]; }
  /// The rounded keys at position i and at its parent, the entries an update() at i compares first: a
  /// caller may read them early to bring their lines in.
  float key_at(std::size_t i) const noexcept { return h_[i].key; }
  float parent_key_at(std::size_t i) const noexcept { return h_[i > 0 ? (i - 1) / kArity : 0].key; }
  Index top() const noexcept { return h_[0].id; }
  double top_cost() const noexcept { return cost_[h_[0].id]; }

  /// Adds an id that is not in the heap. O(log n).
  void push(Index id, double cost, std::uint64_t tie) {
    set_key(id, cost, tie);
    if (size_ == cap_) grow(2 * cap_ + 64);
    h_[size_] = {static_cast<float>(cost), id};
    sift_up(size_++);
  }
  /// Appends without ordering; call heapify() before any other operation. O(1).
  void push_unordered(Index id, double cost, std::uint64_t tie) {
    set_key(id, cost, tie);
    if (size_ == cap_) grow(2 * cap_ + 64);
    pos_[id] = static_cast<Index>(size_);
    h_[size_++] = {static_cast<float>(cost), id};
  }
  /// Floyd's bottom-up construction. O(n).
  void heapify() {
    if (size_ < 2) return;
    for (std::size_t i = (size_ - 2) / kArity + 1; i-- > 0;) sift_down(i);
  }
  /// Changes the key of `id`, or adds it if absent. Cheaper than erase() then push(): one sift from where
  /// the entry already is. O(log n).
  void update(Index id, double cost, std::uint64_t tie) {
    if (pos_[id] == kInvalid) {
      push(id, cost, tie);
      return;
    }
    set_key(id, cost, tie);
    const std::size_t i = pos_[id];
    h_[i].key = static_cast<float>(cost);
    if (i > 0 && less(h_[i], h_[(i - 1) / kArity])) sift_up(i); else sift_down(i);
  }
  void pop() { erase_at(0); }
  /// Removes `id` if present. O(log n), O(1) expected for a random entry.
  void erase(Index id) {
    if (pos_[id] != kInvalid) erase_at(pos_[id]);
  }
  void clear() {
    for (std::size_t i = 0; i < size_; ++i) pos_[h_[i].id] = kInvalid;
    size_ = 0;
  }
  bool validate() const {
    for (std::size_t i = 0; i < size_; ++i) {
      if (pos_[h_[i].id] != i) return false;
      if (h_[i].key != static_cast<float>(cost_[h_[i].id])) return false;
      if (i > 0 && less(h_[i], h_[(i - 1) / kArity])) return false;
    }
    return true;
  }

 private:
  struct Entry {
    float key;  // cost rounded to float
    Index id;
  };
  void set_key(Index id, double cost, std::uint64_t tie) {
    cost_[id] = cost;
    tie_[id] = tie;
  }
  bool less(const Entry& x, const Entry& y) const noexcept {
    if (x.key != y.key) return x.key < y.key;
    const double cx = cost_[x.id], cy = cost_[y.id];
    return cx < cy || (cx == cy && tie_[x.id] < tie_[y.id]);
  }
  void place(std::size_t i, const Entry& e) {
    h_[i] = e;
    pos_[e.id] = static_cast<Index>(i);
  }
  void sift_up(std::size_t i) {
    const Entry e = h_[i];
    while (i > 0) {
      const std::size_t p = (i - 1) / kArity;
      if (!less(e, h_[p])) break;
      place(i, h_[p]);
      i = p;
    }
    place(i, e);
  }
  void sift_down(std::size_t i) {
    const Entry e = h_[i];
    const std::size_t n = size_;
    for (;;) {
      const std::size_t c0 = kArity * i + 1;
      if (c0 >= n) break;
      std::size_t best = c0;
      const std::size_t end = c0 + kArity < n ? c0 + kArity : n;
      for (std::size_t c = c0 + 1; c < end; ++c)
        if (less(h_[c], h_[best])) best = c;
      if (!less(h_[best], e)) break;
      place(i, h_[best]);
      i = best;
    }
    place(i, e);
  }
  void erase_at(std::size_t i) {
    pos_[h_[i].id] = kInvalid;
    const Entry last = h_[--size_];
    if (i == size_) return;
    h_[i] = last;
    if (i > 0 && less(last, h_[(i - 1) / kArity])) sift_up(i); else sift_down(i);
  }
  // New storage with room for n entries, h_ placed so that h_ + 1 starts a 64-byte line (then so does the
  // first child kArity i + 1 of every node i).
  void grow(std::size_t n) {
    std::vector<Entry> s(n + 64 / sizeof(Entry));
    const auto addr = reinterpret_cast<std::uintptr_t>(s.data() + 1);
    const std::size_t off = ((64 - addr % 64) % 64) / sizeof(Entry);
    Entry* h = s.data() + off;
    for (std::size_t i = 0; i < size_; ++i) h[i] = h_[i];
    store_ = std::move(s);
    h_ = h;
    cap_ = n;
  }

  std::vector<Entry> store_;
  Entry* h_ = nullptr;
  std::size_t size_ = 0, cap_ = 0;
  std::vector<Index> pos_;          // per id: index in h_, kInvalid when absent
  std::vector<double> cost_;        // per id
  std::vector<std::uint64_t> tie_;  // per id
};

}  // namespace varmesh::detail
