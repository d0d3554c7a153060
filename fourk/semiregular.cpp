// Semi-regular 4-8 refinement of an arbitrary triangle mesh.
//
// Papers and results used:
// - L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000): 6.2 (semi-regular 4-8 meshes), 7.2 (each
//   level is an independent set of two-face clusters covering the mesh), 8.1 (interleaved edge splits).
// - J. Edmonds, "Paths, trees, and flowers" (1965): maximum matching in general graphs by shrinking odd
//   cycles (blossoms); here with union-find blossom bases, the usual O(V E alpha) formulation.
// - R. Karp, M. Sipser (1981): the degree-one rule (matching a vertex of degree one to its only neighbour
//   never loses), which leaves few vertices for the blossom searches.
// - Gallai-Edmonds decomposition and the Tutte-Berge formula: why every leftover face can be moved to the
//   border (semiregular.hpp) and how tests certify maximality.
#include "fourk/semiregular.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "multitri/huge_pages.hpp"

namespace varmesh {

namespace {

constexpr std::uint8_t kFree = 0, kEven = 1, kOdd = 2;

// One alternating-tree search at a time over a fixed graph and a shared `mate` array. Per-search state is
// reset lazily (only the vertices the search labelled), so a search costs what it explores.
class BlossomSearch {
 public:
  BlossomSearch(std::span<const Index> offsets, std::span<const Index> nbrs, std::vector<Index>& mate)
      : off_(offsets), nbr_(nbrs), mate_(mate), label_(mate.size(), kFree), pre_(mate.size(), kInvalid),
        base_(mate.size()), stamp_(mate.size(), 0) {
    for (Index v = 0; v < base_.size(); ++v) base_[v] = v;
  }

  // Grows the alternating tree of the unmatched vertex `root`; augments and returns true when it meets
  // another unmatched vertex. Labels stay until reset().
  bool search(Index root) {
    label(root, kEven);
    queue_.assign(1, root);
    for (std::size_t qi = 0; qi < queue_.size(); ++qi) {
      const Index v = queue_[qi];
      for (Index i = off_[v]; i < off_[v + 1]; ++i) {
        const Index w = nbr_[i];
        if (w == v) continue;
        if (label_[w] == kFree) {
          pre_[w] = v;
          const Index x = mate_[w];
          if (x == kInvalid) {
            touched_.push_back(w);
            augment(w);
            return true;
          }
          label(w, kOdd);
          label(x, kEven);
          queue_.push_back(x);
        } else if (label_[w] == kEven) {
          const Index bv = find(v), bw = find(w);
          if (bv == bw) continue;
          const Index l = lca(bv, bw);
          shrink(v, w, l);
          shrink(w, v, l);
        }
      }
    }
    return false;
  }

  // After a failed search: the first even (reachable by an even alternating path) vertex with the flag.
  Index find_even(std::span<const std::uint8_t> flag) const {
    for (Index v : touched_)
      if (label_[v] == kEven && flag[v]) return v;
    return kInvalid;
  }

  // After a failed search from `root`: moves the unmatched vertex from root to the even vertex b by
  // flipping the even alternating path b, mate[b], pre[mate[b]], ..., root.
  void flip_even_path(Index root, Index b) {
    if (b == root) return;
    const Index x = mate_[b];
    mate_[b] = kInvalid;
    augment(x);
  }

  template <class Fn>
  void for_each_labelled(Fn&& fn) const {
    for (Index v : touched_) fn(v, label_[v]);
  }

  void reset() {
    for (Index v : touched_) {
      label_[v] = kFree;
      pre_[v] = kInvalid;
      base_[v] = v;
    }
    touched_.clear();
  }

 private:
  // A vertex leaves kFree at most once per search, and only labelled vertices get pre_/base_ changed (the
  // unmatched end of an augmenting path is recorded by search()), so touched_ lists what reset() undoes.
  void label(Index v, std::uint8_t l) {
    if (label_[v] == kFree) touched_.push_back(v);
    label_[v] = l;
  }

  Index find(Index x) {
    while (base_[x] != x) {
      base_[x] = base_[base_[x]];
      x = base_[x];
    }
    return x;
  }

