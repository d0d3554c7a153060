// Hierarchical generalized triangle strips on Multi-Triangulation fronts.
//
// Papers: L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000), 9.2 and Figure 23: a path defined
// on the coarsest mesh is refined while traversing the variable-resolution structure, and stays a
// Hamiltonian path for semi-regular 4-8 connectivity. L. Velho, L. H. de Figueiredo, J. Gomes,
// "Hierarchical generalized triangle strips" (The Visual Computer 15(1), 1999): the child order of a
// bisection follows the Sierpinski curve (entry and exit at the ends of the split edge, the turn at the
// apex). Base strips: depth-first search for a Hamiltonian path of the dual graph with Warnsdorff's rule
// (fewest onward moves first). Generalized strips with swaps: the swaptmesh of IRIS GL, as discussed by
// Evans, Skiena, Varshney, "Optimizing triangle strips for fast rendering" (1996); with one index buffer a
// swap is paid with repeated indices (degenerate triangles).
#include "fourk/strips.hpp"

#include <algorithm>
#include <bit>
#include <numeric>
#include <string>
#include <utility>

#include "multitri/errors.hpp"

namespace varmesh {

namespace {

using Corners = std::array<VertexId, 3>;

bool has_vertex(const Corners& c, VertexId v) { return c[0] == v || c[1] == v || c[2] == v; }

int common_count(const Corners& a, const Corners& b) {
  return int(has_vertex(b, a[0])) + int(has_vertex(b, a[1])) + int(has_vertex(b, a[2]));
}

// The edge two faces share (two common vertices), in a's corner order.
bool shared_edge(const Corners& a, const Corners& b, VertexId& u, VertexId& v) {
  VertexId found[3] = {kInvalid, kInvalid, kInvalid};
  int n = 0;
  for (VertexId x : a)
    if (has_vertex(b, x)) found[n++] = x;
  if (n != 2) return false;
  u = found[0];
  v = found[1];
  return true;
}

bool faces_share_edge(const Mt& mt, FaceId f, FaceId g) { return common_count(mt.face(f), mt.face(g)) == 2; }


// Where the path enters and leaves a face (corners); kInvalid in both for the plain (unoriented) search.
struct Orient {
  VertexId entry = kInvalid, exit = kInvalid;
};

// What a face's orientation should follow: the edge it is split at (kSplit: a recognised bisection
// removes it), else the edge newest-vertex bisection would split (kNatural: opposite the new vertex of the
// bisection that created it), else nothing.
struct Hint {
  enum Kind : std::uint8_t { kNone = 0, kNatural = 1, kSplit = 2 };
  VertexId a = kInvalid, b = kInvalid;
  Kind kind = kNone;
  bool matches(const Orient& o) const { return (o.entry == a && o.exit == b) || (o.entry == b && o.exit == a); }
};

// One pre-image face of an edge bisection and its two halves (4-8 split, Velho-Gomes 5.1 and 7.2).
struct BisectedFace {
  FaceId face = kInvalid;
  std::array<FaceId, 2> child{kInvalid, kInvalid};
  VertexId mid = kInvalid, apex = kInvalid;
  std::array<VertexId, 2> edge{kInvalid, kInvalid};
};

// Recognises node n as edge bisections of its pre-image faces: each image face has one corner that no
// pre-image face has (the new vertex of its parent) and its two others in exactly one pre-image face; each
// pre-image face gets two halves sharing the new vertex and the apex. Seam splits (two new vertices,
// adaptive.hpp) qualify; swaps and generic nodes do not.
bool recognise_bisection(const Mt& mt, NodeId n, std::vector<BisectedFace>& out) {
  out.clear();
  const auto pre = mt.pre_image(n);
  if (pre.empty() || mt.image_size(n) != 2 * pre.size()) return false;
  for (FaceId p : pre) out.push_back({p, {kInvalid, kInvalid}, kInvalid, kInvalid, {kInvalid, kInvalid}});
  for (FaceId g = mt.image_begin(n); g < mt.image_end(n); ++g) {
    const Corners c = mt.face(g);
    std::size_t owner = pre.size();
    int new_corner = -1;
    for (std::size_t i = 0; i < pre.size(); ++i) {
      const Corners pf = mt.face(pre[i]);
      int inside = 0, outside = -1;
      for (int k = 0; k < 3; ++k) {
        if (has_vertex(pf, c[k])) ++inside;
        else outside = k;
      }
      if (inside == 3) return false;
      if (inside == 2) {
        if (owner != pre.size()) return false;
        owner = i;
        new_corner = outside;
      }
    }
    if (owner == pre.size()) return false;
    const VertexId m = c[static_cast<std::size_t>(new_corner)];
    for (FaceId p : pre)
      if (has_vertex(mt.face(p), m)) return false;
    BisectedFace& b = out[owner];
    if (b.child[0] == kInvalid) {
      b.child[0] = g;
      b.mid = m;
    } else if (b.child[1] == kInvalid && b.mid == m) {
      b.child[1] = g;
    } else {
      return false;
    }
  }
  for (BisectedFace& b : out) {
    if (b.child[1] == kInvalid) return false;
    const Corners pf = mt.face(b.face), c0 = mt.face(b.child[0]), c1 = mt.face(b.child[1]);
    int apexes = 0, ends = 0;
    for (VertexId v : pf) {
      const bool in0 = has_vertex(c0, v), in1 = has_vertex(c1, v);
      if (in0 && in1) {
        b.apex = v;
        ++apexes;
      } else if (in0 || in1) {
        if (ends == 2) return false;
        b.edge[static_cast<std::size_t>(ends++)] = v;
      } else {
        return false;
      }
    }
    if (apexes != 1 || ends != 2) return false;
  }
  return true;
}

// The six orientations of a face (ordered pairs of distinct corners).
std::array<Orient, 6> all_orients(const Corners& c) {
  return {Orient{c[0], c[1]}, Orient{c[1], c[0]}, Orient{c[1], c[2]},
          Orient{c[2], c[1]}, Orient{c[2], c[0]}, Orient{c[0], c[2]}};
}

// A path (or several) through the dual graph of a face set. Oriented mode (hints given): a link from face
// f to face g is *good* when they share an edge through the vertex exit(f) = entry(g); faces with a hint
// are oriented along it, others any way. Plain mode: a link is good when the faces share an edge.
class DualPaths {
 public:
  DualPaths(const Mt& mt, std::span<const FaceId> faces, std::span<const Hint> hints)
      : mt_(&mt), faces_(faces), n_(faces.size()), oriented_(!hints.empty()) {
    corners_.resize(n_);
    for (std::size_t i = 0; i < n_; ++i) corners_[i] = mt.face(faces[i]);
    // Adjacency by shared undirected edges (offsets + items).
    std::vector<std::pair<std::uint64_t, Index>> edges;
    edges.reserve(3 * n_);
    for (std::size_t i = 0; i < n_; ++i)
      for (std::size_t k = 0; k < 3; ++k)
        edges.emplace_back(undirected_edge_key(corners_[i][k], corners_[i][(k + 1) % 3]), static_cast<Index>(i));
    std::sort(edges.begin(), edges.end());
    std::vector<std::pair<Index, Nbr>> pairs;
    for (std::size_t s = 0; s < edges.size();) {
      std::size_t e = s;
      while (e < edges.size() && edges[e].first == edges[s].first) ++e;
      const VertexId u = static_cast<VertexId>(edges[s].first >> 32), v = static_cast<VertexId>(edges[s].first);
      for (std::size_t i = s; i < e; ++i)
        for (std::size_t j = s; j < e; ++j)
          if (edges[i].second != edges[j].second) pairs.push_back({edges[i].second, Nbr{edges[j].second, u, v}});
      s = e;
    }
    std::sort(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
      return x.first != y.first ? x.first < y.first : x.second.face < y.second.face;
    });
    nbr_off_.assign(n_ + 1, 0);
    for (const auto& p : pairs) ++nbr_off_[p.first + 1];
    for (std::size_t i = 0; i < n_; ++i) nbr_off_[i + 1] += nbr_off_[i];
    nbrs_.reserve(pairs.size());
    for (const auto& p : pairs) nbrs_.push_back(p.second);
    // Orientation options.
    opt_off_.assign(1, 0);
    for (std::size_t i = 0; i < n_; ++i) {
      if (!oriented_) {
        opts_.push_back(Orient{});
      } else if (hints[i].kind != Hint::kNone) {
        opts_.push_back(Orient{hints[i].a, hints[i].b});
        opts_.push_back(Orient{hints[i].b, hints[i].a});
      } else {
        for (const Orient& o : all_orients(corners_[i])) opts_.push_back(o);
      }
      opt_off_.push_back(static_cast<Index>(opts_.size()));
    }
    start_order_.resize(n_);
    std::iota(start_order_.begin(), start_order_.end(), Index{0});
    std::stable_sort(start_order_.begin(), start_order_.end(), [&](Index x, Index y) { return degree(x) < degree(y); });
  }

