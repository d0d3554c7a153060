#pragma once
/// The one query API of varmesh (DESIGN.md; Velho-Gomes 9.1; De Floriani, Magillo, Puppo 1998).
///
/// A query is an adaptation function (Criterion: is this element fine enough?), a focus set (where the
/// function is evaluated; elsewhere stays coarse) and optional budgets. An element is *wanted* when its
/// bound meets the focus set and the criterion says it is not fine enough.
///
/// - extract(front, query) starts from the coarsest state and refines every wanted element that the current
///   mesh exposes, forcing what each refinement needs. The result is the least fixpoint: the smallest
///   reachable state in which no exposed element is wanted. It does not depend on visiting order.
/// - update(front, query) moves an existing front: it coarsens applied elements that are no longer wanted
///   (only maximal ones, repeatedly), then refines like extract. When the criterion is monotone (a wanted
///   element's ancestors are wanted: true for every ready-made criterion on nested bounds, which all varmesh
///   builders produce) update() returns exactly the state extract() returns. For other criteria both return
///   a conforming mesh on which no exposed element in focus is wanted, but update() may keep a finer one.
/// - With a triangle budget, refinement is priority driven: wanted elements in decreasing priority
///   (Criterion::priority, ties broken parents first), stopping before the first refinement that would
///   exceed the budget; update() reaches the same state for monotone priorities, and when the front
///   cannot coarsen down to the budget from where it is, it answers as extract() does. A time budget stops
///   refinement when the time is up (the result is then conforming but depends on the machine).
///
/// A structure plugs in by providing a front type that models RefinableFront (below): MtFront for explicit
/// Multi-Triangulations, Grid48Front for implicit 4-8 terrain hierarchies, the pm selectively refined mesh.
#include <chrono>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <queue>
#include <vector>

#include "multitri/bounds.hpp"
#include "multitri/camera.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// An adaptation function over element bounds, built from ready-made leaves and combinators.
/// is_fine() returns true when the element needs no refinement.
class Criterion {
 public:
  enum class Kind : std::uint8_t {
    kObjectError, kScreenError, kOutsideFrustum, kBackFacing, kAwayFromSilhouette, kAwayFromPoints,
    kCustom, kAllOf, kAnyOf
  };

  /// Fine when bound.error <= max_error (object units; +infinity: always fine). Throws InvalidInput when
  /// max_error is negative or NaN.
  static Criterion object_error(float max_error);
  /// Fine when the error projected on the screen is <= max_pixels, for a perspective camera and a viewport
  /// `viewport_height` pixels high: error * pixels_per_unit_at_distance_one / distance(eye, sphere).
  /// Inside the sphere (distance <= 0) nothing is fine unless error is 0. Throws InvalidInput when the
  /// camera fails Camera::validate(), max_pixels <= 0 or viewport_height is not positive and finite.
  static Criterion screen_error(const Camera& camera, float viewport_height, float max_pixels);
  /// Fine when the bounding sphere lies entirely outside the frustum (refine only what is visible). Throws
  /// InvalidInput when the frustum fails Frustum::validate() (a NaN plane would cull nothing).
  static Criterion outside_frustum(const Frustum& frustum);
  /// Fine when every normal of the cone faces away from `eye` at every point of the sphere. Throws
  /// InvalidInput for a non-finite eye.
  static Criterion back_facing(const glm::vec3& eye);
  /// Fine when the region is entirely front-facing or entirely back-facing as seen from `eye` (refine only
  /// near silhouettes). Elements without normal information are never fine. Throws InvalidInput for a
  /// non-finite eye.
  static Criterion away_from_silhouette(const glm::vec3& eye);
  /// Fine when the sphere is farther than `radius` from every point (refine near feature points). Throws
  /// InvalidInput when radius is negative or not finite, or a point is not finite (naming it).
  static Criterion away_from_points(std::vector<glm::vec3> points, float radius);
  /// Any function of the bound: returns true when fine.
  static Criterion custom(std::function<bool(const ElementBound&)> is_fine);
  /// Fine when every part is fine (refine if any part asks). Parts are evaluated cheapest kind first
  /// (object error, frustum, screen error, feature points, back-facing, silhouette, combinators, custom;
  /// the given order among equals) and evaluation stops at the first part that decides the answer, so a
  /// custom() part should not rely on being called.
  static Criterion all_of(std::vector<Criterion> parts);
  /// Fine when some part is fine (e.g. culled OR accurate enough). Evaluated as all_of().
  static Criterion any_of(std::vector<Criterion> parts);

