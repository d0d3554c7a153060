#pragma once
/// Hierarchical generalized triangle strips on the fronts of a Multi-Triangulation (Velho-Gomes 2000,
/// section 9.2 and Figure 23; Velho, de Figueiredo, Gomes, "Hierarchical generalized triangle strips",
/// The Visual Computer 15(1), 1999): a path through the faces of an extracted mesh, started on the base
/// mesh and refined together with the front, that stays a Hamiltonian path when the connectivity is
/// semi-regular 4-8.
///
/// The model. A strip is a sequence of the front's faces cut into *runs*: inside a run consecutive faces
/// share an edge; between runs the strip restarts. num_runs() - 1 is the number of breaks.
///
/// The rule (StripPlan, computed once per Mt). Every face f gets an *orientation*: an entry corner and an
/// exit corner, the vertices where the path enters and leaves the part of the surface f covers. When a
/// node is applied, each pre-image face p is replaced, in place, by an ordered list of image faces (its
/// *strip children*) whose path runs from p's entry to p's exit. For an edge bisection (2 -> 4 or 1 -> 2,
/// the 4-8 split) of a face p = (apex w, split edge e0-e1) oriented along its split edge, say e0 -> e1,
/// the children are ordered like the Sierpinski curve: first the child at e0, oriented e0 -> w, then the
/// child at e1, oriented w -> e1. Both children are again oriented along the edge opposite the new vertex,
/// which is the edge newest-vertex bisection splits next (bisection.hpp), so the rule recurses.
///
/// Why one run (the guarantee). Call a plan *Sierpinski* (StripPlanStats::is_sierpinski) when every node
/// is an edge bisection, every split face is oriented along its split edge, and the base strip is one run
/// whose consecutive faces B, B' share an edge through the vertex exit(B) = entry(B'). Then the strip of
/// EVERY front, uniform or adaptive, is one run. Proof sketch: an entry or exit corner is an endpoint of
/// the split edge, so it lies in exactly one child and is never an apex; by induction the first (last)
/// leaf below a face f is the unique front face below f at entry(f) (exit(f)), and it keeps a piece of
/// both edges of f at that corner. Two consecutive leaves are the last leaf below X and the first below Y
/// for siblings X, Y of a bisection (sharing edge (m, w), meeting at w) or for consecutive base faces
/// (sharing an edge through their meeting vertex); both leaves hold the first piece of that shared edge
/// at the meeting vertex, and the edge is cut identically on both sides in any front (a node splits an
/// edge only when both faces of the edge are in its pre-image: minimal compatibility, mt.hpp), so they
/// share that piece. Uniform 4-8 refinement of two right triangles, of a 4-8 (union jack) grid and of an
/// octahedron paired along its equator are Sierpinski (tests/fourk/strips_test.cpp).
///
/// When the plan is not Sierpinski. The base strip comes from a search that minimises breaks plus
/// *mismatches* (links whose faces share an edge but not at the meeting vertex), then breaks: a depth-first
/// search for a perfect path with Warnsdorff's rule within a budget; failing that, greedy covers and the
/// best plain Hamiltonian path of the dual graph, each oriented by dynamic programming and improved by
/// 2-opt. A mismatch is harmless on the base but may become a break once both sides are refined; for
/// bisection-only hierarchies with aligned faces every front has at most base_runs + base_mismatches runs,
/// at every level (each base link is one link of every front). Generic nodes (swaps, k -> m) get a local
/// rebuild planned once: pre-image faces that follow each other in the strip form one slot (so the image
/// of a swap of two consecutive faces is one path through both), each image face goes to the slot
/// sharing most corners with it, and each slot is ordered by an exhaustive search (up to 6 faces, greedy
/// beyond) that keeps, in this order of priority, the links inside the slot, the *portal edges* (the edges
/// shared with the faces before and after the slot), the portal vertices, and the orientation along split
/// edges. Slots of a k -> m node with m < k may stay empty. Such plans carry no guarantee; the runs are
/// measured (tests/fourk/strips_test.cpp prints them).
///
/// Why a plan and not a rebuild at each move. The strip of a front is a function of the front alone: it
/// is the front sorted by a fixed key (the preorder of the strip-children forest). Hence applying then
/// undoing a node restores the strip exactly, coarsening everything returns the base strip, and the
/// maintained strip equals hierarchical_strip() computed from scratch. Undo merges each pre-image face back
/// into the slot its children occupied. The price: a generic node's rebuild is chosen once from the plan's
/// neighbours, not from the current front's.
///
/// Invariants of StripFront (validate()): the keyed set holds exactly the front's faces; the break count
/// equals the number of consecutive pairs (in key order) that share no edge; the front itself is valid.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "multitri/detail/assert.hpp"
#include "multitri/mt.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// A strip: runs of faces; within a run consecutive faces share an edge.
using StripRuns = std::vector<std::vector<FaceId>>;

