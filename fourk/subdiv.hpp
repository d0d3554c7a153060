#pragma once
/// Primal subdivision surfaces as binary 4-8 steps: Catmull-Clark, 4-8 subdivision (Velho-Zorin) and
/// linear 4-8 refinement, on quad-dominant polygon meshes (poly_mesh.hpp).
///
/// The 4-8 view. A quad with its diagonal (corners 0 and 2) is a *block*: two triangles that a binary step
/// bisects together. Two binary steps make one quadrisection of the quad mesh:
/// - the diagonal step (step A) inserts one vertex per face (the face point) and splits every face into a
///   fan of triangles, one per face edge; each old edge is then the diagonal of a block formed by the two
///   fan triangles on its sides (one on a border edge);
/// - the edge step (step B) inserts one vertex per old edge (the edge point) and bisects those blocks;
///   the result is the quad mesh whose face (v, e_i, f, e_{i-1}) has diagonal v-f: the next level.
/// So the state after an even number of steps is a quad mesh (faces of level 0 may be any polygons; a
/// triangle's diagonal step is a 1 -> 3 split), and after an odd number it is that quad mesh plus its face
/// points. Seen on the quad mesh alone, each binary step turns faces into edges (the new faces are the old
/// edges): the topology of sqrt(2) subdivision (Li, Ma, Bao 2004).
///
/// Numbering: after a quadrisection of a level with V vertices, F faces and E edges, vertex v keeps its
/// index, face f's point is V + f and edge e's point is V + F + e. OpenSubdiv's Far::TopologyRefiner orders
/// child vertices in the same blocks, but numbers child edges and child faces differently from level 2 on,
/// so only level 1 coincides index for index (tests/fourk/subdiv_osd_test.cpp maps the two level by level). Child faces of face f with k corners are offset(f) + i, i < k, where
/// offset(f) = sum of the sizes of the faces before f; child face offset(f) + i = (c_i, e_i, f, e_{i-1}),
/// e_i = the edge c_i -> c_{i+1}. A vertex therefore has one index at every level from its creation on.
///
/// Rules (each step reads only positions from before the step; n = number of edges at a vertex, k = number
/// of corners of a face; "short" neighbours are those across the block legs, "long" those across the
/// block diagonals):
///
/// | scheme        | diagonal step (A)                        | edge step (B)                                    |
/// |---------------|------------------------------------------|--------------------------------------------------|
/// | linear        | f = mean of corners; old unchanged       | e = midpoint; old unchanged                      |
/// | Catmull-Clark | f = mean of corners; old unchanged       | e = (v0 + v1 + f0 + f1) / 4; v' = (n-2)/n v      |
/// |               |                                          |   + 1/n^2 sum(edge neighbours) + 1/n^2 sum(f)    |
/// | 4-8           | f = mean of corners; v' = (1-a_n) v      | e = (v0 + v1 + f0 + f1) / 4; v' = (1-a_n) v      |
/// |               |   + a_n/n sum(edge neighbours)           |   + a_n/n sum(f); f' = f/2 + 1/(2k) sum(corners) |
///
/// With a_4 = 1/2 the 4-8 rules are Velho and Zorin's regular two-pass smoothing ("4-8 Subdivision",
/// CAGD 18(5), 2001): new vertex = 1/4 of its block's corners, old vertex = 1/2 itself + 1/8 of its four
/// short-edge neighbours; two steps give the degree-6 four-direction (C4) box spline. The paper's
/// extraordinary weights are not reproduced here; four_eight_weight() documents ours and
/// subdiv_analysis.hpp checks their spectrum. Catmull-Clark's two steps are Velho's 4-8 factorisation of
/// quadrilateral subdivision: they equal one Catmull-Clark level (Catmull and Clark 1978) exactly, which
/// the tests check against OpenSubdiv.
///
/// Borders (all schemes): border vertices and border edges follow the cubic B-spline curve of the
/// border: edge step e = midpoint, v' = 3/4 v + 1/8 (b0 + b1) with b0, b1 its border neighbours; the
/// diagonal step leaves border vertices where they are. For Catmull-Clark these are OpenSubdiv's rules
/// with Sdc::Options::VTX_BOUNDARY_EDGE_ONLY. Vertices no face uses keep their position in every scheme.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "fourk/poly_mesh.hpp"
#include "multitri/mt.hpp"
#include "multitri/tri_mesh.hpp"
#include "multitri/types.hpp"

