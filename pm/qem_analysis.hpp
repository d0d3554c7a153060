#pragma once
/// Analysis phase (Kim-Lee section 4.2): full-edge collapses ordered by Garland-Heckbert 1997 quadrics,
/// recorded as a VertexHierarchy.
///
/// Each step collapses the cheapest legal edge (vt, vu) into a new vertex vs placed at the quadric's
/// minimiser (Quadric::optimal_on_segment: the linear solve when well conditioned, else the best point of
/// the edge), moved by default to the volume-preserving plane (QemOptions::preserve_volume). With a face or
/// vertex target, the last stretch (from QemOptions::lt_finish times the target on) is ordered and placed
/// by Lindstrom-Turk costs.
/// QemOptions::cost = CollapseCost::kLindstromTurk orders and places the collapses by Lindstrom-Turk's
/// memoryless costs all the way (slower; see CollapseCost). Legal means:
/// - link condition: the common neighbours of vt and vu are exactly the apexes of the edge's faces (two, or
///   one on a border edge), and an interior edge does not join two border vertices (Hoppe et al. 1993);
/// - no duplicate face appears (the tetrahedron case) and the component keeps at least 4 vertices;
/// - no face around vt or vu turns over or becomes degenerate at vs's position (normals keep a positive dot
///   product);
/// - neither end is locked, and the new node's subtree stays within the depth budget of the 64-bit keys.
/// Border edges get GH97 border constraint quadrics (weight options.border_penalty). With colours
/// (options.use_colors and input colours), GH98 attribute quadrics in (x, y, z, w r, w g, w b) order the
/// collapses and place colour too.
///
/// Node bounds for the view criteria: sphere = enclosing sphere of the children's spheres and vs's
/// position (a leaf's sphere covers its incident faces); cone = merged cone of the children's cones and the
/// normals of the faces around vs; error = max(children's errors) + the local move, accumulated up the tree:
/// the largest of the distances from vs to the planes of the current faces around vt and vu, from vt and
/// from vu to the new fan around vs (the old vertices left behind: without it, closed meshes measured up to
/// 3x E), and, where vt or vu is on a border, between the border polylines through them and through vs (a
/// vertex sliding along a border stays in its faces' planes: a flat disk used to reach one triangle with
/// error 0); and at least, where vt or vu is a leaf next to nodes made by earlier collapses, its distance
/// to its input faces with the corners under vt and vu moved to vs (the fan it lands in when a front
/// refines those neighbours back to leaves, which the current fan does not see: without it, the meshes with
/// holes measured up to 1.4x E on the shark and 1.9x on the elephant). It estimates how far the surface
/// moved in vs's region; it is not a strict bound (points inside the old faces, and fronts that put a node
/// next to neighbours coarser than when it was made, are not measured): Kim-Lee extractions at
/// object_error(E), E = 0.05 % to 2 % of the diagonal, measured at most 0.91x E on the closed meshes of the
/// data folder (knight, cow, armadillo, gatech bunny, fandisk), 0.91x on the shark and 0.97x on the
/// elephant, with 0-0.3 % more faces than without the leaf term; bumpy icospheres reach 1.0-1.4x, once
/// 2.1x in 80 (a front that joins a node to some neighbours refined to leaves and others left coarse). The fan term costs about 4 % of the analysis time, the leaf term
/// 10-15 % (bunny, dragon at 1 %; BENCHMARKS.md).
/// All three are nested by construction and do not depend on QemOptions::cost.
#include <cstddef>
#include <functional>
#include <limits>

#include "multitri/tri_mesh.hpp"
#include "pm/manifold_input.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