  bool is_fine(const ElementBound& b) const;
  /// is_fine() and a conservative margin (length units, may be +infinity) for coherent updates: the answer
  /// for b stays the same while no view-dependent leaf moves by `margin` or more, where a leaf's move at b
  /// is bounded by motion_to() (the eye's displacement for screen_error / back_facing /
  /// away_from_silhouette; a frustum plane's change in signed distance at b.center for outside_frustum).
  /// Leaves that do not depend on a view give +infinity, custom() leaves 0 (always re-evaluated).
  bool is_fine_with_margin(const ElementBound& b, float& margin) const;
  /// Compares this criterion with `next`, the same criterion for a moved camera. Returns false when they
  /// differ otherwise (shape, thresholds, viewport, feature points): then no margin carries over. Else
  /// raises `turn` to at least the largest change of a frustum plane's unit normal and `shift` to at least
  /// the largest eye displacement and frustum plane offset change measured at `origin`, so that the move of
  /// every leaf at a point c is at most turn * |c - origin| + shift.
  bool motion_to(const Criterion& next, const glm::vec3& origin, double& turn, double& shift) const;
  /// Priority for budgeted refinement: the largest screen-space error of the screen_error leaves if any,
  /// else the bound's object error. Monotone on nested bounds.
  float priority(const ElementBound& b) const;
  Kind kind() const noexcept { return kind_; }
  /// True when no custom() leaf is involved: every ready-made leaf is monotone on nested bounds.
  bool is_monotone() const;
  /// The threshold of an object_error leaf (for fast paths); meaningful only when kind() == kObjectError.
  float threshold() const noexcept { return value_; }

 private:
  Kind kind_ = Kind::kObjectError;
  float value_ = 0.0f;   // max error, max pixels, radius
  float scale_ = 0.0f;   // pixels per unit at distance one
  float ratio_ = 0.0f;   // scale_ / value_ for screen_error (a distance per unit of error)
  glm::vec3 point_{0.0f};
  Frustum frustum_{};
  std::vector<glm::vec3> points_;
  std::function<bool(const ElementBound&)> custom_;
  std::vector<Criterion> parts_;  // sorted by evaluation cost (all_of / any_of)
  bool has_screen_leaf() const;
  // The per-kind bodies, split so that a combinator's loop calls a leaf without a second dispatch.
  bool leaf_is_fine(const ElementBound& b) const;
  bool part_is_fine(const ElementBound& b) const;
  bool leaf_is_fine_with_margin(const ElementBound& b, float& margin) const;
  bool part_is_fine_with_margin(const ElementBound& b, float& margin) const;
  static Criterion combine(Kind kind, std::vector<Criterion> parts);
};

struct Query {
  Criterion criterion = Criterion::object_error(0.0f);
  FocusSet focus;                   ///< empty: everywhere
  std::size_t triangle_budget = 0;  ///< 0: no budget
  double time_budget_ms = 0.0;      ///< 0, negative or NaN: no budget

  /// Throws InvalidInput when the focus set is not valid (FocusSet::validate; the criterion was checked
  /// when it was made). extract() and update() call it first; O(focus shapes).
  void validate() const { focus.validate(); }
  bool wants(const ElementBound& b) const { return focus.intersects(b.center, b.radius) && !criterion.is_fine(b); }
};

struct QueryStats {
  std::size_t evaluated = 0;  ///< criterion evaluations
  std::size_t reused = 0;     ///< answers reused from a QueryCoherence (update() with coherence only)
  std::size_t refined = 0;    ///< elements refined (forced ones included)
  std::size_t coarsened = 0;  ///< elements coarsened
  bool budget_reached = false;
  bool time_reached = false;
};

