#pragma once
/// The selectively refined mesh (synthesis phase): a manifold triangle mesh whose vertices are an active
/// set of VertexHierarchy nodes, changed by vertex splits and edge collapses under one of three dependency
/// rules, so the schemes can be compared on one hierarchy and one data structure:
///
/// - kKimLee (Kim-Lee 2001, section 4): vsplit_new on ANY active non-leaf vertex, ecol_new on any edge whose
///   two ends are active siblings. The cut vertices are the active ancestors of the stored fundamental cut
///   vertices vl^, vr^, found in the current 1-ring with the O(1) ancestor test of 64-bit keys (section 4.3),
///   so an operation costs O(k) for a k-vertex 1-ring. Degenerate cases (section 4.4), counted in
///   SrStats::degenerate_cases: an ecol whose ends have common neighbours besides the cut vertices is
///   postponed (ecol returns false); a vsplit whose two cut vertices coincide first splits that vertex.
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
/// (one per original face: three corners and the three faces across its edges) and one incident face per
/// active vertex, so every operation walks only 1-rings.
///
/// Query API note: update() may keep a few sibling pairs finer than extract() would, because a Kim-Lee ecol
/// postponed by the degenerate case (section 4.4) is not retried until its neighbourhood changes; the answer
/// is still a fixpoint of the query (tests/pm/sr_query_test.cpp).
///
/// Invariants (validate()): every active face's corners are active; adjacency is symmetric and across
/// opposite directed edges; every active vertex has one fan of faces (disc or half-disc); node states are
/// consistent (an active node's ancestors are refined, its descendants inactive). The dual-piece oracle
/// (dual_pieces.hpp) checks independently that the faces are those the active set defines.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "multitri/bounds.hpp"
#include "multitri/tri_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

enum class RefinementScheme : std::uint8_t { kKimLee, kHoppe97, kXiaVarshney };
const char* scheme_name(RefinementScheme s) noexcept;

struct SrStats {
  std::size_t vsplits = 0;          ///< every vsplit performed (requested and forced)
  std::size_t ecols = 0;            ///< every ecol performed (requested and forced)
  std::size_t forced_vsplits = 0;   ///< vsplits done only to satisfy a dependency rule
  std::size_t forced_ecols = 0;     ///< ecols done only to satisfy a dependency rule (Xia-Varshney)
  std::size_t degenerate_cases = 0; ///< Kim-Lee #DC: postponed ecols + cut-vertex pre-splits
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
  State state(Index v) const noexcept { return static_cast<State>(state_[v]); }
  bool is_active(Index v) const noexcept { return state_[v] == 1; }
  std::size_t num_active_vertices() const noexcept { return num_active_; }
  std::size_t num_faces() const noexcept { return num_faces_; }
  bool face_active(Index f) const noexcept { return corners_[3 * f] != kInvalid; }
  std::array<Index, 3> face(Index f) const noexcept { return {corners_[3 * f], corners_[3 * f + 1], corners_[3 * f + 2]}; }
  /// The face across edge k (corners k, k+1) of active face f; kInvalid on the border.
  Index neighbor(Index f, int k) const noexcept { return adj_[3 * f + static_cast<std::size_t>(k)]; }

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
  template <class Fn> void for_each_face(Fn&& fn) const {
    for (Index f = 0; f < num_slots_; ++f)
      if (corners_[3 * f] != kInvalid) fn(f, corners_[3 * f], corners_[3 * f + 1], corners_[3 * f + 2]);
  }
  /// The current mesh with compact vertex numbering; vertex_nodes (optional) receives node id per vertex.
  TriMesh to_mesh(std::vector<Index>* vertex_nodes = nullptr) const;

  const SrStats& stats() const noexcept { return stats_; }
  void reset_stats() noexcept { stats_ = {}; }
  void validate() const;

