#pragma once
/// Structure metrics of a Multi-Triangulation: the three criteria of Puppo 1998 ("Variable resolution
/// triangulations", Comput. Geom. 11) as restated by Velho-Gomes 2000, section 3.3 (expressive power,
/// depth, growth rate), plus sizes. Used to compare hierarchies built by different front-ends.
///
/// Definitions used throughout (all on the node DAG of an Mt, see mt.hpp):
/// - level(source) = 0 and level(n) = 1 + max level(parents of n): the longest path from the source,
///   counted in arcs. Nodes of one level are pairwise independent (no one is an ancestor of another).
/// - depth = max level = the number of non-source nodes on the longest source -> drain path (the source
///   and the implicit drain are not counted; the paper's lattice path then has depth + 2 nodes).
/// - a front = an order ideal of the DAG (a set of nodes containing the source and closed under parents);
///   fronts and conforming meshes extractable from the Mt are in one-to-one correspondence (non-redundancy).
///
/// An empty Mt (no node, not even the source: default-constructed or moved-from; MtBuilder never builds
/// one) has no front at all. compute_metrics() reports it as all zeros and chain_growth() as not computed;
/// expressive_power() and count_level_fronts(), whose answers count fronts, throw InvalidInput for it.
#include <compare>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "multitri/mt.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// Arbitrary-precision unsigned integer for front counts (they exceed 64 bits quickly: eq. 4 of
/// Velho-Gomes gives ~1.8e19 for six levels). Little-endian 64-bit limbs, no leading zero limb.
class BigUint {
 public:
  BigUint() = default;
  BigUint(std::uint64_t value);  // NOLINT(google-explicit-constructor): counts read naturally as numbers
  /// 2^k.
  static BigUint pow2(std::size_t k);

  BigUint& operator+=(const BigUint& other);
  /// Throws InvalidInput when value > *this (the result would be negative), leaving *this unchanged.
  BigUint& operator-=(std::uint64_t value);
  BigUint& operator*=(const BigUint& other);
  friend BigUint operator+(BigUint a, const BigUint& b) { return a += b; }
  friend BigUint operator*(BigUint a, const BigUint& b) { return a *= b; }
  friend bool operator==(const BigUint& a, const BigUint& b) noexcept { return a.limbs_ == b.limbs_; }
  friend std::strong_ordering operator<=>(const BigUint& a, const BigUint& b) noexcept;

  bool is_zero() const noexcept { return limbs_.empty(); }
  /// Number of significant bits (0 for zero).
  std::size_t bit_width() const noexcept;
  bool fits_u64() const noexcept { return limbs_.size() <= 1; }
  /// The low 64 bits.
  std::uint64_t low_u64() const noexcept { return limbs_.empty() ? 0 : limbs_[0]; }
  /// log2 of the value (-infinity for zero); relative error ~1e-16.
  double log2() const noexcept;
  /// Decimal digits.
  std::string to_string() const;
  std::span<const std::uint64_t> limbs() const noexcept { return limbs_; }
  /// From little-endian limbs (leading zeros allowed).
  static BigUint from_limbs(std::span<const std::uint64_t> limbs);

 private:
  void trim() noexcept;
  std::vector<std::uint64_t> limbs_;
};

/// Sizes and shape of an Mt.
struct MtMetrics {
  std::size_t nodes = 0;           ///< modifications, the source excluded
  std::size_t faces = 0;           ///< all faces of the Mt (its arcs, counted once each)
  std::size_t coarsest_faces = 0;  ///< |K0|: the source's image
  std::size_t finest_faces = 0;    ///< faces of the drain mesh (no node removes them)
  std::size_t depth = 0;           ///< max level; see the header comment (0 for an Mt with no node)
  /// nodes_per_level[j] = number of nodes of level j; nodes_per_level[0] = 1 (the source); size depth + 1.
  std::vector<std::size_t> nodes_per_level;
  /// Growth rate (Velho-Gomes 3.3: the size of the longest sequence of modifications over the size of the
  /// mesh its cumulative application gives), read here for the sequence that applies every modification
  /// (see ChainGrowth for the chain reading that eq. 5 fits). The longest sequence is one that applies every
  /// modification (a linear extension of the DAG, the compatible sequence K0..Kn of Velho-Gomes 3.1); its
  /// size is the number of faces it creates, source included (= faces); its cumulative application is the
  /// finest mesh. So growth_rate = faces / finest_faces. It is >= 1, and it is bounded by a constant (the
  /// Mt is linear in the size of its finest mesh, "linear growth") when every node creates more faces than
  /// it removes by a fixed ratio: below 2 for 2 -> 4 splits (the paper's remark under eq. 5).
  double growth_rate = 0.0;
  std::size_t memory_bytes = 0;  ///< Mt::memory_bytes()
  double bytes_per_face = 0.0;   ///< memory_bytes / finest_faces
};

/// Level of every node (see the header comment), indexed by NodeId. O(nodes + arcs).
std::vector<Index> compute_node_levels(const Mt& mt);

/// Sizes, depth, per-level counts and growth rate. O(nodes + faces + arcs).
MtMetrics compute_metrics(const Mt& mt);

