// VertexHierarchy as a value: copies, moves, and the empty hierarchy a default construction or a move
// leaves behind; validate() split over two threads against the serial one.
#include "pm/vertex_hierarchy.hpp"

#include <cstdint>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "multitri/errors.hpp"
#include "multitri/query.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"
#include "pm_fixtures.hpp"

namespace varmesh {
namespace {

static_assert(std::is_nothrow_default_constructible_v<VertexHierarchy>);
static_assert(std::is_nothrow_move_constructible_v<VertexHierarchy> && std::is_nothrow_move_assignable_v<VertexHierarchy>);

// Every observable of the empty hierarchy, and that what reads a hierarchy takes it.
void expect_empty(const VertexHierarchy& h) {
  EXPECT_EQ(h.num_leaves(), 0u);
  EXPECT_EQ(h.num_nodes(), 0u);
  EXPECT_EQ(h.num_collapses(), 0u);
  EXPECT_EQ(h.num_faces(), 0u);
  EXPECT_EQ(h.num_roots(), 0u);
  EXPECT_EQ(h.max_depth(), 0);
  EXPECT_FALSE(h.has_colors());
  EXPECT_TRUE(h.positions().empty());
  EXPECT_TRUE(h.face_corners().empty());
  EXPECT_TRUE(h.base_faces().empty());
  EXPECT_TRUE(h.leaf_to_input().empty());
  EXPECT_TRUE(h.face_to_input().empty());
  EXPECT_EQ(h.repair_report().input_vertices, 0u);
  EXPECT_EQ(h.repair_report().input_faces, 0u);
  EXPECT_EQ(h.memory_bytes(), 0u);
  EXPECT_FALSE(h.is_leaf(0));
  EXPECT_NO_THROW(h.validate());
  EXPECT_THROW(encode_vertex_hierarchy(h), InvalidInput);  // "never built"
  EXPECT_THROW(mesh_after_collapses(h, 1), InvalidInput);
  EXPECT_EQ(mesh_after_collapses(h, 0).num_faces(), 0u);
  SrMesh sr(h);
  Query q;
  extract(sr, q);
  EXPECT_EQ(sr.num_faces(), 0u);
  sr.validate();
}

TEST(VertexHierarchy, DefaultIsEmpty) { expect_empty(VertexHierarchy{}); }

// A moved-from hierarchy is the empty one (the implicit move left num_leaves() at the old count over
// emptied arrays: 96 leaves and no node), and the moved-to one is the original, byte for byte in its file.
TEST(VertexHierarchy, MovedFromIsEmptyAndMovedToIsTheOriginal) {
  const TriMesh m = make_torus(12, 8);
  const VertexHierarchy reference = build_vertex_hierarchy(m);
  const std::vector<std::uint8_t> bytes = encode_vertex_hierarchy(reference);

  VertexHierarchy a = reference;  // a copy
  EXPECT_EQ(encode_vertex_hierarchy(a), bytes);
  VertexHierarchy b(std::move(a));
  expect_empty(a);
  EXPECT_EQ(encode_vertex_hierarchy(b), bytes);
  b.validate();

  VertexHierarchy c = build_vertex_hierarchy(make_icosphere(2));
  c = std::move(b);  // over a hierarchy with arrays of its own
  expect_empty(b);
  EXPECT_EQ(encode_vertex_hierarchy(c), bytes);
  a = std::move(c);  // into a moved-from one
  expect_empty(c);
  EXPECT_EQ(encode_vertex_hierarchy(a), bytes);
  b = a;  // a copy into a moved-from one
  EXPECT_EQ(encode_vertex_hierarchy(b), bytes);

  SrMesh sr(a);
  sr.refine_all();
  sr.validate();
  EXPECT_EQ(sr.num_faces(), reference.num_faces());
}

// What validate(threads) throws ("" when it passes).
std::string validate_error(const VertexHierarchy& h, unsigned threads) {
  try {
    h.validate(threads);
  } catch (const std::logic_error& e) {
    return e.what();
  }
  return "";
}

// The oracle of the split validation: on hierarchies edited so that finish() still takes them (its structural
// checks only), the serial run and the two-thread run agree on whether they pass and on the error. Edits fall
// anywhere in the records, so the failures land in both parts of the split replay, and pairs of edits (one
// early, one late) check that the earlier failure is the one reported.
TEST(VertexHierarchy, SplitValidationReportsTheSerialError) {
  const VertexHierarchy good = build_vertex_hierarchy(testing::make_grid(16, 13));
  ASSERT_EQ(validate_error(good, 1), "");
  ASSERT_EQ(validate_error(good, 2), "");
  const VertexHierarchyBuilder::Raw base = testing::raw_of(good);
  const std::size_t nl = good.num_leaves(), nn = good.num_nodes(), nc = good.num_collapses(), nf = good.num_faces();
  ASSERT_GT(nc, 100u);
  std::mt19937 rng(20261125);
  auto pick = [&](std::size_t n) { return static_cast<std::size_t>(rng() % n); };
  auto edit_record = [&](VertexHierarchyBuilder::Raw& raw, std::size_t i) {
    CollapseRecord& r = raw.records[i];
    Index* fields[] = {&r.vt, &r.vu, &r.vl_hat, &r.vr_hat, &r.fl_hat, &r.fr_hat, &r.fn[0], &r.fn[1], &r.fn[2], &r.fn[3]};
    const std::size_t k = pick(10);
    const std::size_t range = k < 2 ? nl + i : (k < 4 ? nl : nf);
    *fields[k] = rng() % 2 == 0 ? static_cast<Index>(pick(range)) : *fields[k] + 1;
  };
  std::size_t refused_by_finish = 0, passed = 0, failed = 0, failed_late = 0;
  for (int trial = 0; trial < 1500; ++trial) {
    VertexHierarchyBuilder::Raw raw = base;
    switch (trial % 5) {
      case 0:
      case 1:
        edit_record(raw, pick(nc));
        break;
      case 2:  // a stored ring item
        if (!raw.ring_items.empty()) raw.ring_items[pick(raw.ring_items.size())] = static_cast<Index>(pick(nn));
        break;
      case 3: {  // a face corner moved to a nearby leaf, or two records' fn swapped
        if (trial % 2 == 0) {
          Index& c = raw.faces[pick(raw.faces.size())];
          c = static_cast<Index>((c + 1 + pick(3)) % nl);
        } else {
          std::swap(raw.records[pick(nc)].fn[pick(4)], raw.records[pick(nc)].fn[pick(4)]);
        }
        break;
      }
      case 4:  // two edits: one in the first half of the collapses, one in the last fifth
        edit_record(raw, pick(nc / 2));
        edit_record(raw, nc - 1 - pick(nc / 5));
        break;
    }
    VertexHierarchy h;
    try {
      h = VertexHierarchyBuilder::finish(std::move(raw), false);
    } catch (const InvalidInput&) {
      ++refused_by_finish;
      continue;
    }
    const std::string serial = validate_error(h, 1);
    SCOPED_TRACE("trial " + std::to_string(trial) + ": " + serial);
    ASSERT_EQ(validate_error(h, 2), serial);
    ASSERT_EQ(validate_error(h, 0), serial);
    if (serial.empty()) {
      ++passed;
      continue;
    }
    ++failed;
    // A replay failure in the last fifth of the collapses: in the second part of the split.
    const std::size_t at = serial.find("node ");
    if (serial.find("replaying the collapses") != std::string::npos && at != std::string::npos &&
        std::stoul(serial.substr(at + 5)) >= nl + nc - nc / 5)
      ++failed_late;
  }
  std::printf("split validation: %zu refused by finish, %zu passed, %zu failed (%zu in the last fifth)\n",
              refused_by_finish, passed, failed, failed_late);
  EXPECT_GT(refused_by_finish, 0u);
  EXPECT_GT(passed, 0u);
  EXPECT_GT(failed, 100u);
  EXPECT_GT(failed_late, 10u) << "too few failures in the second part of the replay to test it";
}

}  // namespace
}  // namespace varmesh