/// How collapses are ordered and placed (QemOptions::cost).
enum class CollapseCost {
  /// Garland-Heckbert 1997: accumulated area-weighted plane quadrics (plus border constraint planes) of each
  /// vertex's region; vs at the quadric minimiser, moved to keep the volume (QemOptions::preserve_volume);
  /// Lindstrom-Turk costs for the last collapses before a target (QemOptions::lt_finish). The default.
  kQuadric,
  /// Lindstrom-Turk 1998/1999 memoryless simplification: cost and placement from the current mesh only (the
  /// faces around both ends): vs preserves the enclosed volume and the border's area vector, then minimises
  /// the squared volumes swept by each face, the squared areas swept by each border edge, and edge lengths;
  /// the cost is the volume term plus edge length^2 times the border term (border_penalty is not used).
  /// Every collapse re-costs the edges at vs and marks those of its neighbours stale; a stale edge is placed
  /// again when it reaches the top of the queue (lazy evaluation): about 2x the time of kQuadric. Around a
  /// vertex of more than 24 faces (a hub: a polygon given as one fan, the pole of a cone) the sums over its
  /// faces are cached and moved to each edge's origin, so an edge costs O(the other end's degree); where the
  /// constrained point would turn a face over (nearly dependent constraints among long slivers), the edge's
  /// midpoint and ends are tried, cheapest first, the collapse waiting its turn in the queue if that costs
  /// more than the next edge. At 1 % of
  /// the faces it cuts the bunny's RMS error by a quarter and its max error by a seventh against quadrics to
  /// the end (lt_finish = 0; by a third and a half against the plain GH97 placement; vertex-to-surface
  /// distance), about as much as the default's Lindstrom-Turk finish does; unlike the finish it also shapes
  /// hierarchies built with no target. Ignored (kQuadric is used) when colours are used.
  kLindstromTurk,
};

struct QemOptions {
  /// Stop when this many vertices remain (0: no vertex target).
  std::size_t target_vertices = 0;
  /// Stop when at most this many faces remain (0: no face target).
  std::size_t target_faces = 0;
  /// No collapse whose error (object units, as in the node bound) would exceed this: such collapses are
  /// skipped (QemStats::rejected_error) and tried again when their neighbourhood changes; the analysis ends
  /// when none within the limit is left (or at a target).
  double max_error = std::numeric_limits<double>::infinity();
  /// With no target at all the analysis goes down to the smallest base mesh it can reach.
  double border_penalty = 1000.0;
  /// Ordering and placement of the collapses. The node bounds do not depend on it.
  CollapseCost cost = CollapseCost::kQuadric;
  /// With CollapseCost::kQuadric and no colours: vs goes to the point where the quadric is least among the
  /// points that keep the volume enclosed by the faces around the edge (Lindstrom-Turk 1998's volume
  /// preservation as a constraint on the Garland-Heckbert placement; the collapse order stays the
  /// quadric's). Lower RMS error on every mesh of the data folder but the fandisk at 1 % (BENCHMARKS.md:
  /// bunny at 1 % RMS 20.4 -> 17.2e-4 of the diagonal, max 149 -> 83e-4) for a few per cent of time. Where
  /// the moved point would turn a face over or exceed max_error, the plane's point nearest to the minimiser
  /// and then the minimiser itself are tried. false: vs at the quadric's minimiser (GH97). Collapses whose
  /// quadric has no well-conditioned minimiser keep the segment fallback either way.
  bool preserve_volume = true;
  /// With CollapseCost::kQuadric, no colours and a face or vertex target: once the mesh is down to
  /// lt_finish times the target (faces or vertices, whichever comes first), the remaining collapses are
  /// ordered and placed by Lindstrom-Turk's memoryless costs (see CollapseCost::kLindstromTurk). The
  /// quadrics carry the mesh cheaply through the fine levels, where any reasonable order is nearly as good;
  /// the last collapses, which decide the error at the target, are chosen on the current surface. At 1 % of
  /// the faces this brings the error to Lindstrom-Turk's own (bunny RMS 17.2 -> 13.3e-4 of the diagonal,
  /// BENCHMARKS.md) for 5-8 % more time. Memoryless costs forget the detail already removed: taken down to
  /// tens of faces, a model's thin parts go first (the cow at 58 faces: RMS 152 -> 327e-4, CGAL's own
  /// level), where 0 is the better choice. 0 turns it off; without a face or vertex target (max_error only,
  /// or the smallest base mesh) it does not apply. Must be 0 or > 1 (at 1 the target would come first).
  double lt_finish = 4.0;
  bool use_colors = false;     ///< GH98 attribute quadrics when the input has colours
  double color_weight = 1.0;   ///< colour unit = color_weight * bounding-box diagonal
  NonManifoldPolicy non_manifold = NonManifoldPolicy::kSplit;
  /// Deepest tree allowed (node ids need depth + 1 bits; the tree ids take the rest of the 64 bits).
  int max_depth = 44;
  /// Parts simplified at the same time, each on a thread of its own (0: one per hardware thread). With
  /// more than one, the faces are cut into that many parts of about equal size; each part is simplified
  /// alone, the vertices on and next to the cuts locked, down to its share of the targets, and the whole
  /// mesh goes on from there as a serial run does (qem_analysis.cpp, run_parts()). The hierarchy is valid
  /// and reproducible for a given value, but not the one a serial run gives (a different collapse order).
  /// Applies with CollapseCost::kQuadric and no colours, to meshes of at least min_part_faces faces per part
  /// (fewer parts otherwise), and at most 256 parts; 1 (the default) is the serial analysis. What fails in a
  /// part (std::bad_alloc) stops the others at their next 4096 collapses and is rethrown on the caller's
  /// thread once all are joined; a thread that cannot be started gives std::system_error.
  std::size_t threads = 1;
  /// The fewest faces a part of a parallel analysis may have (>= 1; see threads). Smaller parts have a larger
  /// share of their vertices locked near the cuts.
  std::size_t min_part_faces = 16384;
  /// Called every 4096 collapses with (collapses done, vertices left), on the caller's thread; may be empty.
  /// With parts (threads), the same calls as a serial run making as many collapses: the parts report to the
  /// caller's thread as they go, and the calls their last steps owe come when they are done. What it throws
  /// ends the analysis (parts stop at their next 4096 collapses) and propagates.
  std::function<void(std::size_t, std::size_t)> progress;
};

