#pragma once
/// Regular 4-8 hierarchies of height fields: the hierarchy of right triangles (interleaved binary
/// subdivision, Velho-Gomes 2000 section 5) over a grid of any size, as an implicit Multi-Triangulation.
///
/// Layout. The W x H samples are covered by Tx x Ty square tiles of S = 2^k cells (the lattice,
/// (Tx*S+1) x (Ty*S+1) points; S is chosen so that the padding stays small). Each tile is two right
/// triangles; every lattice point that is not a tile corner is the centre of one *diamond*: the two
/// triangles (one at the lattice border) sharing the edge that point bisects. A diamond is a split node of
/// the MT (2 faces -> 4, or 1 -> 2 on the lattice border); its parents are the diamonds centred at its
/// triangles' apexes, its children the diamonds centred at the midpoints of its four (two) outer edges.
/// Nodes are lattice points, so the structure needs no arcs: it is the "pointerless" 4-8 structure of
/// section 7.2. Samples outside the grid (padding) repeat the nearest border sample; extracted meshes are
/// clipped to the grid rectangle [0, W-1] x [0, H-1] exactly (new vertices on the clipping lines lie on
/// mesh edges, so the clipped surface is the unclipped one restricted to the grid).
///
/// Bounds. Node error = the largest vertical distance between the diamond's triangles and the grid samples
/// they cover (exact, over every sample), maximised with the children's errors (saturated). Node sphere:
/// centred at the diamond's centre vertex, containing its corners and its children's spheres (nested).
/// Hence every ready-made criterion is monotone, an extracted mesh whose triangles are all "fine" for
/// object_error(e) is within e of every sample it covers, and update() equals extract().
///
/// Memory: 12 bytes per lattice point (error and height side by side in one 8-byte record, since the descent
/// reads both of a point at once; radius apart), plus a histogram of the errors (about 6 KB at most) that
/// bounds the output size of an object-error extraction. A front adds up to 17 bytes per lattice point
/// (refined flags, one slot shared by its two boundary sets, the touched list, the vertex maps of to_mesh
/// and extract_mesh, each allocated on first use) plus its boundary sets (24 bytes per boundary diamond).
#include <algorithm>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/bounds.hpp"
#include "multitri/camera.hpp"
#include "multitri/detail/assert.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/huge_pages.hpp"
#include "multitri/query.hpp"
#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

namespace detail {

/// Exact division of 31-bit numerators by a fixed divisor d (1 <= d <= 2^31) with one multiply and one
/// shift (Granlund and Montgomery 1994, round-up variant): lattice index -> row without a hardware divide.
struct FastDivider {
  std::uint64_t magic = 1ull << 32;
  int shift = 32;
  FastDivider() = default;
  explicit FastDivider(std::uint32_t d) {
    int l = 0;
    while ((std::uint64_t(1) << l) < d) ++l;
    shift = 32 + l;
    magic = ((std::uint64_t(1) << shift) + d - 1) / d;
  }
  std::uint32_t div(std::uint32_t n) const noexcept { return static_cast<std::uint32_t>((n * magic) >> shift); }
};

/// Trailing zero bits of a lattice coordinate; 62 for 0 (so that 1 << result stays defined).
inline int grid48_ctz(std::uint64_t v) noexcept { return v == 0 ? 62 : std::countr_zero(v); }

}  // namespace detail

struct Grid48Options {
  /// Largest acceptable padded-area ratio when choosing the tile size (>= 1). Larger tiles give a
  /// coarser base mesh but more padding.
  double max_padding = 1.15;
  /// Force a tile size: a power of two from 2 to 2^15 cells, 0 = automatic (which also stays within that
  /// range). The lattice must still hold at most 2^30 points, so 2^14 is the largest size that builds.
  std::size_t tile_size = 0;
  /// Node errors. true (default): the exact largest vertical distance between each diamond's triangles
  /// and the samples they cover (saturated: at least the children's), by scanning the samples at every
  /// level (O(samples * levels); small diamonds through per-row sample lists). false: a guaranteed but
  /// looser upper bound, O(1) per node from its children's signed residual ranges (about as fast to build
  /// since the exact scan got its row lists; more triangles for the same error).
  bool exact_errors = true;
  /// Compute the exact errors with the plain per-diamond row scan instead, and the radii one diamond at a
  /// time: the reference the default build is tested against.
  bool reference_scan = false;
};

/// Point ids: every lattice point p < num_points() has an id (row-major, p = y * lattice_width() + x).
/// The nodes (diamonds) are the points that are not tile corners (is_node()). Accessors taking an id are
/// unchecked, as std::vector::operator[] (VARMESH_ASSERT in debug and sanitizer builds): those reading
/// per-point data need p < num_points(); the hierarchy relations (level, parents, children, family,
/// num_triangles) are meaningful only for nodes and need p < num_points() and is_node(p).
class Grid48 {
 public:
  /// Builds the hierarchy. Throws InvalidInput (naming the option or the sample) for grids smaller than
  /// 2 x 2, larger than 2^30 lattice points, with non-finite samples (HeightField::validate), with a
  /// tile_size that is not a power of two in [2, 2^15] or a max_padding below 1, or too large for float:
  /// the lattice's box, padding included, must have a diagonal whose square is finite in float (at most
  /// about 1.8e19), i.e. X^2 + Y^2 + Z^2 <= 0.999 * FLT_MAX with X = (lattice_width() - 1) * spacing_x,
  /// Y = (lattice_height() - 1) * spacing_y and Z = highest sample - lowest sample. Within that rule every
  /// node error and radius is finite (the build squares distances in float); heights alone may lie anywhere
  /// in float's range. The message names the spacing, or for heights the height span and the (row, column)
  /// of the lowest and highest samples (the element is the highest sample's index). O(samples * levels)
  /// for the exact errors.
  explicit Grid48(const HeightField& field, const Grid48Options& options = {});
  Grid48(const Grid48&) = default;
  Grid48& operator=(const Grid48&) = default;
  /// A move leaves `other` an empty hierarchy: num_points() == 0, no nodes; a Grid48Front refuses it.
  /// Fronts built on `other` are not moved with it (they keep referring to the emptied object).
  Grid48(Grid48&& other) noexcept;
  Grid48& operator=(Grid48&& other) noexcept;

