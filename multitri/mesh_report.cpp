// Topology report of a triangle mesh (mesh_report.hpp).
//
// Every count follows the definitions of ../shared/data/tools/meshstat.py, so that the numbers in
// MANIFEST.md are an independent oracle for the tests. The algorithms differ from that script: instead of
// hashing tuples, half-edges go into a bucket table (offsets + items, filled by a counting sort on their
// smaller vertex, each short bucket then sorted), one scan of which gives edges, boundary, non-manifold edges
// and duplicate faces; connectivity is union-find over flat arrays: vertices for components and boundary
// loops, corners for the fans around each vertex. Coincident positions are counted in a hash table keyed on
// the coordinates' bit patterns.
// Zero-area faces use an exact collinearity test (detail/topology.hpp, after Shewchuk 1997).
#include "multitri/mesh_report.hpp"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "multitri/detail/topology.hpp"
#include "multitri/errors.hpp"

namespace varmesh {
namespace {

using detail::DisjointSets;

constexpr std::uint64_t pack(Index hi, Index lo) noexcept { return (std::uint64_t{hi} << 32) | lo; }
constexpr Index high(std::uint64_t key) noexcept { return static_cast<Index>(key >> 32); }
constexpr Index low(std::uint64_t key) noexcept { return static_cast<Index>(key & 0xffffffffu); }

// Buckets hold a handful of keys (a vertex is the smaller end of about three edges), so insertion sort wins;
// a hub vertex with a long fan falls back to std::sort to keep the whole O(F log F).
void sort_bucket(std::uint64_t* first, std::uint64_t* last) {
  // An empty bucket may be a null range (no edge at all: every face degenerate), where first + 1 is
  // undefined; a single key is sorted already.
  if (last - first < 2) return;
  if (last - first > 16) {
    std::sort(first, last);
    return;
  }
  for (std::uint64_t* i = first + 1; i < last; ++i) {
    const std::uint64_t key = *i;
    std::uint64_t* j = i;
    for (; j > first && *(j - 1) > key; --j) *j = *(j - 1);
    *j = key;
  }
}

// Counting sort of (bucket, key) pairs into offsets + items, then each bucket sorted by key.
// `for_each_pair(emit)` is called twice (count, then fill) and must emit the same pairs both times;
// offsets ends with size num_buckets + 1.
template <class Emit>
void build_buckets(std::size_t num_buckets, Emit&& for_each_pair, std::vector<Index>& offsets,
                   std::vector<std::uint64_t>& items) {
  offsets.assign(num_buckets, 0);
  for_each_pair([&](Index bucket, std::uint64_t) { ++offsets[bucket]; });
  // Inclusive prefix sums, then place each item at --end of its bucket: the ends become the starts.
  Index total = 0;
  for (auto& c : offsets) {
    total += c;
    c = total;
  }
  items.resize(total);
  for_each_pair([&](Index bucket, std::uint64_t key) { items[--offsets[bucket]] = key; });
  offsets.push_back(total);
  for (std::size_t b = 0; b < num_buckets; ++b) sort_bucket(items.data() + offsets[b], items.data() + offsets[b + 1]);
}

// The corner of half-edge h (= 3f + k, running from corner k to corner k+1 of face f) that holds vertex v.
Index corner_at(const std::vector<Index>& idx, Index h, Index v) noexcept {
  const Index k = h % 3;
  return idx[h] == v ? h : h - k + (k + 1) % 3;
}

// The vertex of half-edge h's face that is not on h.
Index third_vertex(const std::vector<Index>& idx, Index h) noexcept {
  const Index k = h % 3;
  return idx[h - k + (k + 2) % 3];
}

// Python's floor division, which meshstat.py uses for the genus.
long long floor_half(long long x) noexcept { return x >= 0 ? x / 2 : -((-x + 1) / 2); }

// Vertex flags, one byte per vertex.
constexpr std::uint8_t kUsed = 1;      // corner of a non-degenerate face
constexpr std::uint8_t kBoundary = 2;  // end of a boundary edge
constexpr std::uint8_t kOneFan = 4;    // at least one fan seen
constexpr std::uint8_t kTwoFans = 8;   // a second fan seen: non-manifold vertex

// Bit pattern of a finite coordinate with -0 folded onto +0: two finite floats are equal exactly when these
// patterns are (NaN, the one exception, cannot occur: TriMesh::validate() rejects it).
std::uint32_t place_bits(float x) noexcept {
  const auto b = std::bit_cast<std::uint32_t>(x);
  return b == 0x80000000u ? 0u : b;
}

struct Place {
  std::uint32_t x, y, z;
  bool operator==(const Place&) const = default;
};

Place place_of(const glm::vec3& p) noexcept { return {place_bits(p.x), place_bits(p.y), place_bits(p.z)}; }

// Mixes all 96 bits (positions on a grid differ in few of them); the final steps are splitmix64's.
std::uint64_t place_hash(const Place& k) noexcept {
  std::uint64_t h = ((std::uint64_t{k.x} << 32) | k.y) * 0x9E3779B97F4A7C15ull ^ std::uint64_t{k.z} * 0xC2B2AE3D27D4EB4Full;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return h;
}

// Vertices at the position of an earlier vertex = V minus the number of distinct positions. Open addressing
// with linear probing over vertex ids, at most half full: O(V) expected, where sorting took O(V log V) and
// made analyze_mesh 60 % slower on the dragon.
std::size_t count_coincident(const std::vector<glm::vec3>& pos) {
  const std::size_t nv = pos.size();
  if (nv < 2) return 0;
  const std::size_t cap = std::bit_ceil(2 * nv);
  const std::size_t mask = cap - 1;
  const int shift = 64 - std::countr_zero(cap);
  std::vector<Index> slots(cap, kInvalid);
  std::size_t count = 0;
  for (Index v = 0; v < static_cast<Index>(nv); ++v) {
    const Place key = place_of(pos[v]);
    for (std::size_t s = static_cast<std::size_t>(place_hash(key) >> shift);; s = (s + 1) & mask) {
      const Index w = slots[s];
      if (w == kInvalid) {
        slots[s] = v;
        break;
      }
      if (place_of(pos[w]) == key) {
        ++count;
        break;
      }
    }
  }
  return count;
}

}  // namespace

MeshReport analyze_mesh(const TriMesh& mesh) {
  mesh.validate();
  const auto& idx = mesh.indices;
  if (idx.size() >= kInvalid || mesh.positions.size() >= kInvalid)
    throw InvalidInput("analyze_mesh: " + std::to_string(idx.size()) + " corners or " +
                       std::to_string(mesh.positions.size()) + " vertices exceed 32-bit ids");

  MeshReport report;
  const std::size_t nv = mesh.num_vertices();
  const Index nf = static_cast<Index>(mesh.num_faces());
  report.vertices = nv;
  report.faces = nf;
  report.bounds = mesh.bounds();

  // Faces with a repeated index are counted and then take no part in anything else (as in meshstat.py):
  // their vertices may end up unreferenced, their edges do not exist.
  std::vector<std::uint8_t> kept(nf, 0);
  std::vector<std::uint8_t> flags(nv, 0);
  Index num_kept = 0;
  for (Index f = 0; f < nf; ++f) {
    const Index a = idx[3 * f], b = idx[3 * f + 1], c = idx[3 * f + 2];
    if (a == b || b == c || a == c) {
      ++report.degenerate_faces;
      continue;
    }
    kept[f] = 1;
    ++num_kept;
    flags[a] |= kUsed;
    flags[b] |= kUsed;
    flags[c] |= kUsed;
    if (detail::exactly_collinear(mesh.positions[a], mesh.positions[b], mesh.positions[c]))
      ++report.zero_area_faces;
  }
  std::size_t num_used = 0;
  for (const auto fl : flags) num_used += fl & kUsed;
  report.unreferenced_vertices = nv - num_used;
  // Before the half-edge buckets are allocated, so that its table is freed by then.
  report.coincident_vertices = count_coincident(mesh.positions);

  std::vector<Index> offsets;
  std::vector<std::uint64_t> items;

  // Half-edges bucketed by their smaller vertex; an item packs (larger vertex, half-edge id), so a sorted
  // bucket lists the half-edges of each undirected edge next to each other.
  build_buckets(
      nv,
      [&](auto&& emit) {
        for (Index f = 0; f < nf; ++f) {
          if (!kept[f]) continue;
          for (Index k = 0; k < 3; ++k) {
            const Index h = 3 * f + k;
            const Index a = idx[h], b = idx[3 * f + (k + 1) % 3];
            emit(std::min(a, b), pack(std::max(a, b), h));
          }
        }
      },
      offsets, items);

  // Fans: two corners of a vertex v are in one fan when their faces share an edge (v, u). Joining the
  // corners of every face on an edge (however many there are) and counting the roots per vertex reproduces
  // meshstat.py's per-vertex union-find in one pass.
  DisjointSets corners(idx.size());
  DisjointSets verts(nv);
  std::vector<Index> thirds;  // scratch for non-manifold edges
  for (Index v = 0; v < static_cast<Index>(nv); ++v) {
    const Index end = offsets[v + 1];
    for (Index i = offsets[v]; i < end;) {
      const Index u = high(items[i]);
      Index j = i + 1;
      while (j < end && high(items[j]) == u) ++j;
      ++report.edges;
      const Index run = j - i;
      if (run == 1) {
        ++report.boundary_edges;
        verts.unite(v, u);
        flags[v] |= kBoundary;
        flags[u] |= kBoundary;
      } else if (run > 2) {
        ++report.non_manifold_edges;
      }
      const Index h0 = low(items[i]);
      for (Index t = i + 1; t < j; ++t) {
        const Index h = low(items[t]);
        corners.unite(corner_at(idx, h0, v), corner_at(idx, h, v));
        corners.unite(corner_at(idx, h0, u), corner_at(idx, h, u));
      }
      // Duplicates: each face is looked at on the edge joining its two smallest vertices (its third vertex is
      // larger than u there), where copies of it show up as equal third vertices.
      if (run == 2) {
        report.orientation_inconsistent_edges += idx[h0] == idx[low(items[i + 1])];
        const Index w = third_vertex(idx, h0);
        if (w > u && w == third_vertex(idx, low(items[i + 1]))) ++report.duplicate_faces;
      } else if (run > 2) {
        thirds.clear();
        for (Index t = i; t < j; ++t) {
          const Index w = third_vertex(idx, low(items[t]));
          if (w > u) thirds.push_back(w);
        }
        std::sort(thirds.begin(), thirds.end());
        for (std::size_t t = 1; t < thirds.size(); ++t) report.duplicate_faces += thirds[t] == thirds[t - 1];
      }
      i = j;
    }
  }
  // Boundary loops are the components of the boundary-edge graph: a vertex where two holes touch joins them.
  for (Index v = 0; v < static_cast<Index>(nv); ++v)
    if ((flags[v] & kBoundary) && verts.is_root(v)) ++report.boundary_loops;

  for (Index c = 0; c < static_cast<Index>(idx.size()); ++c) {
    if (!kept[c / 3] || !corners.is_root(c)) continue;
    auto& fl = flags[idx[c]];
    fl |= (fl & kOneFan) ? kTwoFans : kOneFan;
  }
  for (const auto fl : flags)
    if (fl & kTwoFans) ++report.non_manifold_vertices;

  verts.reset(nv);
  for (Index f = 0; f < nf; ++f) {
    if (!kept[f]) continue;
    verts.unite(idx[3 * f], idx[3 * f + 1]);
    verts.unite(idx[3 * f], idx[3 * f + 2]);
  }
  for (Index v = 0; v < static_cast<Index>(nv); ++v)
    if ((flags[v] & kUsed) && verts.is_root(v)) ++report.components;

  report.euler_characteristic = static_cast<long long>(num_used) - static_cast<long long>(report.edges) +
                                static_cast<long long>(num_kept);
  report.closed = num_kept > 0 && report.boundary_edges == 0 && report.non_manifold_edges == 0;
  if (report.closed && report.components == 1 && report.non_manifold_vertices == 0)
    report.genus = static_cast<int>(floor_half(2 - report.euler_characteristic));
  return report;
}

std::string format_report(const MeshReport& r) {
  std::string out;
  char line[256];
  auto add = [&](const char* label, const std::string& text) {
    std::snprintf(line, sizeof line, "%-13s %s\n", label, text.c_str());
    out += line;
  };
  auto num = [](std::size_t n) { return std::to_string(n); };

  add("vertices", num(r.vertices) + " (" + num(r.unreferenced_vertices) + " unreferenced, " + num(r.coincident_vertices) +
                      " at the position of another)");
  add("faces", num(r.faces) + " (" + num(r.degenerate_faces) + " degenerate, " + num(r.zero_area_faces) +
                   " zero-area, " + num(r.duplicate_faces) + " duplicate)");
  add("edges", num(r.edges) + " (" + num(r.orientation_inconsistent_edges) + " where its two faces disagree on orientation)");
  // "1 loop", not "1 loops": a count and its noun agree in the phrases below.
  auto count = [&](std::size_t n, const char* one, const char* many) { return num(n) + " " + (n == 1 ? one : many); };
  add("boundary", count(r.boundary_edges, "edge", "edges") + " in " + count(r.boundary_loops, "loop", "loops"));
  add("non-manifold", count(r.non_manifold_edges, "edge", "edges") + ", " + count(r.non_manifold_vertices, "vertex", "vertices"));
  add("components", num(r.components));
  add("euler char", std::to_string(r.euler_characteristic));
  add("closed", r.closed ? "yes" : "no");
  add("genus", r.genus >= 0 ? std::to_string(r.genus) : std::string("n/a (not closed, connected and manifold)"));
  if (r.bounds.empty()) {
    add("bbox", "empty");
  } else {
    const auto& lo = r.bounds.lo;
    const auto& hi = r.bounds.hi;
    char box[192];
    std::snprintf(box, sizeof box, "[%.7g, %.7g, %.7g] .. [%.7g, %.7g, %.7g]", static_cast<double>(lo.x),
                  static_cast<double>(lo.y), static_cast<double>(lo.z), static_cast<double>(hi.x),
                  static_cast<double>(hi.y), static_cast<double>(hi.z));
    add("bbox", box);
  }
  return out;
}

}  // namespace varmesh
