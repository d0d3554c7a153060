// The correctness oracle of Kim-Lee selective refinement (issue 3, section 2): every mesh reached by random
// vsplit/ecol sequences equals the mesh its active vertex set defines through dual pieces, built
// independently from the original mesh (pm/dual_pieces.hpp).
#include "pm/sr_mesh.hpp"

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/mesh_io.hpp"
#include "pm/dual_pieces.hpp"
#include "pm/qem_analysis.hpp"
#include "pm_fixtures.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

using testing::make_grid;
using testing::make_icosphere;
using testing::make_torus;

std::array<Index, 3> rotate_min_first(std::array<Index, 3> c) {
  while (c[0] > c[1] || c[0] > c[2]) c = {c[1], c[2], c[0]};
  return c;
}

// Compares the SrMesh with the dual-piece mesh of its active set; returns a description of the first
// difference, or "" when they agree.
std::string compare_with_oracle(const SrMesh& sr) {
  const VertexHierarchy& h = sr.hierarchy();
  std::vector<std::uint8_t> active(h.num_nodes(), 0);
  for (Index v : sr.active_vertices()) active[v] = 1;
  const std::vector<Index> anc = active_ancestors(h, active);
  const auto ref = dual_piece_mesh(h, anc);
  if (ref.size() != sr.num_faces()) return "face count " + std::to_string(sr.num_faces()) + " vs oracle " + std::to_string(ref.size());
  std::set<std::array<Index, 3>> unordered;
  std::set<std::pair<Index, Index>> directed;
  for (const DualPieceFace& f : ref) {
    if (!sr.face_active(f.original)) return "oracle face " + std::to_string(f.original) + " inactive";
    if (rotate_min_first(sr.face(f.original)) != rotate_min_first(f.corners)) return "face " + std::to_string(f.original) + " corners differ";
    auto s = f.corners;
    std::sort(s.begin(), s.end());
    if (!unordered.insert(s).second) return "oracle face repeated: " + std::to_string(f.original);
    for (int k = 0; k < 3; ++k)
      if (!directed.insert({f.corners[k], f.corners[(k + 1) % 3]}).second) return "directed edge used twice (not manifold/oriented)";
  }
  // Every active vertex is a corner of some face (no isolated dual piece).
  std::vector<std::uint8_t> used(h.num_nodes(), 0);
  for (const DualPieceFace& f : ref)
    for (Index c : f.corners) used[c] = 1;
  for (Index v : sr.active_vertices())
    if (!used[v]) return "active vertex " + std::to_string(v) + " has no face";
  return "";
}

bool same_as_original(const SrMesh& sr) {
  const VertexHierarchy& h = sr.hierarchy();
  if (sr.num_faces() != h.num_faces()) return false;
  for (Index f = 0; f < h.num_faces(); ++f)
    if (!sr.face_active(f) || rotate_min_first(sr.face(f)) != rotate_min_first(h.face(f))) return false;
  return true;
}

bool at_base(const SrMesh& sr) {
  auto act = sr.active_vertices();
  std::vector<Index> roots(sr.hierarchy().roots().begin(), sr.hierarchy().roots().end());
  std::sort(act.begin(), act.end());
  std::sort(roots.begin(), roots.end());
  return act == roots;
}

struct WalkResult {
  std::size_t splits = 0, collapses = 0, postponed = 0, checks = 0;
};