  std::size_t grid_width() const noexcept { return width_; }
  std::size_t grid_height() const noexcept { return height_; }
  std::size_t lattice_width() const noexcept { return lw_; }
  std::size_t lattice_height() const noexcept { return lh_; }
  std::size_t tile_size() const noexcept { return tile_; }
  std::size_t tiles_x() const noexcept { return tx_; }
  std::size_t tiles_y() const noexcept { return ty_; }
  float spacing_x() const noexcept { return sx_; }
  float spacing_y() const noexcept { return sy_; }
  /// Number of lattice points (node ids range over them; tile corners are not nodes).
  std::size_t num_points() const noexcept { return lw_ * lh_; }
  std::size_t num_nodes() const noexcept;
  /// Whether lattice point p is a node (not a tile corner). Unchecked: p < num_points().
  bool is_node(Index p) const noexcept;
  /// Number of levels of the hierarchy (depth of the DAG below the source).
  int num_levels() const noexcept { return 2 * log2_tile_; }
  /// Level of node p: 0 for tile centres, increasing by one per binary subdivision step, up to
  /// num_levels() - 1. Unchecked: p < num_points() and is_node(p) (a tile corner has no level).
  int level(Index p) const noexcept;

  /// Column and row of lattice point p. Unchecked: p < num_points().
  std::uint32_t px(Index p) const noexcept { return p - py(p) * static_cast<std::uint32_t>(lw_); }
  std::uint32_t py(Index p) const noexcept { return row_of_.div(p); }
  /// World position, height, node error and bounding-sphere radius of lattice point p (error and radius
  /// are 0 for tile corners). Unchecked: p < num_points(), as std::vector::operator[].
  glm::vec3 position(Index p) const noexcept {
    VARMESH_ASSERT(p < num_points());
    const std::uint32_t y = py(p), x = p - y * static_cast<std::uint32_t>(lw_);
    return {static_cast<float>(x) * sx_, static_cast<float>(y) * sy_, records_[p].z};
  }
  float height_at(Index p) const noexcept {
    VARMESH_ASSERT(p < num_points());
    return records_[p].z;
  }
  float error(Index p) const noexcept {
    VARMESH_ASSERT(p < num_points());
    return records_[p].error;
  }
  float radius(Index p) const noexcept {
    VARMESH_ASSERT(p < num_points());
    return radius_[p];
  }
  /// The bound of node p as the query criteria read it. Unchecked: p < num_points().
  ElementBound bound(Index p) const noexcept {
    VARMESH_ASSERT(p < num_points());
    return {position(p), radius_[p], records_[p].error, {}};
  }

  /// Upper bounds on the number of diamonds refined and of faces (unclipped) of an object-error extraction
  /// at `threshold` (the diamonds with error > threshold), from a histogram of the errors at 1/32-octave
  /// resolution: at most a few per cent above the true counts. O(1). Used to size output arrays.
  std::size_t max_refined_above(float threshold) const noexcept;
  std::size_t max_faces_above(float threshold) const noexcept;

  /// Calls fn(parent) for the one or two parents of node p (none for tile centres, whose parent is the
  /// source). Unchecked: p < num_points() and is_node(p).
  template <class Fn> void for_each_parent(Index p, Fn&& fn) const;
  /// Calls fn(child) for the two or four children of node p (none at the finest level). Unchecked:
  /// p < num_points() and is_node(p) (a tile corner has no children; the call would list garbage ids).
  template <class Fn> void for_each_child(Index p, Fn&& fn) const;
  /// Faces node p removes: 2, or 1 on the lattice border. Unchecked: p < num_points() and is_node(p).
  int num_triangles(Index p) const noexcept;

  /// The parents and children of node p (those of for_each_parent and for_each_child), computed together,
  /// and for each child its other parent (kInvalid if it has only p): in the 4-8 lattice the two parents
  /// of a diamond are mirror images through it, so it is 2 c - p when that lies in the lattice. O(1).
  struct Family {
    Index parent[2];
    Index child[4];
    Index co_parent[4];
    int num_parents = 0, num_children = 0;
  };
  /// Unchecked: p < num_points() and is_node(p).
  Family family(Index p) const noexcept;
  /// Whether some child c of node p has refined[c] != 0 (refined: one byte per lattice point). Unchecked:
  /// p < num_points() and is_node(p).
  bool has_refined_child(Index p, const std::uint8_t* refined) const noexcept;

  /// Bytes held by the hierarchy's arrays.
  std::size_t memory_bytes() const noexcept;
  /// The same hierarchy as an explicit Mt (for tests and metrics; grows ~100 bytes per sample). Vertex v of
  /// the Mt is lattice point v; node errors are this hierarchy's errors (not recomputed).
  Mt to_mt() const;

  /// Largest vertical distance between `mesh` (a mesh extracted from this hierarchy, in world coordinates,
  /// covering the grid rectangle) and every grid sample, located by walking the mesh; HUGE_VAL when some
  /// sample lies under no triangle. Throws InvalidInput naming the face or vertex for an index count that
  /// is not a multiple of 3, an index out of range or a non-finite position. For tests/benchmarks.
  double max_vertical_error(const TriMesh& mesh) const;

