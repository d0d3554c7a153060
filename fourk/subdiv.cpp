// Primal subdivision as binary 4-8 steps (subdiv.hpp).
//
// Papers: Velho and Zorin, "4-8 Subdivision", CAGD 18(5) 2001 (regular rules, two-pass smoothing);
// Velho, "Quasi 4-8 subdivision" / "4-8 factorization of quadrilateral subdivision" (Catmull-Clark as a
// diagonal step then an edge step); Catmull and Clark 1978; Li, Ma and Bao, "sqrt(2) subdivision for
// quadrilateral meshes", The Visual Computer 2004 (the same topology seen on the quad mesh).
//
// The rules are written twice on purpose: once against a "sink" of (output, input, weight) triples, which
// records them as stencil tables (the reference, and the way to subdivide other attributes), and once as
// the fast position kernels (one assignment per output, then one scatter pass over the face corners). The
// tests check that the tables reproduce the fast path to 1e-12 on every scheme.
#include "fourk/subdiv.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include <unistd.h>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <glm/geometric.hpp>

#include "multitri/errors.hpp"
#include "multitri/huge_pages.hpp"

namespace varmesh {

const char* to_string(SubdivScheme scheme) noexcept {
  switch (scheme) {
    case SubdivScheme::kLinear: return "linear";
    case SubdivScheme::kCatmullClark: return "catmull-clark";
    case SubdivScheme::kFourEight: return "4-8";
  }
  return "?";
}

double four_eight_weight(int /*n*/) noexcept { return 0.5; }

std::size_t SubdivTopology::memory_bytes() const noexcept {
  return face_offsets.capacity() * sizeof(Index) + face_verts.capacity() * sizeof(Index) +
         face_edges.capacity() * sizeof(Index) + edge_verts.capacity() * sizeof(Index) + edge_border.capacity() +
         valence.capacity() * sizeof(std::uint16_t) + vertex_border.capacity();
}

std::size_t SubdivMesh::memory_bytes() const noexcept {
  return topo.memory_bytes() + positions.capacity() * sizeof(glm::dvec3);
}

SubdivTopology make_subdiv_topology(const PolyMesh& mesh) {
  mesh.validate();
  SubdivTopology t;
  t.num_vertices = mesh.num_vertices();
  t.num_faces = mesh.num_faces();
  if (!mesh.all_quads()) t.face_offsets = mesh.face_offsets;
  t.face_verts = mesh.corners;
  t.face_edges.resize(mesh.corners.size());
  std::unordered_map<std::uint64_t, Index> edge_of;
  edge_of.reserve(mesh.corners.size());
  std::vector<std::uint8_t> uses;
  for (std::size_t f = 0; f < t.num_faces; ++f) {
    const Index off = mesh.face_offsets[f], k = static_cast<Index>(mesh.face_size(f));
    // A face's centre becomes a vertex of valence k at the first step; valences are 16-bit.
    if (k > std::numeric_limits<std::uint16_t>::max())
      throw InvalidInput("subdivision: face " + std::to_string(f) + " has " + std::to_string(k) +
                             " corners (at most 65535 supported)",
                         f);
    for (Index i = 0; i < k; ++i) {
      const Index a = mesh.corners[off + i], b = mesh.corners[off + (i + 1) % k];
      const std::uint64_t key = (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
      auto [it, inserted] = edge_of.emplace(key, static_cast<Index>(t.edge_verts.size() / 2));
      if (inserted) {
        t.edge_verts.push_back(a);
        t.edge_verts.push_back(b);
        uses.push_back(0);
      }
      ++uses[it->second];
      t.face_edges[off + i] = it->second;
    }
  }
  const std::size_t ne = uses.size();
  t.edge_border.resize(ne);
  std::vector<std::uint32_t> valence(t.num_vertices, 0);
  t.vertex_border.assign(t.num_vertices, 0);
  for (std::size_t e = 0; e < ne; ++e) {
    t.edge_border[e] = uses[e] == 1 ? 1 : 0;
    for (int s = 0; s < 2; ++s) {
      const Index v = t.edge_verts[2 * e + s];
      ++valence[v];
      if (uses[e] == 1) t.vertex_border[v] = 1;
    }
  }
  t.valence.resize(t.num_vertices);
  for (std::size_t v = 0; v < t.num_vertices; ++v) {
    if (valence[v] > std::numeric_limits<std::uint16_t>::max())
      throw InvalidInput("subdivision: vertex " + std::to_string(v) + " has " + std::to_string(valence[v]) +
                             " edges (at most 65535 supported)",
                         v);
    t.valence[v] = static_cast<std::uint16_t>(valence[v]);
  }
  return t;
}

namespace {

constexpr std::uint64_t kIndexLimit = std::numeric_limits<Index>::max();

// Counts of the next even level: V' = V + F + E, F' = corners, corners' = 4 corners, E' = 2E + corners.
struct LevelCounts {
  std::uint64_t v = 0, f = 0, c = 0, e = 0;
  LevelCounts next() const noexcept { return {v + f + e, c, 4 * c, 2 * e + c}; }
  bool fits() const noexcept { return v + f + e < kIndexLimit && 4 * c < kIndexLimit && 2 * e + c < kIndexLimit; }
};

LevelCounts counts_of(const SubdivTopology& t) {
  return {t.num_vertices, t.num_faces, t.face_verts.size(), t.num_edges()};
}

// The half of parent edge e that touches its end c.
inline Index half_at(const SubdivTopology& t, Index e, Index c) noexcept {
  return t.edge_verts[2 * e] == c ? 2 * e : 2 * e + 1;
}

}  // namespace

namespace {

// Reserves `n` elements and, on Linux, asks for transparent huge pages on the big untouched buffer (THP in
// "madvise" mode): one page fault per 2 MiB instead of per 4 KiB, which is a large part of the cost of
// writing a fresh level. A hint only; nothing changes where THP is off or always on.
template <class T>
void reserve_huge(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const std::size_t bytes = v.capacity() * sizeof(T);
  if (bytes < 4 * kHuge) return;
  const auto at = reinterpret_cast<std::uintptr_t>(v.data());
  const std::uintptr_t b = (at + kHuge - 1) & ~(kHuge - 1), e = (at + bytes) & ~(kHuge - 1);
  if (e > b) madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE);
#endif
}

}  // namespace

SubdivTopology refine_subdiv_topology(const SubdivTopology& p, bool with_edges) {
  if (!p.has_edges()) throw InvalidInput("refine_subdiv_topology: the parent level has no edges");
  const LevelCounts pc = counts_of(p);
  if (!pc.fits())
    throw InvalidInput("refine_subdiv_topology: the child level would have 2^32 vertices, faces or corners");
  const Index nv = static_cast<Index>(pc.v), nf = static_cast<Index>(pc.f), ne = static_cast<Index>(pc.e);
  const Index nc = static_cast<Index>(pc.c);
  SubdivTopology c;
  c.num_vertices = std::size_t{nv} + nf + ne;
  c.num_faces = nc;
  // Each array is sized once and written through pointers.
  reserve_huge(c.face_verts, std::size_t{4} * nc);
  c.face_verts.resize(std::size_t{4} * nc);
  const Index edge_base = nv + nf;  // index of edge 0's point
  const Index inner_base = 2 * ne;  // first child edge interior to a parent face
  const Index* pev = p.edge_verts.data();
  if (with_edges) {
    reserve_huge(c.face_edges, std::size_t{4} * nc);
    reserve_huge(c.edge_verts, 2 * (std::size_t{2} * ne + nc));
    reserve_huge(c.edge_border, std::size_t{2} * ne + nc);
    c.face_edges.resize(std::size_t{4} * nc);
    c.edge_verts.resize(2 * (std::size_t{2} * ne + nc));
    c.edge_border.resize(std::size_t{2} * ne + nc);
    Index* ev = c.edge_verts.data();
    std::uint8_t* eb = c.edge_border.data();
    for (Index e = 0; e < ne; ++e) {  // the two halves of parent edge e: 2e at its first end, 2e + 1 at its second
      const Index a = pev[2 * e], b = pev[2 * e + 1], m = edge_base + e;
      Index* h = ev + 4 * std::size_t{e};
      h[0] = a;
      h[1] = m;
      h[2] = m;
      h[3] = b;
      eb[2 * std::size_t{e}] = eb[2 * std::size_t{e} + 1] = p.edge_border[e];
    }
  }
  const bool quads = p.all_quads();
  const Index* pfv = p.face_verts.data();
  const Index* pfe = p.face_edges.data();
  Index* cfv = c.face_verts.data();
  Index* cfe = c.face_edges.data();
  // Without edges the child's edge arrays are empty: no offset is formed into them (null + n is undefined).
  Index* cev = with_edges ? c.edge_verts.data() + 2 * std::size_t{inner_base} : nullptr;
  for (Index f = 0; f < nf; ++f) {
    const Index off = quads ? 4 * f : p.face_offsets[f], k = quads ? 4 : p.face_offsets[f + 1] - off;
    const Index fpoint = nv + f;
    for (Index i = 0; i < k; ++i) {
      const Index ci = pfv[off + i];
      const Index ei = pfe[off + i];
      const Index iprev = i == 0 ? k - 1 : i - 1;
      const Index eprev = pfe[off + iprev];
      Index* q = cfv + 4 * std::size_t{off + i};
      q[0] = ci;
      q[1] = edge_base + ei;
      q[2] = fpoint;
      q[3] = edge_base + eprev;
      if (with_edges) {
        Index* qe = cfe + 4 * std::size_t{off + i};
        qe[0] = half_at(p, ei, ci);
        qe[1] = inner_base + off + i;
        qe[2] = inner_base + off + iprev;
        qe[3] = half_at(p, eprev, ci);
        cev[2 * std::size_t{off + i}] = edge_base + ei;
        cev[2 * std::size_t{off + i} + 1] = fpoint;
      }
    }
  }
  reserve_huge(c.valence, c.num_vertices);
  reserve_huge(c.vertex_border, c.num_vertices);
  c.valence.resize(c.num_vertices);
  c.vertex_border.resize(c.num_vertices);
  std::uint16_t* val = c.valence.data();
  std::uint8_t* vb = c.vertex_border.data();
  std::copy(p.valence.begin(), p.valence.end(), val);
  std::copy(p.vertex_border.begin(), p.vertex_border.end(), vb);
  for (Index f = 0; f < nf; ++f) val[nv + f] = static_cast<std::uint16_t>(quads ? 4 : p.face_size(f));
  std::fill(vb + nv, vb + nv + nf, std::uint8_t{0});
  for (Index e = 0; e < ne; ++e) {
    val[edge_base + e] = p.edge_border[e] ? 3 : 4;
    vb[edge_base + e] = p.edge_border[e];
  }
  return c;
}

namespace {

// Records the triples; to_table() groups them by output.
struct TableSink {
  std::vector<Index> dst, src;
  std::vector<double> w;
  void add(Index d, Index s, double weight) {
    dst.push_back(d);
    src.push_back(s);
    w.push_back(weight);
  }
  StencilTable to_table(std::size_t num_inputs, std::size_t num_outputs) const {
    StencilTable t;
    t.num_inputs = num_inputs;
    t.offsets.assign(num_outputs + 1, 0);
    for (Index d : dst) ++t.offsets[d + 1];
    for (std::size_t i = 0; i < num_outputs; ++i) t.offsets[i + 1] += t.offsets[i];
    std::vector<Index> fill(t.offsets.begin(), t.offsets.end() - 1);
    t.sources.resize(dst.size());
    t.weights.resize(dst.size());
    for (std::size_t j = 0; j < dst.size(); ++j) {
      const Index at = fill[dst[j]]++;
      t.sources[at] = src[j];
      t.weights[at] = w[j];
    }
    return t;
  }
};

// 1/n for small n without a division in the loops.
struct InverseTable {
  double inv[65] = {};
  InverseTable() {
    for (int n = 1; n <= 64; ++n) inv[n] = 1.0 / n;
  }
  double operator()(unsigned n) const noexcept { return n <= 64 ? inv[n] : 1.0 / n; }
};
const InverseTable kInverse;

// Self weights of old vertices. A vertex no face uses (valence 0; PolyMesh allows them) stays where it is,
// as in OpenSubdiv.
inline double diagonal_self(const SubdivTopology& t, Index v, SubdivScheme scheme) noexcept {
  if (scheme != SubdivScheme::kFourEight || t.vertex_border[v] || t.valence[v] == 0) return 1.0;
  return 1.0 - four_eight_weight(t.valence[v]);
}
inline double edge_self(const SubdivTopology& t, Index v, SubdivScheme scheme) noexcept {
  if (scheme == SubdivScheme::kLinear || t.valence[v] == 0) return 1.0;
  if (t.vertex_border[v]) return 0.75;
  if (scheme == SubdivScheme::kCatmullClark) return (t.valence[v] - 2.0) * kInverse(t.valence[v]);
  return 1.0 - four_eight_weight(t.valence[v]);
}

template <class Sink>
void diagonal_rules(const SubdivTopology& t, SubdivScheme scheme, Sink& sink) {
  const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
  for (Index f = 0; f < nf; ++f) {
    const Index off = t.offset(f), k = t.face_size(f);
    const double w = kInverse(k);
    for (Index i = 0; i < k; ++i) sink.add(nv + f, t.face_verts[off + i], w);
  }
  if (scheme != SubdivScheme::kFourEight) {
    for (Index v = 0; v < nv; ++v) sink.add(v, v, 1.0);
    return;
  }
  // 4-8: v' = (1 - a_n) v + a_n / n sum(edge neighbours); border vertices stay.
  for (Index v = 0; v < nv; ++v)
    sink.add(v, v, diagonal_self(t, v, scheme));
  const std::size_t ne = t.num_edges();
  for (std::size_t e = 0; e < ne; ++e) {
    const Index a = t.edge_verts[2 * e], b = t.edge_verts[2 * e + 1];
    if (!t.vertex_border[a]) sink.add(a, b, four_eight_weight(t.valence[a]) * kInverse(t.valence[a]));
    if (!t.vertex_border[b]) sink.add(b, a, four_eight_weight(t.valence[b]) * kInverse(t.valence[b]));
  }
}

template <class Sink>
void edge_rules(const SubdivTopology& t, SubdivScheme scheme, Sink& sink) {
  const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
  const Index edge_base = nv + nf;
  const std::size_t ne = t.num_edges();
  const bool linear = scheme == SubdivScheme::kLinear;
  // Edge points: interior (v0 + v1 + f0 + f1) / 4, border and linear the midpoint.
  for (std::size_t e = 0; e < ne; ++e) {
    const Index a = t.edge_verts[2 * e], b = t.edge_verts[2 * e + 1];
    const double w = linear || t.edge_border[e] ? 0.5 : 0.25;
    sink.add(edge_base + static_cast<Index>(e), a, w);
    sink.add(edge_base + static_cast<Index>(e), b, w);
  }
  if (!linear) {
    for (Index f = 0; f < nf; ++f) {
      const Index off = t.offset(f), k = t.face_size(f);
      for (Index i = 0; i < k; ++i) {
        const Index e = t.face_edges[off + i];
        if (!t.edge_border[e]) sink.add(edge_base + e, nv + f, 0.25);
      }
    }
  }
  // Old vertices.
  if (linear) {
    for (Index v = 0; v < nv; ++v) sink.add(v, v, 1.0);
  } else {
    const bool cc = scheme == SubdivScheme::kCatmullClark;
    for (Index v = 0; v < nv; ++v) sink.add(v, v, edge_self(t, v, scheme));
    // Border neighbours (1/8 each) and, for Catmull-Clark, interior edge neighbours (1/n^2).
    for (std::size_t e = 0; e < ne; ++e) {
      const Index a = t.edge_verts[2 * e], b = t.edge_verts[2 * e + 1];
      if (t.edge_border[e]) {
        sink.add(a, b, 0.125);
        sink.add(b, a, 0.125);
      } else if (cc) {
        if (!t.vertex_border[a]) sink.add(a, b, kInverse(t.valence[a]) * kInverse(t.valence[a]));
        if (!t.vertex_border[b]) sink.add(b, a, kInverse(t.valence[b]) * kInverse(t.valence[b]));
      }
    }
    // Face points around interior vertices: 1/n^2 (Catmull-Clark) or a_n / n (4-8).
    for (Index f = 0; f < nf; ++f) {
      const Index off = t.offset(f), k = t.face_size(f);
      for (Index i = 0; i < k; ++i) {
        const Index c = t.face_verts[off + i];
        if (t.vertex_border[c]) continue;
        const double inv = kInverse(t.valence[c]);
        sink.add(c, nv + f, cc ? inv * inv : four_eight_weight(t.valence[c]) * inv);
      }
    }
  }
  // Face points: unchanged, or (4-8) f' = f / 2 + 1 / (2k) sum(corners).
  for (Index f = 0; f < nf; ++f) {
    if (scheme != SubdivScheme::kFourEight) {
      sink.add(nv + f, nv + f, 1.0);
      continue;
    }
    const Index off = t.offset(f), k = t.face_size(f);
    sink.add(nv + f, nv + f, 0.5);
    const double w = 0.5 * kInverse(k);
    for (Index i = 0; i < k; ++i) sink.add(nv + f, t.face_verts[off + i], w);
  }
}

void check_span(std::size_t got, std::size_t want, const char* what) {
  if (got != want)
    throw InvalidInput(std::string("subdivision step: ") + what + " has " + std::to_string(got) +
                       " positions, expected " + std::to_string(want));
}

// The fast path: the same rules as diagonal_rules / edge_rules (the tests check the tables against it),
// in place on one position array whose capacity is the final size (subdivide() reserves it once): new
// points are appended after the old ones, and the old vertices (and 4-8 face points), whose rules read
// pre-step positions, are computed into a scratch array and copied back at the end of the step. Each
// output is assigned once and then receives one scatter pass over the face corners; nothing is zeroed.
// K = 4 for all-quad levels (the loops unroll), 0 for general polygons.
template <int K>
void diagonal_in_place(const SubdivTopology& t, SubdivScheme scheme, glm::dvec3* p, std::vector<glm::dvec3>& tmp) {
  const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
  const Index* fv = t.face_verts.data();
  for (Index f = 0; f < nf; ++f) {
    const Index off = K ? K * f : t.face_offsets[f], k = K ? K : t.face_offsets[f + 1] - off;
    glm::dvec3 sum(0.0);
    for (Index i = 0; i < k; ++i) sum += p[fv[off + i]];
    p[nv + f] = sum * kInverse(k);
  }
  if (scheme != SubdivScheme::kFourEight) return;
  tmp.resize(nv);
  for (Index v = 0; v < nv; ++v)
    tmp[v] = diagonal_self(t, v, scheme) * p[v];
  const std::size_t ne = t.num_edges();
  for (std::size_t e = 0; e < ne; ++e) {
    const Index a = t.edge_verts[2 * e], b = t.edge_verts[2 * e + 1];
    if (!t.vertex_border[a]) tmp[a] += four_eight_weight(t.valence[a]) * kInverse(t.valence[a]) * p[b];
    if (!t.vertex_border[b]) tmp[b] += four_eight_weight(t.valence[b]) * kInverse(t.valence[b]) * p[a];
  }
  std::copy(tmp.begin(), tmp.end(), p);
}

template <int K>
void edge_in_place(const SubdivTopology& t, SubdivScheme scheme, glm::dvec3* p, std::vector<glm::dvec3>& tmp) {
  const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
  const Index edge_base = nv + nf;
  const std::size_t ne = t.num_edges();
  const bool linear = scheme == SubdivScheme::kLinear, cc = scheme == SubdivScheme::kCatmullClark;
  const bool fe = scheme == SubdivScheme::kFourEight;
  const Index* fv = t.face_verts.data();
  const Index* fedge = t.face_edges.data();
  // Scratch: new old-vertex positions [0, nv), then (4-8) new face points [nv, nv + nf).
  if (!linear) {
    tmp.resize(fe ? std::size_t{nv} + nf : nv);
    for (Index v = 0; v < nv; ++v) tmp[v] = edge_self(t, v, scheme) * p[v];
  }
  // Edge points (the corner part) and the border curve.
  for (std::size_t e = 0; e < ne; ++e) {
    const Index a = t.edge_verts[2 * e], b = t.edge_verts[2 * e + 1];
    const bool border = t.edge_border[e] != 0;
    p[edge_base + e] = (linear || border ? 0.5 : 0.25) * (p[a] + p[b]);
    if (border && !linear) {
      tmp[a] += 0.125 * p[b];
      tmp[b] += 0.125 * p[a];
    }
  }
  if (linear) return;
  // Face points into their edge points and interior corners; 4-8 face points smoothed.
  for (Index f = 0; f < nf; ++f) {
    const Index off = K ? K * f : t.face_offsets[f], k = K ? K : t.face_offsets[f + 1] - off;
    const glm::dvec3 fp = p[nv + f];
    const glm::dvec3 quarter = 0.25 * fp;
    glm::dvec3 corner_sum(0.0);
    for (Index i = 0; i < k; ++i) {
      const Index e = fedge[off + i];
      if (!t.edge_border[e]) p[edge_base + e] += quarter;
      const Index c = fv[off + i];
      if (fe) corner_sum += p[c];
      if (t.vertex_border[c]) continue;
      const double inv = kInverse(t.valence[c]);
      if (cc) {
        // 1/n^2 (f + the two edge neighbours in this face / 2): each edge neighbour of an interior vertex
        // lies in two of its faces, so the halves add up to 1/n^2 per neighbour.
        const Index next = fv[off + (i + 1 == k ? 0 : i + 1)], prev = fv[off + (i == 0 ? k - 1 : i - 1)];
        tmp[c] += (inv * inv) * (fp + 0.5 * (p[next] + p[prev]));
      } else {
        tmp[c] += (four_eight_weight(t.valence[c]) * inv) * fp;
      }
    }
    if (fe) tmp[nv + f] = 0.5 * fp + (0.5 * kInverse(k)) * corner_sum;
  }
  std::copy(tmp.begin(), tmp.end(), p);
}

void diagonal_fast(const SubdivTopology& t, SubdivScheme scheme, glm::dvec3* p, std::vector<glm::dvec3>& tmp) {
  if (t.all_quads()) diagonal_in_place<4>(t, scheme, p, tmp);
  else diagonal_in_place<0>(t, scheme, p, tmp);
}

void edge_fast(const SubdivTopology& t, SubdivScheme scheme, glm::dvec3* p, std::vector<glm::dvec3>& tmp) {
  if (t.all_quads()) edge_in_place<4>(t, scheme, p, tmp);
  else edge_in_place<0>(t, scheme, p, tmp);
}

}  // namespace

void subdiv_diagonal_step(const SubdivTopology& topo, SubdivScheme scheme, std::span<const glm::dvec3> in,
                          std::span<glm::dvec3> out) {
  if (!topo.has_edges()) throw InvalidInput("subdiv_diagonal_step: the level has no edges");
  check_span(in.size(), topo.num_vertices, "input");
  check_span(out.size(), topo.num_vertices + topo.num_faces, "output");
  std::copy(in.begin(), in.end(), out.begin());
  std::vector<glm::dvec3> tmp;
  diagonal_fast(topo, scheme, out.data(), tmp);
}

void subdiv_edge_step(const SubdivTopology& topo, SubdivScheme scheme, std::span<const glm::dvec3> in,
                      std::span<glm::dvec3> out) {
  if (!topo.has_edges()) throw InvalidInput("subdiv_edge_step: the level has no edges");
  check_span(in.size(), topo.num_vertices + topo.num_faces, "input");
  check_span(out.size(), topo.num_vertices + topo.num_faces + topo.num_edges(), "output");
  std::copy(in.begin(), in.end(), out.begin());
  std::vector<glm::dvec3> tmp;
  edge_fast(topo, scheme, out.data(), tmp);
}

StencilTable subdiv_diagonal_stencils(const SubdivTopology& topo, SubdivScheme scheme) {
  if (!topo.has_edges()) throw InvalidInput("subdiv_diagonal_stencils: the level has no edges");
  TableSink sink;
  diagonal_rules(topo, scheme, sink);
  return sink.to_table(topo.num_vertices, topo.num_vertices + topo.num_faces);
}

StencilTable subdiv_edge_stencils(const SubdivTopology& topo, SubdivScheme scheme) {
  if (!topo.has_edges()) throw InvalidInput("subdiv_edge_stencils: the level has no edges");
  TableSink sink;
  edge_rules(topo, scheme, sink);
  return sink.to_table(topo.num_vertices + topo.num_faces, topo.num_vertices + topo.num_faces + topo.num_edges());
}

void StencilTable::apply(std::span<const double> in, std::span<double> out, int components) const {
  if (components < 1) throw InvalidInput("StencilTable::apply: components must be at least 1");
  const auto nc = static_cast<std::size_t>(components);
  if (in.size() != num_inputs * nc)
    throw InvalidInput("StencilTable::apply: input has " + std::to_string(in.size()) + " values, expected " +
                       std::to_string(num_inputs * nc));
  if (out.size() != num_outputs() * nc)
    throw InvalidInput("StencilTable::apply: output has " + std::to_string(out.size()) + " values, expected " +
                       std::to_string(num_outputs() * nc));
  check_shape("StencilTable::apply");
  for (std::size_t i = 0; i < num_outputs(); ++i) {
    double* o = out.data() + i * nc;
    std::fill(o, o + nc, 0.0);
    if (offsets[i + 1] < offsets[i]) throw InvalidInput("StencilTable::apply: offsets decrease at stencil " + std::to_string(i), i);
    for (Index j = offsets[i]; j < offsets[i + 1]; ++j) {
      if (sources[j] >= num_inputs)
        throw InvalidInput("StencilTable::apply: stencil " + std::to_string(i) + " reads input " + std::to_string(sources[j]) +
                               " of " + std::to_string(num_inputs),
                           i);
      const double* s = in.data() + std::size_t{sources[j]} * nc;
      const double w = weights[j];
      for (std::size_t c = 0; c < nc; ++c) o[c] += w * s[c];
    }
  }
}

std::vector<double> StencilTable::apply(std::span<const double> in, int components) const {
  // The input size is checked before the output is allocated: a wrong component count must not ask for
  // num_outputs() times that many doubles first.
  if (components < 1) throw InvalidInput("StencilTable::apply: components must be at least 1");
  if (in.size() != num_inputs * static_cast<std::size_t>(components))
    throw InvalidInput("StencilTable::apply: input has " + std::to_string(in.size()) + " values, expected " +
                       std::to_string(num_inputs * static_cast<std::size_t>(components)));
  std::vector<double> out(num_outputs() * static_cast<std::size_t>(components));
  apply(in, out, components);
  return out;
}

void StencilTable::check_shape(const char* who) const {
  if (offsets.empty() || offsets.front() != 0 || offsets.back() != sources.size() || sources.size() != weights.size())
    throw InvalidInput(std::string(who) + ": offsets, sources and weights do not match (" + std::to_string(offsets.size()) +
                       " offsets ending at " + (offsets.empty() ? std::string("-") : std::to_string(offsets.back())) + ", " +
                       std::to_string(sources.size()) + " sources, " + std::to_string(weights.size()) + " weights)");
}

void StencilTable::check_entries(const char* who) const {
  check_shape(who);
  for (std::size_t i = 0; i < num_outputs(); ++i) {
    if (offsets[i + 1] < offsets[i]) throw InvalidInput(std::string(who) + ": offsets decrease at stencil " + std::to_string(i), i);
    for (Index j = offsets[i]; j < offsets[i + 1]; ++j)
      if (sources[j] >= num_inputs)
        throw InvalidInput(std::string(who) + ": stencil " + std::to_string(i) + " reads input " + std::to_string(sources[j]) +
                               " of " + std::to_string(num_inputs),
                           i);
  }
}

StencilTable StencilTable::after(const StencilTable& first) const {
  check_entries("StencilTable::after");
  first.check_entries("StencilTable::after (first table)");
  if (first.num_outputs() != num_inputs)
    throw InvalidInput("StencilTable::after: the first table has " + std::to_string(first.num_outputs()) +
                       " outputs, this one takes " + std::to_string(num_inputs) + " inputs");
  StencilTable r;
  r.num_inputs = first.num_inputs;
  r.offsets.reserve(offsets.size());
  std::vector<double> acc(first.num_inputs, 0.0);
  std::vector<Index> touched;
  std::vector<std::uint8_t> mark(first.num_inputs, 0);
  for (std::size_t i = 0; i < num_outputs(); ++i) {
    touched.clear();
    for (Index j = offsets[i]; j < offsets[i + 1]; ++j) {
      const Index mid = sources[j];
      for (Index k = first.offsets[mid]; k < first.offsets[mid + 1]; ++k) {
        const Index s = first.sources[k];
        if (!mark[s]) {
          mark[s] = 1;
          touched.push_back(s);
        }
        acc[s] += weights[j] * first.weights[k];
      }
    }
    std::sort(touched.begin(), touched.end());
    for (Index s : touched) {
      r.sources.push_back(s);
      r.weights.push_back(acc[s]);
      acc[s] = 0.0;
      mark[s] = 0;
    }
    r.offsets.push_back(static_cast<Index>(r.sources.size()));
  }
  return r;
}

namespace {

// Throws when `steps` is negative or too large; returns the number of positions after `steps` steps.
std::size_t check_steps(const SubdivTopology& t, int steps) {
  if (steps < 0) throw InvalidInput("subdivision: steps must be >= 0 (got " + std::to_string(steps) + ")");
  LevelCounts c = counts_of(t);
  for (int s = 1; s < steps; s += 2) {
    if (!c.fits())
      throw InvalidInput("subdivision: " + std::to_string(steps) +
                             " steps would make 2^32 vertices, faces or corners or more (steps)",
                         static_cast<std::uint64_t>(steps));
    c = c.next();
  }
  if (c.v + c.f >= kIndexLimit)
    throw InvalidInput("subdivision: " + std::to_string(steps) + " steps would make 2^32 vertices or more (steps)",
                       static_cast<std::uint64_t>(steps));
  // Memory of the last level (c holds its counts: positions 24 bytes each, corners 2 x 4, edges 9, vertices
  // 3) and a quarter more for the level it is computed from: refused up front when it exceeds the machine's
  // memory, rather than ending in bad_alloc or the out-of-memory killer half-way through. (Measured on a
  // Catmull-Clark cube: 8.7 GB at 24 steps against 9.7 GB estimated.)
  const double positions = double(steps % 2 ? c.v + c.f : c.v);
  const double bytes = 1.25 * (24.0 * positions + 3.0 * double(c.v) + 8.0 * double(c.c) + 9.0 * double(c.e));
  const double ram = physical_memory_bytes();
  if (ram > 0.0 && bytes > ram)
    throw InvalidInput("subdivision: " + std::to_string(steps) + " steps would need about " +
                           std::to_string(static_cast<long long>(bytes / 1e9)) + " GB, more than the " +
                           std::to_string(static_cast<long long>(ram / 1e9)) + " GB of memory here (steps)",
                       static_cast<std::uint64_t>(steps));
  return static_cast<std::size_t>(steps % 2 ? c.v + c.f : c.v);
}

}  // namespace

SubdivMesh subdivide(const PolyMesh& base, SubdivScheme scheme, int steps, const SubdivOptions& options) {
  SubdivMesh m;
  m.scheme = scheme;
  m.steps = steps;
  m.topo = make_subdiv_topology(base);
  const std::size_t final_size = check_steps(m.topo, steps);
  // One position array for all steps, reserved at its final size: every step appends in place.
  reserve_huge(m.positions, final_size);
  m.positions = base.positions;
  std::vector<glm::dvec3> tmp;
  for (int s = 0; s < steps; ++s) {
    if (s % 2 == 0) {
      m.positions.resize(m.topo.num_vertices + m.topo.num_faces);
      diagonal_fast(m.topo, scheme, m.positions.data(), tmp);
    } else {
      m.positions.resize(m.topo.num_vertices + m.topo.num_faces + m.topo.num_edges());
      edge_fast(m.topo, scheme, m.positions.data(), tmp);
      if (s + 2 >= steps) std::vector<glm::dvec3>().swap(tmp);  // no step needs it any more: lower the peak
      m.topo = refine_subdiv_topology(m.topo, options.keep_last_edges || s + 1 < steps);
    }
  }
  return m;
}

std::vector<StencilTable> subdiv_stencil_tables(const PolyMesh& base, SubdivScheme scheme, int steps) {
  SubdivTopology t = make_subdiv_topology(base);
  // The tables keep every step's stencils, several entries per output: about 240 bytes per final position
  // at the peak, all steps together (measured with 4-8, the largest stencils, on a cube: 367 MB at 18
  // steps for 1.57 M positions). Refused up front when that exceeds the machine's memory.
  const double bytes = 240.0 * double(check_steps(t, steps)), ram = physical_memory_bytes();
  if (ram > 0.0 && bytes > ram)
    throw InvalidInput("subdiv_stencil_tables: " + std::to_string(steps) + " steps would need about " +
                           std::to_string(static_cast<long long>(bytes / 1e9)) + " GB of tables, more than the " +
                           std::to_string(static_cast<long long>(ram / 1e9)) + " GB of memory here (steps)",
                       static_cast<std::uint64_t>(steps));
  std::vector<StencilTable> tables;
  for (int s = 0; s < steps; ++s) {
    if (s % 2 == 0) {
      tables.push_back(subdiv_diagonal_stencils(t, scheme));
    } else {
      tables.push_back(subdiv_edge_stencils(t, scheme));
      t = refine_subdiv_topology(t, true);
    }
  }
  return tables;
}

TriMesh SubdivMesh::to_tri_mesh() const {
  TriMesh out;
  out.positions.reserve(positions.size());
  for (const glm::dvec3& p : positions) out.positions.emplace_back(p);
  const Index nv = static_cast<Index>(topo.num_vertices);
  for (Index f = 0; f < topo.num_faces; ++f) {
    const Index off = topo.offset(f), k = topo.face_size(f);
    const Index* c = &topo.face_verts[off];
    if (half_step()) {
      for (Index i = 0; i < k; ++i) out.indices.insert(out.indices.end(), {nv + f, c[i], c[(i + 1) % k]});
    } else {
      for (Index i = 1; i + 1 < k; ++i) out.indices.insert(out.indices.end(), {c[0], c[i], c[i + 1]});
    }
  }
  return out;
}

PolyMesh SubdivMesh::to_poly_mesh() const {
  PolyMesh out;
  out.positions = positions;
  if (!half_step()) {
    out.corners = topo.face_verts;
    if (topo.all_quads()) {
      out.face_offsets.resize(topo.num_faces + 1);
      for (std::size_t f = 0; f <= topo.num_faces; ++f) out.face_offsets[f] = static_cast<Index>(4 * f);
    } else {
      out.face_offsets = topo.face_offsets;
    }
    return out;
  }
  if (!topo.has_edges()) throw InvalidInput("SubdivMesh::to_poly_mesh: odd steps need the edges (keep_last_edges)");
  // Per edge: the face holding it in its own direction (f0) and the other one (f1).
  const std::size_t ne = topo.num_edges();
  std::vector<Index> f0(ne, kInvalid), f1(ne, kInvalid);
  for (Index f = 0; f < topo.num_faces; ++f) {
    const Index off = topo.offset(f), k = topo.face_size(f);
    for (Index i = 0; i < k; ++i) {
      const Index e = topo.face_edges[off + i];
      (topo.edge_verts[2 * e] == topo.face_verts[off + i] ? f0 : f1)[e] = f;
    }
  }
  const Index nv = static_cast<Index>(topo.num_vertices);
  for (std::size_t e = 0; e < ne; ++e) {
    const Index a = topo.edge_verts[2 * e], b = topo.edge_verts[2 * e + 1];
    if (f0[e] != kInvalid && f1[e] != kInvalid) {
      const Index q[4] = {a, nv + f1[e], b, nv + f0[e]};
      out.add_face(q);
    } else {
      const Index f = f0[e] != kInvalid ? f0[e] : f1[e];
      // The fan triangle of f on this edge, in f's orientation.
      const Index t[3] = {f0[e] != kInvalid ? a : b, f0[e] != kInvalid ? b : a, nv + f};
      out.add_face(t);
    }
  }
  return out;
}

std::vector<glm::dvec3> catmull_clark_limit_positions(const SubdivMesh& mesh) {
  if (mesh.scheme != SubdivScheme::kCatmullClark || mesh.half_step())
    throw InvalidInput("catmull_clark_limit_positions: needs a Catmull-Clark mesh after an even number of steps");
  const SubdivTopology& t = mesh.topo;
  if (!t.all_quads())
    throw InvalidInput("catmull_clark_limit_positions: needs an all-quad level (at least 2 steps on a mesh with "
                       "non-quad faces)");
  const std::size_t nv = t.num_vertices;
  bool any_border = false;
  for (std::size_t v = 0; v < nv && !any_border; ++v) any_border = t.vertex_border[v] != 0;
  if (any_border && !t.has_edges())
    throw InvalidInput("catmull_clark_limit_positions: a mesh with a border needs its edges (keep_last_edges)");
  const auto& p = mesh.positions;
  std::vector<glm::dvec3> acc(nv, glm::dvec3(0.0));
  // Interior: each edge neighbour is seen from the two quads on its sides, hence 2 (next + prev) = 4 e / 2.
  for (std::size_t f = 0; f < t.num_faces; ++f) {
    const Index* q = &t.face_verts[4 * f];
    for (int i = 0; i < 4; ++i) {
      const Index c = q[i];
      if (t.vertex_border[c]) continue;
      acc[c] += 2.0 * (p[q[(i + 1) & 3]] + p[q[(i + 3) & 3]]) + p[q[(i + 2) & 3]];
    }
  }
  if (any_border) {
    for (std::size_t e = 0; e < t.num_edges(); ++e) {
      if (!t.edge_border[e]) continue;
      const Index a = t.edge_verts[2 * e], b = t.edge_verts[2 * e + 1];
      acc[a] += p[b];
      acc[b] += p[a];
    }
  }
  std::vector<glm::dvec3> out(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const double n = t.valence[v];
    if (t.vertex_border[v]) {
      out[v] = (4.0 * p[v] + acc[v]) / 6.0;
    } else if (t.valence[v] == 0) {
      out[v] = p[v];
    } else {
      out[v] = (n * n * p[v] + acc[v]) / (n * (n + 5.0));
    }
  }
  return out;
}

namespace {

// The Mt holds every triangle of every step, several times what subdivide() keeps: refused up front when
// it would not fit in memory, before the uniform mesh is computed. Triangles: the base fans, then per
// level with C corners, C from the diagonal step and 2C from the edge step. About 120 bytes per triangle
// at the peak, builder and Mt together (measured on a 4-8 cube: 6.29 M triangles at 18 steps, 726 MB).
void check_mt_size(const SubdivTopology& t, int steps) {
  check_steps(t, steps);  // the index limits: every level's counts fit below
  double triangles = double(t.face_verts.size()) - 2.0 * double(t.num_faces);
  LevelCounts c = counts_of(t);
  for (int s = 0; s < steps; ++s) {
    if (s % 2 == 0) {
      triangles += double(c.c);
    } else {
      triangles += 2.0 * double(c.c);
      c = c.next();
    }
  }
  const double bytes = 120.0 * triangles, ram = physical_memory_bytes();
  if (ram > 0.0 && bytes > ram)
    throw InvalidInput("build_subdivision_mt: " + std::to_string(steps) + " steps make about " +
                           std::to_string(static_cast<long long>(triangles / 1e6)) +
                           " M triangles in the hierarchy, about " + std::to_string(static_cast<long long>(bytes / 1e9)) +
                           " GB, more than the " + std::to_string(static_cast<long long>(ram / 1e9)) +
                           " GB of memory here (steps)",
                       static_cast<std::uint64_t>(steps));
}

}  // namespace

Mt build_subdivision_mt(const PolyMesh& base, SubdivScheme scheme, int steps, SubdivMtInfo* info) {
  // The Mt keeps float positions, and every scheme's points are convex combinations of the base's: a base
  // within float's range stays there. Past it (validate() takes up to 1e300) the builder would refuse a
  // "position that is not finite" of some subdivided vertex; name the base vertex instead.
  for (std::size_t v = 0; v < base.positions.size(); ++v) {
    const glm::dvec3& q = base.positions[v];
    const double m = std::max({std::abs(q.x), std::abs(q.y), std::abs(q.z)});
    if (!(m <= double(std::numeric_limits<float>::max())))
      throw InvalidInput("build_subdivision_mt: vertex " + std::to_string(v) +
                             " has a coordinate beyond float's range (about 3.4e38), which the hierarchy's float "
                             "positions cannot hold",
                         v);
  }
  check_mt_size(make_subdiv_topology(base), steps);
  const SubdivMesh final_mesh = subdivide(base, scheme, steps);
  const auto& p = final_mesh.positions;
  MtBuilder b;
  for (const glm::dvec3& q : p) b.add_vertex(glm::vec3(q));
  std::vector<std::uint16_t> builder_step{0};
  auto dist = [&](Index v, glm::dvec3 m) { return static_cast<float>(glm::length(p[v] - m)); };

  SubdivTopology t = make_subdiv_topology(base);
  // Triangles of the current even level: per face, its fan (c0, c_i, c_{i+1}) ids from tri_offset[f].
  std::vector<Index> tri_ids, tri_offset(t.num_faces + 1, 0);
  // Two faces whose fans share a triangle (two triangles on one vertex triple, a "pillow") are a valid
  // polygon mesh that subdivide() takes, but the Mt cannot hold the same triangle twice: name the faces.
  struct TriangleHash {
    std::size_t operator()(const std::array<Index, 3>& c) const noexcept {
      return std::hash<std::uint64_t>{}((std::uint64_t{c[0]} << 32 | c[1]) * 0x9E3779B97F4A7C15ull ^ c[2]);
    }
  };
  std::unordered_map<std::array<Index, 3>, Index, TriangleHash> fan_owner;  // sorted corners -> face
  fan_owner.reserve(t.face_verts.size());
  // A fan's diagonals must be new edges: a diagonal that is already an edge of the mesh (or of another
  // face's fan) would be used twice in one direction, and no front would be a conforming mesh. The fan
  // starts at corner 0 unless one of its diagonals is taken; then at the first corner whose diagonals are
  // all free.
  std::unordered_set<std::uint64_t> taken;  // undirected edges of the mesh and of the fans so far
  for (std::size_t e = 0; e < t.num_edges(); ++e) taken.insert(undirected_edge_key(t.edge_verts[2 * e], t.edge_verts[2 * e + 1]));
  // Per base face, the corner its fan starts from: a quad's first diagonal step splits the diagonal from
  // that corner, and its node error is measured against that diagonal's midpoint.
  std::vector<Index> fan_apex(t.num_faces, 0);
  for (Index f = 0; f < t.num_faces; ++f) {
    const Index off = t.offset(f), k = t.face_size(f);
    Index apex = 0;
    if (k > 3) {
      auto free_from = [&](Index r) {
        for (Index i = 2; i + 1 < k; ++i)
          if (taken.count(undirected_edge_key(t.face_verts[off + r], t.face_verts[off + (r + i) % k]))) return false;
        return true;
      };
      while (apex < k && !free_from(apex)) ++apex;
      if (apex == k)
        throw InvalidInput("build_subdivision_mt: face " + std::to_string(f) +
                               ": every fan of it has a diagonal that is already an edge of the mesh (or of another "
                               "face's fan), so its triangles could not form a conforming mesh",
                           f);
      for (Index i = 2; i + 1 < k; ++i)
        taken.insert(undirected_edge_key(t.face_verts[off + apex], t.face_verts[off + (apex + i) % k]));
      fan_apex[f] = apex;
    }
    for (Index i = 1; i + 1 < k; ++i) {
      const std::array<Index, 3> c{t.face_verts[off + apex], t.face_verts[off + (apex + i) % k],
                                   t.face_verts[off + (apex + i + 1) % k]};
      std::array<Index, 3> sorted = c;
      std::sort(sorted.begin(), sorted.end());
      if (const auto [it, inserted] = fan_owner.emplace(sorted, f); !inserted)
        throw InvalidInput("build_subdivision_mt: faces " + std::to_string(it->second) + " and " + std::to_string(f) +
                               " both hold the triangle (" + std::to_string(sorted[0]) + ", " + std::to_string(sorted[1]) +
                               ", " + std::to_string(sorted[2]) +
                               ") in their fans (two faces on one set of corners?): a hierarchy cannot hold it twice",
                           f);
      tri_ids.push_back(b.add_face(c[0], c[1], c[2]));
    }
    tri_offset[f + 1] = static_cast<Index>(tri_ids.size());
  }
  b.set_base(tri_ids);
  std::vector<Index> slot_tri;  // after a diagonal step: per corner slot, the fan triangle (f, c_i, c_{i+1})
  std::vector<FaceId> created;
  for (int s = 0; s < steps; ++s) {
    const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
    if (s % 2 == 0) {
      slot_tri.assign(t.face_verts.size(), kInvalid);
      for (Index f = 0; f < nf; ++f) {
        const Index off = t.offset(f), k = t.face_size(f);
        const Index* c = &t.face_verts[off];
        created.clear();
        glm::dvec3 mid(0.0);
        for (Index i = 0; i < k; ++i) {
          slot_tri[off + i] = b.add_face(nv + f, c[i], c[(i + 1) % k]);
          created.push_back(slot_tri[off + i]);
          mid += p[c[i]];
        }
        // Later levels fan every quad from corner 0; a base quad from its fan_apex.
        const Index a = s == 0 ? fan_apex[f] : 0;
        mid = k == 4 ? 0.5 * (p[c[a]] + p[c[(a + 2) % 4]]) : mid / static_cast<double>(k);
        const std::span<const Index> removed(tri_ids.data() + tri_offset[f], tri_offset[f + 1] - tri_offset[f]);
        b.add_node(k == 4 ? NodeKind::kSplit : NodeKind::kGeneric, removed, created, dist(nv + f, mid));
        builder_step.push_back(static_cast<std::uint16_t>(s + 1));
      }
      continue;
    }
    // Edge step: per edge, its one or two slots; the halves become the triangles of the child quads
    // (child quad off + i = (c_i, e_i, f, e_{i-1}): triangle 0 = (f, c_i, e_i), triangle 1 = (f, e_{i-1}, c_i)).
    const std::size_t ne = t.num_edges();
    std::vector<Index> slot_a(ne, kInvalid), slot_b(ne, kInvalid), slot_face(t.face_verts.size());
    for (Index f = 0; f < nf; ++f)
      for (Index i = t.offset(f); i < t.offset(f) + t.face_size(f); ++i) {
        slot_face[i] = f;
        const Index e = t.face_edges[i];
        (slot_a[e] == kInvalid ? slot_a[e] : slot_b[e]) = i;
      }
    const std::size_t child_faces = t.face_verts.size();
    std::vector<Index> child_tris(2 * child_faces, kInvalid);
    const Index edge_base = nv + nf;
    for (std::size_t e = 0; e < ne; ++e) {
      const Index m = edge_base + static_cast<Index>(e);
      Index removed[2];
      std::size_t nr = 0;
      created.clear();
      for (Index slot : {slot_a[e], slot_b[e]}) {
        if (slot == kInvalid) continue;
        const Index f = slot_face[slot], off = t.offset(f), k = t.face_size(f), i = slot - off;
        const Index ci = t.face_verts[slot], cn = t.face_verts[off + (i + 1) % k];
        removed[nr++] = slot_tri[slot];
        const FaceId first = b.add_face(nv + f, ci, m), second = b.add_face(nv + f, m, cn);
        created.push_back(first);
        created.push_back(second);
        child_tris[2 * std::size_t{slot}] = first;
        child_tris[2 * std::size_t{off + (i + 1) % k} + 1] = second;
      }
      const glm::dvec3 mid = 0.5 * (p[t.edge_verts[2 * e]] + p[t.edge_verts[2 * e + 1]]);
      b.add_node(NodeKind::kSplit, std::span<const Index>(removed, nr), created, dist(m, mid));
      builder_step.push_back(static_cast<std::uint16_t>(s + 1));
    }
    t = refine_subdiv_topology(t, true);
    tri_ids.swap(child_tris);
    tri_offset.resize(t.num_faces + 1);
    for (std::size_t f = 0; f <= t.num_faces; ++f) tri_offset[f] = static_cast<Index>(2 * f);
  }
  std::vector<NodeId> node_new_to_old;
  Mt mt = std::move(b).build(MtBuilder::Options{}, &node_new_to_old);
  if (info) {
    info->node_step.resize(node_new_to_old.size());
    for (std::size_t n = 0; n < node_new_to_old.size(); ++n) info->node_step[n] = builder_step[node_new_to_old[n]];
    info->uniform_faces = final_mesh.to_tri_mesh().num_faces();
  }
  return mt;
}

}  // namespace varmesh
