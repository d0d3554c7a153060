#pragma once
// Slow oracles shared by the test suites.
#include <cstdint>

#include "multitri/mt.hpp"

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

}  // namespace varmesh::testing