  // Internal layout helpers used by Grid48Front.
  int log2_tile() const noexcept { return log2_tile_; }
  bool needs_clip() const noexcept { return lw_ != width_ || lh_ != height_; }
  /// A lattice point's error and height, stored together (one cache line holds both).
  struct PointRecord {
    float error;
    float z;
  };
  const PointRecord* records() const noexcept { return records_.data(); }
  /// Node radii, per lattice point (for prefetching; radius(p) reads the same array).
  const float* radii() const noexcept { return radius_.data(); }

 private:
  void compute_errors();
  void compute_exact_errors();
  double scan_own_error(std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, bool square) const;
  void compute_radii();
  void compute_bounds_fast(bool exact);
  void build_histogram();
  std::size_t histogram_slot(float threshold) const noexcept;
  float sample_clamped(std::ptrdiff_t x, std::ptrdiff_t y) const noexcept;

  std::size_t width_ = 0, height_ = 0;  // grid samples
  std::size_t lw_ = 0, lh_ = 0;         // lattice points
  std::size_t tile_ = 1, tx_ = 0, ty_ = 0;
  int log2_tile_ = 0;
  float sx_ = 1.0f, sy_ = 1.0f;
  detail::FastDivider row_of_;
  // Scratch of the reference scan (Grid48Options::reference_scan), released when the hierarchy is built:
  // heights as contiguous rows, errors. The other builds work in records_ directly.
  HugeVector<float> z_;      // lattice heights (padding repeats the border)
  HugeVector<float> error_;  // per lattice point (0 for tile corners)
  HugeVector<PointRecord> records_;  // per lattice point: error, height
  HugeVector<float> radius_;         // per lattice point
  // Error histogram: key(e) = float bits of e >> 18 (32 keys per octave), clamped below at hist_key0_;
  // refined_above_[k] / faces_above_[k] = nodes (faces they remove) in slots >= k, where slot 0 holds the
  // nodes of error 0 and slot 1 + j those with key hist_key0_ + j.
  std::uint32_t hist_key0_ = 0;
  std::vector<std::uint32_t> refined_above_, faces_above_;
};

/// The usual view-dependent terrain query: refine inside the frustum until the projected error is at most
/// `pixels` on a viewport `viewport_height` pixels high (and, if object_error >= 0, stop wherever the
/// vertical error is at most object_error; a negative or NaN object_error is unused). to_query() gives the
/// equivalent generic Query.
struct ViewQuery {
  Camera camera;
  float viewport_height = 1080.0f;
  float pixels = 1.0f;
  float object_error = -1.0f;
  /// Throws InvalidInput when the camera is invalid (Camera::validate) or pixels or viewport_height is not
  /// > 0 (NaN included): the checks of Criterion::screen_error. to_query() and
  /// Grid48Front::update_view() call it.
  void validate() const;
  /// The equivalent Query. Throws as validate().
  Query to_query() const;
};

/// The state of one extraction on a Grid48: which diamonds are split. Models RefinableFront (query.hpp).
///
/// The front refers to its Grid48, which must outlive it and stay in place (it is not moved along with a
/// moved Grid48). Copies are independent fronts on the same grid. A moved-from front may only be assigned
/// to, reset() or destroyed.
///
/// Threads: the const members (to_mesh, the candidate listings, validate, ...) only read the front, or
/// synchronise what they share (to_mesh's vertex map), so any number of threads may call them on one
/// front at once, as long as no thread calls a non-const member at the same time.
///
/// Exceptions: a criterion (Criterion::custom) may throw, and any member that allocates may throw
/// std::bad_alloc. Every member leaves a valid front when something throws (validate() holds, the
/// candidate listings are the boundary of the refined set, and later calls give the answers a fresh front
/// would). In detail: a single move (refine() of a diamond whose parents are refined, coarsen_one())
/// either completes or changes nothing, since the boundary sets make room before the move starts;
/// refine() of a deeper diamond keeps the ancestors it had refined; the generic extract()/update()
/// (query.hpp) and update_view() stop between moves (update_view() also forgets its motion records, so
/// the next call re-evaluates every boundary diamond); extract_fast() and extract_mesh(), which rebuild
/// the front in place, leave it at the base mesh (as after reset()); reset() leaves the base mesh; a copy
/// assignment leaves the target unchanged.
class Grid48Front {
 public:
  /// The base front (the two triangles of every tile). Throws InvalidInput when `grid` is empty (a
  /// moved-from Grid48).
  explicit Grid48Front(const Grid48& grid);
  /// A front keeps a reference to its grid: a temporary Grid48 would leave it dangling.
  explicit Grid48Front(const Grid48&& grid) = delete;
  Grid48Front(const Grid48Front&) = default;
  Grid48Front(Grid48Front&&) noexcept = default;
  /// Copies into a new front, then moves it in: the target is unchanged if the copy throws.
  Grid48Front& operator=(const Grid48Front& other);
  Grid48Front& operator=(Grid48Front&&) noexcept = default;

  const Grid48& grid() const noexcept { return *grid_; }
  std::size_t num_faces() const noexcept { return num_faces_; }
  std::size_t num_refined() const noexcept { return num_refined_; }

