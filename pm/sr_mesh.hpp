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
/// neighbour goes away through a split of update()'s refine step, after its coarsen step, or that no split
/// ever unblocks (see coarsen_all). The answer is still a fixpoint of the query (tests/pm/sr_query_test.cpp).
/// With a triangle budget such postponed collapses can leave the mesh over the budget (common near the base
/// mesh: from a view-dependent state, budgets a few faces above a 4-face base all stalled); update() then
/// answers from the base mesh as extract() does, so the budget holds under every scheme.
///
/// Invariants (validate()): every active face's corners are active; adjacency is symmetric and across
/// opposite directed edges; every active vertex has one fan of faces (disc or half-disc); node states are
/// consistent (an active node's ancestors are refined, its descendants inactive). The dual-piece oracle
/// (dual_pieces.hpp) checks independently that the faces are those the active set defines.
///
/// Threads: const members only read (they keep no scratch in the object), so any number of threads may call
/// them on one SrMesh while no thread changes it. Non-const members need the mesh to themselves. Meshes
/// over one hierarchy are independent.
///
/// Errors: InvalidInput for bad arguments, as each member says. std::logic_error only on a broken internal
/// invariant: a bug, or a hierarchy that does not pass VertexHierarchy::validate() (one assembled with
/// VertexHierarchyBuilder::finish(raw, false)). The accessors documented "unchecked" take ids as
/// std::vector::operator[] takes an index: out of range is undefined (VARMESH_ASSERT checks it in debug and
/// sanitizer builds).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/bounds.hpp"
#include "multitri/detail/assert.hpp"
#include "multitri/huge_pages.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

enum class RefinementScheme : std::uint8_t { kKimLee, kHoppe97, kXiaVarshney };

/// "kim-lee", "hoppe97" or "xia-varshney"; "?" for a value outside the enumeration.
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

/// The selectively refined mesh of one VertexHierarchy (see the file comment). It refers to the hierarchy,
/// which must outlive it; copies refer to the same hierarchy. A moved-from SrMesh is an empty mesh over an
/// empty hierarchy (no node, no face): its members work on that, and vsplit/ecol throw InvalidInput.
class SrMesh {
 public:
  /// Starts at the base mesh. The hierarchy must outlive the mesh. Throws InvalidInput when `scheme` is not
  /// one of the enumeration's values or the hierarchy has 2^30 faces or more. O(nodes + faces).
  explicit SrMesh(const VertexHierarchy& h, RefinementScheme scheme = RefinementScheme::kKimLee);
  /// Deleted: the mesh keeps a reference to its hierarchy, which a temporary would not outlive.
  explicit SrMesh(const VertexHierarchy&& h, RefinementScheme scheme = RefinementScheme::kKimLee) = delete;
  SrMesh(const SrMesh&) = default;
  SrMesh& operator=(const SrMesh&) = default;
  /// Leaves `other` empty (see the class comment).
  SrMesh(SrMesh&& other) noexcept;
  SrMesh& operator=(SrMesh&& other) noexcept;
  ~SrMesh() = default;

  const VertexHierarchy& hierarchy() const noexcept { return *h_; }
  RefinementScheme scheme() const noexcept { return scheme_; }