  // Fills order / orient / link (link[i], i > 0: 0 good, 1 mismatch, 2 break before position i). Minimises
  // breaks + mismatches (each may cost a run at depth), then breaks.
  void solve(std::size_t budget) {
    order.clear();
    orient.clear();
    link.clear();
    if (n_ == 0) return;
    if (budget > 0) {
      const Search result = depth_first(budget);
      if (result == Search::kFound) return;
      exhausted = result == Search::kExhausted;
    }
    std::vector<Index> best_order;
    std::vector<Orient> best_orient;
    std::vector<std::uint8_t> best_link;
    std::pair<std::size_t, std::size_t> best_score{n_ + 1, n_ + 1};
    auto consider = [&] {
      if (oriented_) orient_dp();
      two_opt();
      if (oriented_) orient_dp();
      const auto sc = score();
      if (sc < best_score) {
        best_score = sc;
        best_order = order;
        best_orient = orient;
        best_link = link;
      }
    };
    // Greedy covers from several first starts (all of them on small sets).
    const std::size_t seeds = n_ <= 64 ? n_ : 8;
    for (std::size_t s = 0; s < seeds && best_score.first > 0; ++s) {
      greedy(start_order_[s]);
      consider();
    }
    // Oriented: the best plain path (fewest breaks), oriented afterwards by dynamic programming.
    if (oriented_ && best_score.first > 0) {
      DualPaths plain(*mt_, faces_, {});
      plain.solve(budget);
      order = plain.order;
      orient.clear();
      for (Index f : order) orient.push_back(opts_[opt_off_[f]]);
      relink(0, n_);
      consider();
    }
    order = std::move(best_order);
    orient = std::move(best_orient);
    link = std::move(best_link);
  }

  std::vector<Index> order;
  std::vector<Orient> orient;
  std::vector<std::uint8_t> link;
  bool exhausted = false;

 private:
  struct Nbr {
    Index face;
    VertexId u, v;  // the shared edge
  };
  struct Cand {
    Index face, opt, rank;
  };
  struct Frame {
    Index face, opt;
    std::size_t begin, end, next;
  };
  enum class Search { kFound, kExhausted, kNone };

  std::size_t degree(Index f) const { return nbr_off_[f + 1] - nbr_off_[f]; }
  std::span<const Nbr> nbrs(Index f) const { return {nbrs_.data() + nbr_off_[f], degree(f)}; }
  std::span<const Orient> opts(Index f) const { return {opts_.data() + opt_off_[f], opt_off_[f + 1] - opt_off_[f]}; }
  const Nbr* find_nbr(Index f, Index g) const {
    for (const Nbr& e : nbrs(f))
      if (e.face == g) return &e;
    return nullptr;
  }

  static bool good(const Orient& from, const Orient& to, const Nbr& e) {
    if (from.exit == kInvalid) return true;
    return from.exit == to.entry && (from.exit == e.u || from.exit == e.v);
  }
  std::uint8_t kind(Index f, const Orient& of, Index g, const Orient& og) const {
    const Nbr* e = find_nbr(f, g);
    if (e == nullptr) return 2;
    return good(of, og, *e) ? 0 : 1;
  }
  static int link_weight(std::uint8_t k) { return k == 0 ? 0 : (k == 1 ? 100 : 101); }
  static Orient flipped(const Orient& o) { return {o.exit, o.entry}; }
  // (breaks + mismatches, breaks)
  std::pair<std::size_t, std::size_t> score() const {
    std::size_t bad = 0, breaks = 0;
    for (std::size_t i = 1; i < link.size(); ++i) {
      bad += link[i] != 0;
      breaks += link[i] == 2;
    }
    return {bad, breaks};
  }
  void relink(std::size_t from, std::size_t to) {
    link.resize(n_);
    link[0] = 0;
    for (std::size_t i = std::max<std::size_t>(from, 1); i < to && i < n_; ++i)
      link[i] = kind(order[i - 1], orient[i - 1], order[i], orient[i]);
  }

  // Free neighbours of f that a good link can reach from f oriented by o (forward), or that can reach f
  // by a good link (backward).
  Index onward(Index f, const Orient& o, bool backward) const {
    Index count = 0;
    for (const Nbr& e : nbrs(f)) {
      if (used_[e.face]) continue;
      for (const Orient& oh : opts(e.face))
        if (backward ? good(oh, o, e) : good(o, oh, e)) {
          ++count;
          break;
        }
    }
    return count;
  }
  Index free_degree(Index f) const {
    Index count = 0;
    for (const Nbr& e : nbrs(f)) count += used_[e.face] ? 0 : 1;
    return count;
  }
  // Warnsdorff: fewest onward moves, but a dead end (0) only when nothing else is left.
  static Index warnsdorff_rank(Index onward_moves) { return onward_moves == 0 ? kInvalid : onward_moves; }

  // A path of good links only (for oriented mode: no mismatch either), depth first within the budget.
  Search depth_first(std::size_t budget) {
    used_.assign(n_, 0);
    std::vector<Frame> stack;
    std::vector<Cand> cands;
    std::size_t expansions = 0;
    auto push = [&](Index f, Index opt) {
      used_[f] = 1;
      Frame fr{f, opt, cands.size(), 0, 0};
      const Orient& o = opts_[opt];
      for (const Nbr& e : nbrs(f)) {
        if (used_[e.face]) continue;
        for (Index k = opt_off_[e.face]; k < opt_off_[e.face + 1]; ++k)
          if (good(o, opts_[k], e)) cands.push_back({e.face, k, warnsdorff_rank(onward(e.face, opts_[k], false))});
      }
      std::sort(cands.begin() + static_cast<std::ptrdiff_t>(fr.begin), cands.end(), [](const Cand& x, const Cand& y) {
        return x.rank != y.rank ? x.rank < y.rank : (x.face != y.face ? x.face < y.face : x.opt < y.opt);
      });
      fr.end = cands.size();
      fr.next = fr.begin;
      stack.push_back(fr);
    };
    for (Index start : start_order_) {
      for (Index k = opt_off_[start]; k < opt_off_[start + 1]; ++k) {
        push(start, k);
        while (!stack.empty()) {
          if (stack.size() == n_) {
            for (const Frame& fr : stack) {
              order.push_back(fr.face);
              orient.push_back(opts_[fr.opt]);
              link.push_back(0);
            }
            return Search::kFound;
          }
          Frame& top = stack.back();
          if (top.next == top.end) {
            used_[top.face] = 0;
            cands.resize(top.begin);
            stack.pop_back();
            continue;
          }
          const Cand c = cands[top.next++];
          if (used_[c.face]) continue;
          if (++expansions > budget) return Search::kExhausted;
          push(c.face, c.opt);
        }
      }
    }
    return Search::kNone;
  }

