#pragma once
/// The Multi-Triangulation (Puppo 1998; De Floriani, Magillo, Puppo 1998; Velho-Gomes 2000, section 3):
/// an immutable DAG whose nodes are modifications of a triangle mesh and whose arcs are faces.
///
/// - Node 0 is the source: its image is the base mesh K0 and its pre-image is empty. The drain is implicit:
///   a face no node removes (destroyer() == kInvalid) belongs to the drain.
/// - Every other node removes its pre-image (faces created by earlier nodes) and creates its image. Kinds:
///   split (2 faces -> 4, or 1 -> 2 on a border), swap (2 -> 2), generic (k -> m).
/// - Nodes are numbered so that every parent precedes its children; faces are numbered by their creator,
///   so the image of node n is the face range [image_begin(n), image_end(n)).
///
/// Invariants: every face is created by exactly one node and removed by at most one; the DAG is acyclic
/// (parents precede children); no two faces have the same three vertices (non-redundancy); every node's
/// image has the same oriented boundary as its pre-image, except that an edge on the border of the whole
/// structure may come back subdivided (a path of edges between its ends), and no interior edge of the
/// pre-image survives in the image (minimally compatible modification, section 3.1). Consequently every
/// front (order ideal of nodes) is a conforming mesh when the base mesh is. MtBuilder::build checks all of
/// them (the geometric ones unless Options::check_geometry is off); validate() re-checks the structure
/// (counts, ranges, creators, destroyers, the order of parents and children), not the geometric ones.
///
/// Storage (about 45 bytes per finest face on a semi-regular 4-8 bunny; BENCHMARKS.md): per face its
/// corners (three 21-bit indices in 8 bytes up to 2^21 vertices, 12 bytes beyond) and its destroyer; per
/// node its kind, image start, sorted pre-image and a 16-byte packed bound. The creator of a face, the
/// parents and the children of a node are derived from those on demand (creator: a sampled hint and a
/// short scan; parents: the creators of the sorted pre-image, whose faces are grouped by creator; children:
/// the destroyers of the image), each in O(its size).
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <span>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "multitri/bounds.hpp"
#include "multitri/detail/assert.hpp"
#include "multitri/types.hpp"

namespace varmesh {

namespace detail {
/// cos of the packed cone half-angles (code * 90/254 degrees); entry 255 is -1 (any direction). Built at
/// compile time, so Mt::bound() is usable from any static initialiser (no start-up order to respect). Each
/// entry is a Taylor series in double rounded to float: cos(x) for x <= 45 degrees, sin(90 degrees - x)
/// above (no cancellation near 90 degrees, where cos is small); 20 terms are far below double rounding.
struct ConeCosTable {
  float v[256];
  constexpr ConeCosTable() noexcept : v{} {
    const double unit = 1.5707963267948966 / 254.0;
    for (int i = 0; i < 255; ++i) {
      const bool use_sin = i > 127;
      const double x = (use_sin ? 254 - i : i) * unit, x2 = x * x;
      double term = use_sin ? x : 1.0, sum = term;
      for (int k = 1; k <= 20; ++k) {
        term *= use_sin ? -x2 / double((2 * k) * (2 * k + 1)) : -x2 / double((2 * k - 1) * (2 * k));
        sum += term;
      }
      v[i] = static_cast<float>(sum);
    }
    v[255] = -1.0f;
  }
};
}  // namespace detail

enum class NodeKind : std::uint8_t { kSource = 0, kSplit = 1, kSwap = 2, kGeneric = 3 };

const char* to_string(NodeKind kind) noexcept;

class Mt {
 public:
  class ParentRange;
  class ChildRange;

  Mt() = default;

  std::size_t num_nodes() const noexcept { return kind_.size(); }  ///< including the source
  std::size_t num_faces() const noexcept { return destroyer_.size(); }
  std::size_t num_vertices() const noexcept { return positions_.size(); }
  static constexpr NodeId source() noexcept { return 0; }

  // The accessors below that take a node, face or vertex id are unchecked, as vector::operator[] is:
  // n < num_nodes(), f < num_faces(), v < num_vertices() (VARMESH_ASSERT in debug and sanitizer builds).
  // A default-constructed or moved-from Mt has no node at all (not even the source).

