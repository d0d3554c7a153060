// Dual subdivision steps on polygon meshes: Zwart-Powell (mid-edge) and Doo-Sabin.
//
// Papers and results used:
// - J. Peters, U. Reif, "The simplest subdivision scheme for smoothing polyhedra", ACM TOG 16(4), 1997:
//   the mid-edge topology (new vertices on edge midpoints, one face per old face and per old vertex).
// - P. B. Zwart, "Multivariate splines with nondegenerate partitions", SIAM J. Numer. Anal. 10, 1973, and
//   M. J. D. Powell, "Piecewise quadratic surface fitting for contour plotting", 1974: the quadratic
//   four-direction box spline whose quincunx refinement is the regular mid-edge step.
// - D. Doo, M. Sabin, "Behaviour of recursive division surfaces near extraordinary points", CAD 10(6),
//   1978: the corner-point weights w_ii = (k + 5) / (4k), w_ij = (3 + 2 cos(2 pi (i - j) / k)) / (4k).
// - G. Chaikin, "An algorithm for high speed curve generation", CGIP 3, 1974: the border rule of the
//   Doo-Sabin step (3/4, 1/4 corner cutting: the quadratic B-spline).
//
// The edges come from find_topology_problem (poly_mesh.hpp), which checks the manifold rules of
// PolyMesh::validate() and pairs the opposite sides of the edges on the way.
#include "fourk/subdiv_dual.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <unordered_map>

#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "multitri/errors.hpp"

namespace varmesh {

namespace {

constexpr std::uint8_t kUnused = 0, kInterior = 1, kInteriorTwo = 2, kBorder = 3;

// Connectivity of a valid PolyMesh as seen by the dual steps. Corner slot s = index into corners.
struct Topology {
  const PolyMesh* mesh = nullptr;
  std::vector<Index> slot_face;   // per slot: its face
  std::vector<Index> face_edge;   // per slot s: the edge corners[s] -> corners[next(s)]
  std::vector<Index> edge_slots;  // per edge: its two slots (the edge starts there); second = kInvalid on the border
  std::vector<Index> start;       // per vertex: first slot of its vertex face walk (kInvalid: unreferenced)
  std::vector<std::uint8_t> kind;  // per vertex: kUnused, kInterior, kInteriorTwo, kBorder
  std::size_t num_border_edges = 0;
  std::size_t num_faced_vertices = 0;  // interior with >= 3 edges, or border
  std::size_t num_interior_two = 0;