  enum class State : std::uint8_t { kBelow = 0, kActive = 1, kRefined = 2 };
  /// Unchecked: v < hierarchy().num_nodes().
  State state(Index v) const noexcept {
    VARMESH_ASSERT(v < nodes_.size());
    return node_active(v) ? State::kActive : node_refined(v) ? State::kRefined : State::kBelow;
  }
  /// Unchecked: v < hierarchy().num_nodes().
  bool is_active(Index v) const noexcept {
    VARMESH_ASSERT(v < nodes_.size());
    return node_active(v);
  }
  std::size_t num_active_vertices() const noexcept { return num_active_; }
  std::size_t num_faces() const noexcept { return num_faces_; }
  /// Is original face f a face of the current mesh? Unchecked: f < hierarchy().num_faces().
  bool face_active(Index f) const noexcept {
    VARMESH_ASSERT(f < num_slots_);
    return faces_[slot_of_[f]].v[0] != kInvalid;
  }
  /// Corners (active nodes, counter-clockwise) of active face f; all kInvalid when f is inactive.
  /// Unchecked: f < hierarchy().num_faces().
  std::array<Index, 3> face(Index f) const noexcept {
    VARMESH_ASSERT(f < num_slots_);
    return faces_[slot_of_[f]].v;
  }
  /// The face across edge k (corners k, k+1) of active face f; kInvalid on the border (and for an inactive
  /// f). Unchecked: f < hierarchy().num_faces() and 0 <= k <= 2.
  Index neighbor(Index f, int k) const noexcept {
    VARMESH_ASSERT(f < num_slots_ && k >= 0 && k <= 2);
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
  /// Would ecol(vs) succeed now without forcing anything? False for an id out of range, a leaf, or a node
  /// whose children are not both active. O(k) for k-vertex 1-rings; no allocation unless a ring has more
  /// than 32 vertices.
  bool can_ecol(Index vs) const;

  /// Splits until every vertex is a leaf / collapses down to the base mesh. Return the vsplits / ecols
  /// done. From the original mesh coarsen_all's collapses are the analysis's, in its order. From a
  /// selectively refined mesh under Kim-Lee, collapsing alone can get stuck above the base mesh: a collapse
  /// can give the children of another refined node a common neighbour besides its cut vertices, and when
  /// every remaining collapse is postponed so (section 4.4 waits for a split) none is possible; coarsen_all
  /// then refines everything and collapses again (those splits are counted in stats().vsplits; reset() goes
  /// to the base mesh without operations).
  std::size_t refine_all();
  std::size_t coarsen_all();

  /// Active vertices (any order) and faces.
  std::vector<Index> active_vertices() const;
  /// fn(face, a, b, c) for each active face (original face id, corners as node ids), in increasing face id
  /// order. fn must not change the mesh.
  template <class Fn> void for_each_face(Fn&& fn) const {
    for (Index f = 0; f < num_slots_; ++f) {
      const FaceSlot& fs = faces_[slot_of_[f]];
      if (fs.v[0] != kInvalid) fn(f, fs.v[0], fs.v[1], fs.v[2]);
    }
  }
  /// fn(face, pa, pb, pc) for each active face with its corners' positions (the nodes' positions), in
  /// increasing face id order: what the spatial queries of multitri/spatial_query.hpp read from a front
  /// (SpatialFront), with the original face id as the face's key (stable). fn must not change the mesh.
  template <class Fn> void for_each_face_geometry(Fn&& fn) const {
    const VertexHierarchy& h = *h_;
    for_each_face([&](Index f, Index a, Index b, Index c) { fn(f, h.position(a), h.position(b), h.position(c)); });
  }
  /// The current mesh with compact vertex numbering; vertex_nodes (optional) receives node id per vertex.
  TriMesh to_mesh(std::vector<Index>* vertex_nodes = nullptr) const;
  /// Bytes held by this object's arrays (the hierarchy it refers to not included).
  std::size_t memory_bytes() const noexcept;

  const SrStats& stats() const noexcept { return stats_; }
  void reset_stats() noexcept { stats_ = {}; }
  /// Checks the invariants of the file comment. Throws std::logic_error naming the first broken one (a bug
  /// or an unvalidated hierarchy, see the class comment). O(nodes + faces).
  void validate() const;

  /// RefinableFront (multitri/query.hpp): elements are non-leaf hierarchy nodes; refining one is its vsplit.
  /// The listings call fn with the mesh unchanged: fn must not change it. is_coarsenable and two listings
  /// have a const overload, which keeps nothing in the mesh (threads may share it, see the file comment),
  /// and a non-const one, which update() calls and which reuses buffers kept in the mesh: same answers, same
  /// order.
  /// Unchecked: e < hierarchy().num_nodes().
  ElementBound element_bound(Index e) const noexcept { return h_->bound(e); }
  /// Unchecked: e < hierarchy().num_nodes().
  bool is_refined(Index e) const noexcept {
    VARMESH_ASSERT(e < nodes_.size());
    return node_refined(e);
  }
  /// can_ecol(e) (checked: false out of range). The const overload walks rings of its own, as can_ecol;
  /// the non-const one, which update() calls, keeps the rings it walked in the mesh for the coarsen_one(e)
  /// that usually follows (one walk instead of two per collapse). Same answer.
  bool is_coarsenable(Index e) const { return can_ecol(e); }
  bool is_coarsenable(Index e);
  std::uint64_t tie_key(Index e) const noexcept { return static_cast<std::uint64_t>(h_->num_nodes() - e); }
  /// Back to the base mesh (statistics kept). O(nodes + faces).
  void reset();
  /// Forces e split (its ancestors first), telling sink(v) of each split once it is done and counted in
  /// stats(). An exception from the sink propagates and leaves a valid mesh with that split done: stats()
  /// then counts exactly the operations done, that split included, and the rest of the request is not
  /// done. Throws InvalidInput when e is out of range or a leaf.
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
    std::array<Index, 256> out;  // written before read
    const std::size_t n = active_list_.size();
    for (std::size_t from = 0; from < n; from += out.size())
      refine_candidates(from, std::min(n, from + out.size()), out.data(), fn);
  }
  template <class Fn> void for_each_refine_candidate(Fn&& fn) {
    if (list_buf_.size() < active_list_.size()) list_buf_.resize(active_list_.size());
    refine_candidates(0, active_list_.size(), list_buf_.data(), fn);
  }
  /// Unchecked: e is a non-leaf node (hierarchy().num_leaves() <= e < hierarchy().num_nodes()).
  template <class Fn> void for_each_child_candidate(Index e, Fn&& fn) const {
    VARMESH_ASSERT(e >= h_->num_leaves() && e < h_->num_nodes());
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
    // so listing them is a dense scan (fn does not change the mesh, so the list stays where it is).
    const Index* list = collapsible_.data();
    const std::size_t m = collapsible_.size();
    for (std::size_t j = 0; j < m; ++j) {
      prefetch_line(&h_->bound(list[j]));
      fn(list[j]);
    }
  }
  /// Unchecked: e < hierarchy().num_nodes().
  template <class Fn> void for_each_parent_candidate(Index e, Fn&& fn) const {
    Ring ring;  // this call's own
    parent_candidates(e, ring, fn);
  }
  template <class Fn> void for_each_parent_candidate(Index e, Fn&& fn) { parent_candidates(e, ring3_, fn); }

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
  // wraps around. Filled from both ends at once so that the two walks' cache misses overlap. The first
  // kInline half-edges are stored in the object, so a ring on the stack costs no allocation (a fan of
  // more than about kInline / 2 faces one way moves to `big`). Scratch: a copy or a move is an empty ring
  // (never a copy of buf, which may point into the source's own storage).
  struct Ring {
    static constexpr std::size_t kInline = 128;
    std::array<Index, kInline> small;  // written before read
    std::vector<Index> big;
    Index* buf = small.data();
    std::size_t cap = kInline;
    std::size_t lo = 0, hi = 0;
    bool closed = false;
    Index fwd = kInvalid, back = kInvalid;  // the two walks' last half-edges (see ring_step)
    bool fwd_open = false, back_open = false;
    Ring() noexcept {}
    Ring(const Ring&) noexcept {}
    Ring& operator=(const Ring&) noexcept { return *this; }
    std::size_t size() const noexcept { return hi - lo; }
    Index operator[](std::size_t i) const noexcept { return buf[lo + i]; }
  };
  static constexpr Index he(Index f, int k) noexcept { return 4 * f + static_cast<Index>(k); }
  // (k + 1) mod 3 and (k + 2) mod 3 for k in 0..2, read from two bits per k of a constant: no branch for the
  // compiler to choose (a mispredicted one cost the ecol's neighbour walk some 8 ns).
  static constexpr Index next_corner(Index k) noexcept { return (0x09u >> (2 * k)) & 3u; }
  static constexpr Index prev_corner(Index k) noexcept { return (0x12u >> (2 * k)) & 3u; }
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