struct StripPlanOptions {
  /// Depth-first expansions spent looking for a base strip with no break and no mismatch (0: greedy only).
  std::size_t search_budget = 200000;
};

/// What StripPlan measured while planning.
struct StripPlanStats {
  std::size_t base_faces = 0;
  std::size_t base_runs = 0;         ///< runs of the base strip
  std::size_t base_mismatches = 0;   ///< base links sharing an edge but not through the meeting vertex
  bool base_search_exhausted = false;  ///< the depth-first search ran out of budget (greedy result used)
  std::size_t bisection_nodes = 0;   ///< nodes recognised as edge bisections (each pre-image face halved)
  std::size_t generic_nodes = 0;     ///< other nodes (swaps, k -> m), planned by the local search
  std::size_t misaligned_faces = 0;  ///< faces split by a bisection whose orientation is not its split edge
  /// Inside the slots: breaks, lost portal edges and portal vertex mismatches (0 for aligned bisections).
  std::size_t local_defects = 0;
  /// The condition of the one-run guarantee (header comment).
  bool is_sierpinski() const noexcept {
    return base_runs <= 1 && base_mismatches == 0 && generic_nodes == 0 && misaligned_faces == 0 &&
           local_defects == 0;
  }
};

/// The strip rule of one Mt: the base strip, and the order each node gives its image inside the slots of
/// its pre-image. Immutable once built; many StripFronts may share it (it must outlive them, and the Mt
/// must outlive it).
class StripPlan {
 public:
  /// Plans every node (parents first). Cost: O(faces) for bisection nodes (about a third of the time
  /// build_bisection_mt takes), plus the base search (bounded by search_budget, then O(base) greedy and
  /// 2-opt passes), plus O(k! k) per slot of k <= 6 image faces of a generic node. Memory kept: 16 bytes
  /// per Mt face. Throws InvalidInput when a face is reached from no base face (an Mt that fails validate()).
  explicit StripPlan(const Mt& mt, const StripPlanOptions& options = {});
  /// A plan keeps a reference to its Mt: a temporary Mt would leave it dangling.
  explicit StripPlan(const Mt&& mt, const StripPlanOptions& options = {}) = delete;

  const Mt& mt() const noexcept { return *mt_; }
  /// Rank of face f in the hierarchical order (the preorder of the strip-children forest). Unchecked:
  /// f < num_faces(), as std::vector::operator[].
  Index key(FaceId f) const noexcept {
    VARMESH_ASSERT(f < key_.size());
    return key_[f];
  }
  /// Inverse of key(). Unchecked: key < num_faces().
  FaceId face_at(Index key) const noexcept {
    VARMESH_ASSERT(key < face_at_.size());
    return face_at_[key];
  }
  std::size_t num_faces() const noexcept { return key_.size(); }
  /// The base strip (the source's image in strip order; the runs are the base front's runs).
  std::span<const FaceId> base_order() const noexcept { return base_order_; }
  /// Orientation of face f: the corner where the path enters it and the corner where it leaves.
  /// Unchecked: f < num_faces().
  VertexId entry(FaceId f) const noexcept {
    VARMESH_ASSERT(f < entry_.size());
    return entry_[f];
  }
  VertexId exit(FaceId f) const noexcept {
    VARMESH_ASSERT(f < exit_.size());
    return exit_[f];
  }
  const StripPlanStats& stats() const noexcept { return stats_; }
  std::size_t memory_bytes() const noexcept;

 private:
  const Mt* mt_;
  std::vector<Index> key_;
  std::vector<FaceId> face_at_;
  std::vector<VertexId> entry_, exit_;
  std::vector<FaceId> base_order_;
  StripPlanStats stats_;
};