namespace varmesh {

enum class SubdivScheme : std::uint8_t { kLinear = 0, kCatmullClark = 1, kFourEight = 2 };

const char* to_string(SubdivScheme scheme) noexcept;

/// The 4-8 vertex weight a_n (see the table above) for a vertex with n edges (n >= 3 in the interior; a_4
/// = 1/2). Ours: a_n = 1/2 for every n, i.e. v' = v/2 + 1/(2n) sum of the short neighbours, the plain
/// generalisation of the regular rule. subdiv_analysis.hpp computes the eigenvalues of the resulting
/// two-step subdivision matrix for valences 3 to 12.
double four_eight_weight(int n) noexcept;

/// Topology of one even level: a polygon mesh (all quads after the first quadrisection) with its edges.
struct SubdivTopology {
  std::size_t num_vertices = 0;
  std::size_t num_faces = 0;
  std::vector<Index> face_offsets;  ///< num_faces + 1 entries, or empty when every face is a quad (offset 4f)
  std::vector<Index> face_verts;    ///< corners of the faces, in orientation order
  std::vector<Index> face_edges;    ///< per corner i: the edge corner i -> corner i + 1 (empty: not built)
  std::vector<Index> edge_verts;    ///< 2 per edge (empty: not built)
  std::vector<std::uint8_t> edge_border;    ///< per edge: 1 on the border
  std::vector<std::uint16_t> valence;       ///< per vertex: number of edges
  std::vector<std::uint8_t> vertex_border;  ///< per vertex: 1 on the border

  std::size_t num_edges() const noexcept { return edge_verts.size() / 2; }
  bool all_quads() const noexcept { return face_offsets.empty(); }
  Index offset(std::size_t f) const noexcept { return all_quads() ? static_cast<Index>(4 * f) : face_offsets[f]; }
  Index face_size(std::size_t f) const noexcept {
    return all_quads() ? 4 : face_offsets[f + 1] - face_offsets[f];
  }
  bool has_edges() const noexcept { return !edge_verts.empty() || num_faces == 0; }
  std::size_t memory_bytes() const noexcept;
};

/// Validates `mesh` (PolyMesh::validate) and builds its level-0 topology. Throws InvalidInput naming the
/// element when the mesh is invalid or a vertex has 2^16 edges or more.
SubdivTopology make_subdiv_topology(const PolyMesh& mesh);

/// The next even level (quadrisection, numbering above). `with_edges` = false skips the child edges, which
/// only a further refinement needs. Throws InvalidInput when the parent has no edges or the child would
/// have 2^32 vertices, faces or corners or more.
SubdivTopology refine_subdiv_topology(const SubdivTopology& parent, bool with_edges = true);

/// Diagonal step A: `in` holds V positions, `out` receives V + F (old vertices, then face points).
void subdiv_diagonal_step(const SubdivTopology& topo, SubdivScheme scheme, std::span<const glm::dvec3> in,
                          std::span<glm::dvec3> out);
/// Edge step B: `in` holds V + F positions (after step A), `out` receives V + F + E; the first V + F are
/// the smoothed old vertices and face points, the last E the edge points.
void subdiv_edge_step(const SubdivTopology& topo, SubdivScheme scheme, std::span<const glm::dvec3> in,
                      std::span<glm::dvec3> out);

/// Stencils as a table: output i = sum over j in [offsets[i], offsets[i+1]) of weights[j] * in[sources[j]].
struct StencilTable {
  std::size_t num_inputs = 0;
  std::vector<Index> offsets{0};
  std::vector<Index> sources;
  std::vector<double> weights;

  std::size_t num_outputs() const noexcept { return offsets.size() - 1; }
  /// Applies the table to a per-vertex attribute of `components` doubles per vertex (positions: 3,
  /// colours: 3, texture coordinates: 2, ...). Throws InvalidInput when the sizes do not match or the table
  /// is malformed (see check_entries).
  void apply(std::span<const double> in, std::span<double> out, int components) const;
  std::vector<double> apply(std::span<const double> in, int components) const;
  /// Composition: (this o first), i.e. apply `first`, then this. Entries with the same source are merged.
  StencilTable after(const StencilTable& first) const;
  /// Both throw InvalidInput naming the stencil when the fields (public, so anything can be in them) do not
  /// form a table: offsets not starting at 0, decreasing or not ending at the source count, a source count
  /// other than the weight count; check_entries() also a source >= num_inputs. apply() and after() check.
  void check_shape(const char* who) const;
  void check_entries(const char* who) const;
};

/// The same rules as the step functions, as tables (stencil i = output vertex i).
StencilTable subdiv_diagonal_stencils(const SubdivTopology& topo, SubdivScheme scheme);
StencilTable subdiv_edge_stencils(const SubdivTopology& topo, SubdivScheme scheme);

struct SubdivOptions {
  /// Keep the edges of the last even level (needed to subdivide further or to build stencils on it).
  bool keep_last_edges = true;
};

/// The result of `steps` binary steps.
struct SubdivMesh {
  SubdivScheme scheme = SubdivScheme::kLinear;
  int steps = 0;
  SubdivTopology topo;  ///< the last even level (after steps - steps % 2 binary steps)
  /// Positions of topo's vertices, followed (odd steps) by one face point per face of topo.
  std::vector<glm::dvec3> positions;