  // Picks the best good link from (f, o), forward or backward; kInvalid face when none.
  Cand best_good(Index f, const Orient& o, bool backward) const {
    Cand best{kInvalid, kInvalid, kInvalid};
    for (const Nbr& e : nbrs(f)) {
      if (used_[e.face]) continue;
      for (Index k = opt_off_[e.face]; k < opt_off_[e.face + 1]; ++k) {
        if (!(backward ? good(opts_[k], o, e) : good(o, opts_[k], e))) continue;
        const Index rank = warnsdorff_rank(onward(e.face, opts_[k], backward));
        if (best.face == kInvalid || rank < best.rank) best = {e.face, k, rank};
      }
    }
    return best;
  }
  // A free neighbour reached by a mismatched link, oriented for the most good continuations.
  Cand best_mismatch(Index f, bool backward) const {
    Cand best{kInvalid, kInvalid, kInvalid};
    for (const Nbr& e : nbrs(f)) {
      if (used_[e.face]) continue;
      const Index rank = warnsdorff_rank(free_degree(e.face));
      if (best.face != kInvalid && rank >= best.rank) continue;
      Index opt = opt_off_[e.face], moves = 0;
      for (Index k = opt_off_[e.face]; k < opt_off_[e.face + 1]; ++k) {
        const Index m = onward(e.face, opts_[k], backward);
        if (k == opt_off_[e.face] || m > moves) {
          moves = m;
          opt = k;
        }
      }
      best = {e.face, opt, rank};
    }
    return best;
  }

  // Paths grown greedily at both ends (good links by Warnsdorff's rule, then mismatched ones), a new path
  // whenever both ends are stuck.
  void greedy(Index first_start) {
    order.clear();
    orient.clear();
    link.clear();
    used_.assign(n_, 0);
    std::size_t placed = 0, next_start = 0;
    std::vector<std::pair<Index, Index>> forward, backward;  // (face, option)
    std::vector<std::uint8_t> fw_link, bw_link;
    bool first = true;
    while (placed < n_) {
      Index start = first_start;
      if (!first) {
        while (used_[start_order_[next_start]]) ++next_start;
        start = start_order_[next_start];
      }
      first = false;
      Index start_opt = opt_off_[start], moves = 0;
      used_[start] = 1;
      for (Index k = opt_off_[start]; k < opt_off_[start + 1]; ++k) {
        const Index m = onward(start, opts_[k], false);
        if (k == opt_off_[start] || m > moves) {
          moves = m;
          start_opt = k;
        }
      }
      forward.assign(1, {start, start_opt});
      fw_link.assign(1, 2);
      ++placed;
      for (;;) {
        const auto [f, o] = forward.back();
        Cand c = best_good(f, opts_[o], false);
        std::uint8_t k = 0;
        if (c.face == kInvalid) {
          c = best_mismatch(f, false);
          k = 1;
        }
        if (c.face == kInvalid) break;
        used_[c.face] = 1;
        ++placed;
        forward.push_back({c.face, c.opt});
        fw_link.push_back(k);
      }
      backward.clear();
      bw_link.clear();
      for (;;) {
        const auto [f, o] = backward.empty() ? forward.front() : backward.back();
        Cand c = best_good(f, opts_[o], true);
        std::uint8_t k = 0;
        if (c.face == kInvalid) {
          c = best_mismatch(f, true);
          k = 1;
        }
        if (c.face == kInvalid) break;
        used_[c.face] = 1;
        ++placed;
        backward.push_back({c.face, c.opt});
        bw_link.push_back(k);  // the link after this face
      }
      // Emit backward (reversed), then forward. The link before position i describes (i - 1, i).
      for (std::size_t i = backward.size(); i-- > 0;) {
        order.push_back(backward[i].first);
        orient.push_back(opts_[backward[i].second]);
        link.push_back(i + 1 == backward.size() ? 2 : bw_link[i + 1]);
      }
      for (std::size_t i = 0; i < forward.size(); ++i) {
        order.push_back(forward[i].first);
        orient.push_back(opts_[forward[i].second]);
        link.push_back(i == 0 ? (backward.empty() ? 2 : bw_link[0]) : fw_link[i]);
      }
    }
    link[0] = 0;
  }

  // The orientations minimising the link weights for the current order (a chain: dynamic programming).
  void orient_dp() {
    std::vector<std::array<int, 6>> dp(n_);
    std::vector<std::array<std::uint8_t, 6>> from(n_);
    auto opt_of = [&](std::size_t i, std::size_t a) { return opts_[opt_off_[order[i]] + a]; };
    auto count = [&](std::size_t i) { return static_cast<std::size_t>(opt_off_[order[i] + 1] - opt_off_[order[i]]); };
    for (std::size_t a = 0; a < count(0); ++a) dp[0][a] = 0;
    for (std::size_t i = 1; i < n_; ++i)
      for (std::size_t b = 0; b < count(i); ++b) {
        int m = -1;
        for (std::size_t a = 0; a < count(i - 1); ++a) {
          const int v = dp[i - 1][a] + link_weight(kind(order[i - 1], opt_of(i - 1, a), order[i], opt_of(i, b)));
          if (m < 0 || v < m) {
            m = v;
            from[i][b] = static_cast<std::uint8_t>(a);
          }
        }
        dp[i][b] = m;
      }
    std::size_t cur = 0;
    for (std::size_t b = 1; b < count(n_ - 1); ++b)
      if (dp[n_ - 1][b] < dp[n_ - 1][cur]) cur = b;
    for (std::size_t i = n_; i-- > 0;) {
      orient[i] = opt_of(i, cur);
      if (i > 0) cur = from[i][cur];
    }
    relink(0, n_);
  }

  // 2-opt on the path: reversing positions [a, b] replaces links (a-1, a) and (b, b+1) by (a-1, b) and
  // (a, b+1), and swaps entry and exit inside. Only reversals that make a bad link's face meet a
  // neighbour are tried; the total reversed length is bounded.
  void two_opt() {
    std::vector<Index> pos(n_);
    for (std::size_t i = 0; i < n_; ++i) pos[order[i]] = static_cast<Index>(i);
    std::size_t work = 0;
    const std::size_t work_budget = 64 * n_ + 100000;
    auto gain = [&](std::size_t a, std::size_t b) {
      int old_w = link_weight(link[a]), new_w = link_weight(kind(order[a - 1], orient[a - 1], order[b], flipped(orient[b])));
      if (b + 1 < n_) {
        old_w += link_weight(link[b + 1]);
        new_w += link_weight(kind(order[a], flipped(orient[a]), order[b + 1], orient[b + 1]));
      }
      return old_w - new_w;
    };
    auto reverse = [&](std::size_t a, std::size_t b) {
      std::reverse(order.begin() + static_cast<std::ptrdiff_t>(a), order.begin() + static_cast<std::ptrdiff_t>(b) + 1);
      std::reverse(orient.begin() + static_cast<std::ptrdiff_t>(a), orient.begin() + static_cast<std::ptrdiff_t>(b) + 1);
      for (std::size_t i = a; i <= b; ++i) {
        orient[i] = flipped(orient[i]);
        pos[order[i]] = static_cast<Index>(i);
      }
      relink(a, b + 2);
      work += b - a + 1;
    };
    for (bool improved = true; improved && work < work_budget;) {
      improved = false;
      for (std::size_t i = 1; i < n_ && work < work_budget; ++i) {
        if (link[i] == 0) continue;
        // Reverse [i, b] where order[b] neighbours order[i - 1].
        for (const Nbr& e : nbrs(order[i - 1])) {
          const std::size_t b = pos[e.face];
          if (b > i && gain(i, b) > 0) {
            reverse(i, b);
            improved = true;
            break;
          }
        }
        if (link[i] == 0) continue;
        // Reverse [a, i - 1] where order[a - 1] neighbours order[i].
        for (const Nbr& e : nbrs(order[i])) {
          const std::size_t a = static_cast<std::size_t>(pos[e.face]) + 1;
          if (a < i && gain(a, i - 1) > 0) {
            reverse(a, i - 1);
            improved = true;
            break;
          }
        }
      }
    }
  }