// Random walk of vsplit/ecol requests; the oracle every `check_every` steps, the local truly-selective
// property at every non-degenerate Kim-Lee split.
WalkResult random_walk(SrMesh& sr, std::size_t steps, std::uint32_t seed, std::size_t check_every, double split_bias = 0.55) {
  const VertexHierarchy& h = sr.hierarchy();
  std::mt19937 rng(seed);
  std::uniform_int_distribution<Index> pick(static_cast<Index>(h.num_leaves()), static_cast<Index>(h.num_nodes() - 1));
  std::bernoulli_distribution want_split(split_bias);
  WalkResult res;
  for (std::size_t step = 0; step < steps; ++step) {
    const bool split = want_split(rng);
    for (int attempt = 0; attempt < 64; ++attempt) {
      const Index v = pick(rng);
      if (split && sr.is_active(v)) {
        const std::size_t dc = sr.stats().degenerate_cases, forced = sr.stats().forced_vsplits;
        const std::size_t active_before = sr.num_active_vertices();
        const CollapseRecord r = h.record(v);
        EXPECT_TRUE(sr.vsplit(v));
        EXPECT_FALSE(sr.is_active(v));
        EXPECT_TRUE(sr.is_active(r.vt) && sr.is_active(r.vu));
        if (sr.scheme() == RefinementScheme::kKimLee && sr.stats().degenerate_cases == dc && sr.stats().forced_vsplits == forced) {
          // Truly selective: exactly one vertex became two.
          EXPECT_EQ(sr.num_active_vertices(), active_before + 1) << "vsplit of " << v;
        }
        ++res.splits;
        break;
      }
      if (!split && sr.state(v) == SrMesh::State::kRefined && sr.is_active(h.vt(v)) && sr.is_active(h.vu(v))) {
        const std::size_t active_before = sr.num_active_vertices();
        if (sr.ecol(v)) {
          ++res.collapses;
          if (sr.scheme() == RefinementScheme::kKimLee) {
            EXPECT_EQ(sr.num_active_vertices(), active_before - 1);
          }
        } else {
          ++res.postponed;
        }
        break;
      }
    }
    if ((step + 1) % check_every == 0 || step + 1 == steps) {
      sr.validate();
      const std::string diff = compare_with_oracle(sr);
      EXPECT_EQ(diff, "") << "after step " << step;
      if (!diff.empty()) return res;
      ++res.checks;
    }
  }
  return res;
}

VertexHierarchy full_hierarchy(const TriMesh& m) {
  QemOptions opt;  // down to the smallest base mesh
  return build_vertex_hierarchy(m, opt);
}

TEST(SrMesh, StartsAtBaseAndMatchesOracle) {
  const VertexHierarchy h = full_hierarchy(make_icosphere(2));
  SrMesh sr(h);
  sr.validate();
  EXPECT_TRUE(at_base(sr));
  EXPECT_EQ(compare_with_oracle(sr), "");
  EXPECT_EQ(sr.num_faces(), h.base_faces().size());
}

TEST(SrMesh, RefineAllGivesOriginalAndCoarsenAllGivesBase) {
  for (const TriMesh& m : {make_icosphere(3), make_grid(12, 9), make_torus(16, 10),
                           testing::concat(make_icosphere(1), make_grid(5, 5), {3, 0, 0})}) {
    const VertexHierarchy h = full_hierarchy(m);
    for (RefinementScheme s : {RefinementScheme::kKimLee, RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney}) {
      SrMesh sr(h, s);
      sr.refine_all();
      sr.validate();
      EXPECT_TRUE(same_as_original(sr)) << scheme_name(s);
      EXPECT_EQ(sr.num_active_vertices(), h.num_leaves());
      sr.coarsen_all();
      sr.validate();
      EXPECT_TRUE(at_base(sr)) << scheme_name(s) << ": coarsen_all stopped at " << sr.num_active_vertices() << " vertices";
      EXPECT_EQ(compare_with_oracle(sr), "");
    }
  }
}

TEST(SrMesh, RandomWalksMatchDualPieceOracleKimLee) {
  std::size_t total = 0, dc = 0;
  int seed = 1;
  for (const TriMesh& m : {make_icosphere(3), make_grid(20, 14), make_torus(24, 12)}) {
    const VertexHierarchy h = full_hierarchy(m);
    SrMesh sr(h);
    const WalkResult r = random_walk(sr, 40000, static_cast<std::uint32_t>(seed++), 500);
    total += r.splits + r.collapses;
    dc += sr.stats().degenerate_cases;
    EXPECT_GT(r.collapses, 1000u);
    EXPECT_GT(r.splits, 1000u);
  }
  EXPECT_GE(total, 100000u);
  RecordProperty("degenerate_cases", static_cast<int>(dc));
}