  std::size_t num_edges() const noexcept { return edge_slots.size() / 2; }
  Index next(Index s) const noexcept {
    const Index f = slot_face[s];
    return s + 1 == mesh->face_offsets[f + 1] ? mesh->face_offsets[f] : s + 1;
  }
  Index prev(Index s) const noexcept {
    const Index f = slot_face[s];
    return s == mesh->face_offsets[f] ? mesh->face_offsets[f + 1] - 1 : s - 1;
  }
  // The corner of the same vertex in the face across the edge that enters corners[s] in its face
  // (kInvalid on the border). Following it from start[v] visits v's faces in the order of v's vertex face.
  Index across_in(Index s) const noexcept {
    const Index p = prev(s);
    const Index e = face_edge[p];
    return edge_slots[2 * e] == p ? edge_slots[2 * e + 1] : edge_slots[2 * e];
  }
};

std::string str(std::uint64_t x) { return std::to_string(x); }

// Throws, as PolyMesh::validate() does, when face f's offsets run backwards or past the corners, it has
// fewer than 3 corners or a corner out of range.
void check_face(const PolyMesh& in, std::size_t f, const std::string& w) {
  const std::size_t nc = in.corners.size(), nv = in.positions.size();
  const Index b = in.face_offsets[f], e = in.face_offsets[f + 1];
  // e > nc: the offsets must decrease later; caught here, before any corner beyond the array is read.
  if (e < b || e > nc) throw InvalidInput(w + "face_offsets decrease or run past the corners at face " + str(f), f);
  if (e - b < 3) throw InvalidInput(w + "face " + str(f) + " has fewer than 3 corners", f);
  for (Index s = b; s < e; ++s)
    if (in.corners[s] >= nv)
      throw InvalidInput(w + "face " + str(f) + " uses vertex " + str(in.corners[s]) + " out of range (" + str(nv) +
                             " vertices)",
                         f);
}

// Builds the topology and checks the conditions of PolyMesh::validate(): it throws what validate() throws
// (the same element, the same words after `who: ` in place of "polygon mesh: "), but for "has no face".
// The manifold rules are find_topology_problem's (poly_mesh.hpp), whose opposite sides give the edges: its
// sort of the sides around each vertex costs less than the hash table of edges it replaced (this function
// took 0.13 s instead of 0.25 s on a 1000 x 1000 torus of quads, -O3).
Topology build_topology(const PolyMesh& in, const char* who) {
  const std::string w = std::string(who) + ": ";
  if (in.face_offsets.empty() || in.face_offsets.front() != 0)
    throw InvalidInput(w + "face_offsets must start with 0");
  if (in.face_offsets.back() != in.corners.size())
    throw InvalidInput(w + "face_offsets must end with the number of corners");
  const std::size_t nf = in.num_faces();
  if (nf == 0) throw InvalidInput(w + "the polygon mesh has no face");
  const std::size_t nv = in.positions.size();
  for (std::size_t v = 0; v < nv; ++v) {
    const glm::dvec3& p = in.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InvalidInput(w + "vertex " + str(v) + " has a non-finite coordinate", v);
    // As PolyMesh::validate(): a midpoint or a corner point of coordinates near the double maximum
    // overflows before it is scaled down.
    if (std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) > 1e300)
      throw InvalidInput(w + "vertex " + str(v) + " has a coordinate beyond 1e300 in size", v);
  }
  for (std::size_t f = 0; f < nf; ++f) check_face(in, f, w);
  std::vector<Index> opposite;
  if (const TopologyProblem problem = find_topology_problem(in.face_offsets, in.corners, nv, kPolyMeshRules, &opposite))
    throw InvalidInput(w + describe_topology_problem(problem), problem.element());

  const std::size_t nc = in.corners.size();
  Topology t;
  t.mesh = &in;
  t.slot_face.resize(nc);
  for (std::size_t f = 0; f < nf; ++f)
    for (Index s = in.face_offsets[f]; s < in.face_offsets[f + 1]; ++s) t.slot_face[s] = static_cast<Index>(f);
  // Edges in order of first appearance: a side opens an edge unless its opposite side came before it.
  t.face_edge.resize(nc);
  t.edge_slots.reserve(nc + 2);
  t.start.assign(nv, kInvalid);
  std::vector<Index> corners_at(nv, 0);
  std::vector<std::uint8_t> has_border(nv, 0);
  for (Index s = 0; s < nc; ++s) {
    const Index v = in.corners[s], o = opposite[s];
    if (corners_at[v]++ == 0) t.start[v] = s;
    if (o != kInvalid && o < s) {
      t.face_edge[s] = t.face_edge[o];
      continue;
    }
    t.face_edge[s] = static_cast<Index>(t.edge_slots.size() / 2);
    t.edge_slots.push_back(s);
    t.edge_slots.push_back(o);
    // A border vertex starts its walk at the corner whose outgoing edge is on the border (one fan: one such).
    if (o == kInvalid) {
      ++t.num_border_edges;
      has_border[v] = 1;
      t.start[v] = s;
    }
  }
  t.kind.assign(nv, kUnused);
  for (std::size_t v = 0; v < nv; ++v) {
    if (corners_at[v] == 0) continue;
    if (has_border[v]) {
      t.kind[v] = kBorder;
      ++t.num_faced_vertices;
    } else if (corners_at[v] == 2) {
      t.kind[v] = kInteriorTwo;
      ++t.num_interior_two;
    } else {
      t.kind[v] = kInterior;
      ++t.num_faced_vertices;
    }
  }
  return t;
}

// Calls fn(slot) for the corners of v in the order of v's vertex face.
template <class Fn>
void walk(const Topology& t, Index v, Fn&& fn) {
  const Index s0 = t.start[v];
  Index s = s0;
  do {
    fn(s);
    s = t.across_in(s);
  } while (s != s0 && s != kInvalid);
}

// Lengths of the maximal paths of interior 2-edge vertices (joined by edges whose ends are both such
// vertices), and the number of such vertices on closed cycles (pillows). A ZP step turns a path of m
// into one of m - 1 (the midpoints of its inner edges) and keeps a cycle; nothing else makes them.
struct InteriorTwoChains {
  std::vector<std::uint64_t> path_lengths;
  std::uint64_t on_cycles = 0;