  const Mt* mt_;
  std::span<const FaceId> faces_;
  std::size_t n_;
  bool oriented_;
  std::vector<Corners> corners_;
  std::vector<Index> nbr_off_;
  std::vector<Nbr> nbrs_;
  std::vector<Index> opt_off_;
  std::vector<Orient> opts_;
  std::vector<Index> start_order_;
  std::vector<std::uint8_t> used_;
};

// Where the path crosses into a face: the vertex, and the edge (u, v) it shares with the face before
// (entry) or after (exit) it in the plan; kInvalid when unknown (the ends of the base strip).
struct Portal {
  VertexId s = kInvalid;
  VertexId u = kInvalid, v = kInvalid;
};

// Costs of the local order search (plan_slot): a break first, then a lost portal edge (a break as soon as
// the faces are in a front together), then a portal vertex mismatch (a break after enough bisections),
// then a face not oriented along its split edge, then one not along its newest-vertex edge.
constexpr int kBreakCost = 256;
constexpr int kEdgePortalCost = 64;
constexpr int kPortalCost = 16;
constexpr int kSplitMisalignCost = 2;
constexpr int kNaturalMisalignCost = 1;
constexpr std::size_t kExhaustiveSlot = 6;

int align_cost(const Hint& h, const Orient& o) {
  if (h.kind == Hint::kNone || h.matches(o)) return 0;
  return h.kind == Hint::kSplit ? kSplitMisalignCost : kNaturalMisalignCost;
}

int link_cost(const Corners& a, const Orient& oa, const Corners& b, const Orient& ob) {
  VertexId u, v;
  if (!shared_edge(a, b, u, v)) return kBreakCost;
  return oa.exit == ob.entry && (oa.exit == u || oa.exit == v) ? 0 : kPortalCost;
}

// Whether child c keeps the piece of the portal edge next to the portal vertex: the edge itself, or, when
// the slot's face is bisected at that edge (mid given), the half at the portal vertex. `piece` receives it.
bool keeps_portal(const Corners& c, const Portal& p, VertexId mid, Portal& piece) {
  piece = Portal{p.s, kInvalid, kInvalid};
  if (p.u == kInvalid) return true;
  if (has_vertex(c, p.u) && has_vertex(c, p.v)) {
    piece.u = p.u;
    piece.v = p.v;
    return true;
  }
  if (mid == kInvalid || !has_vertex(c, mid)) return false;
  const VertexId end = has_vertex(c, p.u) ? p.u : (has_vertex(c, p.v) ? p.v : kInvalid);
  if (end == kInvalid) return false;
  piece.u = end;
  piece.v = mid;
  return (p.s != p.u && p.s != p.v) || end == p.s;
}

// The plan of one slot: the image faces that take the place of one pre-image face (or of a chain of
// consecutive ones), in order, with orientations and portals.
struct SlotPlan {
  std::vector<FaceId> order;
  std::vector<Orient> orient;
  std::vector<Portal> in, out;
  std::size_t defects = 0;  // breaks, lost portal edges and portal vertex mismatches
};

// Reused buffers of plan_slot (no allocation per node once warm).
struct SlotScratch {
  std::vector<FaceId> perm;
  std::vector<Corners> corners;
  std::vector<std::array<Orient, 6>> orients;
  std::vector<std::array<int, 6>> dp;
  std::vector<std::array<std::uint8_t, 6>> from;
  std::vector<Portal> shared;
};

// Orders `kids` and orients them, minimising the costs above: every permutation for up to kExhaustiveSlot
// faces, a greedy walk beyond, and for each order a dynamic program over the six orientations of each
// face. `mid`: the new vertex when the slot's face is bisected (kInvalid otherwise).
void plan_slot(const Mt& mt, const Portal& in, const Portal& out, VertexId mid, std::span<const FaceId> kids,
               const std::vector<Hint>& hint, SlotPlan& best_plan, SlotScratch& scratch) {
  const std::size_t k = kids.size();
  best_plan.order.clear();
  best_plan.orient.clear();
  best_plan.in.clear();
  best_plan.out.clear();
  best_plan.defects = 0;
  if (k == 0) return;
  std::vector<FaceId>& perm = scratch.perm;
  perm.assign(kids.begin(), kids.end());
  std::sort(perm.begin(), perm.end());
  if (k > kExhaustiveSlot) {
    // Greedy walk: start at a face keeping the entry portal, then an unplaced face sharing an edge with
    // the last one.
    std::vector<FaceId> walk;
    std::vector<std::uint8_t> placed(k, 0);
    std::size_t cur = 0;
    Portal piece;
    for (std::size_t i = 0; i < k; ++i)
      if (has_vertex(mt.face(perm[i]), in.s) && keeps_portal(mt.face(perm[i]), in, mid, piece)) {
        cur = i;
        break;
      }
    for (std::size_t step = 0; step < k; ++step) {
      placed[cur] = 1;
      walk.push_back(perm[cur]);
      std::size_t next = k;
      for (std::size_t i = 0; i < k && next == k; ++i)
        if (!placed[i] && faces_share_edge(mt, perm[cur], perm[i])) next = i;
      for (std::size_t i = 0; i < k && next == k; ++i)
        if (!placed[i]) next = i;
      cur = next;
    }
    perm = std::move(walk);
  }
  std::vector<Corners>& c = scratch.corners;
  std::vector<std::array<Orient, 6>>& o = scratch.orients;
  std::vector<std::array<int, 6>>& dp = scratch.dp;
  std::vector<std::array<std::uint8_t, 6>>& from = scratch.from;
  std::vector<Portal>& shared = scratch.shared;  // shared[i]: the edge of faces i - 1 and i (u kInvalid: none)
  c.resize(k);
  o.resize(k);
  dp.resize(k);
  from.resize(k);
  shared.resize(k);
  auto link = [&](std::size_t i, const Orient& a, const Orient& b) {
    if (shared[i].u == kInvalid) return kBreakCost;
    return a.exit == b.entry && (a.exit == shared[i].u || a.exit == shared[i].v) ? 0 : kPortalCost;
  };
  auto load = [&] {
    for (std::size_t i = 0; i < k; ++i) {
      c[i] = mt.face(perm[i]);
      o[i] = all_orients(c[i]);
      shared[i] = Portal{};
      if (i > 0) shared_edge(c[i - 1], c[i], shared[i].u, shared[i].v);
    }
  };
  int best = -1;
  Portal piece;
  // Fast path, the 4-8 case: a face bisected along its entry-exit edge takes the Sierpinski order (the
  // half at the entry first, turning at the apex). Taken only when it costs nothing, hence optimal.
  if (k == 2 && mid != kInvalid && in.s != kInvalid && out.s != kInvalid) {
    if (!has_vertex(mt.face(perm[0]), in.s)) std::swap(perm[0], perm[1]);
    load();
    VertexId apex = kInvalid;
    for (VertexId v : c[0])
      if (v != mid && v != in.s) apex = v;
    const Orient first{in.s, apex}, second{apex, out.s};
    if (has_vertex(c[0], in.s) && has_vertex(c[1], out.s) && !has_vertex(c[0], out.s) && !has_vertex(c[1], in.s) &&
        keeps_portal(c[0], in, mid, piece) && keeps_portal(c[1], out, mid, piece) && link(1, first, second) == 0 &&
        align_cost(hint[perm[0]], first) == 0 && align_cost(hint[perm[1]], second) == 0) {
      best = 0;
      best_plan.order.assign(perm.begin(), perm.end());
      best_plan.orient = {first, second};
    }
    std::sort(perm.begin(), perm.end());
  }
  while (best != 0) {
    load();
    const int in_edge = keeps_portal(c[0], in, mid, piece) ? 0 : kEdgePortalCost;
    const int out_edge = keeps_portal(c[k - 1], out, mid, piece) ? 0 : kEdgePortalCost;
    for (std::size_t a = 0; a < 6; ++a)
      dp[0][a] = in_edge + (in.s == kInvalid || o[0][a].entry == in.s ? 0 : kPortalCost) + align_cost(hint[perm[0]], o[0][a]);
    for (std::size_t i = 1; i < k; ++i)
      for (std::size_t b = 0; b < 6; ++b) {
        int m = -1;
        for (std::size_t a = 0; a < 6; ++a) {
          const int v = dp[i - 1][a] + link(i, o[i - 1][a], o[i][b]);
          if (m < 0 || v < m) {
            m = v;
            from[i][b] = static_cast<std::uint8_t>(a);
          }
        }
        dp[i][b] = m + align_cost(hint[perm[i]], o[i][b]);
      }
    for (std::size_t b = 0; b < 6; ++b) {
      const int v = dp[k - 1][b] + out_edge + (out.s == kInvalid || o[k - 1][b].exit == out.s ? 0 : kPortalCost);
      if (best < 0 || v < best) {
        best = v;
        best_plan.order.assign(perm.begin(), perm.end());
        best_plan.orient.assign(k, Orient{});
        std::size_t cur = b;
        for (std::size_t i = k; i-- > 0;) {
          best_plan.orient[i] = o[i][cur];
          if (i > 0) cur = from[i][cur];
        }
      }
    }
    if (k > kExhaustiveSlot || !std::next_permutation(perm.begin(), perm.end())) break;
  }

  // Portals of the chosen order, and what it could not satisfy.
  SlotPlan& p = best_plan;
  p.in.assign(k, Portal{});
  p.out.assign(k, Portal{});
  const Corners first = mt.face(p.order[0]), last = mt.face(p.order[k - 1]);
  p.defects += !keeps_portal(first, in, mid, p.in[0]);
  p.defects += !keeps_portal(last, out, mid, p.out[k - 1]);
  p.in[0].s = p.orient[0].entry;
  p.out[k - 1].s = p.orient[k - 1].exit;
  p.defects += in.s != kInvalid && p.orient[0].entry != in.s;
  p.defects += out.s != kInvalid && p.orient[k - 1].exit != out.s;
  for (std::size_t i = 1; i < k; ++i) {
    const Corners a = mt.face(p.order[i - 1]), b = mt.face(p.order[i]);
    VertexId u = kInvalid, v = kInvalid;
    shared_edge(a, b, u, v);
    p.defects += link_cost(a, p.orient[i - 1], b, p.orient[i]) != 0;
    p.out[i - 1] = Portal{p.orient[i - 1].exit, u, v};
    p.in[i] = Portal{p.orient[i].entry, u, v};
  }
}

// Distributes the image of a node that is not a bisection over slots (chains of its pre-image faces):
// first one image face per slot (most shared corners first), then each other image face to a slot holding
// a face it shares an edge with, else to the slot it shares most corners with.
void assign_generic(const Mt& mt, NodeId n, const std::vector<std::vector<FaceId>>& slots, std::vector<Index>& owner) {
  const FaceId ib = mt.image_begin(n);
  const std::size_t kp = slots.size(), ka = mt.image_size(n);
  owner.assign(ka, kInvalid);
  std::vector<Index> count(kp, 0);
  struct Pair {
    int score;
    Index p, g;
  };
  auto score = [&](Index p, FaceId g) {
    int best = 0;
    for (FaceId f : slots[p]) best = std::max(best, common_count(mt.face(f), mt.face(g)));
    return best;
  };
  std::vector<Pair> pairs;
  for (Index p = 0; p < kp; ++p)
    for (Index g = 0; g < ka; ++g) pairs.push_back({score(p, ib + g), p, g});
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    return x.score != y.score ? x.score > y.score : (x.p != y.p ? x.p < y.p : x.g < y.g);
  });
  for (const Pair& pr : pairs)
    if (owner[pr.g] == kInvalid && count[pr.p] == 0) {
      owner[pr.g] = pr.p;
      ++count[pr.p];
    }
  for (bool progress = true; progress;) {
    progress = false;
    for (Index g = 0; g < ka; ++g) {
      if (owner[g] != kInvalid) continue;
      Index best = kInvalid;
      int best_score = -1;
      for (Index h = 0; h < ka; ++h) {
        if (owner[h] == kInvalid || !faces_share_edge(mt, ib + g, ib + h)) continue;
        const int sc = score(owner[h], ib + g);
        if (sc > best_score || (sc == best_score && owner[h] < best)) {
          best_score = sc;
          best = owner[h];
        }
      }
      if (best != kInvalid) {
        owner[g] = best;
        progress = true;
      }
    }
  }
  for (const Pair& pr : pairs)
    if (owner[pr.g] == kInvalid) owner[pr.g] = pr.p;
}