  void reset();
  /// Unchecked: p < grid().num_points(), as std::vector::operator[].
  bool is_refined(Index p) const noexcept {
    VARMESH_ASSERT(p < refined_.size());
    return refined_[p] != 0;
  }
  /// Refined, and no child refined. Unchecked: p < grid().num_points().
  bool is_coarsenable(Index p) const noexcept;
  /// Throws InvalidInput naming `p` and `who` when p is not a diamond of the grid (out of range, or a tile
  /// corner: those are never refined). refine() and coarsen_one() check.
  void check_diamond(Index p, const char* who) const;
  /// Unchecked: p < grid().num_points().
  ElementBound element_bound(Index p) const noexcept { return grid_->bound(p); }
  /// Unchecked: p is a node (Grid48::level's precondition).
  std::uint64_t tie_key(Index p) const noexcept { return (std::uint64_t(grid_->level(p)) << 32) | p; }
  /// Refines diamond p after its missing ancestors, calling sink(r) after each diamond r is refined (the
  /// front is complete at that point, so a sink that throws leaves it valid). Throws as check_diamond.
  template <class Sink> void refine(Index p, Sink&& sink);
  void refine(Index p) { refine(p, [](Index) {}); }
  /// Unrefines p. Throws InvalidInput naming p unless it is a diamond and is_coarsenable(p).
  void coarsen_one(Index p);
  /// The exposed diamonds (unrefined, a tile centre or with a refined parent) and the maximal ones
  /// (refined, no refined child), in no particular order. Read-only: after extract_fast(), which leaves the
  /// boundary sets to be rebuilt by the next move, they are listed from the diamonds that extraction
  /// evaluated (O(those)); otherwise from the sets (O(listed)).
  template <class Fn> void for_each_refine_candidate(Fn&& fn) const;
  template <class Fn> void for_each_coarsen_candidate(Fn&& fn) const;
  /// Unchecked: p is a node (Grid48::for_each_child's precondition).
  template <class Fn> void for_each_child_candidate(Index p, Fn&& fn) const { grid_->for_each_child(p, fn); }
  template <class Fn> void for_each_parent_candidate(Index p, Fn&& fn) const { grid_->for_each_parent(p, fn); }

  /// The current mesh in world coordinates, clipped to the grid rectangle; vertices are shared, triangles
  /// counter-clockwise seen from +z. `lattice_ids` (optional) gets the lattice point of each vertex
  /// (kInvalid for vertices created by clipping). O(faces): the lattice point -> vertex map (4 bytes per
  /// lattice point, kept by the front between calls) is borrowed for the call. Safe to call from several
  /// threads at once: a call that finds the map borrowed by another allocates and fills its own
  /// (O(lattice points) more); the results are the same.
  TriMesh to_mesh(std::vector<Index>* lattice_ids = nullptr) const;

  /// extract() for queries without budgets, by one recursive descent over the triangles (no candidate
  /// stack). For monotone criteria this is the least fixpoint extract() computes; if the descent finds a
  /// refined diamond whose parent is not refined (a non-monotone criterion), it falls back to the generic
  /// algorithm, so the result is always the same as extract(). Queries with budgets go to extract().
  /// If the criterion throws, the front is left at the base mesh and the exception propagates.
  QueryStats extract_fast(const Query& q);

  /// extract_fast(q) then to_mesh(lattice_ids): the same front and the same triangles (vertex numbering may
  /// differ). For object-error queries without focus or budget (the usual terrain query) both happen in one
  /// descent that writes vertices and triangles as it goes, into arrays sized from the hierarchy's error
  /// histogram (no growth, and no per-point map to fill on a fresh front); other queries take the two calls.
  /// On an exception the front is left at the base mesh (as extract_fast).
  TriMesh extract_mesh(const Query& q, std::vector<Index>* lattice_ids = nullptr);

  /// Frame-to-frame update for a moving camera: the same state update(front, v.to_query()) reaches (which
  /// is extract()'s), but a boundary diamond is re-evaluated only when the camera has moved enough since
  /// its last evaluation to possibly change its status. Each evaluation stores a slack: how far the eye may
  /// translate (and the view rotate, scaled by the diamond's distance) before the status can flip (a
  /// diamond stays unwanted while it stays outside the frustum *or* fine on screen), split into a
  /// translation and a rotation budget in proportion to the last frame's motion. When the viewport, pixels,
  /// field of view, aspect, clipping distances or object error change, it re-evaluates everything. A
  /// diamond the update refines (coarsens) because it is (not) wanted keeps its record in its new set.
  /// Costs 24 bytes per boundary diamond (the record and a copy of the diamond's bound) and 4 per lattice
  /// point. Throws InvalidInput as v.validate() and v.camera.view() (checked before the front changes).
  QueryStats update_view(const ViewQuery& v);
  /// Calls fn(apex, h0, h1) (lattice points, counter-clockwise) for every current triangle, unclipped.
  template <class Fn> void for_each_triangle(Fn&& fn) const;
  /// Calls fn(key, a, b, c) with world positions for every current triangle, unclipped (spatial queries);
  /// key = the triangle's rank in walk order (stable while the front does not change).
  template <class Fn> void for_each_face_geometry(Fn&& fn) const {
    Index key = 0;
    for_each_triangle([&](Index a, Index b, Index c) {
      fn(key++, grid_->position(a), grid_->position(b), grid_->position(c));
    });
  }

  /// Throws InvalidInput if the refined set is not an order ideal or the face count is stale.
  void validate() const;