  // Nearest common base of two even bases on their paths to the root (alternate steps, timestamps).
  Index lca(Index a, Index b) {
    if (++clock_ == 0) {
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      clock_ = 1;
    }
    while (true) {
      if (a != kInvalid) {
        if (stamp_[a] == clock_) return a;
        stamp_[a] = clock_;
        a = mate_[a] == kInvalid ? kInvalid : find(pre_[mate_[a]]);
      }
      std::swap(a, b);
    }
  }

  // Contracts the half of the blossom from v up to base l; w is across the closing edge. Odd vertices on
  // the way become even (they now have an even alternating path through the other side).
  void shrink(Index v, Index w, Index l) {
    while (find(v) != l) {
      pre_[v] = w;
      const Index x = mate_[v];
      if (label_[x] == kOdd) {
        label_[x] = kEven;
        queue_.push_back(x);
      }
      if (find(v) == v) base_[v] = l;
      if (find(x) == x) base_[x] = l;
      w = x;
      v = pre_[x];
    }
  }

  // w is unmatched (or just unmatched by flip_even_path) and pre_[w] is its even predecessor.
  void augment(Index w) {
    while (w != kInvalid) {
      const Index v = pre_[w];
      const Index next = mate_[v];
      mate_[w] = v;
      mate_[v] = w;
      w = next;
    }
  }