// Corners of f other than v, as a hint edge.
Hint edge_without(const Corners& c, VertexId v, Hint::Kind kind) {
  Hint h;
  h.kind = kind;
  for (VertexId x : c)
    if (x != v) (h.a == kInvalid ? h.a : h.b) = x;
  return h;
}

void check_face_ids(const char* who, std::size_t num_faces, std::span<const FaceId> faces) {
  for (std::size_t i = 0; i < faces.size(); ++i)
    if (faces[i] >= num_faces)
      throw InvalidInput(std::string(who) + ": face " + std::to_string(faces[i]) + " (entry " + std::to_string(i) +
                             ") is not a face of the Mt (" + std::to_string(num_faces) + " faces)",
                         i);
}

}  // namespace

namespace detail {

void StripKeySet::reset(std::size_t n) {
  n_ = n;
  size_ = 0;
  levels_.clear();
  std::size_t words = std::max<std::size_t>(1, (n + 63) / 64);
  levels_.emplace_back(words, 0);
  while (words > 1) {
    words = (words + 63) / 64;
    levels_.emplace_back(words, 0);
  }
}

void StripKeySet::insert(Index k) noexcept {
  std::uint64_t& w0 = levels_[0][k >> 6];
  const std::uint64_t bit = std::uint64_t(1) << (k & 63);
  if (w0 & bit) return;
  const bool was_empty = w0 == 0;
  w0 |= bit;
  ++size_;
  if (!was_empty) return;
  std::size_t i = k >> 6;
  for (std::size_t l = 1; l < levels_.size(); ++l) {
    std::uint64_t& w = levels_[l][i >> 6];
    const bool empty = w == 0;
    w |= std::uint64_t(1) << (i & 63);
    if (!empty) return;
    i >>= 6;
  }
}

void StripKeySet::erase(Index k) noexcept {
  std::uint64_t& w0 = levels_[0][k >> 6];
  const std::uint64_t bit = std::uint64_t(1) << (k & 63);
  if (!(w0 & bit)) return;
  w0 &= ~bit;
  --size_;
  if (w0 != 0) return;
  std::size_t i = k >> 6;
  for (std::size_t l = 1; l < levels_.size(); ++l) {
    std::uint64_t& w = levels_[l][i >> 6];
    w &= ~(std::uint64_t(1) << (i & 63));
    if (w != 0) return;
    i >>= 6;
  }
}

Index StripKeySet::next(Index k) const noexcept {
  std::size_t i = k == kInvalid ? 0 : std::size_t(k) + 1;  // search keys >= i
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    const std::vector<std::uint64_t>& lv = levels_[l];
    const std::size_t wi = i >> 6;
    if (wi >= lv.size()) return kInvalid;
    const std::uint64_t w = lv[wi] & (~std::uint64_t(0) << (i & 63));
    if (w != 0) {
      std::size_t b = (wi << 6) | static_cast<std::size_t>(std::countr_zero(w));
      while (l > 0) {
        --l;
        b = (b << 6) | static_cast<std::size_t>(std::countr_zero(levels_[l][b]));
      }
      return static_cast<Index>(b);
    }
    i = wi + 1;
  }
  return kInvalid;
}