 private:
  template <class Fn> void walk(std::uint32_t ax, std::uint32_t ay, std::uint32_t bx, std::uint32_t by, std::uint32_t cx,
                                std::uint32_t cy, Fn& fn) const;
  template <class Fn> void for_each_root(Fn&& fn) const;
  template <class Wants>
  void descend(std::uint32_t ax, std::uint32_t ay, std::uint32_t bx, std::uint32_t by, std::uint32_t cx,
               std::uint32_t cy, Wants& wants);
  void clear_refined();
  // After an exception inside a rebuild of the front: back to the base mesh (refined_ fully cleared, since
  // the touched list may be incomplete), with the boundary sets to be rebuilt.
  void restore_base() noexcept;
  QueryStats extract_fast_unguarded(const Query& q);
  template <bool kClip, bool kEmit>
  QueryStats descend_object(float threshold, TriMesh* out, std::vector<Index>* ids);
  // extract_mesh scratch, uninitialised: valid only for points the running descent made vertices. Holds
  // nothing between calls, so a copied front starts without one.
  struct UninitIndices {
    std::unique_ptr<Index[]> data;
    std::size_t size = 0;
    UninitIndices() = default;
    UninitIndices(const UninitIndices&) {}
    UninitIndices& operator=(const UninitIndices&) { return *this; }
    UninitIndices(UninitIndices&&) = default;
    UninitIndices& operator=(UninitIndices&&) = default;
  };
  UninitIndices vertex_id_;
  const Grid48* grid_;
  // 0: not refined; 1: refined. During extract_fast, 2 marks "evaluated, not wanted".
  std::vector<std::uint8_t> refined_;
  // to_mesh's lattice point -> vertex map, all kInvalid while not borrowed. One call at a time borrows it
  // (busy); a concurrent call uses a map of its own. Copies and moves start without one.
  struct VertexMap {
    std::vector<Index> map;
    std::atomic<bool> busy{false};
    VertexMap() = default;
    VertexMap(const VertexMap&) {}
    VertexMap& operator=(const VertexMap&) { return *this; }
    VertexMap(VertexMap&&) noexcept {}
    VertexMap& operator=(VertexMap&&) noexcept { return *this; }
  };
  mutable VertexMap vertex_map_;
  // Diamonds the last extract_fast evaluated (a superset of the refined ones); room for every point.
  std::vector<Index> touched_;
  std::size_t num_touched_ = 0;
  bool touched_valid_ = false;  // true while nothing but extract_fast changed refined_
  std::size_t num_faces_ = 0;
  std::size_t num_refined_ = 0;
  std::vector<Index> stack_;

  // The boundary of the refined set, kept up to date by refine/coarsen_one so that update() touches only
  // it: exposed diamonds (unrefined, with a refined parent or a tile centre: exactly the hypotenuse
  // midpoints of current triangles) and maximal diamonds (refined, no refined child). extract_fast leaves
  // them stale (sets_valid_ false, and then touched_valid_ is true, while slot_ still matches the stale
  // sets): the next move rebuilds them (for_each_boundary), and the const candidate listings enumerate
  // the boundary without storing it. The two sets are disjoint (one holds unrefined diamonds, the other
  // refined ones), so one slot per lattice point serves both: slot_[p] is p's index in exposed_ if p is
  // unrefined, in maximal_ if p is refined, kInvalid if p is in neither.
  //
  // Per boundary diamond, for update_view: when its last evaluation expires. The status it recorded cannot
  // change while the accumulated camera translation stays below `moved` and the accumulated rotation below
  // `turned` (both -1: never evaluated, or the record does not hold for the diamond's current set).
  struct Expiry {
    float moved = -1.0f, turned = -1.0f;
  };
  // A boundary diamond and a copy of its bound (the centre's x and y follow from the point), so that
  // update_view evaluates a stale diamond from the set's own arrays instead of random reads of the
  // hierarchy. 16 bytes: four to a cache line.
  struct Entry {
    Index point = kInvalid;
    float z = 0.0f, radius = 0.0f, error = 0.0f;
  };
  struct BoundarySet {
    std::vector<Expiry> expiry;  // scanned sequentially by update_view every frame (8 bytes per diamond)
    std::vector<Entry> entry;    // parallel: read for stale diamonds, moved between the sets
    std::size_t size() const noexcept { return entry.size(); }
    void clear() noexcept {
      expiry.clear();
      entry.clear();
    }
  };
  BoundarySet exposed_, maximal_;
  std::vector<Index> slot_;
  // During update_view: where on_refined / on_coarsened report diamonds newly added to the sets, and
  // whether a diamond moving from one set to the other keeps its record (update_view refines only diamonds
  // it found wanted and coarsens only ones it found unwanted, so their records stay true in the other set).
  std::vector<Index>* new_exposed_ = nullptr;
  std::vector<Index>* new_maximal_ = nullptr;
  bool carry_records_ = false;
  bool sets_valid_ = false;