  std::span<const Index> off_, nbr_;
  std::vector<Index>& mate_;
  std::vector<std::uint8_t> label_;
  std::vector<Index> pre_, base_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t clock_ = 0;
  std::vector<Index> queue_, touched_;
};

void check_graph(std::span<const Index> offsets, std::span<const Index> nbrs) {
  if (offsets.empty() || offsets[0] != 0) throw InvalidInput("maximum_matching: offsets must start with 0");
  const std::size_t n = offsets.size() - 1;
  if (n >= kInvalid) throw InvalidInput("maximum_matching: too many vertices for 32-bit ids");
  for (std::size_t v = 0; v < n; ++v)
    if (offsets[v + 1] < offsets[v]) throw InvalidInput("maximum_matching: offsets decrease at vertex " + std::to_string(v), v);
  if (offsets[n] != nbrs.size())
    throw InvalidInput("maximum_matching: offsets end at " + std::to_string(offsets[n]) + " but there are " +
                       std::to_string(nbrs.size()) + " neighbours");
  std::vector<std::uint64_t> arcs;
  arcs.reserve(nbrs.size());
  for (Index v = 0; v < n; ++v)
    for (Index i = offsets[v]; i < offsets[v + 1]; ++i) {
      const Index w = nbrs[i];
      if (w >= n)
        throw InvalidInput("maximum_matching: vertex " + std::to_string(v) + " has neighbour " + std::to_string(w) +
                               " out of range",
                           v);
      arcs.push_back((std::uint64_t(v) << 32) | w);
    }
  std::vector<std::uint64_t> reversed(arcs.size());
  for (std::size_t i = 0; i < arcs.size(); ++i) reversed[i] = (arcs[i] << 32) | (arcs[i] >> 32);
  std::sort(arcs.begin(), arcs.end());
  std::sort(reversed.begin(), reversed.end());
  for (std::size_t i = 0; i < arcs.size(); ++i)
    if (arcs[i] != reversed[i]) {
      const std::uint64_t a = std::min(arcs[i], reversed[i]);
      throw InvalidInput("maximum_matching: vertex " + std::to_string(a >> 32) + " lists neighbour " +
                             std::to_string(a & 0xffffffffu) + " a different number of times than it is listed back",
                         a >> 32);
    }
}

// Karp-Sipser: match degree-one vertices to their only neighbour first, otherwise the lowest-numbered
// unmatched vertex to its unmatched neighbour of smallest degree. Degrees count unmatched neighbours with
// multiplicity.
std::size_t greedy_matching(std::span<const Index> off, std::span<const Index> nbr, std::vector<Index>& mate) {
  const std::size_t n = mate.size();
  std::vector<Index> degree(n, 0);
  std::vector<Index> ones;
  for (Index v = 0; v < n; ++v) {
    for (Index i = off[v]; i < off[v + 1]; ++i)
      if (nbr[i] != v) ++degree[v];
    if (degree[v] == 1) ones.push_back(v);
  }
  std::size_t pairs = 0;
  auto match = [&](Index v, Index w) {
    mate[v] = w;
    mate[w] = v;
    ++pairs;
    for (Index u : {v, w})
      for (Index i = off[u]; i < off[u + 1]; ++i) {
        const Index x = nbr[i];
        if (x == u || mate[x] != kInvalid) continue;
        if (--degree[x] == 1) ones.push_back(x);
      }
  };
  auto unmatched_neighbour = [&](Index v, bool smallest_degree) {
    Index best = kInvalid;
    for (Index i = off[v]; i < off[v + 1]; ++i) {
      const Index x = nbr[i];
      if (x == v || mate[x] != kInvalid) continue;
      if (!smallest_degree) return x;
      if (best == kInvalid || degree[x] < degree[best]) best = x;
    }
    return best;
  };
  Index scan = 0;
  while (true) {
    while (!ones.empty()) {
      const Index v = ones.back();
      ones.pop_back();
      if (mate[v] != kInvalid) continue;
      const Index w = unmatched_neighbour(v, false);
      if (w != kInvalid) match(v, w);
    }
    while (scan < n && mate[scan] != kInvalid) ++scan;
    if (scan == n) break;
    const Index w = unmatched_neighbour(scan, true);
    if (w == kInvalid) {
      ++scan;  // isolated among unmatched vertices: stays unmatched for the greedy
      continue;
    }
    match(scan, w);
  }
  return pairs;
}


// maximum_matching without the input checks (for adjacency built here, symmetric by construction).
GraphMatching match_graph(std::span<const Index> offsets, std::span<const Index> neighbours,
                          const MatchingOptions& options) {
  const std::size_t n = offsets.size() - 1;
  GraphMatching out;
  out.mate.assign(n, kInvalid);
  if (options.greedy_start) out.greedy_pairs = greedy_matching(offsets, neighbours, out.mate);

  BlossomSearch search(offsets, neighbours, out.mate);
  // One search per unmatched vertex suffices: if none augments from v now, none will after other
  // augmentations either (Edmonds 1965; the standard "no augmenting path from v stays true" lemma).
  for (Index v = 0; v < n; ++v) {
    if (out.mate[v] != kInvalid || offsets[v] == offsets[v + 1]) continue;
    if (search.search(v)) ++out.augmentations;
    search.reset();
  }
  if (!options.prefer_unmatched.empty()) {
    for (Index v = 0; v < n; ++v) {
      if (out.mate[v] != kInvalid || options.prefer_unmatched[v] || offsets[v] == offsets[v + 1]) continue;
      if (search.search(v)) {
        ++out.augmentations;  // not reachable when the first pass is right; kept for safety
      } else if (const Index b = search.find_even(options.prefer_unmatched); b != kInvalid) {
        search.flip_even_path(v, b);
        ++out.moved;
      }
      search.reset();
    }
  }
  if (options.certificate) {
    std::vector<std::uint8_t> odd(n, 0), even(n, 0);
    for (Index v = 0; v < n; ++v) {
      if (out.mate[v] != kInvalid) continue;
      if (search.search(v)) throw std::logic_error("maximum_matching: augmenting path left after the last pass");
      search.for_each_labelled([&](Index u, std::uint8_t l) {
        if (l == kOdd) odd[u] = 1;
        if (l == kEven) even[u] = 1;
      });
      search.reset();
    }
    for (Index v = 0; v < n; ++v)
      if (odd[v] && !even[v]) out.tutte_set.push_back(v);
  }
  for (Index v = 0; v < n; ++v) {
    if (out.mate[v] == kInvalid) ++out.num_unmatched;
    else if (out.mate[v] > v) ++out.num_pairs;
  }
  return out;
}

}  // namespace

GraphMatching maximum_matching(std::span<const Index> offsets, std::span<const Index> neighbours,
                               const MatchingOptions& options) {
  check_graph(offsets, neighbours);
  const std::size_t n = offsets.size() - 1;
  if (!options.prefer_unmatched.empty() && options.prefer_unmatched.size() != n)
    throw InvalidInput("maximum_matching: prefer_unmatched has " + std::to_string(options.prefer_unmatched.size()) +
                       " flags for " + std::to_string(n) + " vertices");
  return match_graph(offsets, neighbours, options);
}

namespace {

DualMatching match_dual(const FourKMesh& mesh, bool certificate) {
  const std::size_t nf = mesh.num_base_faces();
  std::vector<Index> offsets(nf + 1, 0), nbrs;
  nbrs.reserve(3 * nf);
  std::vector<std::uint8_t> border(nf, 0);
  for (FaceId f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const HalfEdgeId m = mesh.mate(FourKMesh::edge(f, k));
      if (m == kInvalid) border[f] = 1;
      else nbrs.push_back(FourKMesh::fbase(m));
    }
    offsets[f + 1] = static_cast<Index>(nbrs.size());
  }
  MatchingOptions mo;
  mo.prefer_unmatched = border;
  mo.certificate = certificate;
  DualMatching out;
  out.graph = match_graph(offsets, nbrs, mo);
  out.mate = out.graph.mate;
  out.num_pairs = out.graph.num_pairs;
  out.num_leftovers = out.graph.num_unmatched;
  out.refinement_edge.assign(nf, 0);
  for (FaceId f = 0; f < nf; ++f) {
    out.num_border_faces += border[f];
    const FaceId g = out.mate[f];
    if (g == kInvalid) {
      int k = 0;
      while (k < 3 && mesh.mate(FourKMesh::edge(f, k)) != kInvalid) ++k;
      // semiregular.hpp proves this cannot happen for an edge-manifold mesh.
      if (k == 3) throw std::logic_error("match_dual_faces: interior face " + std::to_string(f) + " left unmatched");
      out.refinement_edge[f] = static_cast<std::uint8_t>(k);
    } else if (f < g) {
      // Two faces may share two edges: mark one of them on both sides.
      for (int k = 0; k < 3; ++k) {
        const HalfEdgeId m = mesh.mate(FourKMesh::edge(f, k));
        if (m != kInvalid && FourKMesh::fbase(m) == g) {
          out.refinement_edge[f] = static_cast<std::uint8_t>(k);
          out.refinement_edge[g] = static_cast<std::uint8_t>(m % 3);
          break;
        }
      }
    }
  }
  return out;
}

// Refuses, before anything is allocated, a level count that is negative, makes 2^31 faces or more, or needs
// more memory than the machine has: about bytes_per_face per finest face at the peak (measured on the cow
// at 7 levels, 743k finest faces: 88 bytes for the FourKMesh alone, 246 with the Mt built from it).
void check_levels(std::size_t faces, int levels, const char* who, double bytes_per_face) {
  if (levels < 0)
    throw InvalidInput(std::string(who) + ": parameter levels = " + std::to_string(levels) + " is negative");
  if (levels > max_semiregular_levels(faces))
    throw InvalidInput(std::string(who) + ": parameter levels = " + std::to_string(levels) + " with " +
                       std::to_string(faces) + " base faces would exceed 2^31 faces (at most " +
                       std::to_string(max_semiregular_levels(faces)) + " levels)");
  const double finest = std::ldexp(double(faces), levels);
  const double need = bytes_per_face * finest, have = physical_memory_bytes();
  if (have > 0.0 && need > have) {
    char text[240];
    std::snprintf(text, sizeof text, "%s: parameter levels = %d with %zu base faces makes %.3g faces and needs about %.1f GB; this machine has %.1f GB",
                  who, levels, faces, finest, need / 1e9, have / 1e9);
    throw InvalidInput(text);
  }
}

}  // namespace