  // The listings' work, on buffers their two overloads provide. Refine candidates: the active non-leaf
  // vertices among active_list_[from, to), filtered without branches into `out` first (whether a vertex
  // qualifies is hard to predict); the candidates' bounds are asked for as they are listed.
  template <class Fn> void refine_candidates(std::size_t from, std::size_t to, Index* out, Fn& fn) const {
    const auto leaves = static_cast<Index>(h_->num_leaves());
    std::size_t m = 0;
    for (std::size_t i = from; i < to; ++i) {
      const Index v = active_list_[i];
      out[m] = v;
      m += v >= leaves;
    }
    for (std::size_t j = 0; j < m; ++j) {
      prefetch_line(&h_->bound(out[j]));
      fn(out[j]);
    }
  }
  template <class Fn> void parent_candidates(Index e, Ring& ring, Fn& fn) const {
    VARMESH_ASSERT(e < nodes_.size());
    const Index p = h_->parent(e);
    if (p != kInvalid) fn(p);
    // Collapsing e can make the collapses next to it legal: Hoppe's ecol needs its fn faces and Xia-Varshney's
    // its stored rings, and a Kim-Lee ecol postponed by the degenerate case needs a common neighbour gone. So
    // the collapsible parents of e's neighbours are candidates again too; without them update() stopped short
    // of extract()'s answer under Hoppe-97 and Xia-Varshney (and a second update() changed the mesh).
    if (!node_active(e)) return;
    gather_ring(nodes_[e].corner, ring);
    const std::size_t nn = ring.size() + (ring.closed ? 0 : 1);
    for (std::size_t i = 0; i < nn; ++i) {
      const Index q = h_->parent(ring_neighbor(ring, i));
      if (q != kInvalid && q != p && collapsible(q)) fn(q);
    }
  }