  bool view_valid_ = false;
  ViewQuery last_view_{};
  // Accumulated camera translation and rotation (radians) since the last full re-evaluation, and the last
  // frame's increments (used to split each diamond's slack between the two).
  double moved_ = 0.0, turned_ = 0.0;
  float step_moved_ = 0.0f, step_turned_ = 0.0f;
  struct ViewContext;
  Entry entry_of(Index p) const noexcept { return {p, grid_->height_at(p), grid_->radius(p), grid_->error(p)}; }
  void set_add(BoundarySet& s, const Entry& e, Expiry x);
  // Room in the boundary sets (and the list of diamonds newly added to one, during update_view) for the
  // diamonds a move adds, so that on_refined and on_coarsened, once the refined flags have changed, allocate
  // nothing: the only step that can throw comes before the move. on_refined adds a diamond to the maximal
  // set and up to four children to the exposed set (and to new_exposed_); on_coarsened one diamond to the
  // exposed set and up to two parents to the maximal set. The tests are inline and branch once; the growth
  // is out of line.
  template <class T> static std::size_t spare(const std::vector<T>& v) noexcept { return v.capacity() - v.size(); }
  static std::size_t spare(const std::vector<Index>* v) noexcept {
    return v ? v->capacity() - v->size() : std::size_t(-1);
  }
  static bool lacks_room(const BoundarySet& s, std::size_t extra) noexcept {
    // | on ints, not ||: both tests are cheap and the branch is rarely taken (int keeps clang's
    // -Wbitwise-instead-of-logical quiet).
    return (int{spare(s.entry) < extra} | int{spare(s.expiry) < extra}) != 0;
  }
  void make_room_to_refine() {
    if ((int{lacks_room(exposed_, 4)} | int{lacks_room(maximal_, 1)} | int{spare(new_exposed_) < 4}) != 0) [[unlikely]]
      make_room(4, 1, new_exposed_, 4);
  }
  void make_room_to_coarsen() {
    if ((int{lacks_room(exposed_, 1)} | int{lacks_room(maximal_, 2)} | int{spare(new_maximal_) < 2}) != 0) [[unlikely]]
      make_room(1, 2, new_maximal_, 2);
  }
  void make_room(std::size_t exposed, std::size_t maximal, std::vector<Index>* added, std::size_t listed);
  // Room for `extra` more diamonds in s.
  static void make_room(BoundarySet& s, std::size_t extra);
  // Forced inline (defined in grid48.cpp, used only there), as family() is: grid48.cpp reaches GCC's
  // inline-unit-growth limit, and which hot call it then leaves out of line shifts with any change.
  [[gnu::always_inline]] inline void set_remove(BoundarySet& s, Index p);
  void rebuild_sets();
  // The boundary computed from refined_ alone, read-only: exposed(p) and maximal(p) for each diamond of
  // the two sets, in no particular order. O(touched) from the touched list when touched_valid_ and the
  // list is short, else O(lattice points) (a scan of the lattice).
  template <class Exposed, class Maximal> void for_each_boundary(Exposed&& exposed, Maximal&& maximal) const;
  // to_mesh with a lattice point -> vertex map (all kInvalid; restored before it returns).
  TriMesh to_mesh_with(Index* remap, std::vector<Index>* lattice_ids) const;
  void on_refined(Index t);
  void on_coarsened(Index t);
  [[gnu::always_inline]] inline void coarsen_unchecked(Index p);
  QueryStats update_view_unguarded(const ViewQuery& v);
  std::size_t scan_stale(BoundarySet& s, const ViewContext& cx, bool pick, std::vector<Index>& out);
  void prefetch_refine(Index p) const;
  void prefetch_entry(const BoundarySet& s, Index p) const;
  void prefetch_coarsen(Index p) const;
  Index refine_target_ = kInvalid;  // the diamond the running refine() was asked for
  std::vector<Index> view_work_, view_new_, view_stale_;  // update_view scratch
};

// ---- inline implementation -------------------------------------------------------------------------

inline bool Grid48::is_node(Index p) const noexcept {
  VARMESH_ASSERT(p < num_points());
  const std::size_t y = py(p), x = p - y * lw_;
  return (x % tile_) != 0 || (y % tile_) != 0;
}

inline int Grid48::level(Index p) const noexcept {
  VARMESH_ASSERT(p < num_points() && is_node(p));
  const std::size_t y = py(p), x = p - y * lw_;
  const int lx = detail::grid48_ctz(x), ly = detail::grid48_ctz(y);
  const int ld = lx < ly ? lx : ly;  // log2 of the diamond size d
  const bool square = lx == ly;      // both x/d and y/d odd
  return 2 * (log2_tile_ - ld) + (square ? 0 : 1) - 2;
}

template <class Fn>
void Grid48::for_each_parent(Index p, Fn&& fn) const {
  VARMESH_ASSERT(p < num_points() && is_node(p));
  const std::ptrdiff_t y = static_cast<std::ptrdiff_t>(py(p)), x = static_cast<std::ptrdiff_t>(p) - y * static_cast<std::ptrdiff_t>(lw_);
  const int lx = detail::grid48_ctz(static_cast<std::size_t>(x)), ly = detail::grid48_ctz(static_cast<std::size_t>(y));
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  if (lx == ly) {
    // Square diamond: parents are the two corners off its diagonal (edge diamonds of size 2d); tile
    // centres hang from the source.
    const std::ptrdiff_t d = std::ptrdiff_t(1) << lx;
    if (2 * d == static_cast<std::ptrdiff_t>(tile_)) return;
    // The diagonal runs through the corner whose coordinates are odd multiples of 2d.
    const std::ptrdiff_t cx = ((x - d) / (2 * d)) % 2 != 0 ? x - d : x + d;
    const std::ptrdiff_t cy = ((y - d) / (2 * d)) % 2 != 0 ? y - d : y + d;
    const std::ptrdiff_t ox = 2 * x - cx, oy = 2 * y - cy;
    fn(static_cast<Index>(cy * w + ox));
    fn(static_cast<Index>(oy * w + cx));
  } else {
    const std::ptrdiff_t d = std::ptrdiff_t(1) << (lx < ly ? lx : ly);
    if (lx < ly) {  // x/d odd: horizontal edge, apexes above and below
      if (y - d >= 0) fn(static_cast<Index>((y - d) * w + x));
      if (y + d < h) fn(static_cast<Index>((y + d) * w + x));
    } else {  // vertical edge, apexes left and right
      if (x - d >= 0) fn(static_cast<Index>(y * w + x - d));
      if (x + d < w) fn(static_cast<Index>(y * w + x + d));
    }
  }
}

template <class Fn>
void Grid48::for_each_child(Index p, Fn&& fn) const {
  VARMESH_ASSERT(p < num_points() && is_node(p));
  const std::ptrdiff_t y = static_cast<std::ptrdiff_t>(py(p)), x = static_cast<std::ptrdiff_t>(p) - y * static_cast<std::ptrdiff_t>(lw_);
  const int lx = detail::grid48_ctz(static_cast<std::size_t>(x)), ly = detail::grid48_ctz(static_cast<std::size_t>(y));
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  if (lx == ly) {  // square diamond of size d: children are the midpoints of the square's sides
    const std::ptrdiff_t d = std::ptrdiff_t(1) << lx;
    fn(static_cast<Index>(y * w + x - d));
    fn(static_cast<Index>(y * w + x + d));
    fn(static_cast<Index>((y - d) * w + x));
    fn(static_cast<Index>((y + d) * w + x));
  } else {  // edge diamond of size d: children are square diamonds of size d/2 around it
    const int ld = lx < ly ? lx : ly;
    if (ld == 0) return;
    const std::ptrdiff_t e = std::ptrdiff_t(1) << (ld - 1);
    for (int sy = -1; sy <= 1; sy += 2)
      for (int sx = -1; sx <= 1; sx += 2) {
        const std::ptrdiff_t cx = x + sx * e, cy = y + sy * e;
        if (cx >= 0 && cx < w && cy >= 0 && cy < h) fn(static_cast<Index>(cy * w + cx));
      }
  }
}

