#pragma once
// Test helper shared by the Grid48Front tests: the front's candidate listings against the boundary of its
// refined set computed by definition.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "fourk/grid48.hpp"

namespace varmesh::testing {

// The exposed diamonds (not refined, a root or with a refined parent) and the maximal ones (refined, with no
// refined child), from is_refined alone, against for_each_refine_candidate / for_each_coarsen_candidate.
inline void expect_candidates_by_definition(const Grid48Front& fr, const char* what = "") {
  const Grid48& g = fr.grid();
  std::vector<Index> exposed, maximal, listed_exposed, listed_maximal;
  for (Index p = 0; p < g.num_points(); ++p) {
    if (!g.is_node(p)) continue;
    if (fr.is_refined(p)) {
      bool leaf = true;
      g.for_each_child(p, [&](Index c) { leaf = leaf && !fr.is_refined(c); });
      if (leaf) maximal.push_back(p);
    } else {
      bool any = g.level(p) == 0;
      g.for_each_parent(p, [&](Index q) { any = any || fr.is_refined(q); });
      if (any) exposed.push_back(p);
    }
  }
  fr.for_each_refine_candidate([&](Index p) { listed_exposed.push_back(p); });
  fr.for_each_coarsen_candidate([&](Index p) { listed_maximal.push_back(p); });
  std::sort(listed_exposed.begin(), listed_exposed.end());
  std::sort(listed_maximal.begin(), listed_maximal.end());
  EXPECT_EQ(listed_exposed, exposed) << what;
  EXPECT_EQ(listed_maximal, maximal) << what;
}

}  // namespace varmesh::testing