  NodeKind kind(NodeId n) const noexcept {
    VARMESH_ASSERT(n < kind_.size());
    return kind_[n];
  }
  /// The faces n removes, in increasing order.
  std::span<const FaceId> pre_image(NodeId n) const noexcept {
    VARMESH_ASSERT(n < kind_.size());
    return {pre_items_.data() + pre_offsets_[n], pre_offsets_[n + 1] - pre_offsets_[n]};
  }
  FaceId image_begin(NodeId n) const noexcept {
    VARMESH_ASSERT(n < kind_.size());
    return image_begin_[n];
  }
  FaceId image_end(NodeId n) const noexcept {
    VARMESH_ASSERT(n < kind_.size());
    return image_begin_[n + 1];
  }
  std::size_t image_size(NodeId n) const noexcept {
    VARMESH_ASSERT(n < kind_.size());
    return image_begin_[n + 1] - image_begin_[n];
  }
  /// Distinct nodes that create a face of n's pre-image, in increasing order (derived, not stored). The
  /// range refers to this Mt, so it is not available on a temporary one.
  ParentRange parents(NodeId n) const& noexcept;
  ParentRange parents(NodeId n) const&& = delete;
  /// Distinct nodes that remove a face of n's image, in the order of their first face in n's image
  /// (derived, not stored; refers to this Mt as parents() does).
  ChildRange children(NodeId n) const& noexcept;
  ChildRange children(NodeId n) const&& = delete;

  std::array<VertexId, 3> face(FaceId f) const noexcept {
    VARMESH_ASSERT(f < destroyer_.size());
    if (!wide_corners_.empty()) return {wide_corners_[3 * f], wide_corners_[3 * f + 1], wide_corners_[3 * f + 2]};
    const std::uint64_t w = packed_corners_[f];
    return {static_cast<VertexId>(w & kCornerMask), static_cast<VertexId>((w >> kCornerBits) & kCornerMask),
            static_cast<VertexId>(w >> (2 * kCornerBits))};
  }
  /// The node whose image holds f: a short forward scan of image_begin from a sampled hint (every
  /// 2^kHintShift faces), since images are non-empty and numbered consecutively.
  NodeId creator(FaceId f) const noexcept {
    VARMESH_ASSERT(f < destroyer_.size());
    NodeId n = creator_hint_[f >> kHintShift];
    while (image_begin_[n + 1] <= f) ++n;
    return n;
  }
  /// kInvalid: the drain.
  NodeId destroyer(FaceId f) const noexcept {
    VARMESH_ASSERT(f < destroyer_.size());
    return destroyer_[f];
  }

  const glm::vec3& position(VertexId v) const noexcept {
    VARMESH_ASSERT(v < positions_.size());
    return positions_[v];
  }
  const std::vector<glm::vec3>& positions() const noexcept { return positions_; }
  /// The node's bound, decoded from its 16-byte packed form (see PackedBound). Conservative: the decoded
  /// sphere and cone contain the exact ones, the error is exact; decoded bounds are nested (a child's
  /// sphere inside its parent's, its cone inside its parent's) when the builder saturates.
  ElementBound bound(NodeId n) const noexcept {
    VARMESH_ASSERT(n < bounds_.size());
    const PackedBound& p = bounds_[n];
    ElementBound b;
    b.center = frame_.center(p.c);
    b.radius = frame_.radius(p.r);
    b.error = p.error;
    if ((p.cone >> 24) != kFullConeCode) {
      b.cone.axis = decode_octahedral(p.cone);
      b.cone.cos_half_angle = cone_cos(p.cone >> 24);
    }
    return b;
  }

  /// Re-checks the structural invariants (see above: not non-redundancy nor the boundary rules, which
  /// MtBuilder::build checks); throws InvalidInput naming the node or face. O(size log size).
  void validate() const;
  /// Bytes held by this structure (its arrays and the object itself), and the same split by array.
  std::size_t memory_bytes() const noexcept;
  struct MemoryItem {
    const char* name;
    std::size_t bytes;
  };
  std::vector<MemoryItem> memory_breakdown() const;
  /// True when corners take 12 bytes per face (more than 2^21 vertices) instead of 8.
  bool wide_corners() const noexcept { return !wide_corners_.empty(); }

  // Packed-bound codec, public for tests.
  static constexpr int kCornerBits = 21;
  static constexpr std::uint64_t kCornerMask = (std::uint64_t{1} << kCornerBits) - 1;
  static constexpr unsigned kFullConeCode = 255;
  static glm::vec3 decode_octahedral(std::uint32_t code) noexcept {
    float x = float(code & 4095u) * (2.0f / 4095.0f) - 1.0f;
    float y = float((code >> 12) & 4095u) * (2.0f / 4095.0f) - 1.0f;
    const float z = 1.0f - std::abs(x) - std::abs(y);
    if (z < 0.0f) {
      const float ox = x;
      x = std::copysign(1.0f - std::abs(y), ox);
      y = std::copysign(1.0f - std::abs(ox), y);
    }
    const float len = std::sqrt(x * x + y * y + z * z);
    return {x / len, y / len, z / len};
  }
  /// Unchecked: angle_code <= 255.
  static constexpr float cone_cos(unsigned angle_code) noexcept {
    VARMESH_ASSERT(angle_code <= 255u);
    return kConeCos.v[angle_code];
  }