/// What extract()/update() need from the state of one extraction. Elements are indices. refine(e, sink)
/// refines e and whatever it forces, calling sink(r) for each element refined; coarsen_one(e) undoes one
/// coarsenable element. Candidates: elements whose refinement would change the current mesh
/// (for_each_refine_candidate; for_each_child_candidate(e) lists those exposed by refining e), and
/// refined elements that nothing refined depends on (for_each_coarsen_candidate; for_each_parent_candidate(e)
/// lists those that may become coarsenable when e is coarsened). tie_key orders parents before children.
template <class F>
concept RefinableFront = requires(F& f, const F& cf, Index e, void (*fn)(Index)) {
  { cf.element_bound(e) } -> std::convertible_to<ElementBound>;
  { cf.is_refined(e) } -> std::convertible_to<bool>;
  { cf.is_coarsenable(e) } -> std::convertible_to<bool>;
  { cf.num_faces() } -> std::convertible_to<std::size_t>;
  { cf.tie_key(e) } -> std::convertible_to<std::uint64_t>;
  f.reset();
  f.refine(e, fn);
  f.coarsen_one(e);
  cf.for_each_refine_candidate(fn);
  cf.for_each_child_candidate(e, fn);
  cf.for_each_coarsen_candidate(fn);
  cf.for_each_parent_candidate(e, fn);
};

/// Frame-to-frame coherence for update() (the overload taking one): it remembers, per element, the
/// criterion's answer and how far the view may move before that answer can change (Criterion::
/// is_fine_with_margin), and accumulates the view's motion between calls (Criterion::motion_to). An
/// element whose margin is not yet used up is answered from memory, without fetching its bound. The
/// answers are exactly those of a fresh evaluation (margins are conservative, floating-point slack
/// included), so update() with coherence returns the same front as without.
///
/// Answers depend only on an element's bound and on the query, so one QueryCoherence serves any front of
/// ONE structure; call invalidate() before using it with another structure. It falls back to plain
/// evaluation (and forgets) for queries with a focus set or a triangle budget, or when the criterion
/// changed otherwise than by its camera. Memory: a 16-byte record for every index up to the largest
/// element index seen, grown by half again each time it grows: up to about 24 x (largest index + 1) bytes.
///
/// When it pays: a reused answer replaces one criterion evaluation by a record lookup (about 2 ns with the
/// records in cache), but an answer that cannot be reused costs is_fine_with_margin(), which measures a margin
/// for every part it evaluates (square roots and divisions where is_fine() compares squares): 2 to 3 times
/// is_fine(). And the answers re-evaluated are the costliest ones, of elements near a decision boundary (small
/// margins). With a fraction u of the answers reused, an asked element costs about lookup +
/// (1 - u) x is_fine_with_margin() instead of is_fine(), so the cheaper the criterion, the larger u must be.
/// The ready-made view criteria cost a few ns to ~15 ns; for the combination below coherence breaks even near
/// u = 70%. Measured on the bunny orbit of bench/pm_bench.cpp (any_of frustum, back-facing and screen error,
/// 10,700 answers asked per frame; is_fine() 13 ns on average and 17 ns on the elements re-evaluated,
/// is_fine_with_margin() 38 ns on those): at 1.8 degrees per frame (the eye moves 3% of its distance to the
/// model's centre) 72% of the answers were reused and update() took as long with coherence as without
/// (plain / coherent time 0.9 to 1.0), 1.3x to 1.7x faster at 0.36 degrees per frame; since the back-facing
/// margin's turn rate is (pi / 2) / dist instead of pi / dist (query.cpp), 75% are reused at 1.8 degrees
/// (plain / coherent about 1.05) and coherence is about 1.75x faster at 0.36 degrees. An answer that a
/// custom() part decides has margin 0 and is never reused.
class QueryCoherence {
 public:
  /// Forgets every answer (e.g. before serving another structure).
  void invalidate() noexcept {
    valid_ = false;
    next_generation();
  }
  /// Prepares a frame for query q (update() calls it). Returns false when q cannot use coherence.
  bool begin(const Query& q);
  /// Hint that wants(e, ...) comes soon: starts loading e's record (update() calls it when it queues e).
  void prefetch(Index e) const noexcept {
#if defined(__GNUC__) || defined(__clang__)
    if (e < records_.size()) __builtin_prefetch(&records_[e]);
#else
    (void)e;
#endif
  }
  /// wants(q) for element e, from memory when its margin allows; bound() gives the element's bound.
  template <class BoundFn>
  bool wants(Index e, const Query& q, BoundFn&& bound, QueryStats& stats) {
    if (e >= records_.size()) records_.resize(std::size_t{e} + 1 + records_.size() / 2);
    Record& r = records_[e];
    if ((r.tag >> 1) == generation_ && turn_ * static_cast<double>(r.reach) + shift_ < r.limit) {
      ++stats.reused;
      return (r.tag & 1u) != 0;
    }
    ++stats.evaluated;
    const ElementBound b = bound();
    if (!has_origin_) {
      origin_ = b.center;
      has_origin_ = true;
    }
    float margin = 0.0f;
    const bool wanted = !q.criterion.is_fine_with_margin(b, margin);
    r.tag = generation_ << 1 | (wanted ? 1u : 0u);
    r.reach = glm::length(b.center - origin_);
    r.limit = turn_ * static_cast<double>(r.reach) + shift_ + static_cast<double>(margin);
    return wanted;
  }