  /// RefinableFront (multitri/query.hpp): elements are non-leaf hierarchy nodes; refining one is its vsplit.
  ElementBound element_bound(Index e) const noexcept { return h_->bound(e); }
  bool is_refined(Index e) const noexcept { return state_[e] == 2; }
  bool is_coarsenable(Index e) const { return state_[e] == 2 && can_ecol(e); }
  std::uint64_t tie_key(Index e) const noexcept { return static_cast<std::uint64_t>(h_->num_nodes() - e); }
  void reset();
  template <class Sink> void refine(Index e, Sink&& sink) {
    sink_ = [](void* ctx, Index v) { (*static_cast<std::remove_reference_t<Sink>*>(ctx))(v); };
    sink_ctx_ = &sink;
    refine_forced(e);
    sink_ = nullptr;
  }
  void coarsen_one(Index e) { ecol(e); }
  // Candidates come from the list of active nodes, so a frame costs O(active vertices), not O(nodes).
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const {
    const auto leaves = static_cast<Index>(h_->num_leaves());
    for (Index v : active_list_)
      if (v >= leaves) fn(v);
  }
  template <class Fn> void for_each_child_candidate(Index e, Fn&& fn) const {
    const CollapseRecord& r = h_->record(e);
    if (!h_->is_leaf(r.vt)) fn(r.vt);
    if (!h_->is_leaf(r.vu)) fn(r.vu);
  }
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const {
    // A refined node whose two children are active, found from its child vt.
    for (Index v : active_list_) {
      const Index p = h_->parent(v);
      if (p == kInvalid) continue;
      const CollapseRecord& r = h_->record(p);
      if (r.vt == v && state_[r.vu] == 1) fn(p);
    }
  }
  template <class Fn> void for_each_parent_candidate(Index e, Fn&& fn) const {
    const Index p = h_->parent(e);
    if (p != kInvalid) fn(p);
  }

 private:
  struct RingFace {
    Index face;
    int corner;  // corner of the centre vertex in `face`
  };
  // One fan around v, counter-clockwise; `closed` when it wraps around.
  bool gather_ring(Index v, std::vector<RingFace>& ring) const;
  Index neighbor_a(const RingFace& rf) const noexcept { return corners_[3 * rf.face + (rf.corner + 1) % 3]; }
  Index neighbor_b(const RingFace& rf) const noexcept { return corners_[3 * rf.face + (rf.corner + 2) % 3]; }

  void do_vsplit(Index vs, Index vl, Index vr, bool closed);  // the physical operation on ring_, cut vertices given
  void do_ecol(Index vs);  // uses ring_/ring2_ left by extra_common_neighbors(vs)
  Index find_cut_vertex(Index leaf, std::span<const RingFace> ring, bool closed) const;
  bool vsplit_kim_lee(Index vs);
  bool vsplit_hoppe(Index vs);
  bool vsplit_xv(Index vs, int depth);
  bool ecol_xv(Index vs, int depth);
  bool make_active_xv(Index n, int depth);
  bool extra_common_neighbors(Index vs) const;
  bool hoppe_ecol_legal(Index vs) const;
  bool xv_ring_matches(Index vs) const;
  void refine_forced(Index e);
  void report(Index v) { if (sink_) sink_(sink_ctx_, v); }
  void check_node(Index v, const char* what) const;

  const VertexHierarchy* h_;
  RefinementScheme scheme_;
  Index num_slots_ = 0;
  std::vector<Index> corners_;  // 3 per original face; kInvalid when inactive
  std::vector<Index> adj_;      // 3 per original face
  std::vector<Index> vface_;    // per node: an incident active face
  std::vector<std::uint8_t> state_;
  std::vector<Index> active_list_;  // the active nodes, in no particular order
  std::vector<Index> active_pos_;   // per node: its place in active_list_, kInvalid when not active
  std::size_t num_active_ = 0, num_faces_ = 0;
  void activate(Index v) {
    active_pos_[v] = static_cast<Index>(active_list_.size());
    active_list_.push_back(v);
  }
  void deactivate(Index v) {
    const Index at = active_pos_[v], last = active_list_.back();
    active_list_[at] = last;
    active_pos_[last] = at;
    active_list_.pop_back();
    active_pos_[v] = kInvalid;
  }
  SrStats stats_;
  mutable std::vector<RingFace> ring_, ring2_;
  mutable std::vector<std::uint32_t> mark_;
  mutable std::uint32_t stamp_ = 0;
  std::vector<std::uint8_t> in_progress_;  // Xia-Varshney cycle guard
  void (*sink_)(void*, Index) = nullptr;
  void* sink_ctx_ = nullptr;
};

}  // namespace varmesh
