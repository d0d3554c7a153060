#pragma once
/// Eigen-analysis of the extraordinary-vertex rules of the binary 4-8 schemes (subdiv.hpp).
///
/// The patch. extraordinary_patch(k, R) is a quad mesh around one interior vertex of valence k (vertex 0,
/// the centre): k sectors, sector s an R x R grid of quads with sector coordinates (i, j), 0 <= i, j <= R,
/// i along spoke s and j along spoke s + 1. The vertex (0, j) of sector s is the vertex (j, 0) of sector
/// s + 1, so every vertex other than the centre has one canonical coordinate (s, i, j) with 1 <= i <= R,
/// 0 <= j <= R; its index is 1 + s R (R + 1) + (i - 1)(R + 1) + j. Face s R^2 + a R + b is the quad
/// (a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1) of sector s (corners 0 and 2 on its 4-8 diagonal).
/// Every vertex with max(i, j) < R is interior with 4 edges (the centre: k); those with max(i, j) = R are
/// on the border.
///
/// The local subdivision matrix. Ring r is the set of positions with max(i, j) <= r (the vertices of
/// the r-ring of faces around the centre), ordered: the centre, then sector by sector (i - 1)(r + 1) + j,
/// m = r (r + 1) positions per sector. One quadrisection (a diagonal step then an edge step) maps the
/// coarse vertex at (s, i, j) to the fine vertex at (s, 2i, 2j), the edge point of the coarse edge with
/// doubled coordinates (s, i0 + i1, j0 + j1) there, and the face point likewise; so the fine patch is
/// again a patch of the same shape and a position means the same thing at both levels. The matrix
/// S[p][q] is the weight of the coarse vertex at position q in the fine vertex at position p, read from
/// the engine's composed stencil tables (subdiv_stencil_tables, StencilTable::after): it analyses the
/// code, not a re-derivation. local_subdivision_matrix() picks the smallest r whose rows reference only
/// ring-r columns (Catmull-Clark: 1, 4-8: 2) and checks that the fine topology is the 2R patch.
///
/// The spectrum. S commutes with the rotation by one sector, so it is block-circulant: its eigenvalues
/// are those of the Fourier blocks S^(w) = sum_u C_u exp(2 pi i w u / k), w = 0 .. k - 1, where C_u is
/// the block from coarse sector s + u to fine sector s; the centre couples to mode 0 only, which is one
/// larger. A necessary condition for a C1 limit at the centre (Reif 1995; Peters and Reif, "Subdivision
/// Surfaces", 2008, ch. 5) is: the dominant eigenvalue 1 is simple and in mode 0; the subdominant is real,
/// positive, double, in modes 1 and k - 1, and strictly larger in modulus than every other eigenvalue.
/// SubdivSpectrum::meets_subdominant_condition() checks exactly that; tests/fourk/subdiv_analysis_test.cpp
/// checks it for the 4-8 rule of four_eight_weight() and for Catmull-Clark at valences 3 to 12, and
/// Catmull-Clark's subdominant against Stam's closed form.
///
/// The 4-8 rule (four_eight_weight() = 1/2). Only the centre's rules use a_n, and the centre lives in
/// mode 0, so a_n moves only mode 0 (there: 1, then 1/4 for every n); the blocks of modes w != 0 hold
/// only the regular rules and depend on cos(2 pi w / n) alone. Subdominant (modes 1, n - 1) for n = 3..12:
/// 0.408311, 0.5, 0.551323, 0.581868, 0.601250, 0.614232, 0.623318, 0.629913, 0.634843, 0.638622; the
/// next eigenvalue is 1/4 (mode 0, and mode 2 at n = 4) for n = 3, 4 and the mode-2 pair beyond.
#include <complex>
#include <cstddef>
#include <vector>

#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "multitri/types.hpp"