namespace detail {

/// An ordered set of keys in [0, n) as a 64-ary tree of bit words: insert, erase, successor and
/// predecessor in O(log_64 n). The storage of StripFront's order (no per-element allocation).
class StripKeySet {
 public:
  void reset(std::size_t n);
  void insert(Index k) noexcept;
  void erase(Index k) noexcept;
  bool contains(Index k) const noexcept { return (levels_[0][k >> 6] >> (k & 63)) & 1u; }
  std::size_t size() const noexcept { return size_; }
  /// Smallest key > k (k may be kInvalid to get the first), kInvalid when none.
  Index next(Index k) const noexcept;
  /// Largest key < k (k may be kInvalid to get the last), kInvalid when none.
  Index prev(Index k) const noexcept;
  std::size_t memory_bytes() const noexcept;

 private:
  std::vector<std::vector<std::uint64_t>> levels_;  // levels_[0]: one bit per key
  std::size_t n_ = 0, size_ = 0;
};

}  // namespace detail

/// An MtFront with its hierarchical strip, maintained under every move.
///
/// The moves mirror MtFront (same legality rules, same InvalidInput errors); each also updates the strip in
/// O(faces changed * log_64 faces). StripFront models RefinableFront, so extract()/update() (query.hpp)
/// maintain the strip too.
class StripFront {
 public:
  /// The base front and the base strip.
  explicit StripFront(const StripPlan& plan);
  /// A front keeps a reference to its plan: a temporary StripPlan would leave it dangling.
  explicit StripFront(const StripPlan&& plan) = delete;

  const StripPlan& plan() const noexcept { return *plan_; }
  const Mt& mt() const noexcept { return plan_->mt(); }
  const MtFront& front() const noexcept { return front_; }

  void apply(NodeId n);
  void undo(NodeId n);
  /// As MtFront::refine / coarsen: sink(m) is called for each node applied / undone, in order.
  template <class Sink> void refine(NodeId n, Sink&& sink) {
    front_.refine(n, [&](NodeId m) {
      on_applied(m);
      sink(m);
    });
  }
  void refine(NodeId n) { refine(n, [](NodeId) {}); }
  template <class Sink> void coarsen(NodeId n, Sink&& sink) {
    front_.coarsen(n, [&](NodeId m) {
      on_undone(m);
      sink(m);
    });
  }
  void coarsen(NodeId n) { coarsen(n, [](NodeId) {}); }
  /// Back to the base front and the base strip.
  void reset();

  std::size_t num_faces() const noexcept { return front_.num_faces(); }
  /// Number of runs (0 for an empty front). O(1).
  std::size_t num_runs() const noexcept { return keys_.size() == 0 ? 0 : breaks_ + 1; }
  std::size_t num_breaks() const noexcept { return breaks_; }
  /// Walking the strip: the first face, the face after / before f (f in the front), kInvalid at the ends.
  FaceId first_face() const noexcept;
  FaceId next_face(FaceId f) const noexcept;
  FaceId prev_face(FaceId f) const noexcept;
  /// The faces in strip order. O(front + Mt faces / 64).
  std::vector<FaceId> sequence() const;
  /// The runs. O(front + Mt faces / 64).
  StripRuns runs() const;

  /// Throws InvalidInput naming the first violated invariant (header comment). O(front + Mt size).
  void validate() const;

  // The RefinableFront interface (query.hpp).
  ElementBound element_bound(NodeId n) const noexcept { return front_.element_bound(n); }
  bool is_refined(NodeId n) const noexcept { return front_.is_refined(n); }
  bool is_coarsenable(NodeId n) const noexcept { return front_.is_coarsenable(n); }
  std::uint64_t tie_key(NodeId n) const noexcept { return front_.tie_key(n); }
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const { front_.for_each_refine_candidate(fn); }
  template <class Fn> void for_each_child_candidate(NodeId n, Fn&& fn) const { front_.for_each_child_candidate(n, fn); }
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const { front_.for_each_coarsen_candidate(fn); }
  template <class Fn> void for_each_parent_candidate(NodeId n, Fn&& fn) const { front_.for_each_parent_candidate(n, fn); }
  void coarsen_one(NodeId n) { undo(n); }

 private:
  void on_applied(NodeId n);
  void on_undone(NodeId n);
  // Replaces `removed` by `added` in the keyed set and updates the break count of the links that changed.
  void replace(std::span<const FaceId> removed, std::span<const FaceId> added);
  bool link_breaks(FaceId f) const noexcept;