// Forced inline: refine() and the boundary updates call it once per move (see Grid48Front::set_remove).
[[gnu::always_inline]] inline Grid48::Family Grid48::family(Index p) const noexcept {
  VARMESH_ASSERT(p < num_points() && is_node(p));
  Family f;
  const std::uint32_t w = static_cast<std::uint32_t>(lw_), h = static_cast<std::uint32_t>(lh_);
  const std::uint32_t y = py(p), x = p - y * w;
  const int lx = detail::grid48_ctz(x), ly = detail::grid48_ctz(y);
  // The child at offset (dx, dy) and its other parent at twice that offset. Coordinates are unsigned: a
  // negative one wraps to a value >= w (or h), so one comparison tests both ends.
  std::uint32_t dx[4], dy[4];
  int n = 0;
  if (lx == ly) {  // square diamond of size d (see for_each_parent and for_each_child)
    const std::uint32_t d = 1u << lx;
    if (2 * d != tile_) {
      const std::uint32_t cx = (((x - d) >> (lx + 1)) & 1u) != 0 ? x - d : x + d;
      const std::uint32_t cy = (((y - d) >> (lx + 1)) & 1u) != 0 ? y - d : y + d;
      f.parent[0] = cy * w + (2 * x - cx);
      f.parent[1] = (2 * y - cy) * w + cx;
      f.num_parents = 2;
    }
    dx[0] = 0u - d, dy[0] = 0u;
    dx[1] = d, dy[1] = 0u;
    dx[2] = 0u, dy[2] = 0u - d;
    dx[3] = 0u, dy[3] = d;
    n = 4;
  } else {
    const int ld = lx < ly ? lx : ly;
    const std::uint32_t d = 1u << ld;
    if (lx < ly) {
      if (y >= d) f.parent[f.num_parents++] = p - d * w;
      if (y + d < h) f.parent[f.num_parents++] = p + d * w;
    } else {
      if (x >= d) f.parent[f.num_parents++] = p - d;
      if (x + d < w) f.parent[f.num_parents++] = p + d;
    }
    if (ld > 0) {
      const std::uint32_t e = d >> 1;
      dx[0] = 0u - e, dy[0] = 0u - e;
      dx[1] = e, dy[1] = 0u - e;
      dx[2] = 0u - e, dy[2] = e;
      dx[3] = e, dy[3] = e;
      n = 4;
    }
  }
  for (int k = 0; k < n; ++k) {
    const std::uint32_t cx = x + dx[k], cy = y + dy[k];
    if (cx >= w || cy >= h) continue;
    const std::uint32_t ox = cx + dx[k], oy = cy + dy[k];
    f.child[f.num_children] = cy * w + cx;
    f.co_parent[f.num_children++] = ox < w && oy < h ? oy * w + ox : kInvalid;
  }
  return f;
}

inline bool Grid48::has_refined_child(Index p, const std::uint8_t* refined) const noexcept {
  VARMESH_ASSERT(p < num_points() && is_node(p));
  const std::uint32_t w = static_cast<std::uint32_t>(lw_), h = static_cast<std::uint32_t>(lh_);
  const std::uint32_t y = py(p), x = p - y * w;
  const int lx = detail::grid48_ctz(x), ly = detail::grid48_ctz(y);
  if (lx == ly) {  // square: the four side midpoints, always in the lattice
    const std::uint32_t d = 1u << lx;
    return (refined[p - d] | refined[p + d] | refined[p - d * w] | refined[p + d * w]) != 0;
  }
  const int ld = lx < ly ? lx : ly;
  if (ld == 0) return false;
  const std::uint32_t e = 1u << (ld - 1);
  bool any = false;
  if (y >= e) {
    if (x >= e) any |= refined[p - e * w - e] != 0;
    if (x + e < w) any |= refined[p - e * w + e] != 0;
  }
  if (y + e < h) {
    if (x >= e) any |= refined[p + e * w - e] != 0;
    if (x + e < w) any |= refined[p + e * w + e] != 0;
  }
  return any;
}

inline int Grid48::num_triangles(Index p) const noexcept {
  VARMESH_ASSERT(p < num_points() && is_node(p));
  int n = 0;
  const std::size_t y = py(p), x = p - y * lw_;
  const int lx = detail::grid48_ctz(x), ly = detail::grid48_ctz(y);
  if (lx == ly) return 2;
  const std::size_t d = std::size_t(1) << (lx < ly ? lx : ly);
  if (lx < ly) {
    n += y >= d;
    n += y + d < lh_;
  } else {
    n += x >= d;
    n += x + d < lw_;
  }
  return n;
}

inline bool Grid48Front::is_coarsenable(Index p) const noexcept {
  VARMESH_ASSERT(p < refined_.size());
  if (!refined_[p]) return false;
  bool ok = true;
  grid_->for_each_child(p, [&](Index c) { ok = ok && !refined_[c]; });
  return ok;
}