 private:
  friend class MtBuilder;
  static constexpr int kHintShift = 4;
  static constexpr detail::ConeCosTable kConeCos{};

  /// 16 bytes per node: centre quantized to 16 bits per axis on the vertices' box, radius as a 16-bit
  /// float (5-bit exponent, 11-bit mantissa) in units of the box diagonal, exact error, and the normal cone
  /// as a 12+12-bit octahedral axis with an 8-bit half-angle (units of 90/254 degrees; 255 = any direction).
  struct PackedBound {
    std::uint16_t c[3];
    std::uint16_t r;
    float error;
    std::uint32_t cone;
  };
  struct Frame {
    glm::vec3 lo{0.0f}, step{0.0f};
    float unit = 1.0f;  // radius unit: the box diagonal
    glm::vec3 center(const std::uint16_t* q) const noexcept {
      return lo + glm::vec3(float(q[0]), float(q[1]), float(q[2])) * step;
    }
    float radius(std::uint16_t code) const noexcept {
      // Exponents 2^-28 .. 2^3: the float's own bits, rebuilt by shifts.
      const std::uint32_t bits = ((std::uint32_t(code >> 11) + 99u) << 23) | (std::uint32_t(code & 2047u) << 12);
      return std::bit_cast<float>(bits) * unit;
    }
    std::uint16_t encode_radius(float need) const;
  };
  void pack_bounds(const std::vector<ElementBound>& bounds, bool nest);

  std::vector<glm::vec3> positions_;
  std::vector<std::uint64_t> packed_corners_;  // per face: 3 x 21 bits (when <= 2^21 vertices)
  std::vector<Index> wide_corners_;            // 3 per face otherwise
  std::vector<NodeId> destroyer_;              // per face
  std::vector<NodeId> creator_hint_;           // creator of face i << kHintShift
  std::vector<NodeKind> kind_;                 // per node
  std::vector<Index> pre_offsets_, pre_items_;
  std::vector<FaceId> image_begin_;            // num_nodes + 1
  std::vector<PackedBound> bounds_;
  Frame frame_;
};

namespace detail {
/// What Mt::ParentRange and Mt::ChildRange share: the iterator's member types (operator* returns a NodeId by
/// value, so the iterators are forward iterators for std::ranges and input iterators for the classic
/// traits), and front(), size() and the bool test written once over the range's begin(), end() and empty().
struct NodeIteratorTypes {
  using iterator_concept = std::forward_iterator_tag;
  using iterator_category = std::input_iterator_tag;
  using value_type = NodeId;
  using difference_type = std::ptrdiff_t;
  using reference = NodeId;
  using pointer = void;
};

template <class Range>
class NodeRangeOps {
 public:
  explicit operator bool() const noexcept { return !self().empty(); }
  /// The first node. Unchecked: !empty().
  NodeId front() const noexcept {
    VARMESH_ASSERT(!self().empty());
    return *self().begin();
  }
  /// Walks the range; its cost is given with Mt::ParentRange and Mt::ChildRange.
  std::size_t size() const noexcept {
    std::size_t n = 0;
    for (auto it = self().begin(), e = self().end(); it != e; ++it) ++n;
    return n;
  }

 private:
  const Range& self() const noexcept { return static_cast<const Range&>(*this); }
};
}  // namespace detail

/// Forward ranges over derived relations (std::ranges::forward_range; written out rather than derived from
/// std::ranges::view_interface, which clang 14 cannot instantiate with libstdc++ 12). Both have begin(),
/// end(), empty(), front() (the first node; unchecked: !empty()), size() (walks the range) and a bool test.
///
/// The parents of a node: empty() and front() are O(1); size() and a full walk are O(number of parents).
class Mt::ParentRange : public detail::NodeRangeOps<Mt::ParentRange> {
 public:
  class iterator : public detail::NodeIteratorTypes {
   public:
    iterator() = default;
    iterator(const Mt* mt, const FaceId* p, const FaceId* end) noexcept : mt_(mt), p_(p), end_(end) {
      if (p_ != end_) cur_ = mt_->creator(*p_);
    }
    NodeId operator*() const noexcept { return cur_; }
    iterator& operator++() noexcept {
      // The pre-image is sorted and faces are numbered by creator: one creator's faces are consecutive.
      const FaceId stop = mt_->image_end(cur_);
      while (++p_ != end_ && *p_ < stop) {}
      if (p_ != end_) cur_ = mt_->creator(*p_);
      return *this;
    }
    iterator operator++(int) noexcept { iterator t = *this; ++*this; return t; }
    bool operator==(const iterator& o) const noexcept { return p_ == o.p_; }