  std::uint64_t count_after(int steps) const noexcept {
    std::uint64_t n = on_cycles;
    for (const std::uint64_t m : path_lengths)
      if (m > static_cast<std::uint64_t>(steps)) n += m - static_cast<std::uint64_t>(steps);
    return n;
  }
};

InteriorTwoChains interior_two_chains(const Topology& t) {
  InteriorTwoChains out;
  if (t.num_interior_two == 0) return out;
  const PolyMesh& m = *t.mesh;
  const std::size_t nv = m.positions.size();
  // The two neighbours of an interior 2-edge vertex: across its outgoing and its incoming edge.
  auto neighbour = [&](Index v, int side) {
    const Index s = t.start[v];
    return m.corners[side == 0 ? t.next(s) : t.prev(s)];
  };
  auto is_two = [&](Index v) { return t.kind[v] == kInteriorTwo; };
  // The neighbour of x that is not `from` (x has exactly two).
  auto other = [&](Index x, Index from) {
    const Index n0 = neighbour(x, 0);
    return n0 != from ? n0 : neighbour(x, 1);
  };
  std::vector<std::uint8_t> done(nv, 0);
  for (Index v = 0; v < nv; ++v) {
    if (!is_two(v) || done[v]) continue;
    // Walk one way to the end of the path (remembering the neighbour beyond it) or around the cycle.
    Index from = kInvalid, cur = v, beyond = kInvalid;
    bool cycle = false;
    for (;;) {
      const Index nxt = other(cur, from);
      if (!is_two(nxt)) {
        beyond = nxt;
        break;
      }
      if (nxt == v) {
        cycle = true;
        break;
      }
      from = cur;
      cur = nxt;
    }
    // Then count the whole component from there.
    std::uint64_t length = 0;
    Index x = cycle ? v : cur, prev = cycle ? kInvalid : beyond;
    for (;;) {
      done[x] = 1;
      ++length;
      const Index nxt = other(x, prev);
      if (!is_two(nxt) || (cycle && nxt == v)) break;
      prev = x;
      x = nxt;
    }
    if (cycle)
      out.on_cycles += length;
    else
      out.path_lengths.push_back(length);
  }
  return out;
}

struct Counts {
  std::uint64_t v = 0, f = 0, c = 0, border_edges = 0;
};

bool add(std::uint64_t a, std::uint64_t b, std::uint64_t& r) { return !__builtin_add_overflow(a, b, &r); }
bool mul(std::uint64_t a, std::uint64_t b, std::uint64_t& r) { return !__builtin_mul_overflow(a, b, &r); }

// Sizes after one step of a level with counts `x` (V_b = E_b on every 2-manifold border), `faced` vertices
// with a face and `two` interior 2-edge vertices. False on 64-bit overflow.
bool next_counts(DualScheme scheme, const Counts& x, std::uint64_t faced, std::uint64_t two, Counts& y) {
  std::uint64_t e2 = 0, e = 0;  // 2E = C + E_b (every interior edge has two corners, a border edge one)
  if (!add(x.c, x.border_edges, e2)) return false;
  e = e2 / 2;
  bool ok = true;
  if (scheme == DualScheme::kZwartPowell) {
    // V' = E + V_b, F' = F + faced, C' = C + 2E - 2 two + V_b.
    std::uint64_t c = 0;
    ok = add(e, x.border_edges, y.v) && add(x.f, faced, y.f) && add(x.c, e2, c) && add(c, x.border_edges, c);
    y.c = c - 2 * two;
    ok = ok && mul(x.border_edges, 2, y.border_edges);
  } else {
    // V' = C + 2 E_b, F' = F + faced + E, C' = 2C + 4E + 2 V_b - 2 two.
    std::uint64_t be2 = 0, c2 = 0, e4 = 0, c = 0;
    ok = mul(x.border_edges, 2, be2) && add(x.c, be2, y.v) && add(x.f, faced, y.f) && add(y.f, e, y.f) &&
         mul(x.c, 2, c2) && mul(e2, 2, e4) && add(c2, e4, c) && add(c, be2, c);
    y.c = c - 2 * two;
    y.border_edges = be2;
  }
  return ok;
}

DualMeshSize predict(const Topology& t, DualScheme scheme, int steps) {
  const PolyMesh& m = *t.mesh;
  DualMeshSize out;
  Counts x;
  x.v = m.positions.size();
  x.f = m.num_faces();
  x.c = m.corners.size();
  x.border_edges = t.num_border_edges;
  if (steps == 0) return {x.v, x.f, x.c};
  // After the first step every vertex is used; DS makes no interior 2-edge vertex, ZP only along the
  // chains of the input (interior_two_chains).
  InteriorTwoChains chains;
  if (scheme == DualScheme::kZwartPowell && steps > 1) chains = interior_two_chains(t);
  std::uint64_t faced = t.num_faced_vertices, two = t.num_interior_two;
  for (int s = 0; s < steps; ++s) {
    Counts y;
    if (!next_counts(scheme, x, faced, two, y)) {
      out.vertices = out.faces = out.corners = UINT64_MAX;
      return out;
    }
    x = y;
    two = scheme == DualScheme::kZwartPowell ? chains.count_after(s + 1) : 0;
    faced = x.v - two;
  }
  return {x.v, x.f, x.c};
}

void check_output_size(const DualMeshSize& size, const char* who) {
  if (size.corners > kMaxDualCorners || size.vertices > kMaxDualCorners)
    throw InvalidInput(std::string(who) + ": the result would have " + str(size.corners) +
                       " corners, more than 2^31");
}

PolyMesh zwart_powell(const PolyMesh& in, const Topology& t, const DualMeshSize& size) {
  const std::size_t ne = t.num_edges();
  PolyMesh out;
  out.positions.resize(size.vertices);
  for (std::size_t e = 0; e < ne; ++e) {
    const Index s = t.edge_slots[2 * e];
    out.positions[e] = 0.5 * (in.positions[in.corners[s]] + in.positions[in.corners[t.next(s)]]);
  }
  out.face_offsets.reserve(size.faces + 1);
  out.corners.reserve(size.corners);
  // Face f: corner i = midpoint of c_i -> c_{i+1}; the face keeps f's orientation (Peters-Reif, fig. 1).
  out.corners = t.face_edge;
  out.face_offsets = in.face_offsets;
  Index kept = static_cast<Index>(ne);
  for (std::size_t v = 0; v < in.positions.size(); ++v) {
    const std::uint8_t k = t.kind[v];
    if (k == kUnused || k == kInteriorTwo) continue;
    if (k == kBorder) {
      // v closes its face: (v, midpoint of its outgoing border edge, midpoints of the edges entering v).
      out.positions[kept] = in.positions[v];
      out.corners.push_back(kept++);
      out.corners.push_back(t.face_edge[t.start[v]]);
    }
    // Midpoint of the edge entering v in each face: the reverse of the corners (in, out) of the faces.
    walk(t, static_cast<Index>(v), [&](Index s) { out.corners.push_back(t.face_edge[t.prev(s)]); });
    out.face_offsets.push_back(static_cast<Index>(out.corners.size()));
  }
  return out;
}

PolyMesh doo_sabin(const PolyMesh& in, const Topology& t, const DualMeshSize& size) {
  const std::size_t nc = in.corners.size(), ne = t.num_edges();
  PolyMesh out;
  out.positions.resize(size.vertices);
  // Corner points in O(k) per face: sum_j cos(2 pi (i - j) / k) v_j = cos(a_i) Cs + sin(a_i) Sn with
  // Cs = sum cos(a_j) v_j, Sn = sum sin(a_j) v_j, and w_ii = 5 / (4k) + 1/4 is the general term plus 1/4.
  std::vector<double> cosines, sines;
  for (std::size_t f = 0; f < in.num_faces(); ++f) {
    const Index b = in.face_offsets[f];
    const std::size_t k = in.face_size(f);
    const auto p = [&](std::size_t j) { return in.positions[in.corners[b + j]]; };
    if (k == 4) {
      for (std::size_t i = 0; i < 4; ++i)
        out.positions[b + i] =
            (9.0 * p(i) + 3.0 * (p((i + 1) % 4) + p((i + 3) % 4)) + p((i + 2) % 4)) / 16.0;
      continue;
    }
    if (k == 3) {  // w_ii = 8/12, w_ij = (3 + 2 cos(2 pi / 3)) / 12 = 1/6
      for (std::size_t i = 0; i < 3; ++i)
        out.positions[b + i] = (4.0 * p(i) + p((i + 1) % 3) + p((i + 2) % 3)) / 6.0;
      continue;
    }
    cosines.resize(k);
    sines.resize(k);
    glm::dvec3 sum(0.0), cs(0.0), sn(0.0);
    for (std::size_t j = 0; j < k; ++j) {
      const double a = 2.0 * std::numbers::pi * static_cast<double>(j) / static_cast<double>(k);
      cosines[j] = std::cos(a);
      sines[j] = std::sin(a);
      sum += p(j);
      cs += cosines[j] * p(j);
      sn += sines[j] * p(j);
    }
    const double kd = static_cast<double>(k);
    for (std::size_t i = 0; i < k; ++i)
      out.positions[b + i] =
          0.25 * p(i) + (3.0 / (4.0 * kd)) * sum + (1.0 / (2.0 * kd)) * (cosines[i] * cs + sines[i] * sn);
  }
  // Border points (Chaikin): 2 per border edge, near its first then its second vertex.
  std::vector<Index> border_rank(ne, kInvalid);
  Index r = 0;
  for (std::size_t e = 0; e < ne; ++e) {
    if (t.edge_slots[2 * e + 1] != kInvalid) continue;
    const Index s = t.edge_slots[2 * e];
    const glm::dvec3 a = in.positions[in.corners[s]], c = in.positions[in.corners[t.next(s)]];
    out.positions[nc + 2 * r] = 0.75 * a + 0.25 * c;
    out.positions[nc + 2 * r + 1] = 0.25 * a + 0.75 * c;
    border_rank[e] = r++;
  }
  out.face_offsets.reserve(size.faces + 1);
  out.corners.reserve(size.corners);
  out.face_offsets = in.face_offsets;
  out.corners.resize(nc);
  for (std::size_t s = 0; s < nc; ++s) out.corners[s] = static_cast<Index>(s);
  for (std::size_t v = 0; v < in.positions.size(); ++v) {
    const std::uint8_t k = t.kind[v];
    if (k == kUnused || k == kInteriorTwo) continue;
    Index last = kInvalid;
    walk(t, static_cast<Index>(v), [&](Index s) {
      out.corners.push_back(s);
      last = s;
    });
    if (k == kBorder) {
      // Close with the border point near v of the edge entering v, then of the edge leaving v.
      const Index e_in = t.face_edge[t.prev(last)], e_out = t.face_edge[t.start[v]];
      out.corners.push_back(static_cast<Index>(nc + 2 * border_rank[e_in] + 1));
      out.corners.push_back(static_cast<Index>(nc + 2 * border_rank[e_out]));
    }
    out.face_offsets.push_back(static_cast<Index>(out.corners.size()));
  }
  // Edge quads. Interior edge a -> b in f (slot s), b -> a in g (slot u): (c(f,b), c(f,a), c(g,a), c(g,b)).
  for (std::size_t e = 0; e < ne; ++e) {
    const Index s = t.edge_slots[2 * e], u = t.edge_slots[2 * e + 1];
    if (u != kInvalid) {
      out.corners.insert(out.corners.end(), {t.next(s), s, t.next(u), u});
    } else {
      const Index q = static_cast<Index>(nc + 2 * border_rank[e]);
      out.corners.insert(out.corners.end(), {t.next(s), s, q, q + 1});
    }
    out.face_offsets.push_back(static_cast<Index>(out.corners.size()));
  }
  return out;
}

PolyMesh step(const PolyMesh& in, const Topology& t, DualScheme scheme, const char* who) {
  const DualMeshSize size = predict(t, scheme, 1);
  check_output_size(size, who);
  return scheme == DualScheme::kZwartPowell ? zwart_powell(in, t, size) : doo_sabin(in, t, size);
}

}  // namespace