template <class Sink>
void Grid48Front::refine(Index p, Sink&& sink) {
  check_diamond(p, "refine");
  if (refined_[p]) return;
  if (!sets_valid_) rebuild_sets();
  refine_target_ = p;
  stack_.clear();
  stack_.push_back(p);
  while (!stack_.empty()) {
    const Index t = stack_.back();
    if (refined_[t]) {
      stack_.pop_back();
      continue;
    }
    bool pushed = false;
    const Grid48::Family f = grid_->family(t);
    for (int k = 0; k < f.num_parents; ++k) {
      if (!refined_[f.parent[k]]) {
        stack_.push_back(f.parent[k]);
        pushed = true;
      }
    }
    if (!pushed) {
      stack_.pop_back();
      on_refined(t);  // marks t refined (if it throws, nothing has changed)
      ++num_refined_;
      num_faces_ += static_cast<std::size_t>(grid_->num_triangles(t));
      sink(t);
    }
  }
}

template <class Fn>
void Grid48Front::for_each_root(Fn&& fn) const {
  // Each tile: two triangles sharing the tile diagonal, which runs through the tile corner whose
  // coordinates are odd multiples of S (the 4-8 pattern of alternating diagonals).
  const std::size_t s = grid_->tile_size(), w = grid_->lattice_width();
  for (std::size_t ty = 0; ty < grid_->tiles_y(); ++ty)
    for (std::size_t tx = 0; tx < grid_->tiles_x(); ++tx) {
      const std::size_t x0 = tx * s, y0 = ty * s, x1 = x0 + s, y1 = y0 + s;
      const Index a = static_cast<Index>(y0 * w + x0), b = static_cast<Index>(y0 * w + x1);
      const Index c = static_cast<Index>(y1 * w + x1), d = static_cast<Index>(y1 * w + x0);
      if ((tx + ty) % 2 == 0) {  // diagonal a-c
        fn(b, c, a);
        fn(d, a, c);
      } else {  // diagonal b-d
        fn(a, b, d);
        fn(c, d, b);
      }
    }
}

template <class Fn>
void Grid48Front::walk(std::uint32_t ax, std::uint32_t ay, std::uint32_t bx, std::uint32_t by, std::uint32_t cx,
                       std::uint32_t cy, Fn& fn) const {
  // Triangle (a, b, c), counter-clockwise, hypotenuse b-c. Its diamond is the hypotenuse midpoint when that
  // is a lattice point. Coordinates travel with the recursion: no division per triangle.
  const std::uint32_t lw = static_cast<std::uint32_t>(grid_->lattice_width());
  const std::uint32_t sx = bx + cx, sy = by + cy;
  if (((sx | sy) & 1u) == 0) {
    const std::uint32_t mx = sx >> 1, my = sy >> 1;
    if (refined_[my * lw + mx]) {
      walk(mx, my, ax, ay, bx, by, fn);
      walk(mx, my, cx, cy, ax, ay, fn);
      return;
    }
  }
  fn(ay * lw + ax, by * lw + bx, cy * lw + cx);
}

template <class Fn>
void Grid48Front::for_each_triangle(Fn&& fn) const {
  const std::uint32_t lw = static_cast<std::uint32_t>(grid_->lattice_width());
  for_each_root([&](Index a, Index b, Index c) {
    walk(a % lw, a / lw, b % lw, b / lw, c % lw, c / lw, fn);
  });
}

template <class Exposed, class Maximal>
void Grid48Front::for_each_boundary(Exposed&& exposed, Maximal&& maximal) const {
  const Grid48& g = *grid_;
  // The touched list costs a few cache misses per diamond, a scan of the lattice a few nanoseconds per
  // point (sequential): the list wins below about an eighth of the lattice (measured on 1025^2 and 4097^2
  // lattices).
  if (!touched_valid_ || num_touched_ >= g.num_points() / 8) {
    for (Index p = 0; p < g.num_points(); ++p) {
      if (!g.is_node(p)) continue;
      if (refined_[p]) {
        if (!g.has_refined_child(p, refined_.data())) maximal(p);
      } else {
        bool any = g.level(p) == 0;
        g.for_each_parent(p, [&](Index q) { any = any || refined_[q] != 0; });
        if (any) exposed(p);
      }
    }
    return;
  }
  // Every refined diamond is in the touched list. The unrefined tile centres are exposed; so is every
  // unrefined child of a refined diamond, listed once: from its smaller refined parent (the other parent
  // is the co-parent, Grid48::family).
  const std::size_t s = g.tile_size(), w = g.lattice_width();
  for (std::size_t ty = 0; ty < g.tiles_y(); ++ty)
    for (std::size_t tx = 0; tx < g.tiles_x(); ++tx) {
      const Index c = static_cast<Index>((ty * s + s / 2) * w + tx * s + s / 2);
      if (!refined_[c]) exposed(c);
    }
  for (std::size_t i = 0; i < num_touched_; ++i) {
    const Index p = touched_[i];
    if (!refined_[p]) continue;
    const Grid48::Family f = g.family(p);
    bool leaf = true;
    for (int k = 0; k < f.num_children; ++k) {
      const Index c = f.child[k];
      if (refined_[c]) {
        leaf = false;
      } else {
        const Index o = f.co_parent[k];
        if (o == kInvalid || !refined_[o] || p < o) exposed(c);
      }
    }
    if (leaf) maximal(p);
  }
}

template <class Fn>
void Grid48Front::for_each_refine_candidate(Fn&& fn) const {
  if (sets_valid_) {
    for (const Entry& e : exposed_.entry) fn(e.point);
  } else {
    for_each_boundary([&](Index p) { fn(p); }, [](Index) {});
  }
}

template <class Fn>
void Grid48Front::for_each_coarsen_candidate(Fn&& fn) const {
  if (sets_valid_) {
    for (const Entry& e : maximal_.entry) fn(e.point);
  } else {
    for_each_boundary([](Index) {}, [&](Index p) { fn(p); });
  }
}

}  // namespace varmesh