namespace varmesh {

/// A position of extraordinary_patch(): the centre (i = j = 0, any sector) or (sector, i, j).
struct PatchCoord {
  int sector = 0;
  int i = 0;
  int j = 0;
  bool is_centre() const noexcept { return i == 0 && j == 0; }
  int ring() const noexcept { return i > j ? i : j; }  ///< max(i, j): the face ring the vertex closes
};

/// The patch described above, positions i u_s + j u_{s+1} with u_s the unit vector at angle 2 pi s / k
/// (planar, z = 0; non-degenerate for k >= 3). Throws InvalidInput when valence < 3 or rings < 1 or the
/// patch would have 2^31 vertices or more. Cost: O(k R^2).
PolyMesh extraordinary_patch(int valence, int rings);

/// Index in extraordinary_patch(valence, rings) of the vertex at sector coordinates (c.sector, c.i, c.j)
/// (any sector frame: (0, j) is taken as sector + 1's (j, 0)). Throws InvalidInput when c is out of range.
Index extraordinary_patch_vertex(int valence, int rings, PatchCoord c);
/// Canonical coordinate of vertex v (centre: {0, 0, 0}; else 1 <= i). Throws InvalidInput when v is out
/// of range.
PatchCoord extraordinary_patch_coord(int valence, int rings, Index v);

/// The local subdivision matrix of one quadrisection (two binary steps) around a vertex of valence k.
struct LocalSubdivMatrix {
  SubdivScheme scheme = SubdivScheme::kLinear;
  int valence = 0;
  int ring = 0;                      ///< r: the positions are those with max(i, j) <= r
  std::vector<PatchCoord> positions;  ///< row / column p: the centre, then sector by sector (canonical)
  std::vector<double> entries;        ///< row-major, size() x size()

  std::size_t size() const noexcept { return positions.size(); }
  std::size_t sector_size() const noexcept { return static_cast<std::size_t>(ring) * (ring + 1); }
  double at(std::size_t row, std::size_t col) const noexcept { return entries[row * size() + col]; }
  /// Position index of the (canonical or not) coordinate c, or size() when c lies outside ring r.
  std::size_t position_of(PatchCoord c) const noexcept;
};

/// Builds S from subdiv_stencil_tables(extraordinary_patch(valence, r + 2), scheme, 2) for the smallest
/// r in [min_ring, max_ring] whose selected rows reference only selected columns (a larger r adds only
/// the eigenvalues of the outer rings; the tests check that the leading ones do not change). Throws
/// InvalidInput when valence < 3 or not 1 <= min_ring <= max_ring <= 32, or naming the valence when the
/// dense matrix of a ring it tries (8 bytes per entry) would not fit in the machine's physical memory
/// (checked before anything of that ring is built), std::logic_error when no r in
/// the range closes or the refined topology is not the patch of 2(r + 2) rings (an engine bug).
/// Cost: O(k r^2) for the tables plus the dense (1 + k r (r + 1))^2 matrix.
LocalSubdivMatrix local_subdivision_matrix(SubdivScheme scheme, int valence, int min_ring = 1, int max_ring = 8);

/// The spectrum of a local subdivision matrix, mode by mode.
struct SubdivSpectrum {
  int valence = 0;
  /// modes[w]: the eigenvalues of the Fourier block of mode w, by decreasing modulus. Eigenvalues of
  /// defective blocks (Catmull-Clark's 0 for instance) carry the usual eps^(1/size) rounding.
  std::vector<std::vector<std::complex<double>>> modes;
  std::complex<double> dominant;    ///< the eigenvalue of largest modulus (1 for an affine-invariant scheme)
  int dominant_mode = 0;            ///< its mode (0 when one of its copies lies in mode 0)
  int dominant_multiplicity = 0;    ///< copies within 1e-9 of `dominant`, over all modes
  std::complex<double> subdominant; ///< the largest modulus after the dominant cluster
  std::vector<int> subdominant_modes;  ///< one mode per copy within 1e-9 of `subdominant`, increasing
  std::complex<double> next;        ///< the largest modulus after both clusters (0 if none)
  std::vector<int> next_modes;      ///< one mode per copy within 1e-9 of `next`, increasing

  /// |subdominant| - |next|.
  double gap() const noexcept { return std::abs(subdominant) - std::abs(next); }
  /// The condition above: |dominant - 1| <= tol, mode 0, simple; subdominant real (|Im| <= tol) and
  /// > tol, its copies exactly in modes 1 and k - 1; gap() > tol.
  bool meets_subdominant_condition(double tol = 1e-9) const;
};

/// Fourier decomposition of `s` (see above). Throws InvalidInput when `s` is malformed (sizes) or not
/// block-circulant to 1e-12 (naming the first offending entry). Cost: k dense eigenproblems of size m.
SubdivSpectrum fourier_spectrum(const LocalSubdivMatrix& s);

/// fourier_spectrum(local_subdivision_matrix(scheme, valence)).
SubdivSpectrum subdivision_spectrum(SubdivScheme scheme, int valence);

/// All eigenvalues of `s` by one dense (unstructured) eigensolve, by decreasing modulus: the slow
/// reference the Fourier decomposition is tested against. Throws InvalidInput when `s` is malformed.
std::vector<std::complex<double>> dense_eigenvalues(const LocalSubdivMatrix& s);

}  // namespace varmesh