TEST(SrMesh, RandomWalksMatchOracleForBaselines) {
  const VertexHierarchy h = full_hierarchy(make_grid(16, 12));
  for (RefinementScheme s : {RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney}) {
    SrMesh sr(h, s);
    const WalkResult r = random_walk(sr, 6000, 7, 250);
    EXPECT_GT(r.splits, 100u) << scheme_name(s);
  }
}

TEST(SrMesh, KimLeeNeverForces) {
  const VertexHierarchy h = full_hierarchy(make_torus(20, 10));
  SrMesh sr(h);
  random_walk(sr, 5000, 3, 1000);
  EXPECT_EQ(sr.stats().forced_vsplits, 0u);
  EXPECT_EQ(sr.stats().forced_ecols, 0u);
}

// SrMesh stores faces in its own (vsplit) order; the API must still speak original face ids: neighbor()
// names the active face across each edge, for_each_face visits faces in increasing id order.
TEST(SrMesh, NeighborsAndFaceOrderUseOriginalFaceIds) {
  for (const TriMesh& m : {make_torus(16, 10), make_grid(12, 9)}) {
    const VertexHierarchy h = full_hierarchy(m);
    SrMesh sr(h);
    random_walk(sr, 3000, 5, 3000);
    std::vector<Index> visited;
    sr.for_each_face([&](Index f, Index a, Index b, Index c) {
      visited.push_back(f);
      EXPECT_EQ(sr.face(f), (std::array<Index, 3>{a, b, c}));
    });
    EXPECT_TRUE(std::is_sorted(visited.begin(), visited.end()));
    EXPECT_EQ(visited.size(), sr.num_faces());
    for (Index f : visited)
      for (int k = 0; k < 3; ++k) {
        const Index g = sr.neighbor(f, k);
        if (g == kInvalid) continue;  // a border edge
        ASSERT_LT(g, h.num_faces());
        ASSERT_TRUE(sr.face_active(g));
        const auto fc = sr.face(f), gc = sr.face(g);
        const Index a = fc[static_cast<std::size_t>(k)], b = fc[static_cast<std::size_t>((k + 1) % 3)];
        bool reversed = false;
        for (int j = 0; j < 3; ++j)
          reversed = reversed || (gc[static_cast<std::size_t>(j)] == b && gc[static_cast<std::size_t>((j + 1) % 3)] == a);
        EXPECT_TRUE(reversed) << "face " << f << " edge " << k << " neighbour " << g;
      }
  }
}

// The candidate listings (refine: filtered from the active list; coarsen: the collapsible list that every
// vsplit and ecol keeps) against a scan of every node, after walks and after reset(); state() (kept in
// the node slots) against is_active/is_refined.
TEST(SrMesh, CandidateListingsMatchAScanOfAllNodes) {
  const VertexHierarchy h = full_hierarchy(make_torus(24, 12));
  for (const RefinementScheme scheme :
       {RefinementScheme::kKimLee, RefinementScheme::kHoppe97, RefinementScheme::kXiaVarshney}) {
    SrMesh sr(h, scheme);
    std::mt19937 rng(17);
    for (int round = 0; round < 12; ++round) {
      if (round == 9) sr.reset();
      random_walk(sr, 700, static_cast<std::uint32_t>(rng()), 700, round < 6 ? 0.65 : 0.4);
      std::vector<Index> refine, coarsen, want_refine, want_coarsen;
      sr.for_each_refine_candidate([&](Index e) { refine.push_back(e); });
      sr.for_each_coarsen_candidate([&](Index e) { coarsen.push_back(e); });
      for (Index v = 0; v < h.num_nodes(); ++v) {
        const SrMesh::State st = sr.state(v);
        EXPECT_EQ(st == SrMesh::State::kActive, sr.is_active(v)) << v;
        EXPECT_EQ(st == SrMesh::State::kRefined, sr.is_refined(v)) << v;
        if (h.is_leaf(v)) continue;
        if (st == SrMesh::State::kActive) want_refine.push_back(v);
        if (st == SrMesh::State::kRefined && sr.is_active(h.vt(v)) && sr.is_active(h.vu(v))) want_coarsen.push_back(v);
      }
      std::sort(refine.begin(), refine.end());
      std::sort(coarsen.begin(), coarsen.end());
      EXPECT_EQ(refine, want_refine) << "round " << round;
      EXPECT_EQ(coarsen, want_coarsen) << "round " << round << " scheme " << static_cast<int>(scheme);
    }
  }
}