  // Look-ahead for refine_all/coarsen_all: touch the fan around half-edge h `steps` faces out each way
  // (those faces were asked for by an earlier call) and ask for the next ones; see refine_all.
  void prefetch_fan(Index h, int steps) const noexcept;
  void prefetch_vsplit(Index vs, int stage) const noexcept;
  void prefetch_ecol(Index vs, int stage) const noexcept;
  // Why an operation is done, for SrStats. do_vsplit and do_ecol count it with the change itself, before
  // refine()'s sink hears of it: a sink that throws then leaves the counters equal to what was done (a
  // caller counting after the return missed a forced split whose sink threw).
  enum class Why : std::uint8_t { kRequested, kForced, kPresplit };
  void do_vsplit(Index vs, Index vl, Index vr, int pl, int pr, Why why);  // on ring_, cut vertices and their places given
  void do_ecol(Index vs, Why why);  // uses ring_/ring2_ left by extra_common_neighbors_kept(vs)
  Index active_ancestor(Index leaf) const noexcept;
  bool vsplit_kim_lee(Index vs, Why why);
  bool vsplit_hoppe(Index vs);
  bool vsplit_xv(Index vs, int depth);
  bool ecol_xv(Index vs, int depth);
  bool make_active_xv(Index n, int depth);
  // Section 4.4: do vt and vu share a neighbour besides the cut vertices? Leaves their rings in rt, ru.
  bool extra_common_neighbors(Index vs, Ring& rt, Ring& ru) const;
  // Its case of a ring over 32 vertices: does a neighbour of the first ring's centre, not in `except`, also
  // neighbour the second's?
  bool long_rings_share(const Ring& rt, std::size_t nt, const Ring& ru, std::size_t nu,
                        const std::array<Index, 3>& except) const;
  // The same on ring_/ring2_, remembered until the mesh or ring_ changes (ecn_).
  bool extra_common_neighbors_kept(Index vs);
  // can_ecol(vs) up to the common-neighbour test.
  bool ecol_rule_allows(Index vs) const;
  bool hoppe_ecol_legal(Index vs) const;
  bool xv_ring_matches(Index vs) const;
  void refine_forced(Index e);
  void report(Index v) { if (sink_) sink_(sink_ctx_, v); }
  void check_node(Index v, const char* what) const;
  void build_base();

  // Everything below but the scratch (rings, list_buf_, ecn_) is listed in swap(): a member added here must
  // be added there.
  void swap(SrMesh& other) noexcept;

  const VertexHierarchy* h_;
  RefinementScheme scheme_ = RefinementScheme::kKimLee;
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
  void refine_passes();   // refine_all's and coarsen_all's loops, inside a BulkScope
  void coarsen_passes();
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
  // Scratch of the non-const members (const members use buffers of their own): the rings of vsplit and
  // ecol, ring3_ of for_each_parent_candidate, list_buf_ of for_each_refine_candidate.
  Ring ring_, ring2_, ring3_;
  std::vector<Index> list_buf_;
  // extra_common_neighbors(vs, ring_, ring2_) was `result` (vs == kInvalid: nothing kept). Every change of
  // the mesh or of ring_ forgets it; a copy starts with nothing kept (its rings are empty).
  struct KeptAnswer {
    Index vs = kInvalid;
    bool result = false;
    KeptAnswer() noexcept {}
    KeptAnswer(const KeptAnswer&) noexcept {}
    KeptAnswer& operator=(const KeptAnswer&) noexcept {
      vs = kInvalid;
      return *this;
    }
  };
  KeptAnswer ecn_;
  std::vector<std::uint8_t> in_progress_;  // Xia-Varshney cycle guard
  struct InProgress;                        // marks one node of in_progress_ while in scope
  void (*sink_)(void*, Index) = nullptr;
  void* sink_ctx_ = nullptr;
};

}  // namespace varmesh
