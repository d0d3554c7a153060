#pragma once
/// The selectively refined mesh (synthesis phase): a manifold triangle mesh whose vertices are an active
/// set of VertexHierarchy nodes, changed by vertex splits and edge collapses under one of three dependency
/// rules, so the schemes can be compared on one hierarchy and one data structure:
///
/// - kKimLee (Kim-Lee 2001, section 4): vsplit_new on ANY active non-leaf vertex, ecol_new on any edge whose
///   two ends are active siblings. The cut vertices are the active ancestors of the stored fundamental cut
///   vertices vl^, vr^, found in the current 1-ring with the O(1) ancestor test of 64-bit keys (section 4.3),
///   so an operation costs O(k) for a k-vertex 1-ring. (A split done in the PM order, as refine_all does
///   them, knows its cut vertices from the collapse sequence and compares node ids instead of reading
///   keys; so does a split in another order whose PM-order cut vertex is in the ring.) Degenerate cases
///   (section 4.4), counted in SrStats::degenerate_cases and apart: an ecol whose ends have common
///   neighbours besides the cut vertices is postponed (ecol returns false; SrStats::postponed_ecols); a
///   vsplit whose two cut vertices coincide first splits that vertex (SrStats::presplits).
/// - kHoppe97 (Hoppe 1997, "View-dependent refinement of progressive meshes", section 4): vsplit(vs) is legal
///   when vs is active and the four stored neighbour faces fn0..fn3 are active; otherwise the vertices whose
///   splits create the missing faces are split first (forced, recursively). ecol is legal when the faces
///   adjacent to fl and fr are exactly fn0..fn3; otherwise it is refused (no forced collapses in that scheme).
/// - kXiaVarshney (Xia-Varshney 1996, "Dynamic view-dependent simplification for polygonal models"): vsplit(vs)
///   and ecol(vs) are legal when the current 1-ring of vs (of vt and vu for ecol) is the stored 1-ring of vs
///   at analysis time; otherwise stored neighbours that are too coarse are split and those that are too fine
///   are collapsed first (forced, recursively; a dependency cycle makes the operation fail and it is counted).
///
/// Faces are original faces (see vertex_hierarchy.hpp): face f is active when its three corners have three
/// distinct active ancestors, and then its corners are those ancestors. The mesh is stored as face slots
/// (one per original face, 24 bytes: three corners and the three twin half-edges across its edges, a
/// half-edge being 4 * slot + corner) and one 8-byte slot per node (an incident corner and its place in
/// the active list, which also encodes the node's state), so every operation walks only 1-rings, a ring
/// step is one load, and a split or collapse reads and writes one line per node it changes. Slots are the
/// original faces in vsplit order (internal; the API speaks original face ids). The big arrays ask for
/// transparent huge pages on Linux, and refine_all/coarsen_all walk the fans of the operations a few steps
/// ahead (prefetches only).
///
/// Query API note: after a collapse, update() retries the collapses next to it (for_each_parent_candidate), so
/// under Hoppe-97 and Xia-Varshney it reaches extract()'s answer. Under Kim-Lee it may keep a few sibling
/// pairs finer than extract() would: an ecol postponed by the degenerate case (section 4.4) whose extra common
/// neighbour goes away through a split of update()'s refine step, after its coarsen step. The answer is
/// still a fixpoint of the query (tests/pm/sr_query_test.cpp).
///
/// Invariants (validate()): every active face's corners are active; adjacency is symmetric and across
/// opposite directed edges; every active vertex has one fan of faces (disc or half-disc); node states are
/// consistent (an active node's ancestors are refined, its descendants inactive). The dual-piece oracle
/// (dual_pieces.hpp) checks independently that the faces are those the active set defines.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "multitri/bounds.hpp"
#include "multitri/huge_pages.hpp"
#include "multitri/tri_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

enum class RefinementScheme : std::uint8_t { kKimLee, kHoppe97, kXiaVarshney };

const char* scheme_name(RefinementScheme s) noexcept;