  bool half_step() const noexcept { return steps % 2 == 1; }
  /// Triangles of the 4-8 mesh: even steps, each quad (c0, c1, c2, c3) as (c0, c1, c2), (c0, c2, c3)
  /// and other faces as fans; odd steps, each face as the fan (f, c_i, c_{i+1}) around its face point.
  TriMesh to_tri_mesh() const;
  /// The polygon mesh: even steps, topo's faces; odd steps, one quad (v0, f1, v1, f0) per interior edge
  /// and one triangle per border edge (the sqrt(2) view). Odd steps need the edges (keep_last_edges).
  PolyMesh to_poly_mesh() const;
  std::size_t memory_bytes() const noexcept;
};

/// `steps` binary steps of `scheme` on `base` (validated). Throws InvalidInput naming the parameter when
/// steps < 0, the result would have 2^32 elements or more, or its arrays (estimated, two levels) would not
/// fit in the machine's physical memory (checked before allocating), and as make_subdiv_topology (which
/// also refuses faces of more than 65535 corners). Cost: linear in the output; peak memory holds two levels of topology.
SubdivMesh subdivide(const PolyMesh& base, SubdivScheme scheme, int steps, const SubdivOptions& options = {});

/// The per-step stencil tables of subdivide(base, scheme, steps): table s maps the vertices after s steps
/// to those after s + 1. For attributes other than positions (colours, texture coordinates, ...). Throws
/// as subdivide, and InvalidInput naming `steps` when the tables (about 240 bytes per final position, all
/// steps together) would not fit in the machine's physical memory, checked before allocating.
std::vector<StencilTable> subdiv_stencil_tables(const PolyMesh& base, SubdivScheme scheme, int steps);

/// Catmull-Clark limit positions of the vertices of an even-step Catmull-Clark mesh: interior vertex with
/// n >= 3 edges (n^2 v + 4 sum(edge neighbours) + sum(diagonal neighbours)) / (n (n + 5)); border vertex
/// (b0 + 4 v + b1) / 6. The interior formula holds for n = 2 too (the true limit, as OpenSubdiv's Bfr
/// evaluates it; PrimvarRefiner::Limit instead returns the point itself there). A vertex no face uses
/// stays where it is.
/// Throws InvalidInput when mesh is not an even-step Catmull-Clark mesh.
std::vector<glm::dvec3> catmull_clark_limit_positions(const SubdivMesh& mesh);

/// Adaptive subdivision through the Multi-Triangulation: the binary steps of subdivide(base, scheme,
/// steps) as an Mt whose nodes are the block bisections (a diagonal step on a quad: 2 -> 4 triangles, on
/// another polygon: k - 2 -> k; an edge step: 2 -> 4, or 1 -> 2 on a border edge). Every vertex sits at
/// its position after all `steps` steps, so the fully refined front is the uniform result (to_tri_mesh)
/// and every front is a conforming mesh through points of it. Node error: the largest distance, over the
/// node and its descendants, between a new vertex and the midpoint of the edge it splits (for a base
/// quad, the diagonal its fan was cut along; saturated by MtBuilder). The base polygons are fanned from
/// their first corner, or from the first corner whose diagonals are not edges already (a diagonal used
/// twice would leave no front conforming). Throws as subdivide; InvalidInput naming `steps` when the
/// hierarchy (every triangle of every step, about 120 bytes each at the peak) would not fit in the
/// machine's physical memory, checked before allocating; and InvalidInput naming a face whose every fan
/// has such a diagonal, or two faces whose fans share a triangle.
struct SubdivMtInfo {
  std::vector<std::uint16_t> node_step;  ///< per Mt node: its binary step (1-based; 0 for the source)
  std::size_t uniform_faces = 0;         ///< triangles of the fully refined front
};
Mt build_subdivision_mt(const PolyMesh& base, SubdivScheme scheme, int steps, SubdivMtInfo* info = nullptr);

}  // namespace varmesh