 private:
  struct Record {
    double limit = 0.0;  // valid while turn_ * reach + shift_ < limit
    float reach = 0.0f;  // |centre - origin_|
    std::uint32_t tag = 0;  // generation << 1 | wanted
  };
  void next_generation() noexcept {
    if (++generation_ >= (1u << 31)) {  // the 31-bit field would wrap: clear the records instead
      for (Record& r : records_) r.tag = 0;
      generation_ = 1;
    }
    turn_ = shift_ = 0.0;
  }
  std::vector<Record> records_;
  std::uint32_t generation_ = 1;  // records of other generations are stale
  bool valid_ = false;            // last_ holds the previous frame's criterion
  bool has_origin_ = false;
  glm::vec3 origin_{0.0f};
  double turn_ = 0.0, shift_ = 0.0;  // accumulated view motion of this generation
  Criterion last_ = Criterion::object_error(0.0f);
};

namespace detail {

// Called with each element update() queues for a criterion answer (a prefetch hint), or nothing.
struct NoTouch {
  void operator()(Index) const noexcept {}
};

class Deadline {
 public:
  // A budget beyond a year (or infinite) is no budget: converted to integer nanoseconds it would overflow
  // and put the deadline in the past.
  explicit Deadline(double ms)
      : active_(ms > 0.0 && ms < kYearMs),
        end_(std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                    std::chrono::duration<double, std::milli>(active_ ? ms : 0.0))) {}
  bool passed() {
    if (!active_ || (++calls_ & 63u) != 0) return false;
    return std::chrono::steady_clock::now() >= end_;
  }

 private:
  static constexpr double kYearMs = 365.0 * 24.0 * 3600.0 * 1000.0;
  bool active_;
  std::chrono::steady_clock::time_point end_;
  std::uint32_t calls_ = 0;
};

struct Keyed {
  float priority;
  std::uint64_t tie;
  Index element;
};
// Max-heap order: higher priority first, then smaller tie key (parents first).
struct RefineOrder {
  bool operator()(const Keyed& a, const Keyed& b) const {
    return a.priority < b.priority || (a.priority == b.priority && a.tie > b.tie);
  }
};
// Min-heap order on the same key: the element refined last comes out first.
struct CoarsenOrder {
  bool operator()(const Keyed& a, const Keyed& b) const { return RefineOrder{}(b, a); }
};
inline bool before(const Keyed& a, const Keyed& b) { return RefineOrder{}(b, a); }