// A copied (and a moved) mesh carries its node lists: walking the copy and the original the same way keeps
// both valid and equal, including refine_all/coarsen_all, whose collapsible list is rebuilt at the end.
TEST(SrMesh, CopiesAndMovesKeepTheirNodeLists) {
  const VertexHierarchy h = full_hierarchy(make_torus(20, 10));
  SrMesh a(h);
  random_walk(a, 500, 3, 500);
  SrMesh b = a;
  SrMesh c(h);
  c = b;
  SrMesh d = std::move(c);
  auto coarsen_list = [](const SrMesh& m) {
    std::vector<Index> out;
    m.for_each_coarsen_candidate([&](Index e) { out.push_back(e); });
    std::sort(out.begin(), out.end());
    return out;
  };
  for (SrMesh* m : {&a, &b, &d}) {
    random_walk(*m, 400, 9, 400);
    m->validate();
  }
  EXPECT_EQ(coarsen_list(a), coarsen_list(b));
  EXPECT_EQ(coarsen_list(a), coarsen_list(d));
  b.refine_all();
  b.validate();
  EXPECT_TRUE(coarsen_list(b).size() > 0u);
  b.coarsen_all();
  b.validate();
  d.reset();
  d.validate();
  EXPECT_EQ(coarsen_list(b), coarsen_list(d));  // both at the base mesh
  EXPECT_EQ(b.num_faces(), d.num_faces());
}

// vsplit finds the cut vertices of splits done in decreasing node order (the PM order) without the
// section 4.3 keys, and of other splits with them: PM-order splits after a selective walk (a mix of
// both cases) still give the oracle's meshes and end at the original mesh.
TEST(SrMesh, PmOrderSplitsAfterASelectiveWalkMatchOracle) {
  for (const TriMesh& m : {make_icosphere(3), make_grid(16, 12)}) {
    const VertexHierarchy h = full_hierarchy(m);
    SrMesh sr(h);
    random_walk(sr, 300, 23, 300);
    std::size_t done = 0;
    for (std::size_t v = h.num_nodes(); v-- > h.num_leaves();) {
      if (!sr.is_active(static_cast<Index>(v))) continue;
      EXPECT_TRUE(sr.vsplit(static_cast<Index>(v)));
      if (++done % 97 == 0) {
        sr.validate();
        ASSERT_EQ(compare_with_oracle(sr), "") << "after the split of " << v;
      }
    }
    sr.validate();
    EXPECT_TRUE(same_as_original(sr));
    EXPECT_GT(done, 100u);
  }
}

TEST(SrMesh, RejectsBadRequests) {
  const VertexHierarchy h = full_hierarchy(make_icosphere(1));
  SrMesh sr(h);
  EXPECT_THROW(sr.vsplit(static_cast<Index>(h.num_nodes())), InvalidInput);
  EXPECT_THROW(sr.vsplit(0), InvalidInput);  // a leaf
  const Index root = h.roots()[0];
  if (!h.is_leaf(root)) {
    EXPECT_THROW(sr.ecol(root), InvalidInput);  // children inactive
  }
}

TEST(SrMesh, RealMeshesRandomWalks) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bunny_libigl_3485v.off");
  std::size_t steps = 0;
  for (const char* rel : {"meshes/bunny_libigl_3485v.off", "meshes/cow_viewpoint_2903v.obj", "meshes/dragon_vrip_res4_5205v.ply"}) {
    const TriMesh m = read_mesh(testing::shared_data(rel));
    const VertexHierarchy h = full_hierarchy(m);
    SrMesh sr(h);
    sr.refine_all();
    EXPECT_TRUE(same_as_original(sr)) << rel;
    sr.coarsen_all();
    EXPECT_TRUE(at_base(sr)) << rel;
    const WalkResult r = random_walk(sr, 35000, 11, 2500);
    steps += r.splits + r.collapses;
  }
  EXPECT_GE(steps, 100000u);
}

}  // namespace
}  // namespace varmesh