Index StripKeySet::prev(Index k) const noexcept {
  if (size_ == 0 || k == 0) return kInvalid;
  std::size_t i = k == kInvalid || k > n_ ? n_ - 1 : std::size_t(k) - 1;  // search keys <= i
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    const std::size_t wi = i >> 6, r = i & 63;
    const std::uint64_t mask = r == 63 ? ~std::uint64_t(0) : (std::uint64_t(2) << r) - 1;
    const std::uint64_t w = levels_[l][wi] & mask;
    if (w != 0) {
      std::size_t b = (wi << 6) | static_cast<std::size_t>(63 - std::countl_zero(w));
      while (l > 0) {
        --l;
        b = (b << 6) | static_cast<std::size_t>(63 - std::countl_zero(levels_[l][b]));
      }
      return static_cast<Index>(b);
    }
    if (wi == 0) return kInvalid;
    i = wi - 1;
  }
  return kInvalid;
}

std::size_t StripKeySet::memory_bytes() const noexcept {
  std::size_t bytes = 0;
  for (const auto& lv : levels_) bytes += lv.capacity() * sizeof(std::uint64_t);
  return bytes;
}

}  // namespace detail

StripPlan::StripPlan(const Mt& mt, const StripPlanOptions& options) : mt_(&mt) {
  const std::size_t nf = mt.num_faces(), nn = mt.num_nodes();
  // Hints: the split edge of every face a bisection removes; the newest-vertex edge of its halves.
  std::vector<Hint> hint(nf);
  std::vector<std::uint8_t> is_bisection(nn, 0);
  std::vector<BisectedFace> bis;
  for (NodeId n = 1; n < nn; ++n) {
    if (!recognise_bisection(mt, n, bis)) continue;
    is_bisection[n] = 1;
    for (const BisectedFace& b : bis) {
      hint[b.face] = Hint{b.edge[0], b.edge[1], Hint::kSplit};
      for (FaceId c : b.child)
        if (hint[c].kind == Hint::kNone) hint[c] = edge_without(mt.face(c), b.mid, Hint::kNatural);
    }
  }

  entry_.assign(nf, kInvalid);
  exit_.assign(nf, kInvalid);
  std::vector<Portal> in(nf), out(nf);
  // The strip-children forest, and each face's static successor: the face whose subtree follows its own
  // in the hierarchical order (kInvalid at the end of the base strip).
  std::vector<FaceId> strip_parent(nf, kInvalid), succ(nf, kInvalid);
  std::vector<Index> rank(nf, 0);

  // The base strip (section 9.2: "starts with a path, defined on the coarsest mesh").
  if (nn > 0 && mt.image_size(0) > 0) {
    std::vector<FaceId> base(mt.image_size(0));
    std::iota(base.begin(), base.end(), mt.image_begin(0));
    std::vector<Hint> base_hints(base.size());
    for (std::size_t i = 0; i < base.size(); ++i)
      base_hints[i] = hint[base[i]].kind == Hint::kSplit ? hint[base[i]] : Hint{};
    stats_.base_faces = base.size();
    DualPaths paths(mt, base, base_hints);  // oriented mode: faces without a split edge take any orientation
    paths.solve(options.search_budget);
    stats_.base_search_exhausted = paths.exhausted;
    stats_.base_runs = 1;
    for (std::size_t i = 0; i < paths.order.size(); ++i) {
      const FaceId f = base[paths.order[i]];
      base_order_.push_back(f);
      entry_[f] = paths.orient[i].entry;
      exit_[f] = paths.orient[i].exit;
      in[f].s = entry_[f];
      out[f].s = exit_[f];
      if (i > 0) {
        stats_.base_runs += paths.link[i] == 2;
        stats_.base_mismatches += paths.link[i] == 1;
        const FaceId p = base_order_[i - 1];
        succ[p] = f;
        VertexId u, v;
        if (shared_edge(mt.face(p), mt.face(f), u, v)) {
          out[p].u = in[f].u = u;
          out[p].v = in[f].v = v;
        }
      }
    }
  }

  // In any front holding both, q comes right after p: q is the first leaf below p's successor.
  auto follows = [&](FaceId p, FaceId q) {
    const FaceId s = succ[p];
    if (s == kInvalid) return false;
    for (FaceId cur = q;;) {
      if (cur == s) return true;
      if (strip_parent[cur] == kInvalid || rank[cur] != 0) return false;
      cur = strip_parent[cur];
    }
  };
  auto commit = [&](std::span<const FaceId> chain, const SlotPlan& sp) {
    const std::size_t k = sp.order.size();
    for (std::size_t i = 0; i < k; ++i) {
      const FaceId g = sp.order[i];
      strip_parent[g] = chain.front();
      rank[g] = static_cast<Index>(i);
      entry_[g] = sp.orient[i].entry;
      exit_[g] = sp.orient[i].exit;
      in[g] = sp.in[i];
      out[g] = sp.out[i];
      succ[g] = i + 1 < k ? sp.order[i + 1] : succ[chain.back()];
    }
    stats_.local_defects += sp.defects;
  };

  // Nodes, parents first: each pre-image face's slot receives its ordered strip children.
  SlotPlan sp;
  SlotScratch scratch;
  std::vector<Index> owner, next_in_chain;
  std::vector<std::uint8_t> has_prev, done;
  std::vector<std::vector<FaceId>> chains;
  std::vector<FaceId> kids;
  for (NodeId n = 1; n < nn; ++n) {
    if (is_bisection[n]) {
      ++stats_.bisection_nodes;
      recognise_bisection(mt, n, bis);
      for (const BisectedFace& b : bis) {
        plan_slot(mt, in[b.face], out[b.face], b.mid, b.child, hint, sp, scratch);
        const FaceId self[1] = {b.face};
        commit(self, sp);
      }
      continue;
    }
    // Generic node: pre-image faces that follow each other in the strip form one slot (the brief's
    // "Hamiltonian path through the new faces" when the old ones were consecutive), held by the first;
    // the others keep no children.
    ++stats_.generic_nodes;
    const auto pre = mt.pre_image(n);
    next_in_chain.assign(pre.size(), kInvalid);
    has_prev.assign(pre.size(), 0);
    for (Index i = 0; i < pre.size(); ++i)
      for (Index j = 0; j < pre.size(); ++j)
        if (i != j && next_in_chain[i] == kInvalid && !has_prev[j] && follows(pre[i], pre[j])) {
          next_in_chain[i] = j;
          has_prev[j] = 1;
        }
    chains.clear();
    done.assign(pre.size(), 0);
    for (Index i = 0; i < pre.size(); ++i) {
      if (has_prev[i]) continue;
      chains.emplace_back();
      for (Index j = i; j != kInvalid && !done[j]; j = next_in_chain[j]) {
        done[j] = 1;
        chains.back().push_back(pre[j]);
      }
    }
    for (Index i = 0; i < pre.size(); ++i)
      if (!done[i]) chains.push_back({pre[i]});  // only on a cycle, which a strict order cannot have
    assign_generic(mt, n, chains, owner);
    for (Index c = 0; c < chains.size(); ++c) {
      kids.clear();
      for (Index g = 0; g < owner.size(); ++g)
        if (owner[g] == c) kids.push_back(mt.image_begin(n) + g);
      plan_slot(mt, in[chains[c].front()], out[chains[c].back()], kInvalid, kids, hint, sp, scratch);
      commit(chains[c], sp);
    }
  }

  // Keys: preorder of the strip-children forest, roots in base-strip order, children in slot order.
  std::vector<Index> child_off(nf + 1, 0);
  for (FaceId f = 0; f < nf; ++f)
    if (strip_parent[f] != kInvalid) ++child_off[strip_parent[f] + 1];
  for (std::size_t f = 0; f < nf; ++f) child_off[f + 1] += child_off[f];
  std::vector<FaceId> child_items(child_off[nf], kInvalid);
  for (FaceId f = 0; f < nf; ++f)
    if (strip_parent[f] != kInvalid) child_items[child_off[strip_parent[f]] + rank[f]] = f;
  key_.assign(nf, kInvalid);
  face_at_.assign(nf, kInvalid);
  Index next_key = 0;
  std::vector<FaceId> stack;
  for (std::size_t i = base_order_.size(); i-- > 0;) stack.push_back(base_order_[i]);
  while (!stack.empty()) {
    const FaceId f = stack.back();
    stack.pop_back();
    key_[f] = next_key;
    face_at_[next_key++] = f;
    for (Index j = child_off[f + 1]; j-- > child_off[f];) stack.push_back(child_items[j]);
  }
  if (next_key != nf)
    throw InvalidInput("StripPlan: " + std::to_string(nf - next_key) +
                       " faces are reached from no base face (the Mt does not pass validate())");
  for (FaceId f = 0; f < nf; ++f)
    if (hint[f].kind == Hint::kSplit && !hint[f].matches(Orient{entry_[f], exit_[f]})) ++stats_.misaligned_faces;
}