template <RefinableFront F, class Wants, class Touch = NoTouch>
void refine_unbudgeted(F& front, Wants&& wants, std::vector<Index>& stack, QueryStats& stats, Deadline& deadline,
                       Touch touch = {}) {
  while (!stack.empty()) {
    const Index e = stack.back();
    stack.pop_back();
    if (front.is_refined(e)) continue;
    if (!wants(e)) continue;
    if (deadline.passed()) {
      stats.time_reached = true;
      return;
    }
    front.refine(e, [&](Index r) {
      ++stats.refined;
      front.for_each_child_candidate(r, [&](Index c) {
        touch(c);
        stack.push_back(c);
      });
    });
  }
}

template <RefinableFront F>
void refine_budgeted(F& front, const Query& q, std::priority_queue<Keyed, std::vector<Keyed>, RefineOrder>& heap,
                     QueryStats& stats, Deadline& deadline) {
  std::vector<Index> done;
  while (!heap.empty()) {
    const Keyed top = heap.top();
    heap.pop();
    if (front.is_refined(top.element)) continue;
    if (deadline.passed()) {
      stats.time_reached = true;
      return;
    }
    done.clear();
    front.refine(top.element, [&](Index r) { done.push_back(r); });
    if (front.num_faces() > q.triangle_budget) {
      for (auto it = done.rbegin(); it != done.rend(); ++it) front.coarsen_one(*it);
      stats.budget_reached = true;
      return;
    }
    stats.refined += done.size();
    for (Index r : done)
      front.for_each_child_candidate(r, [&](Index c) {
        if (front.is_refined(c)) return;
        const ElementBound& b = front.element_bound(c);
        ++stats.evaluated;
        if (q.wants(b)) heap.push({q.criterion.priority(b), front.tie_key(c), c});
      });
  }
}


template <RefinableFront F>
auto plain_wants(const F& front, const Query& q, QueryStats& stats) {
  return [&front, &q, &stats](Index e) {
    ++stats.evaluated;
    return q.wants(front.element_bound(e));
  };
}

// Step 1 of update(): coarsen maximal elements that are no longer wanted, and their parents in turn.
template <RefinableFront F, class Wants, class Touch = NoTouch>
void coarsen_unwanted(F& front, Wants&& wants, QueryStats& stats, Touch touch = {}) {
  std::vector<Index> work;
  front.for_each_coarsen_candidate([&](Index e) {
    touch(e);
    work.push_back(e);
  });
  while (!work.empty()) {
    const Index e = work.back();
    work.pop_back();
    // Ask the criterion first: most candidates are still wanted, and is_coarsenable can cost a 1-ring walk
    // (SrMesh checks the Kim-Lee degenerate case there).
    if (wants(e)) continue;
    if (!front.is_coarsenable(e)) continue;
    front.coarsen_one(e);
    ++stats.coarsened;
    front.for_each_parent_candidate(e, [&](Index p) {
      touch(p);
      work.push_back(p);
    });
  }
}

template <RefinableFront F, class Wants, class Touch = NoTouch>
void update_unbudgeted(F& front, Wants&& wants, QueryStats& stats, Deadline& deadline, Touch touch = {}) {
  coarsen_unwanted(front, wants, stats, touch);
  std::vector<Index> stack;
  front.for_each_refine_candidate([&](Index e) {
    touch(e);
    stack.push_back(e);
  });
  refine_unbudgeted(front, wants, stack, stats, deadline, touch);
}

}  // namespace detail

/// Refines from the coarsest state (see the file comment). Returns counters. Throws InvalidInput from
/// q.validate() before touching the front.
template <RefinableFront F>
QueryStats extract(F& front, const Query& q) {
  q.validate();
  front.reset();
  QueryStats stats;
  detail::Deadline deadline(q.time_budget_ms);
  if (q.triangle_budget == 0) {
    std::vector<Index> stack;
    front.for_each_refine_candidate([&](Index e) { stack.push_back(e); });
    detail::refine_unbudgeted(front, detail::plain_wants(front, q, stats), stack, stats, deadline);
  } else {
    std::priority_queue<detail::Keyed, std::vector<detail::Keyed>, detail::RefineOrder> heap;
    front.for_each_refine_candidate([&](Index e) {
      const ElementBound& b = front.element_bound(e);
      ++stats.evaluated;
      if (q.wants(b)) heap.push({q.criterion.priority(b), front.tie_key(e), e});
    });
    detail::refine_budgeted(front, q, heap, stats, deadline);
  }
  return stats;
}


