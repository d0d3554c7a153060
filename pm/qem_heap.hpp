#pragma once
/// Indexed min-heap of candidate edges for the QEM analysis (internal to qem_analysis.cpp).
///
/// Items are small integer ids (edge slots) with a cost and a 64-bit tie key; the order is (cost, tie), a
/// total order when tie keys are distinct, so the pop sequence does not depend on insertion order. The heap
/// keeps each id's position, so an edge that dies is erased at once (mostly near the leaves, hence cheap)
/// instead of lingering as a stale entry that a later pop must sift through the whole depth of the heap.
/// 4-ary: a node's four children share one 64-byte line (16-byte entries), halving the depth of a sift-down.
/// Invariant (checked by validate()): pos_[heap_[i].id] == i for every i, and no entry is less than its parent.
#include <cstdint>
#include <vector>

#include "multitri/types.hpp"

namespace varmesh::detail {

class EdgeHeap {
 public:
  /// Ids must be < the largest value ever given to grow_ids().
  void grow_ids(std::size_t n) {
    if (pos_.size() < n) {
      pos_.resize(n, kInvalid);
      tie_.resize(n, 0);
    }
  }
  bool empty() const noexcept { return heap_.empty(); }
  std::size_t size() const noexcept { return heap_.size(); }
  bool contains(Index id) const noexcept { return pos_[id] != kInvalid; }
  /// Cache hint before erase(id) or contains(id).
  void prefetch(Index id) const noexcept { __builtin_prefetch(pos_.data() + id); }
  Index top() const noexcept { return heap_[0].id; }
  double top_cost() const noexcept { return heap_[0].cost; }

  /// Adds an id that is not in the heap. O(log n).
  void push(Index id, double cost, std::uint64_t tie) {
    tie_[id] = tie;
    heap_.push_back({cost, id});
    sift_up(heap_.size() - 1);
  }
  /// Appends without ordering; call heapify() before any other operation. O(1).
  void push_unordered(Index id, double cost, std::uint64_t tie) {
    tie_[id] = tie;
    pos_[id] = static_cast<Index>(heap_.size());
    heap_.push_back({cost, id});
  }
  /// Floyd's bottom-up construction. O(n).
  void heapify() {
    if (heap_.size() < 2) return;
    for (std::size_t i = (heap_.size() - 2) / 4 + 1; i-- > 0;) sift_down(i);
  }
  /// Changes the key of `id`, or adds it if absent. Cheaper than erase() then push(): one sift from where
  /// the entry already is. O(log n).
  void update(Index id, double cost, std::uint64_t tie) {
    if (pos_[id] == kInvalid) {
      push(id, cost, tie);
      return;
    }
    tie_[id] = tie;
    const std::size_t i = pos_[id];
    heap_[i].cost = cost;
    if (i > 0 && less(heap_[i], heap_[(i - 1) / 4])) sift_up(i); else sift_down(i);
  }
  void pop() { erase_at(0); }
  /// Removes `id` if present. O(log n), O(1) expected for a random entry.
  void erase(Index id) {
    if (pos_[id] != kInvalid) erase_at(pos_[id]);
  }
  void clear() {
    for (const Entry& e : heap_) pos_[e.id] = kInvalid;
    heap_.clear();
  }
  bool validate() const {
    for (std::size_t i = 0; i < heap_.size(); ++i) {
      if (pos_[heap_[i].id] != i) return false;
      if (i > 0 && less(heap_[i], heap_[(i - 1) / 4])) return false;
    }
    return true;
  }

 private:
  struct Entry {
    double cost;
    Index id;
  };
  bool less(const Entry& x, const Entry& y) const noexcept {
    return x.cost < y.cost || (x.cost == y.cost && tie_[x.id] < tie_[y.id]);
  }
  void place(std::size_t i, const Entry& e) {
    heap_[i] = e;
    pos_[e.id] = static_cast<Index>(i);
  }
  void sift_up(std::size_t i) {
    const Entry e = heap_[i];
    while (i > 0) {
      const std::size_t p = (i - 1) / 4;
      if (!less(e, heap_[p])) break;
      place(i, heap_[p]);
      i = p;
    }
    place(i, e);
  }
  void sift_down(std::size_t i) {
    const Entry e = heap_[i];
    const std::size_t n = heap_.size();
    for (;;) {
      const std::size_t c0 = 4 * i + 1;
      if (c0 >= n) break;
      std::size_t best = c0;
      const std::size_t end = c0 + 4 < n ? c0 + 4 : n;
      for (std::size_t c = c0 + 1; c < end; ++c)
        if (less(heap_[c], heap_[best])) best = c;
      if (!less(heap_[best], e)) break;
      place(i, heap_[best]);
      i = best;
    }
    place(i, e);
  }
  void erase_at(std::size_t i) {
    pos_[heap_[i].id] = kInvalid;
    const Entry last = heap_.back();
    heap_.pop_back();
    if (i == heap_.size()) return;
    heap_[i] = last;
    if (i > 0 && less(last, heap_[(i - 1) / 4])) sift_up(i); else sift_down(i);
  }

  std::vector<Entry> heap_;
  std::vector<Index> pos_;          // per id: index in heap_, kInvalid when absent
  std::vector<std::uint64_t> tie_;  // per id
};

}  // namespace varmesh::detail
