#pragma once
// Slow oracles shared by the test suites.
#include <algorithm>
#include <cstdint>
#include <functional>

#include "multitri/mt.hpp"
#include "multitri/mt_front.hpp"

namespace varmesh::testing {

/// Number of fronts of a small MT by brute force: every subset of the non-source nodes that is closed
/// under parents (at most ~24 nodes).
inline std::uint64_t brute_force_fronts(const Mt& mt) {
  const std::size_t n = mt.num_nodes() - 1;
  std::uint64_t count = 0;
  for (std::uint64_t s = 0; s < (std::uint64_t(1) << n); ++s) {
    bool ok = true;
    for (NodeId v = 1; v <= n && ok; ++v)
      if (s >> (v - 1) & 1u)
        for (NodeId p : mt.parents(v))
          if (p != 0 && !(s >> (p - 1) & 1u)) ok = false;
    count += ok;
  }
  return count;
}

/// The largest chain growth (mt_metrics.hpp, ChainGrowth) by brute force on a small MT: every chain (path of
/// non-source nodes, each a parent of the next) is enumerated, and its cumulative application is measured
/// by refining its last node in a fresh MtFront (which applies exactly the ancestors) and counting faces.
inline double brute_force_chain_growth(const Mt& mt) {
  const double base = static_cast<double>(mt.image_size(Mt::source()));
  double best = 0.0;
  for (NodeId end = 1; end < mt.num_nodes(); ++end) {
    MtFront front(mt);
    front.refine(end);
    const double mesh = static_cast<double>(front.num_faces());
    // Every path into `end`, by its image sum.
    std::function<void(NodeId, double)> walk = [&](NodeId v, double images) {
      images += static_cast<double>(mt.image_size(v));
      best = std::max(best, (base + images) / mesh);
      for (NodeId p : mt.parents(v))
        if (p != Mt::source()) walk(p, images);
    };
    walk(end, 0.0);
  }
  return best;
}

}  // namespace varmesh::testing