struct SrStats {
  std::size_t vsplits = 0;          ///< every vsplit performed (requested, forced and presplits)
  std::size_t ecols = 0;            ///< every ecol performed (requested and forced)
  std::size_t forced_vsplits = 0;   ///< vsplits done only to satisfy a dependency rule (not the presplits)
  std::size_t forced_ecols = 0;     ///< ecols done only to satisfy a dependency rule (Xia-Varshney)
  /// Kim-Lee #DC (section 4.4): presplits + postponed_ecols, kept as their sum for the callers of the total.
  std::size_t degenerate_cases = 0;
  std::size_t presplits = 0;        ///< splits of a cut vertex found as both cut vertices of a vsplit (any scheme)
  std::size_t postponed_ecols = 0;  ///< Kim-Lee ecols postponed while vt and vu have extra common neighbours
  std::size_t refused_ecols = 0;    ///< ecols not done because their rule did not allow them
  std::size_t failed_vsplits = 0;   ///< vsplits abandoned on a dependency cycle (Xia-Varshney only)
};

class SrMesh {
 public:
  /// Starts at the base mesh. The hierarchy must outlive the mesh.
  explicit SrMesh(const VertexHierarchy& h, RefinementScheme scheme = RefinementScheme::kKimLee);

  const VertexHierarchy& hierarchy() const noexcept { return *h_; }
  RefinementScheme scheme() const noexcept { return scheme_; }

  enum class State : std::uint8_t { kBelow = 0, kActive = 1, kRefined = 2 };
  State state(Index v) const noexcept {
    return node_active(v) ? State::kActive : node_refined(v) ? State::kRefined : State::kBelow;
  }
  bool is_active(Index v) const noexcept { return node_active(v); }
  std::size_t num_active_vertices() const noexcept { return num_active_; }
  std::size_t num_faces() const noexcept { return num_faces_; }
  bool face_active(Index f) const noexcept { return faces_[slot_of_[f]].v[0] != kInvalid; }
  std::array<Index, 3> face(Index f) const noexcept { return faces_[slot_of_[f]].v; }
  /// The face across edge k (corners k, k+1) of active face f; kInvalid on the border.
  Index neighbor(Index f, int k) const noexcept {
    const Index t = faces_[slot_of_[f]].twin[static_cast<std::size_t>(k)];
    return t == kInvalid ? kInvalid : face_of_[t >> 2];
  }

  /// Splits active non-leaf vertex vs under the scheme's rule (forcing what it needs). Returns true when vs
  /// is split afterwards. Throws InvalidInput if vs is out of range, inactive or a leaf.
  bool vsplit(Index vs);
  /// Collapses the two active children of vs into vs under the scheme's rule. Returns false when the rule
  /// refuses or postpones it (counted). Throws InvalidInput if vs is out of range, a leaf, or its children are
  /// not both active.
  bool ecol(Index vs);
  /// Would ecol(vs) succeed now without forcing anything? O(k).
  bool can_ecol(Index vs) const;

  /// Splits until every vertex is a leaf / collapses until no ecol is possible. Return the operations done.
  std::size_t refine_all();
  std::size_t coarsen_all();

  /// Active vertices (any order) and faces.
  std::vector<Index> active_vertices() const;
  /// fn(face, a, b, c) for each active face, in increasing face id order.
  template <class Fn> void for_each_face(Fn&& fn) const {
    for (Index f = 0; f < num_slots_; ++f) {
      const FaceSlot& fs = faces_[slot_of_[f]];
      if (fs.v[0] != kInvalid) fn(f, fs.v[0], fs.v[1], fs.v[2]);
    }
  }
  /// The current mesh with compact vertex numbering; vertex_nodes (optional) receives node id per vertex.
  TriMesh to_mesh(std::vector<Index>* vertex_nodes = nullptr) const;
  /// Bytes held by this object's arrays (the hierarchy it refers to not included).
  std::size_t memory_bytes() const noexcept;

  const SrStats& stats() const noexcept { return stats_; }
  void reset_stats() noexcept { stats_ = {}; }
  void validate() const;