/// Moves an existing front to the answer of `q` (see the file comment). Returns counters. Throws
/// InvalidInput from q.validate() before touching the front.
template <RefinableFront F>
QueryStats update(F& front, const Query& q) {
  q.validate();
  QueryStats stats;
  detail::Deadline deadline(q.time_budget_ms);
  if (q.triangle_budget == 0) {
    detail::update_unbudgeted(front, detail::plain_wants(front, q, stats), stats, deadline);
    return stats;
  }
  detail::coarsen_unwanted(front, detail::plain_wants(front, q, stats), stats);
  // 2. Budget: make the refined set a prefix of the priority order, fit it in the budget, then grow it.
  using detail::Keyed;
  std::priority_queue<Keyed, std::vector<Keyed>, detail::RefineOrder> refine_heap;
  std::priority_queue<Keyed, std::vector<Keyed>, detail::CoarsenOrder> coarsen_heap;
  auto key = [&](Index e) {
    const ElementBound& b = front.element_bound(e);
    return Keyed{q.criterion.priority(b), front.tie_key(e), e};
  };
  front.for_each_refine_candidate([&](Index e) {
    ++stats.evaluated;
    if (!front.is_refined(e) && q.wants(front.element_bound(e))) refine_heap.push(key(e));
  });
  front.for_each_coarsen_candidate([&](Index e) { coarsen_heap.push(key(e)); });
  auto pop_coarsenable = [&](Keyed& out) {
    while (!coarsen_heap.empty()) {
      out = coarsen_heap.top();
      coarsen_heap.pop();
      if (front.is_coarsenable(out.element)) return true;
    }
    return false;
  };
  auto coarsen = [&](const Keyed& m) {
    front.coarsen_one(m.element);
    ++stats.coarsened;
    refine_heap.push(m);  // still wanted (it survived step 1), so it is a refine candidate again
    front.for_each_parent_candidate(m.element, [&](Index p) {
      if (front.is_coarsenable(p)) coarsen_heap.push(key(p));
    });
  };
  Keyed m{};
  while (true) {
    while (!refine_heap.empty() && front.is_refined(refine_heap.top().element)) refine_heap.pop();
    const bool over = front.num_faces() > q.triangle_budget;
    if (!over && refine_heap.empty()) break;
    if (!pop_coarsenable(m)) {
      // Over the budget with nothing left to coarsen: a front whose remaining coarsenings all wait for
      // something else (a Kim-Lee mesh whose collapses are postponed, section 4.4 of Kim-Lee 2001, gave 48
      // faces for a budget of 6; listing the candidates again found none coarsenable) answers from the
      // coarsest state, as extract() does. A front at its coarsest state already (a budget below the base
      // mesh) gets the same answer this way.
      if (over) {
        QueryStats fresh = extract(front, q);
        fresh.evaluated += stats.evaluated;
        fresh.coarsened += stats.coarsened;
        return fresh;
      }
      break;
    }
    if (over || detail::before(refine_heap.top(), m)) {
      coarsen(m);
    } else {
      coarsen_heap.push(m);
      break;
    }
  }
  detail::refine_budgeted(front, q, refine_heap, stats, deadline);
  return stats;
}

/// update() with frame-to-frame coherence (see QueryCoherence): the same front as update(front, q), with
/// fewer criterion evaluations when the camera moves a little between calls.
template <RefinableFront F>
QueryStats update(F& front, const Query& q, QueryCoherence& coherence) {
  q.validate();
  if (!coherence.begin(q)) return update(front, q);
  QueryStats stats;
  detail::Deadline deadline(q.time_budget_ms);
  auto wants = [&](Index e) { return coherence.wants(e, q, [&] { return front.element_bound(e); }, stats); };
  detail::update_unbudgeted(front, wants, stats, deadline, [&coherence](Index e) { coherence.prefetch(e); });
  return stats;
}

}  // namespace varmesh