  const StripPlan* plan_;
  MtFront front_;
  detail::StripKeySet keys_;
  std::size_t breaks_ = 0;
  std::vector<FaceId> links_, image_;  // scratch
};

/// The hierarchical strip of any set of faces of plan.mt() (e.g. MtFront::faces()), computed from
/// scratch: the faces sorted by key, cut where consecutive faces share no edge. For a front it equals
/// StripFront::runs() of a StripFront in that state. Throws InvalidInput naming a face id out of range.
/// O(faces log faces).
StripRuns hierarchical_strip(const StripPlan& plan, std::span<const FaceId> faces);

struct GreedyStripOptions {
  /// Depth-first expansions spent looking for a one-run strip (a Hamiltonian path of the dual graph)
  /// before the greedy cover; 0: greedy only.
  std::size_t search_budget = 100000;
};

/// A strip of any set of faces of `mt` ignoring the hierarchy (the from-scratch comparison): a depth-first
/// search for a Hamiltonian path of the dual graph (Warnsdorff's rule: fewest free neighbours first) within
/// the budget, else a greedy cover by paths (each grown at both ends). Faces adjacent = two common
/// vertices. Throws InvalidInput naming a face id out of range or repeated. O(faces log faces + budget).
StripRuns greedy_strip(const Mt& mt, std::span<const FaceId> faces, const GreedyStripOptions& options = {});

/// What check_strip() found.
struct StripCheck {
  bool ok = false;            ///< every face exactly once, consecutive faces of a run share an edge
  std::size_t num_faces = 0;  ///< faces listed by the runs
  std::size_t num_runs = 0;
  /// Swaps the index encoding needs (encode_strip): 0 means every run is a plain OpenGL strip whose
  /// triangles alternate orientation; otherwise the strip is *generalized* (Velho et al. 1999).
  std::size_t num_swaps = 0;
  std::size_t num_indices = 0;  ///< length of encode_strip()'s output (restarts included)
  std::string problem;          ///< the first violation, empty when ok

  bool is_sequential() const noexcept { return ok && num_swaps == 0; }
};

/// Checks `runs` against the face set `faces` of `mt`: each face of `faces` appears exactly once, no other
/// face appears, no run is empty, and consecutive faces of a run share an edge (two common vertices).
/// Never throws for bad runs (they are reported); O(faces + Mt faces).
StripCheck check_strip(const Mt& mt, std::span<const FaceId> faces, const StripRuns& runs);

/// The restart marker of encode_strip(): (uint32)-1, OpenGL's GL_PRIMITIVE_RESTART_FIXED_INDEX.
inline constexpr Index kStripRestart = kInvalid;

/// Encodes runs as one index sequence for GL_TRIANGLE_STRIP with primitive restart. Within a segment
/// (between restarts) triangle i is (s[i], s[i+1], s[i+2]) for even i and (s[i+1], s[i], s[i+2]) for odd
/// i; triangles with a repeated index are degenerate and draw nothing. Encoding of a run: its first face
/// is emitted from the corner not on the edge shared with the next face (winding kept); each next face
/// sharing the last two emitted vertices costs its third vertex; a face sharing the edge (last, third to
/// last) needs a *swap*: the last and the third-to-last vertex are emitted again (two degenerate
/// triangles) before the new vertex, which also keeps the winding of consistently oriented meshes (a
/// parity fix, one repeated index, is added for inconsistent input). Runs are separated by kStripRestart.
/// Output indices are Mt vertex ids, or vertex_map[id] when vertex_map is not empty (it must be one-to-one
/// on the vertices used, e.g. the inverse of MtFront::to_mesh's vertex_ids, and never kStripRestart).
/// `num_swaps` (optional) receives the number of swaps. Throws InvalidInput (element: the run) for
/// consecutive faces that share no edge, an empty run, a face id out of range, or a vertex outside
/// vertex_map or mapped to kStripRestart.
std::vector<Index> encode_strip(const Mt& mt, const StripRuns& runs, std::span<const Index> vertex_map = {},
                                std::size_t* num_swaps = nullptr);

/// Decodes an index sequence as above into its non-degenerate triangles, with the winding the strip
/// gives them (parity rule above). O(indices).
std::vector<std::array<VertexId, 3>> decode_strip(std::span<const Index> indices);

}  // namespace varmesh