std::size_t StripPlan::memory_bytes() const noexcept {
  return (key_.capacity() + face_at_.capacity() + entry_.capacity() + exit_.capacity() + base_order_.capacity()) *
         sizeof(Index);
}

StripFront::StripFront(const StripPlan& plan) : plan_(&plan), front_(plan.mt()) { reset(); }

void StripFront::reset() {
  front_.reset();
  keys_.reset(plan_->num_faces());
  for (FaceId f : front_.faces()) keys_.insert(plan_->key(f));
  breaks_ = 0;
  for (Index k = keys_.next(kInvalid); k != kInvalid; k = keys_.next(k)) breaks_ += link_breaks(plan_->face_at(k));
}

void StripFront::apply(NodeId n) {
  front_.apply(n);
  on_applied(n);
}

void StripFront::undo(NodeId n) {
  front_.undo(n);
  on_undone(n);
}

void StripFront::on_applied(NodeId n) {
  const Mt& m = mt();
  image_.clear();
  for (FaceId f = m.image_begin(n); f < m.image_end(n); ++f) image_.push_back(f);
  replace(m.pre_image(n), image_);
}

void StripFront::on_undone(NodeId n) {
  // Undo merges each pre-image face back into the slot its strip children held: the same replacement
  // with the roles exchanged (keys are fixed, so the order is restored exactly).
  const Mt& m = mt();
  image_.clear();
  for (FaceId f = m.image_begin(n); f < m.image_end(n); ++f) image_.push_back(f);
  replace(image_, m.pre_image(n));
}

void StripFront::replace(std::span<const FaceId> removed, std::span<const FaceId> added) {
  // A link (f, successor of f) changes only when f is removed or added, or when a face is removed or
  // inserted right after f: the faces listed below. Each surviving one appears in both lists, so its old
  // state is subtracted and its new one added.
  auto push_prev = [&](Index k) {
    const Index pk = keys_.prev(k);
    if (pk != kInvalid) links_.push_back(plan_->face_at(pk));
  };
  auto settle = [&](bool add) {
    std::sort(links_.begin(), links_.end());
    links_.erase(std::unique(links_.begin(), links_.end()), links_.end());
    for (FaceId l : links_) {
      if (!link_breaks(l)) continue;
      if (add) ++breaks_;
      else --breaks_;
    }
    links_.clear();
  };
  links_.clear();
  for (FaceId p : removed) {
    links_.push_back(p);
    push_prev(plan_->key(p));
  }
  for (FaceId g : added) push_prev(plan_->key(g));
  settle(false);
  for (FaceId p : removed) keys_.erase(plan_->key(p));
  for (FaceId g : added) keys_.insert(plan_->key(g));
  for (FaceId g : added) {
    links_.push_back(g);
    push_prev(plan_->key(g));
  }
  for (FaceId p : removed) push_prev(plan_->key(p));
  settle(true);
}

bool StripFront::link_breaks(FaceId f) const noexcept {
  const Index nk = keys_.next(plan_->key(f));
  return nk != kInvalid && !faces_share_edge(mt(), f, plan_->face_at(nk));
}

FaceId StripFront::first_face() const noexcept {
  const Index k = keys_.next(kInvalid);
  return k == kInvalid ? kInvalid : plan_->face_at(k);
}

FaceId StripFront::next_face(FaceId f) const noexcept {
  const Index k = keys_.next(plan_->key(f));
  return k == kInvalid ? kInvalid : plan_->face_at(k);
}

FaceId StripFront::prev_face(FaceId f) const noexcept {
  const Index k = keys_.prev(plan_->key(f));
  return k == kInvalid ? kInvalid : plan_->face_at(k);
}

std::vector<FaceId> StripFront::sequence() const {
  std::vector<FaceId> out;
  out.reserve(keys_.size());
  for (Index k = keys_.next(kInvalid); k != kInvalid; k = keys_.next(k)) out.push_back(plan_->face_at(k));
  return out;
}

StripRuns StripFront::runs() const {
  StripRuns out;
  FaceId prev = kInvalid;
  for (Index k = keys_.next(kInvalid); k != kInvalid; k = keys_.next(k)) {
    const FaceId f = plan_->face_at(k);
    if (prev == kInvalid || !faces_share_edge(mt(), prev, f)) out.emplace_back();
    out.back().push_back(f);
    prev = f;
  }
  return out;
}

void StripFront::validate() const {
  auto fail = [](const std::string& why, std::uint64_t e) { throw InvalidInput("StripFront::validate: " + why, e); };
  front_.validate();
  if (keys_.size() != front_.num_faces())
    fail("the strip holds " + std::to_string(keys_.size()) + " faces, the front " + std::to_string(front_.num_faces()),
         keys_.size());
  for (FaceId f : front_.faces())
    if (!keys_.contains(plan_->key(f))) fail("front face " + std::to_string(f) + " is not in the strip", f);
  std::size_t breaks = 0;
  for (Index k = keys_.next(kInvalid); k != kInvalid; k = keys_.next(k)) breaks += link_breaks(plan_->face_at(k));
  if (breaks != breaks_)
    fail("break count is stale (" + std::to_string(breaks_) + " kept, " + std::to_string(breaks) + " found)", breaks);
}

// From-scratch strips, checks and the index encoding.

StripRuns hierarchical_strip(const StripPlan& plan, std::span<const FaceId> faces) {
  check_face_ids("hierarchical_strip", plan.num_faces(), faces);
  std::vector<Index> keys;
  keys.reserve(faces.size());
  for (FaceId f : faces) keys.push_back(plan.key(f));
  std::sort(keys.begin(), keys.end());
  StripRuns out;
  FaceId prev = kInvalid;
  for (Index k : keys) {
    const FaceId f = plan.face_at(k);
    if (prev == kInvalid || !faces_share_edge(plan.mt(), prev, f)) out.emplace_back();
    out.back().push_back(f);
    prev = f;
  }
  return out;
}