/// Growth of chains: one constructed reading of Velho-Gomes 3.3's growth rate, made to test eq. 5 of
/// section 7.2. A chain is a sequence of modifications W_1..W_k in which each W_i consumes a face that
/// W_(i-1) created (a path of the node DAG that avoids the source); its cumulative application to the base
/// mesh K0 applies the chain with everything it needs, the closure C = all ancestors of W_k (W_k included,
/// source excluded). Its growth is
///   (|K0| + sum over the chain of |image(W_i)|) / (|K0| + sum over C of (|image| - |pre-image|)).
/// In a layered 4-8 structure (every parent of a level-j node on level j - 1) whose splits past the first
/// level have two distinct parents, a chain of k splits has a closure of at least 2k - 1 nodes, so the
/// largest growth is that of one split, (|K0| + 4) / (|K0| + 2): eq. 5's (n + 2) / (n + 1) only with n
/// reinterpreted as |K0| / 2 two-face clusters (the paper writes |K0| = n, with which eq. 5 fails), and
/// reached by the shortest chain, not the longest sequence. README.md discusses what this does and does
/// not show. Without the layering the bound can fail (a chain whose nodes share ancestors).
struct ChainGrowth {
  bool computed = false;         ///< false for an empty Mt or one past max_nodes (nothing else is set)
  double max_growth = 0.0;       ///< over all chains; 0 when the Mt has only its source
  NodeId argmax_end = kInvalid;  ///< the last node of a chain reaching it
  std::size_t argmax_length = 0; ///< that chain's length k
  std::size_t argmax_closure = 0;///< and its closure's size
};

/// The largest chain growth, over chains ending at every node (for an end node the longest-image path into
/// it gives the largest numerator; the denominator depends on the end node only). O(sum of closure sizes)
/// time, which is O(nodes * depth^2) on 4-8 structures (~50 ms for 522k nodes): refused (computed = false)
/// above max_nodes non-source nodes.
ChainGrowth chain_growth(const Mt& mt, std::size_t max_nodes = std::size_t(1) << 22);

/// Result of a front count.
struct FrontCount {
  bool exact = false;  ///< value is the exact count
  BigUint value;       ///< the exact count when exact, else 0
  /// log2 of the count when exact; otherwise a lower bound (log2 of the distinct level fronts, see
  /// count_level_fronts).
  double log2 = 0.0;
  /// An upper bound on log2 of the count: the number of non-source nodes (every front is a subset of them).
  double log2_upper = 0.0;
  std::size_t peak_states = 0;  ///< largest number of DP states held (0 if refused before the DP ran)
  std::size_t peak_width = 0;   ///< largest number of nodes held in a DP state
};

struct FrontCountOptions {
  std::size_t max_nodes = 4096;        ///< refuse (inexact result) above this many non-source nodes
  std::size_t max_width = 64;          ///< refuse when the DP frontier exceeds this many nodes (<= 64)
  std::size_t max_states = std::size_t(1) << 20;  ///< refuse when the DP holds more states than this
  /// Refuse when one DP step would need more memory than this: about states * (24 * (nodes / 64 + 2) + 16)
  /// bytes.
  std::size_t max_memory_bytes = std::size_t(256) << 20;
};

/// Expressive power (Velho-Gomes 3.3, Puppo 1998): the number of distinct fronts of the Mt = the number of
/// order ideals of its node DAG that contain the source (the base mesh, one node applied, counts as one).
///
/// Exact by a frontier (transfer-matrix) dynamic programme: nodes are visited in a topological order chosen
/// greedily to keep few "live" nodes (visited nodes with an unvisited child); a state is the subset of live
/// nodes in the ideal, with the number of ways to reach it. Counting order ideals is #P-hard in general,
/// so the cost is exponential in the frontier width: O(nodes * states * limbs) time, O(states * limbs)
/// memory, states <= 2^width, limbs = nodes / 64 + 1, plus O(nodes * ready nodes) for the order. Past the
/// options' limits it returns exact = false with log2 bounds instead. For scale: a tetrahedron bisected 6
/// times (126 nodes, frontier 24, 28k states) takes ~0.05 s; 7 times (254 nodes, 2.9M states) ~30 s and
/// ~300 MB, past the default limits (refused after ~5 s).
/// Throws InvalidInput for an empty Mt (see the header comment); never throws for a valid Mt (std::bad_alloc
/// aside).
FrontCount expressive_power(const Mt& mt, const FrontCountOptions& options = {});

/// Fronts counted by eq. 4 of Velho-Gomes (section 7.2).
struct LevelFrontCount {
  /// sum over j = 1..depth of 2^(nodes of level j): the fronts that apply all nodes of levels < j, any
  /// subset of level j and nothing deeper, counted once per j. 0 for an Mt with no node (empty sum).
  BigUint total;
  /// The same fronts counted once: the front "all of levels < j" is both j-1's full subset and j's empty
  /// subset, so distinct = total - (depth - 1) for depth >= 1, and 1 (the base mesh) for depth 0. Always a
  /// lower bound of the expressive power.
  BigUint distinct;
  std::vector<std::size_t> nodes_per_level;  ///< as in MtMetrics
};

/// Eq. 4 count. Every such set is a front because a node's parents all lie on lower levels, so the nodes of
/// level j are pairwise independent given levels < j; the function re-checks this (throws InvalidInput
/// naming the node if a parent is not on a lower level, which a valid Mt never triggers; and for an empty
/// Mt). O(nodes + arcs + digits of the result).
LevelFrontCount count_level_fronts(const Mt& mt);

}  // namespace varmesh