const char* to_string(DualScheme scheme) noexcept {
  switch (scheme) {
    case DualScheme::kZwartPowell:
      return "zwart-powell";
    case DualScheme::kDooSabin:
      return "doo-sabin";
  }
  return "unknown";
}

PolyMesh zwart_powell_step(const PolyMesh& in) {
  const Topology t = build_topology(in, "zwart_powell_step");
  return step(in, t, DualScheme::kZwartPowell, "zwart_powell_step");
}

PolyMesh doo_sabin_step(const PolyMesh& in) {
  const Topology t = build_topology(in, "doo_sabin_step");
  return step(in, t, DualScheme::kDooSabin, "doo_sabin_step");
}

PolyMesh dual_step(const PolyMesh& in, DualScheme scheme) {
  return scheme == DualScheme::kZwartPowell ? zwart_powell_step(in) : doo_sabin_step(in);
}

DualMeshSize dual_mesh_size(const PolyMesh& base, DualScheme scheme, int steps) {
  if (steps < 0) throw InvalidInput("dual_mesh_size: steps = " + std::to_string(steps) + " is negative");
  const Topology t = build_topology(base, "dual_mesh_size");
  return predict(t, scheme, steps);
}

PolyMesh subdivide_dual(const PolyMesh& base, DualScheme scheme, int steps) {
  if (steps < 0) throw InvalidInput("subdivide_dual: steps = " + std::to_string(steps) + " is negative");
  Topology t = build_topology(base, "subdivide_dual");
  if (steps == 0) return base;
  const DualMeshSize total = predict(t, scheme, steps);
  if (total.corners > kMaxDualCorners || total.vertices > kMaxDualCorners)
    throw InvalidInput("subdivide_dual: steps = " + std::to_string(steps) + " would give " +
                       (total.corners == UINT64_MAX ? std::string("more than 2^64") : str(total.corners)) +
                       " corners, more than 2^31");
  PolyMesh out = step(base, t, scheme, "subdivide_dual");
  for (int s = 1; s < steps; ++s) {
    t = build_topology(out, "subdivide_dual");
    out = step(out, t, scheme, "subdivide_dual");
  }
  return out;
}