DualMatching match_dual_faces(const TriMesh& mesh, bool certificate) {
  const FourKMesh fk(mesh);
  return match_dual(fk, certificate);
}

int max_semiregular_levels(std::size_t faces) noexcept {
  if (faces == 0) return 30;
  int levels = -1;
  while (levels < 40 && (std::uint64_t(faces) << (levels + 1)) < (std::uint64_t(1) << 31)) ++levels;
  return levels;
}

FourKMesh build_semiregular_fourk(const TriMesh& base, int levels, const SemiRegularOptions& options,
                                  SemiRegularInfo* info) {
  base.validate();
  if (base.num_faces() == 0) throw InvalidInput("build_semiregular: the base mesh has no face (empty mesh)");
  check_levels(base.num_faces(), levels, "build_semiregular", 90.0);
  FourKMesh fk(base);
  DualMatching dm = match_dual(fk, false);

  const std::size_t n = base.num_faces();
  const std::size_t finest = n << levels;
  fk.reserve(2 * finest - n, base.num_vertices() + finest);
  std::vector<std::uint16_t> mod_level, vertex_level(base.num_vertices(), 0);
  std::vector<std::size_t> faces_per_level{n}, splits{1}, lone{0};
  mod_level.reserve(finest);

  // Splits the current half-edge h (edge[0] of its face after the shift) as node of level `level`.
  auto split_at = [&](HalfEdgeId h, int level) {
    const HalfEdgeId hm = fk.mate(h);
    BisectionSplit s;
    s.level = level;
    s.e0 = fk.point(h);
    s.e1 = fk.target(h);
    s.apex = {fk.point(FourKMesh::prev(h)), hm == kInvalid ? kInvalid : fk.point(FourKMesh::prev(hm))};
    s.positions = fk.positions();
    // Midpoint and length in double: in float, |e1 - e0|^2 overflows once coordinates pass ~1.8e19 and
    // a + b near FLT_MAX, which turned a valid mesh into a "non-finite error" the caller never gave.
    const glm::dvec3 d0(fk.position(s.e0)), d1(fk.position(s.e1));
    const glm::vec3 p = options.place_vertex ? options.place_vertex(s) : glm::vec3(0.5 * (d0 + d1));
    const float len = static_cast<float>(std::min(glm::length(d1 - d0), double(std::numeric_limits<float>::max())));
    s.mid = fk.split(h, p, 0.0f);
    s.positions = fk.positions();
    const float error = options.node_error ? options.node_error(s) : len;
    fk.set_error(fk.modifications().back(), error);
    mod_level.push_back(static_cast<std::uint16_t>(level));
    vertex_level.push_back(static_cast<std::uint16_t>(level));
    ++splits.back();
    if (hm == kInvalid) ++lone.back();
  };

  FaceId begin = 0, end = static_cast<FaceId>(n);
  for (int level = 1; level <= levels; ++level) {
    splits.push_back(0);
    lone.push_back(0);
    for (FaceId f = begin; f < end; ++f) {
      if (!fk.is_current(f)) continue;  // split with its partner earlier in this level
      HalfEdgeId h = FourKMesh::split_edge(f);
      if (level == 1) {
        h += dm.refinement_edge[f];
      } else if (const HalfEdgeId m = fk.mate(h); m != kInvalid && m % 3 != 0) {
        // Newest-vertex bisection keeps a compatible marking compatible (semiregular.hpp).
        throw std::logic_error("build_semiregular: face " + std::to_string(f) + " lost its compatible marking");
      }
      split_at(h, level);
    }
    begin = end;
    end = static_cast<FaceId>(fk.num_faces());
    faces_per_level.push_back(fk.num_current_faces());
  }
  if (info) {
    info->matching = std::move(dm);
    info->modification_level = std::move(mod_level);
    info->vertex_level = std::move(vertex_level);
    info->faces_per_level = std::move(faces_per_level);
    info->splits_per_level = std::move(splits);
    info->border_splits_per_level = std::move(lone);
    info->node_level.clear();
  }
  return fk;
}

Mt build_semiregular_mt(const TriMesh& base, int levels, const SemiRegularOptions& options, SemiRegularInfo* info) {
  SemiRegularInfo local;
  SemiRegularInfo& inf = info ? *info : local;
  check_levels(base.num_faces(), levels, "build_semiregular", 260.0);  // the FourKMesh and the Mt at once
  const FourKMesh fk = build_semiregular_fourk(base, levels, options, &inf);
  FourKMtMap map;
  Mt mt = fk.to_mt(options.build, &map);
  // Log position of each modification, to read its level.
  std::vector<Index> log_index(fk.num_faces(), kInvalid);
  const auto log = fk.modifications();
  for (Index i = 0; i < log.size(); ++i) log_index[FourKMesh::fbase(log[i])] = i;
  inf.node_level.assign(mt.num_nodes(), 0);
  for (NodeId v = 1; v < mt.num_nodes(); ++v) inf.node_level[v] = inf.modification_level[log_index[FourKMesh::fbase(map.node_edge[v])]];
  return mt;
}

}  // namespace varmesh
