// Eigen-analysis of extraordinary vertices (subdiv_analysis.hpp).
//
// References: Doo and Sabin 1978 (the local subdivision matrix and its Fourier blocks); Ball and Storry,
// "Conditions for tangent plane continuity over recursively generated B-spline surfaces", ACM TOG 1988;
// Reif, "A unified approach to subdivision algorithms near extraordinary vertices", CAGD 12 (1995);
// Peters and Reif, "Subdivision Surfaces" (Springer 2008), ch. 5 (the subdominant eigenvalue condition);
// Stam, "Exact evaluation of Catmull-Clark subdivision surfaces at arbitrary parameter values", SIGGRAPH
// 1998 (Catmull-Clark's closed form, used by the tests).
//
// Why the composed stencil tables: the matrix must be the one the engine applies, including any slip in
// a weight; rebuilding S from the formulas in subdiv.hpp would check the formulas against themselves.
#include "fourk/subdiv_analysis.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_set>

#include "multitri/errors.hpp"
#include "multitri/huge_pages.hpp"

namespace varmesh {

namespace {

constexpr double kClusterTol = 1e-9;      // eigenvalues closer than this are copies of one eigenvalue
constexpr double kCirculantTol = 1e-12;   // rotation symmetry of S, entries are O(1)

void check_patch_args(int valence, int rings, const char* who) {
  if (valence < 3)
    throw InvalidInput(std::string(who) + ": valence must be at least 3 (got " + std::to_string(valence) + ")");
  if (rings < 1) throw InvalidInput(std::string(who) + ": rings must be at least 1 (got " + std::to_string(rings) + ")");
  const long long n = 1 + static_cast<long long>(valence) * rings * (rings + 1LL);
  if (n >= (1LL << 31) || static_cast<long long>(rings) * rings * valence >= (1LL << 29))
    throw InvalidInput(std::string(who) + ": the patch would have 2^31 vertices or more");
}

// The coordinate c expressed in the frame of sector t, if it can be: the centre is in every frame, a
// canonical (s, i, 0) also in frame s - 1 as (0, i).
std::optional<PatchCoord> in_frame(PatchCoord c, int t, int k) {
  if (c.is_centre()) return PatchCoord{t, 0, 0};
  if (c.sector == t) return PatchCoord{t, c.i, c.j};
  if (c.j == 0 && c.sector == (t + 1) % k) return PatchCoord{t, 0, c.i};
  return std::nullopt;
}

PatchCoord canonical(PatchCoord c, int k) {
  if (c.is_centre()) return {0, 0, 0};
  if (c.i == 0) return {(c.sector + 1) % k, c.j, 0};
  return c;
}

// Child coordinate of a parent element with corners `coords` (1 vertex, 2 for an edge, 4 for a quad):
// twice their mean, in a sector frame holding all of them. Uses only the topology of the parent.
std::optional<PatchCoord> child_coord(const std::vector<PatchCoord>& coords, int k) {
  for (const PatchCoord& probe : coords) {
    for (int t : {probe.sector, (probe.sector + k - 1) % k}) {
      int si = 0, sj = 0;
      bool ok = true;
      for (const PatchCoord& c : coords) {
        const auto f = in_frame(c, t, k);
        if (!f) {
          ok = false;
          break;
        }
        si += f->i;
        sj += f->j;
      }
      if (!ok) continue;
      const int n = static_cast<int>(coords.size());
      if ((2 * si) % n != 0 || (2 * sj) % n != 0) return std::nullopt;
      return canonical(PatchCoord{t, 2 * si / n, 2 * sj / n}, k);
    }
  }
  return std::nullopt;
}

// The fine level of one quadrisection of patch(k, R) labelled by coordinates, checked to be patch(k, 2R).
// Returns, per position index of patch(k, 2R), the fine vertex there.
std::vector<Index> fine_vertex_of_patch_index(const PolyMesh& coarse, int k, int rings) {
  const SubdivTopology t0 = make_subdiv_topology(coarse);
  const SubdivTopology t1 = refine_subdiv_topology(t0, false);
  const Index nv = static_cast<Index>(t0.num_vertices), nf = static_cast<Index>(t0.num_faces);
  const int fine_rings = 2 * rings;
  auto fail = [](const std::string& why) { throw std::logic_error("local_subdivision_matrix: " + why); };
  std::vector<Index> fine_index(t1.num_vertices, kInvalid);  // fine vertex -> patch(k, 2R) index
  auto label = [&](Index child, const std::vector<PatchCoord>& parents) {
    const auto c = child_coord(parents, k);
    if (!c) fail("fine vertex " + std::to_string(child) + " has no sector frame");
    fine_index[child] = extraordinary_patch_vertex(k, fine_rings, *c);
  };
  std::vector<PatchCoord> corner;
  for (Index v = 0; v < nv; ++v) label(v, {extraordinary_patch_coord(k, rings, v)});
  for (Index f = 0; f < nf; ++f) {
    corner.clear();
    for (Index i = 0; i < t0.face_size(f); ++i)
      corner.push_back(extraordinary_patch_coord(k, rings, t0.face_verts[t0.offset(f) + i]));
    label(nv + f, corner);
  }
  for (std::size_t e = 0; e < t0.num_edges(); ++e)
    label(nv + nf + static_cast<Index>(e), {extraordinary_patch_coord(k, rings, t0.edge_verts[2 * e]),
                                             extraordinary_patch_coord(k, rings, t0.edge_verts[2 * e + 1])});
  // The labelling must be a bijection that maps every fine face onto a face of patch(k, 2R) with the
  // same orientation: then positions mean the same thing at both levels.
  const PolyMesh fine = extraordinary_patch(k, fine_rings);
  if (fine.num_vertices() != t1.num_vertices || fine.num_faces() != t1.num_faces)
    fail("the refined patch does not have the counts of the patch of " + std::to_string(fine_rings) + " rings");
  std::vector<Index> inverse(t1.num_vertices, kInvalid);
  for (Index v = 0; v < t1.num_vertices; ++v) {
    if (inverse[fine_index[v]] != kInvalid) fail("two fine vertices share a position");
    inverse[fine_index[v]] = v;
  }
  std::unordered_set<std::uint64_t> directed;
  auto key = [](Index a, Index b) { return (std::uint64_t{a} << 32) | b; };
  for (std::size_t f = 0; f < fine.num_faces(); ++f) {
    const auto q = fine.face(f);
    for (std::size_t i = 0; i < q.size(); ++i) directed.insert(key(q[i], q[(i + 1) % q.size()]));
  }
  for (Index f = 0; f < t1.num_faces; ++f)
    for (Index i = 0; i < 4; ++i) {
      const Index a = t1.face_verts[4 * f + i], b = t1.face_verts[4 * f + (i + 1) % 4];
      if (!directed.count(key(fine_index[a], fine_index[b])))
        fail("fine face " + std::to_string(f) + " is not a face of the patch of " + std::to_string(fine_rings) +
             " rings");
    }
  return inverse;
}

std::optional<LocalSubdivMatrix> try_ring(SubdivScheme scheme, int k, int r) {
  // The dense matrix grows as (k r^2)^2: refused before the patch and its tables are built when it would
  // not fit in memory (valence 40000 at ring 1: 80001^2 entries, 51 GB, which ended in std::bad_alloc).
  const double dim = 1.0 + double(k) * r * (r + 1.0), bytes = 8.0 * dim * dim, ram = physical_memory_bytes();
  if (ram > 0.0 && bytes > ram)
    throw InvalidInput("local_subdivision_matrix: valence " + std::to_string(k) + " at ring " + std::to_string(r) +
                       " makes a dense " + std::to_string(static_cast<long long>(dim)) + " x " +
                       std::to_string(static_cast<long long>(dim)) + " matrix, about " +
                       std::to_string(static_cast<long long>(bytes / 1e9)) + " GB, more than the " +
                       std::to_string(static_cast<long long>(ram / 1e9)) + " GB of memory here (valence)",
                       static_cast<std::uint64_t>(k));
  // Two rings beyond r: every rule that can reach a ring-r row is then an interior rule, and a border
  // rule could only enter through a column outside ring r, which the closure test rejects.
  const int rings = r + 2;
  const PolyMesh patch = extraordinary_patch(k, rings);
  const std::vector<Index> fine_at = fine_vertex_of_patch_index(patch, k, rings);
  const std::vector<StencilTable> tables = subdiv_stencil_tables(patch, scheme, 2);
  const StencilTable composed = tables[1].after(tables[0]);

  LocalSubdivMatrix s;
  s.scheme = scheme;
  s.valence = k;
  s.ring = r;
  s.positions.push_back({0, 0, 0});
  for (int sec = 0; sec < k; ++sec)
    for (int i = 1; i <= r; ++i)
      for (int j = 0; j <= r; ++j) s.positions.push_back({sec, i, j});
  const std::size_t n = s.size();
  s.entries.assign(n * n, 0.0);
  for (std::size_t p = 0; p < n; ++p) {
    const Index w = fine_at[extraordinary_patch_vertex(k, 2 * rings, s.positions[p])];
    for (Index e = composed.offsets[w]; e < composed.offsets[w + 1]; ++e) {
      if (composed.weights[e] == 0.0) continue;
      const std::size_t q = s.position_of(extraordinary_patch_coord(k, rings, composed.sources[e]));
      if (q == n) return std::nullopt;  // not closed: enlarge r
      s.entries[p * n + q] += composed.weights[e];
    }
  }
  return s;
}

void check_matrix(const LocalSubdivMatrix& s, const char* who) {
  const std::size_t m = s.sector_size();
  if (s.valence < 3 || s.ring < 1 || s.size() != 1 + static_cast<std::size_t>(s.valence) * m ||
      s.entries.size() != s.size() * s.size())
    throw InvalidInput(std::string(who) + ": the matrix sizes do not match its valence and ring");
}

using Cplx = std::complex<double>;

std::vector<Cplx> sorted_by_modulus(std::vector<Cplx> v) {
  std::sort(v.begin(), v.end(), [](Cplx a, Cplx b) {
    const double ma = std::abs(a), mb = std::abs(b);
    if (ma != mb) return ma > mb;
    if (a.real() != b.real()) return a.real() > b.real();
    return a.imag() > b.imag();
  });
  return v;
}

}  // namespace

PolyMesh extraordinary_patch(int valence, int rings) {
  check_patch_args(valence, rings, "extraordinary_patch");
  const int k = valence, r = rings;
  PolyMesh m;
  m.positions.resize(1 + static_cast<std::size_t>(k) * r * (r + 1));
  m.positions[0] = glm::dvec3(0.0);
  for (int s = 0; s < k; ++s) {
    const double a0 = 2 * std::numbers::pi * s / k, a1 = 2 * std::numbers::pi * (s + 1) / k;
    const glm::dvec3 u0(std::cos(a0), std::sin(a0), 0.0), u1(std::cos(a1), std::sin(a1), 0.0);
    for (int i = 1; i <= r; ++i)
      for (int j = 0; j <= r; ++j)
        m.positions[extraordinary_patch_vertex(k, r, {s, i, j})] = static_cast<double>(i) * u0 +
                                                                      static_cast<double>(j) * u1;
  }
  m.corners.reserve(4 * static_cast<std::size_t>(k) * r * r);
  for (int s = 0; s < k; ++s)
    for (int a = 0; a < r; ++a)
      for (int b = 0; b < r; ++b) {
        const Index q[4] = {extraordinary_patch_vertex(k, r, {s, a, b}), extraordinary_patch_vertex(k, r, {s, a + 1, b}),
                            extraordinary_patch_vertex(k, r, {s, a + 1, b + 1}),
                            extraordinary_patch_vertex(k, r, {s, a, b + 1})};
        m.add_face(q);
      }
  return m;
}

Index extraordinary_patch_vertex(int valence, int rings, PatchCoord c) {
  check_patch_args(valence, rings, "extraordinary_patch_vertex");
  if (c.sector < 0 || c.sector >= valence || c.i < 0 || c.j < 0 || c.i > rings || c.j > rings)
    throw InvalidInput("extraordinary_patch_vertex: coordinate (" + std::to_string(c.sector) + ", " +
                       std::to_string(c.i) + ", " + std::to_string(c.j) + ") outside the patch");
  if (c.is_centre()) return 0;
  const PatchCoord k = canonical(c, valence);
  return static_cast<Index>(1 + k.sector * rings * (rings + 1) + (k.i - 1) * (rings + 1) + k.j);
}

PatchCoord extraordinary_patch_coord(int valence, int rings, Index v) {
  check_patch_args(valence, rings, "extraordinary_patch_coord");
  const Index per_sector = static_cast<Index>(rings * (rings + 1));
  if (v >= 1 + static_cast<Index>(valence) * per_sector)
    throw InvalidInput("extraordinary_patch_coord: vertex " + std::to_string(v) + " outside the patch", v);
  if (v == 0) return {0, 0, 0};
  const Index w = v - 1, in = w % per_sector;
  const Index row = static_cast<Index>(rings + 1);
  return {static_cast<int>(w / per_sector), static_cast<int>(in / row) + 1, static_cast<int>(in % row)};
}

std::size_t LocalSubdivMatrix::position_of(PatchCoord c) const noexcept {
  if (valence < 3 || c.i < 0 || c.j < 0 || c.sector < 0 || c.sector >= valence) return size();
  if (c.is_centre()) return 0;
  if (c.ring() > ring) return size();
  const PatchCoord k = canonical(c, valence);
  return 1 + static_cast<std::size_t>(k.sector) * sector_size() + static_cast<std::size_t>(k.i - 1) * (ring + 1) +
         static_cast<std::size_t>(k.j);
}

LocalSubdivMatrix local_subdivision_matrix(SubdivScheme scheme, int valence, int min_ring, int max_ring) {
  check_patch_args(valence, 1, "local_subdivision_matrix");
  if (min_ring < 1 || max_ring < min_ring || max_ring > 32)
    throw InvalidInput("local_subdivision_matrix: need 1 <= min_ring <= max_ring <= 32 (got " +
                       std::to_string(min_ring) + ", " + std::to_string(max_ring) + ")");
  for (int r = min_ring; r <= max_ring; ++r)
    if (auto s = try_ring(scheme, valence, r)) return std::move(*s);
  throw std::logic_error("local_subdivision_matrix: no ring in [" + std::to_string(min_ring) + ", " +
                         std::to_string(max_ring) + "] is invariant under one quadrisection");
}

SubdivSpectrum fourier_spectrum(const LocalSubdivMatrix& s) {
  check_matrix(s, "fourier_spectrum");
  const int k = s.valence;
  const std::size_t m = s.sector_size();
  const auto km = static_cast<std::size_t>(k);
  auto row0 = [&](std::size_t sec, std::size_t a) { return 1 + sec * m + a; };
  auto bad = [](std::size_t row, std::size_t col) {
    throw InvalidInput("fourier_spectrum: the matrix is not block-circulant at entry (" + std::to_string(row) + ", " +
                       std::to_string(col) + ")");
  };
  // C_u = block (fine sector 0, coarse sector u); check every other block against it, and the centre.
  for (std::size_t sec = 0; sec < km; ++sec) {
    for (std::size_t a = 0; a < m; ++a) {
      if (std::abs(s.at(0, row0(sec, a)) - s.at(0, row0(0, a))) > kCirculantTol) bad(0, row0(sec, a));
      if (std::abs(s.at(row0(sec, a), 0) - s.at(row0(0, a), 0)) > kCirculantTol) bad(row0(sec, a), 0);
      for (std::size_t t = 0; t < km; ++t)
        for (std::size_t b = 0; b < m; ++b) {
          const std::size_t u = (t + km - sec) % km;
          if (std::abs(s.at(row0(sec, a), row0(t, b)) - s.at(row0(0, a), row0(u, b))) > kCirculantTol)
            bad(row0(sec, a), row0(t, b));
        }
    }
  }
  SubdivSpectrum out;
  out.valence = k;
  out.modes.resize(km);
  const auto mi = static_cast<Eigen::Index>(m);
  for (std::size_t w = 0; w < km; ++w) {
    Eigen::MatrixXcd block = Eigen::MatrixXcd::Zero(mi, mi);
    for (std::size_t u = 0; u < km; ++u) {
      const Cplx phase = std::polar(1.0, 2 * std::numbers::pi * static_cast<double>(w * u) / k);
      for (std::size_t a = 0; a < m; ++a)
        for (std::size_t b = 0; b < m; ++b)
          block(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) += phase * s.at(row0(0, a), row0(u, b));
    }
    std::vector<Cplx> ev;
    if (w == 0) {
      // Mode 0 with the centre: x = (x_c, x^ in every sector).
      Eigen::MatrixXd full(mi + 1, mi + 1);
      full(0, 0) = s.at(0, 0);
      for (Eigen::Index a = 0; a < mi; ++a) {
        full(0, a + 1) = static_cast<double>(k) * s.at(0, row0(0, static_cast<std::size_t>(a)));
        full(a + 1, 0) = s.at(row0(0, static_cast<std::size_t>(a)), 0);
        for (Eigen::Index b = 0; b < mi; ++b) full(a + 1, b + 1) = block(a, b).real();
      }
      const Eigen::EigenSolver<Eigen::MatrixXd> solver(full, false);
      for (Eigen::Index i = 0; i <= mi; ++i) ev.push_back(solver.eigenvalues()(i));
    } else {
      const Eigen::ComplexEigenSolver<Eigen::MatrixXcd> solver(block, false);
      for (Eigen::Index i = 0; i < mi; ++i) ev.push_back(solver.eigenvalues()(i));
    }
    out.modes[w] = sorted_by_modulus(std::move(ev));
  }
  // All eigenvalues with their modes, by decreasing modulus; then the dominant and subdominant clusters.
  struct Entry {
    Cplx value;
    int mode;
  };
  std::vector<Entry> all;
  for (std::size_t w = 0; w < km; ++w)
    for (Cplx v : out.modes[w]) all.push_back({v, static_cast<int>(w)});
  std::stable_sort(all.begin(), all.end(),
                   [](const Entry& a, const Entry& b) { return std::abs(a.value) > std::abs(b.value); });
  std::vector<bool> used(all.size(), false);
  out.dominant = all[0].value;
  out.dominant_mode = all[0].mode;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (std::abs(all[i].value - out.dominant) <= kClusterTol) {
      used[i] = true;
      ++out.dominant_multiplicity;
      if (all[i].mode == 0) out.dominant_mode = 0;
    }
  const auto first_unused = [&]() {
    for (std::size_t i = 0; i < all.size(); ++i)
      if (!used[i]) return i;
    return all.size();
  };
  const std::size_t sub = first_unused();
  if (sub == all.size()) return out;
  out.subdominant = all[sub].value;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (!used[i] && std::abs(all[i].value - out.subdominant) <= kClusterTol) {
      used[i] = true;
      out.subdominant_modes.push_back(all[i].mode);
    }
  std::sort(out.subdominant_modes.begin(), out.subdominant_modes.end());
  const std::size_t nx = first_unused();
  if (nx == all.size()) return out;
  out.next = all[nx].value;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (!used[i] && std::abs(all[i].value - out.next) <= kClusterTol) out.next_modes.push_back(all[i].mode);
  std::sort(out.next_modes.begin(), out.next_modes.end());
  return out;
}

bool SubdivSpectrum::meets_subdominant_condition(double tol) const {
  const int k = valence;
  if (k < 3 || std::abs(dominant - 1.0) > tol || dominant_mode != 0 || dominant_multiplicity != 1) return false;
  if (std::abs(subdominant.imag()) > tol || subdominant.real() <= tol) return false;
  if (subdominant_modes != std::vector<int>{1, k - 1}) return false;
  return gap() > tol;
}

SubdivSpectrum subdivision_spectrum(SubdivScheme scheme, int valence) {
  return fourier_spectrum(local_subdivision_matrix(scheme, valence));
}

std::vector<std::complex<double>> dense_eigenvalues(const LocalSubdivMatrix& s) {
  check_matrix(s, "dense_eigenvalues");
  const auto n = static_cast<Eigen::Index>(s.size());
  Eigen::MatrixXd a(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) a(i, j) = s.at(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(a, false);
  std::vector<Cplx> ev(solver.eigenvalues().data(), solver.eigenvalues().data() + n);
  return sorted_by_modulus(std::move(ev));
}

}  // namespace varmesh