PolyMesh doo_sabin_by_four_eight_steps(const PolyMesh& base) {
  // Three binary steps of linear 4-8 refinement: level-1 vertices, then one point per level-1 quad.
  const SubdivMesh m = subdivide(base, SubdivScheme::kLinear, 3);
  const SubdivTopology& t = m.topo;
  const auto nv = static_cast<Index>(t.num_vertices);
  for (Index v = 0; v < nv; ++v)
    if (t.vertex_border[v])
      throw InvalidInput("doo_sabin_by_four_eight_steps: the mesh has a border (level-1 vertex " + std::to_string(v) +
                             "); only closed meshes",
                         v);
  PolyMesh out;
  out.positions.assign(m.positions.begin() + nv, m.positions.end());
  // Directed edge a -> b of a level-1 quad -> the corner slot of a in it.
  std::unordered_map<std::uint64_t, Index> slot_of;
  slot_of.reserve(t.face_verts.size());
  for (Index s = 0; s < t.face_verts.size(); ++s) {
    const Index a = t.face_verts[s], b = t.face_verts[(s & ~3u) | ((s + 1) & 3u)];
    slot_of.emplace((std::uint64_t{a} << 32) | b, s);
  }
  std::vector<Index> first_slot(nv, kInvalid);
  for (Index s = 0; s < t.face_verts.size(); ++s)
    if (first_slot[t.face_verts[s]] == kInvalid) first_slot[t.face_verts[s]] = s;
  std::vector<Index> ring;
  for (Index u = 0; u < nv; ++u) {
    if (first_slot[u] == kInvalid || t.valence[u] < 3) continue;
    // Counter-clockwise around u: from the quad with corner u, p before u, to the quad holding u -> p.
    ring.clear();
    Index s = first_slot[u];
    do {
      ring.push_back(s / 4);
      const Index p = t.face_verts[(s & ~3u) | ((s + 3) & 3u)];
      s = slot_of.at((std::uint64_t{u} << 32) | p);
    } while (s != first_slot[u] && ring.size() <= t.valence[u]);
    out.add_face(ring);
  }
  return out;
}

}  // namespace varmesh