   private:
    const Mt* mt_ = nullptr;
    const FaceId* p_ = nullptr;
    const FaceId* end_ = nullptr;
    NodeId cur_ = kInvalid;
  };
  ParentRange(const Mt* mt, std::span<const FaceId> pre) noexcept : mt_(mt), pre_(pre) {}
  iterator begin() const noexcept { return {mt_, pre_.data(), pre_.data() + pre_.size()}; }
  iterator end() const noexcept { return {mt_, pre_.data() + pre_.size(), pre_.data() + pre_.size()}; }
  bool empty() const noexcept { return pre_.empty(); }

 private:
  const Mt* mt_;
  std::span<const FaceId> pre_;
};

/// The children of a node: empty() and front() are O(image size) (no child when no face of the image is
/// removed); size() and a full walk are O(image size + the children's pre-images).
class Mt::ChildRange : public detail::NodeRangeOps<Mt::ChildRange> {
 public:
  class iterator : public detail::NodeIteratorTypes {
   public:
    iterator() = default;
    iterator(const Mt* mt, FaceId f, FaceId b, FaceId e) noexcept : mt_(mt), f_(f), b_(b), e_(e) { settle(); }
    NodeId operator*() const noexcept { return mt_->destroyer(f_); }
    iterator& operator++() noexcept {
      ++f_;
      settle();
      return *this;
    }
    iterator operator++(int) noexcept { iterator t = *this; ++*this; return t; }
    bool operator==(const iterator& o) const noexcept { return f_ == o.f_; }

   private:
    // Stops at a face whose destroyer is listed here for the first time: no face of the destroyer's
    // (sorted) pre-image lies in [b_, f_).
    void settle() noexcept {
      for (; f_ != e_; ++f_) {
        const NodeId d = mt_->destroyer(f_);
        if (d == kInvalid) continue;
        bool first = true;
        for (FaceId g : mt_->pre_image(d)) {
          if (g >= f_) break;
          if (g >= b_) {
            first = false;
            break;
          }
        }
        if (first) return;
      }
    }
    const Mt* mt_ = nullptr;
    FaceId f_ = 0, b_ = 0, e_ = 0;
  };
  ChildRange(const Mt* mt, FaceId b, FaceId e) noexcept : mt_(mt), b_(b), e_(e) {}
  iterator begin() const noexcept { return {mt_, b_, b_, e_}; }
  iterator end() const noexcept { return {mt_, e_, b_, e_}; }
  bool empty() const noexcept { return begin() == end(); }

 private:
  const Mt* mt_;
  FaceId b_, e_;
};

inline Mt::ParentRange Mt::parents(NodeId n) const& noexcept { return {this, pre_image(n)}; }
inline Mt::ChildRange Mt::children(NodeId n) const& noexcept { return {this, image_begin(n), image_end(n)}; }

/// Builds an Mt from modifications given in any order, checks the definition and renumbers.
///
/// Faces and nodes get builder-local ids from add_face / add_node. build() checks (throwing InvalidInput
/// that names the offending builder node or face): base set and every node non-empty; kind arity; every
/// face created exactly once and removed at most once; no face removed by its own creator; no degenerate
/// face; non-redundancy (two faces with one vertex triple); minimal compatibility (same oriented boundary,
/// interior edges replaced); acyclicity. Then it numbers nodes parents-first and faces by creator, computes
/// bounds (sphere and normal cone of each node's pre-image and image, the caller's error) and, unless told
/// not to, saturates them so that bounds are nested (see bounds.hpp).
class MtBuilder {
 public:
  VertexId add_vertex(const glm::vec3& p);
  FaceId add_face(VertexId a, VertexId b, VertexId c);
  /// The source's image: the base mesh. Call once.
  void set_base(std::span<const FaceId> faces);
  /// `error`: approximation error of the pre-image w.r.t. the finest data (>= 0), in object units.
  NodeId add_node(NodeKind kind, std::span<const FaceId> removed, std::span<const FaceId> created, float error);

  std::size_t num_vertices() const noexcept { return positions_.size(); }
  std::size_t num_faces() const noexcept { return corners_.size() / 3; }

  struct Options {
    bool saturate = true;        ///< nest spheres, errors and cones (required for exact update == extract)
    bool check_geometry = true;  ///< minimal-compatibility check of every node
  };
  /// Consumes the builder. `node_new_to_old` / `face_new_to_old` (optional) receive the renumbering maps.
  Mt build(const Options& options, std::vector<NodeId>* node_new_to_old = nullptr,
           std::vector<FaceId>* face_new_to_old = nullptr) &&;
  Mt build() && { return std::move(*this).build(Options{}); }

 private:
  std::vector<glm::vec3> positions_;
  std::vector<Index> corners_;
  std::vector<FaceId> base_;
  bool has_base_ = false;
  std::vector<NodeKind> kinds_;
  std::vector<float> errors_;
  std::vector<Index> removed_offsets_{0}, removed_items_;
  std::vector<Index> created_offsets_{0}, created_items_;
};

}  // namespace varmesh