struct QemStats {
  std::size_t collapses = 0;
  /// Pops refused by each check. rejected_locked counts the locked leaves' (NonManifoldPolicy::kLock) refusals
  /// in the serial loop only: the parts of a parallel analysis also lock their cuts' bands, and their
  /// refusals for locks are not counted (the other counts include the parts').
  std::size_t rejected_link = 0, rejected_flip = 0, rejected_depth = 0, rejected_locked = 0;
  std::size_t rejected_error = 0;  ///< pops whose error would exceed QemOptions::max_error
  std::size_t queue_rebuilds = 0;  ///< extra passes over all edges once the queue ran dry
  bool lt_finished = false;        ///< the Lindstrom-Turk finish started (QemOptions::lt_finish)
  std::size_t lt_finish_from = 0;  ///< collapses done when it started (valid when lt_finished)
  std::size_t lt_finish_edges = 0; ///< edges it costed then: every edge of the mesh at that point
  std::size_t base_vertices = 0, base_faces = 0;
  double seconds = 0.0;
};

/// Builds the hierarchy of `mesh` (repaired as manifold_input.hpp says). Throws InvalidInput on invalid
/// input (naming the element) or options (naming the option: a value out of its range, an enumeration
/// member that does not exist). O(n log n) for n faces.
VertexHierarchy build_vertex_hierarchy(const TriMesh& mesh, const QemOptions& options = {}, QemStats* stats = nullptr);

/// The mesh M^i after the first `collapses` collapses of the hierarchy (the plain PM order): vertices are
/// node positions indexed by node id (the leaves and the nodes the collapses made; unused ones are simply
/// unreferenced), faces the original faces that survive, relabelled. collapses = h.num_collapses() gives
/// the base mesh. Throws InvalidInput when collapses > h.num_collapses(). O(nodes + faces).
TriMesh mesh_after_collapses(const VertexHierarchy& h, std::size_t collapses);

}  // namespace varmesh