StripRuns greedy_strip(const Mt& mt, std::span<const FaceId> faces, const GreedyStripOptions& options) {
  check_face_ids("greedy_strip", mt.num_faces(), faces);
  std::vector<FaceId> sorted(faces.begin(), faces.end());
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i] == sorted[i - 1])
      throw InvalidInput("greedy_strip: face " + std::to_string(sorted[i]) + " is listed twice", sorted[i]);
  DualPaths paths(mt, sorted, {});
  paths.solve(options.search_budget);
  StripRuns out;
  for (std::size_t i = 0; i < paths.order.size(); ++i) {
    if (i == 0 || paths.link[i] == 2) out.emplace_back();
    out.back().push_back(sorted[paths.order[i]]);
  }
  return out;
}

namespace {

// The encoder of encode_strip(); `out` may be null (counting only). Returns an empty string or the
// reason the runs cannot be encoded.
std::string encode_runs(const Mt& mt, const StripRuns& runs, std::span<const Index> vertex_map,
                        std::vector<Index>* out, std::size_t& swaps, std::size_t& count, std::size_t& bad_run) {
  swaps = 0;
  count = 0;
  auto emit = [&](VertexId v) {
    ++count;
    if (out) out->push_back(vertex_map.empty() ? v : vertex_map[v]);
  };
  for (std::size_t r = 0; r < runs.size(); ++r) {
    bad_run = r;
    const std::vector<FaceId>& run = runs[r];
    if (run.empty()) return "run " + std::to_string(r) + " is empty";
    for (std::size_t i = 0; i < run.size(); ++i)
      if (run[i] >= mt.num_faces()) return "run " + std::to_string(r) + " position " + std::to_string(i) + ": face " +
                                           std::to_string(run[i]) + " is not a face of the Mt";
    if (!vertex_map.empty())
      for (FaceId f : run)
        for (VertexId v : mt.face(f)) {
          if (v >= vertex_map.size())
            return "vertex " + std::to_string(v) + " of face " + std::to_string(f) + " is outside vertex_map";
          if (vertex_map[v] == kStripRestart)
            return "vertex_map sends vertex " + std::to_string(v) + " to the restart marker";
        }
    if (r > 0) {
      ++count;
      if (out) out->push_back(kStripRestart);
    }
    std::size_t seg = 0;  // indices emitted in this segment (the next one closes triangle seg - 2)
    // Last three emitted Mt vertices: z, x, y (y last).
    VertexId z, x, y;
    Corners c = mt.face(run[0]);
    if (run.size() >= 2) {
      VertexId u, v;
      if (!shared_edge(c, mt.face(run[1]), u, v))
        return "run " + std::to_string(r) + " position 1: faces " + std::to_string(run[0]) + " and " +
               std::to_string(run[1]) + " share no edge";
      while (c[0] == u || c[0] == v) c = {c[1], c[2], c[0]};  // start at the corner off the shared edge
    }
    z = c[0];
    x = c[1];
    y = c[2];
    emit(z);
    emit(x);
    emit(y);
    seg = 3;
    for (std::size_t i = 1; i < run.size(); ++i) {
      const Corners g = mt.face(run[i]);
      VertexId u, v;
      if (!shared_edge(mt.face(run[i - 1]), g, u, v))
        return "run " + std::to_string(r) + " position " + std::to_string(i) + ": faces " + std::to_string(run[i - 1]) +
               " and " + std::to_string(run[i]) + " share no edge";
      const bool on_last_two = (u == x && v == y) || (u == y && v == x);
      if (!on_last_two) {
        ++swaps;
        if (u == y || v == y) {  // edge (z, y): repeat y and z (two degenerate triangles)
          emit(y);
          emit(z);
          x = y;
          y = z;
          seg += 2;
        } else {  // edge (z, x): only on inconsistent input; three repeats
          emit(x);
          emit(x);
          emit(z);
          y = z;
          seg += 3;
        }
      }
      VertexId w = kInvalid;
      for (VertexId t : g)
        if (t != x && t != y) w = t;
      // Winding of the triangle w closes: (x, y, w) at an even index, (y, x, w) at an odd one.
      const std::size_t tri = seg - 2;
      const Corners made = (tri % 2 == 0) ? Corners{x, y, w} : Corners{y, x, w};
      const bool same = (made[0] == g[0] && made[1] == g[1] && made[2] == g[2]) ||
                        (made[0] == g[1] && made[1] == g[2] && made[2] == g[0]) ||
                        (made[0] == g[2] && made[1] == g[0] && made[2] == g[1]);
      if (!same) {  // parity fix: repeat x (a degenerate triangle), flipping the next winding
        ++swaps;
        emit(x);
        std::swap(x, y);
        ++seg;
      }
      emit(w);
      ++seg;
      z = x;
      x = y;
      y = w;
    }
  }
  return {};
}

}  // namespace

StripCheck check_strip(const Mt& mt, std::span<const FaceId> faces, const StripRuns& runs) {
  StripCheck out;
  out.num_runs = runs.size();
  std::vector<std::uint8_t> state(mt.num_faces(), 0);  // 1: expected, 2: seen
  for (FaceId f : faces)
    if (f < state.size()) state[f] = 1;
  auto problem = [&](const std::string& why) {
    if (out.problem.empty()) out.problem = why;
  };
  for (FaceId f : faces)
    if (f >= state.size()) problem("face " + std::to_string(f) + " of the face set is not a face of the Mt");
  for (std::size_t r = 0; r < runs.size(); ++r) {
    if (runs[r].empty()) problem("run " + std::to_string(r) + " is empty");
    for (std::size_t i = 0; i < runs[r].size(); ++i) {
      const FaceId f = runs[r][i];
      ++out.num_faces;
      const std::string where = "run " + std::to_string(r) + " position " + std::to_string(i);
      if (f >= state.size()) {
        problem(where + ": face " + std::to_string(f) + " is not a face of the Mt");
        continue;
      }
      if (state[f] == 0) problem(where + ": face " + std::to_string(f) + " is not in the face set");
      if (state[f] == 2) problem(where + ": face " + std::to_string(f) + " appears twice");
      state[f] = 2;
      if (i > 0 && runs[r][i - 1] < state.size() && !faces_share_edge(mt, runs[r][i - 1], f))
        problem(where + ": faces " + std::to_string(runs[r][i - 1]) + " and " + std::to_string(f) + " share no edge");
    }
  }
  for (FaceId f : faces)
    if (f < state.size() && state[f] == 1) problem("face " + std::to_string(f) + " is missing from the strip");
  out.ok = out.problem.empty();
  if (out.ok) {
    std::size_t bad_run = 0;
    const std::string why = encode_runs(mt, runs, {}, nullptr, out.num_swaps, out.num_indices, bad_run);
    if (!why.empty()) {
      out.ok = false;
      out.problem = why;
    }
  }
  return out;
}

std::vector<Index> encode_strip(const Mt& mt, const StripRuns& runs, std::span<const Index> vertex_map,
                                std::size_t* num_swaps) {
  std::vector<Index> out;
  std::size_t swaps = 0, count = 0, bad_run = 0;
  const std::string why = encode_runs(mt, runs, vertex_map, &out, swaps, count, bad_run);
  if (!why.empty()) throw InvalidInput("encode_strip: " + why, bad_run);
  if (num_swaps) *num_swaps = swaps;
  return out;
}

std::vector<std::array<VertexId, 3>> decode_strip(std::span<const Index> indices) {
  std::vector<std::array<VertexId, 3>> out;
  std::size_t seg_begin = 0;
  for (std::size_t i = 0; i <= indices.size(); ++i) {
    if (i < indices.size() && indices[i] != kStripRestart) continue;
    for (std::size_t j = seg_begin; j + 2 < i; ++j) {
      const Index a = indices[j], b = indices[j + 1], c = indices[j + 2];
      if (a == b || b == c || a == c) continue;
      if ((j - seg_begin) % 2 == 0) out.push_back({a, b, c});
      else out.push_back({b, a, c});
    }
    seg_begin = i + 1;
  }
  return out;
}

}  // namespace varmesh