  /// RefinableFront (multitri/query.hpp): elements are non-leaf hierarchy nodes; refining one is its vsplit.
  ElementBound element_bound(Index e) const noexcept { return h_->bound(e); }
  bool is_refined(Index e) const noexcept { return node_refined(e); }
  bool is_coarsenable(Index e) const { return node_refined(e) && can_ecol(e); }
  std::uint64_t tie_key(Index e) const noexcept { return static_cast<std::uint64_t>(h_->num_nodes() - e); }
  void reset();
  template <class Sink> void refine(Index e, Sink&& sink) {
    check_node(e, "refine");
    sink_ = [](void* ctx, Index v) { (*static_cast<std::remove_reference_t<Sink>*>(ctx))(v); };
    sink_ctx_ = &sink;
    // The sink lives in the caller's frame: forget it however refine_forced() leaves, or a later vsplit
    // would call into a dead object.
    struct Forget {
      SrMesh* m;
      ~Forget() { m->sink_ = nullptr, m->sink_ctx_ = nullptr; }
    } forget{this};
    refine_forced(e);
  }
  void coarsen_one(Index e) { ecol(e); }
  // Candidates come from the list of active nodes, so a frame costs O(active vertices), not O(nodes).
  // The candidates' bounds (and a child's record) are read soon after by the query and by vsplit, in an
  // order unrelated to their addresses: asking for them while listing overlaps those cache misses.
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const {
    // Filtered into a buffer without branches first: whether a vertex qualifies is hard to predict.
    const auto leaves = static_cast<Index>(h_->num_leaves());
    const std::size_t n = active_list_.size();
    if (list_buf_.size() < n) list_buf_.resize(n);
    Index* out = list_buf_.data();
    std::size_t m = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Index v = active_list_[i];
      out[m] = v;
      m += v >= leaves;
    }
    for (std::size_t j = 0; j < m; ++j) {
      prefetch_line(&h_->bound(out[j]));
      fn(out[j]);
    }
  }
  template <class Fn> void for_each_child_candidate(Index e, Fn&& fn) const {
    const Split& r = split_of(e);
    for (Index c : {r.vt, r.vu})
      if (!h_->is_leaf(c)) {
        prefetch_line(&h_->bound(c));
        prefetch_line(&split_of(c));
        fn(c);
      }
  }
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const {
    // The refined nodes whose two children are active are kept in collapsible_ by every vsplit and ecol,
    // so listing them is a dense scan. Copied first: fn may change the mesh.
    const std::size_t m = collapsible_.size();
    if (list_buf_.size() < m) list_buf_.resize(m);
    Index* out = list_buf_.data();
    std::copy(collapsible_.begin(), collapsible_.end(), out);
    for (std::size_t j = 0; j < m; ++j) {
      prefetch_line(&h_->bound(out[j]));
      fn(out[j]);
    }
  }
  template <class Fn> void for_each_parent_candidate(Index e, Fn&& fn) const {
    const Index p = h_->parent(e);
    if (p != kInvalid) fn(p);
    // Collapsing e can make the collapses next to it legal: Hoppe's ecol needs its fn faces and Xia-Varshney's
    // its stored rings, and a Kim-Lee ecol postponed by the degenerate case needs a common neighbour gone. So
    // the collapsible parents of e's neighbours are candidates again too; without them update() stopped short
    // of extract()'s answer under Hoppe-97 and Xia-Varshney (and a second update() changed the mesh).
    if (!node_active(e)) return;
    gather_ring(nodes_[e].corner, ring3_);
    const std::size_t nn = ring3_.size() + (ring3_.closed ? 0 : 1);
    for (std::size_t i = 0; i < nn; ++i) {
      const Index q = h_->parent(ring_neighbor(ring3_, i));
      if (q != kInvalid && q != p && collapsible(q)) fn(q);
    }
  }

 private:
  static void prefetch_line(const void* p) noexcept {
#if defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(p);
#else
    (void)p;
#endif
  }
  // Half-edge h = 4 * face + corner: the edge from that corner to the next one, and the corner itself.
  struct FaceSlot {
    std::array<Index, 3> v;     // corners (active nodes); v[0] == kInvalid when the face is inactive
    std::array<Index, 3> twin;  // twin[k]: the half-edge across edge k, kInvalid on the border
  };
  // What a vsplit/ecol of node vs reads, copied from its CollapseRecord: 40 bytes, read in the order of node
  // ids by refine_all/coarsen_all. fl/fr are face slots (kInvalid when absent); kl/kr the section 4.3 keys
  // of the fundamental cut vertices vl^, vr^ (which would otherwise be two scattered loads); nl/nr their
  // ancestors that are active just before this split when the splits are done in decreasing node order
  // (the PM order of refine_all): the cut vertices of that order, known without reading any key.
  struct Split {
    Index vt, vu, fl, fr, nl, nr;
    std::uint64_t kl, kr;
  };
  const Split& split_of(Index vs) const noexcept { return splits_[vs - h_->num_leaves()]; }
  // The node's state is in active_pos: its place in active_list_ when active, kRefinedPos when refined,
  // kInvalid when below the front. So a vsplit/ecol finds the state of vs, vt and vu on the lines it
  // writes anyway. A refined node has no corner: that field then holds its place in collapsible_ when its
  // two children are active, else kInvalid.
  static constexpr Index kRefinedPos = kInvalid - 1;
  struct NodeSlot {
    Index corner = kInvalid;      // active: a half-edge starting at this vertex; refined: see above
    Index active_pos = kInvalid;  // see above
  };
  bool node_active(std::size_t v) const noexcept { return nodes_[v].active_pos < kRefinedPos; }
  bool node_refined(std::size_t v) const noexcept { return nodes_[v].active_pos == kRefinedPos; }
  bool node_below(std::size_t v) const noexcept { return nodes_[v].active_pos == kInvalid; }
  // Non-leaf v is refined and both its children are active (what an ecol of v needs, before its rule).
  bool collapsible(Index v) const noexcept {
    const Split& r = split_of(v);
    return node_refined(v) && node_active(r.vt) && node_active(r.vu);
  }
  // One fan around a vertex as half-edges leaving it, counter-clockwise in buf[lo, hi); `closed` when it
  // wraps around. Filled from both ends at once so that the two walks' cache misses overlap.
  struct Ring {
    std::vector<Index> buf;
    std::size_t lo = 0, hi = 0;
    bool closed = false;
    Index fwd = kInvalid, back = kInvalid;  // the two walks' last half-edges (see ring_step)
    bool fwd_open = false, back_open = false;
    std::size_t size() const noexcept { return hi - lo; }
    Index operator[](std::size_t i) const noexcept { return buf[lo + i]; }
  };
  static constexpr Index he(Index f, int k) noexcept { return 4 * f + static_cast<Index>(k); }
  static constexpr Index next_corner(Index k) noexcept { return k == 2 ? 0 : k + 1; }
  static constexpr Index prev_corner(Index k) noexcept { return k == 0 ? 2 : k - 1; }
  Index corner_node(Index h) const noexcept { return faces_[h >> 2].v[h & 3]; }
  Index head(Index h) const noexcept { return faces_[h >> 2].v[next_corner(h & 3)]; }   // neighbour a
  Index third(Index h) const noexcept { return faces_[h >> 2].v[prev_corner(h & 3)]; }  // neighbour b
  void gather_ring(Index start, Ring& ring) const;
  void gather_rings(Index start_a, Ring& a, Index start_b, Ring& b) const;  // two rings, walked together
  void ring_begin(Index start, Ring& ring) const;
  bool ring_step(Ring& ring) const;  // one step each way; true when the ring is complete
  // The i-th neighbour of the ring's centre: heads of its half-edges, then (open fan) the last face's third.
  Index ring_neighbor(const Ring& ring, std::size_t i) const noexcept {
    return i < ring.size() ? head(ring[i]) : third(ring[ring.size() - 1]);
  }

  // Look-ahead for refine_all/coarsen_all: touch the fan around half-edge h `steps` faces out each way
  // (those faces were asked for by an earlier call) and ask for the next ones; see refine_all.
  void prefetch_fan(Index h, int steps) const noexcept;
  void prefetch_vsplit(Index vs, int stage) const noexcept;
  void prefetch_ecol(Index vs, int stage) const noexcept;
  void do_vsplit(Index vs, Index vl, Index vr, int pl, int pr);  // on ring_, cut vertices and their places given
  void do_ecol(Index vs);  // uses ring_/ring2_ left by extra_common_neighbors(vs)
  Index active_ancestor(Index leaf) const noexcept;
  bool vsplit_kim_lee(Index vs);
  bool vsplit_hoppe(Index vs);
  bool vsplit_xv(Index vs, int depth);
  bool ecol_xv(Index vs, int depth);
  bool make_active_xv(Index n, int depth);
  bool extra_common_neighbors(Index vs) const;
  bool extra_common_neighbors_walk(Index vs) const;
  bool hoppe_ecol_legal(Index vs) const;
  bool xv_ring_matches(Index vs) const;
  void refine_forced(Index e);
  void report(Index v) { if (sink_) sink_(sink_ctx_, v); }
  void check_node(Index v, const char* what) const;
  void build_base();

  const VertexHierarchy* h_;
  RefinementScheme scheme_;
  Index num_slots_ = 0;
  // Face slots are original faces renumbered in vsplit order (Hoppe's implicit layout): the base faces,
  // then fl^ and fr^ of the last collapse, of the one before, and so on. The faces of a coarse mesh are
  // then a prefix of the array, and a vsplit writes fl and fr side by side.
  // An operation touches some twenty scattered cache lines of these arrays; with 4 KiB pages nearly each is
  // also a TLB miss on a mesh of 10^5-10^6 faces, with 2 MiB pages their translations fit in the TLB.
  HugeVector<FaceSlot> faces_;  // one per original face, by slot
  HugeVector<Index> slot_of_, face_of_;  // original face -> slot and back
  HugeVector<Split> splits_;            // per non-leaf node
  HugeVector<NodeSlot> nodes_;  // one per node
  std::vector<std::pair<Index, FaceSlot>> base_slots_;  // the base mesh's faces by slot, for reset()
  std::vector<Index> base_corners_;                     // a half-edge of each root, as h_->roots()
  std::vector<Index> active_list_;  // the active nodes, in no particular order
  std::vector<Index> collapsible_;  // the refined nodes whose two children are active, in no particular order
  bool track_collapsible_ = true;   // false inside refine_all/coarsen_all (see BulkScope)
  struct BulkScope;
  void suspend_collapsible();
  void rebuild_collapsible();
  std::size_t num_active_ = 0, num_faces_ = 0;
  // Two lists of nodes with O(1) insertion and removal: each member's place is kept in a field of its
  // node slot (active_list_: active_pos; collapsible_: corner, free while the node is refined).
  template <Index NodeSlot::*kPlace> void list_insert(std::vector<Index>& list, Index v) {
    nodes_[v].*kPlace = static_cast<Index>(list.size());
    list.push_back(v);
  }
  template <Index NodeSlot::*kPlace> void list_erase(std::vector<Index>& list, Index v) {
    const Index at = nodes_[v].*kPlace, last = list.back();
    list[at] = last;
    nodes_[last].*kPlace = at;
    list.pop_back();
    nodes_[v].*kPlace = kInvalid;
  }
  void activate(Index v) { list_insert<&NodeSlot::active_pos>(active_list_, v); }
  void deactivate(Index v) { list_erase<&NodeSlot::active_pos>(active_list_, v); }
  void add_collapsible(Index p) { list_insert<&NodeSlot::corner>(collapsible_, p); }
  void remove_collapsible(Index p) { list_erase<&NodeSlot::corner>(collapsible_, p); }
  SrStats stats_;
  mutable std::vector<Index> list_buf_;  // scratch of the candidate listings
  mutable Ring ring_, ring2_, ring3_;  // ring3_: for_each_parent_candidate's, apart from vsplit's and ecol's
  mutable Index ecn_for_ = kInvalid;  // extra_common_neighbors(ecn_for_) is ecn_result_, rings in ring_/ring2_
  mutable bool ecn_result_ = false;
  mutable std::vector<Index> nbrs_;  // scratch: the neighbours of vt in extra_common_neighbors
  mutable std::vector<std::uint32_t> mark_;
  mutable std::uint32_t stamp_ = 0;
  std::vector<std::uint8_t> in_progress_;  // Xia-Varshney cycle guard
  void (*sink_)(void*, Index) = nullptr;
  void* sink_ctx_ = nullptr;
};

}  // namespace varmesh
