// Catmull-Clark as binary 4-8 steps (fourk/subdiv.hpp) against OpenSubdiv 3.5 (Far::TopologyRefiner +
// PrimvarRefinerReal<double>, Catmark, uniform, VTX_BOUNDARY_EDGE_ONLY): positions after 2L binary steps
// against OpenSubdiv's level L, limit positions against PrimvarRefiner::Limit and against Bfr.
//
// Vertex correspondence, built per level by osd_correspondence() and checked to be a bijection:
// - level 0: our vertex v is OpenSubdiv's vertex v and our face f its face f (the TopologyDescriptor is
//   made from the same arrays).
// - level L -> L + 1, with V, F, E the counts of level L and m the level-L map:
//     our old vertex v             -> GetVertexChildVertex(m(v))
//     our face point V + f         -> GetFaceChildVertex(g), g = the OSD face whose corners are m(c_0..c_k-1)
//                                     in the same cyclic order (a closed two-quad pillow has two faces
//                                     with the same corner set)
//     our edge point V + F + e     -> GetEdgeChildVertex(FindEdge(m(a), m(b))), e = (a, b)
//     our child face offset(f) + i -> GetFaceChildFaces(g)[j], j = the corner of g equal to m(c_i).
// What OpenSubdiv 3.5.0 does (default UniformOptions, orderVerticesFromFacesFirst = false), checked here:
// - child vertices are [children of vertices | of faces | of edges], each block in parent order: the
//   child of parent vertex u is u, of parent face g is V + g, of parent edge e is V + F + e;
// - the child faces of face g are GetFaceChildFaces(g)[j] at corner j, with corners (c_j, e_j, g, e_{j-1})
//   like ours, but rotated when g is a quad: corner c_j's child sits at position j (position 0 when g is
//   not a quad). So OSD's corner 0 of a child face is not the 4-8 block corner, and from level 2 on its
//   face numbering (and so its face points from level 3 on) differs from ours;
// - the edges of level 0 came out numbered as ours on every mesh here (first use in face order), so the
//   map is the identity at level 1 and the vertices of level 1 keep their index on both sides for ever;
//   but the child edges of level >= 1 are numbered differently, so the edge points of level 2 on (and
//   the face points of level 3 on) need the map.
//
// Rules at the special vertices (sdc/catmarkScheme.h, and the fixtures below exercise each):
// - border vertices: VTX_BOUNDARY_EDGE_ONLY makes the border edges infinitely sharp and sharpens no
//   vertex, so OpenSubdiv applies the crease rule 3/4 v + 1/8 (b0 + b1) and the crease limit
//   (b0 + 4 v + b1) / 6 also at a corner with one face (RULE_CREASE): ours. (VTX_BOUNDARY_EDGE_AND_CORNER
//   would pin those corners: RULE_CORNER.)
// - interior vertices with 2 edges (pairing triangles makes them): RULE_SMOOTH, (n - 2)/n v + 1/n^2
//   (sum e + sum f) = 0 v + 1/4 (e0 + e1 + f0 + f1): ours. Limit: PrimvarRefiner::Limit uses the corner
//   mask (the level-L point itself), which is not the limit point: Bfr gives (4 v + 4 sum e + sum d) / 14
//   (d the diagonal neighbours), the general formula with n = 2, the same from every level, and so does
//   catmull_clark_limit_positions. So limits are compared with PrimvarRefiner::Limit away from interior
//   valence-2 vertices and with Bfr everywhere.
#include "fourk/subdiv.hpp"

#include <gtest/gtest.h>

#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "fourk/poly_mesh.hpp"
#include "multitri/mesh_io.hpp"
#include "test_support.hpp"

namespace varmesh {
namespace {

namespace Bfr = OpenSubdiv::Bfr;
namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

// The tolerance: max |ours - OpenSubdiv| over the bounding-box diagonal (both sides in double).
constexpr double kTolerance = 1e-6;

// Vertex type for PrimvarRefinerReal<double>.
struct OsdPoint {
  double x = 0.0, y = 0.0, z = 0.0;
  void Clear(void* = nullptr) { x = y = z = 0.0; }
  void AddWithWeight(const OsdPoint& s, double w) {
    x += w * s.x;
    y += w * s.y;
    z += w * s.z;
  }
  glm::dvec3 vec() const { return {x, y, z}; }
};

// OpenSubdiv's refiner of `mesh`, refined uniformly to `levels` (full topology in the last level, which
// PrimvarRefiner::Limit needs). Catmark, border edges sharp, no vertex sharpened (our border rules).
std::unique_ptr<Far::TopologyRefiner> make_osd_refiner(const PolyMesh& mesh, int levels) {
  std::vector<int> sizes(mesh.num_faces());
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) sizes[f] = static_cast<int>(mesh.face_size(f));
  std::vector<Far::Index> corners(mesh.corners.begin(), mesh.corners.end());
  Far::TopologyDescriptor desc;
  desc.numVertices = static_cast<int>(mesh.num_vertices());
  desc.numFaces = static_cast<int>(mesh.num_faces());
  desc.numVertsPerFace = sizes.data();
  desc.vertIndicesPerFace = corners.data();
  Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
  sdc.SetTriangleSubdivision(Sdc::Options::TRI_SUB_CATMARK);
  sdc.SetCreasingMethod(Sdc::Options::CREASE_UNIFORM);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  Factory::Options options(Sdc::SCHEME_CATMARK, sdc);
  options.validateFullTopology = true;
  std::unique_ptr<Far::TopologyRefiner> refiner(Factory::Create(desc, options));
  if (!refiner) return nullptr;
  Far::TopologyRefiner::UniformOptions uniform(levels);
  uniform.fullTopologyInLastLevel = true;
  refiner->RefineUniform(uniform);
  return refiner;
}

// Positions of every OpenSubdiv level 0..max, interpolated in double.
std::vector<std::vector<OsdPoint>> osd_positions(const Far::TopologyRefiner& refiner, const PolyMesh& mesh) {
  std::vector<std::vector<OsdPoint>> levels(static_cast<std::size_t>(refiner.GetMaxLevel()) + 1);
  for (const glm::dvec3& p : mesh.positions) levels[0].push_back({p.x, p.y, p.z});
  Far::PrimvarRefinerReal<double> primvar(refiner);
  for (int l = 1; l <= refiner.GetMaxLevel(); ++l) {
    auto& dst = levels[static_cast<std::size_t>(l)];
    dst.resize(static_cast<std::size_t>(refiner.GetLevel(l).GetNumVertices()));
    const OsdPoint* src = levels[static_cast<std::size_t>(l) - 1].data();
    OsdPoint* out = dst.data();
    primvar.Interpolate(l, src, out);
  }
  return levels;
}

// Our level -> OpenSubdiv's level, vertices and faces (see the comment at the top).
struct LevelMap {
  std::vector<Index> vertex;  // our vertex -> OSD vertex
  std::vector<Index> face;    // our face -> OSD face
};

// What the correspondence looked like, for the checks and the log.
struct MapReport {
  // OSD's own child numbering: child of parent vertex u = u, of parent face g = V + g, of parent edge
  // e = V + F + e (default UniformOptions, orderVerticesFromFacesFirst = false).
  bool osd_layout = true;
  // Every child face has our corners (c_i, e_i, f, e_{i-1}) rotated by j on the OSD side, j = the OSD
  // corner index of c_i when the parent is a quad, 0 otherwise.
  bool child_rotation = true;
  int first_level_edges_differ = -1;  // first level whose edge numbering differs from OSD's (-1: none)
  int first_level_faces_differ = -1;  // same for the faces
  std::string error;                  // first failure of the construction, empty if none
};

// The OSD face of level `lvl` whose corners are `osd_corners` in the same cyclic order, with `rotation`
// such that its corner (rotation + i) mod k is osd_corners[i]; -1 if none. (The cyclic order matters: the
// two faces of a closed two-quad "pillow" have the same corner set.)
Far::Index find_osd_face(const Far::TopologyLevel& lvl, const std::vector<Far::Index>& osd_corners, int& rotation) {
  const int k = static_cast<int>(osd_corners.size());
  for (Far::Index g : lvl.GetVertexFaces(osd_corners[0])) {
    Far::ConstIndexArray fv = lvl.GetFaceVertices(g);
    if (fv.size() != k) continue;
    for (int r = 0; r < k; ++r) {
      bool same = true;
      for (int i = 0; same && i < k; ++i) same = fv[(r + i) % k] == osd_corners[static_cast<std::size_t>(i)];
      if (same) {
        rotation = r;
        return g;
      }
    }
  }
  return -1;
}

// Maps of levels 0..levels; `report` collects what was found. Our topology comes from the public
// make_subdiv_topology / refine_subdiv_topology, the same code subdivide() runs.
std::vector<LevelMap> osd_correspondence(const PolyMesh& base, const Far::TopologyRefiner& refiner, int levels,
                                         MapReport& report) {
  std::vector<LevelMap> maps(static_cast<std::size_t>(levels) + 1);
  SubdivTopology t = make_subdiv_topology(base);
  maps[0].vertex.resize(t.num_vertices);
  maps[0].face.resize(t.num_faces);
  for (Index v = 0; v < t.num_vertices; ++v) maps[0].vertex[v] = v;
  for (Index f = 0; f < t.num_faces; ++f) maps[0].face[f] = f;
  auto fail = [&report](const std::string& why) {
    if (report.error.empty()) report.error = why;
  };
  for (int l = 0; l < levels; ++l) {
    const Far::TopologyLevel& parent = refiner.GetLevel(l);
    const Far::TopologyLevel& child = refiner.GetLevel(l + 1);
    const LevelMap& m = maps[static_cast<std::size_t>(l)];
    LevelMap& next = maps[static_cast<std::size_t>(l) + 1];
    const Index nv = static_cast<Index>(t.num_vertices), nf = static_cast<Index>(t.num_faces);
    const Index ne = static_cast<Index>(t.num_edges());
    const Far::Index onv = static_cast<Far::Index>(nv), onf = static_cast<Far::Index>(nf);
    const std::string at = "level " + std::to_string(l) + ": ";
    if (parent.GetNumVertices() != static_cast<int>(nv) || parent.GetNumFaces() != static_cast<int>(nf) ||
        parent.GetNumEdges() != static_cast<int>(ne)) {
      fail(at + "counts differ from OpenSubdiv's");
      return {};
    }
    next.vertex.assign(std::size_t{nv} + nf + ne, kInvalid);
    next.face.assign(t.face_verts.size(), kInvalid);
    std::vector<std::uint8_t> parent_quad(t.face_verts.size(), 0);  // per our child face: OSD parent is a quad
    std::vector<int> parent_corner(t.face_verts.size(), 0);         // per our child face: j in the OSD parent
    for (Index v = 0; v < nv; ++v) {
      const Far::Index c = parent.GetVertexChildVertex(static_cast<Far::Index>(m.vertex[v]));
      next.vertex[v] = static_cast<Index>(c);
      if (c != static_cast<Far::Index>(m.vertex[v])) report.osd_layout = false;
    }
    std::vector<Far::Index> osd_corners;
    for (Index f = 0; f < nf; ++f) {
      const Index off = t.offset(f), k = t.face_size(f);
      osd_corners.clear();
      for (Index i = 0; i < k; ++i) osd_corners.push_back(static_cast<Far::Index>(m.vertex[t.face_verts[off + i]]));
      int rot = 0;
      const Far::Index g = find_osd_face(parent, osd_corners, rot);
      if (g < 0) {
        fail(at + "no OpenSubdiv face with the corners of our face " + std::to_string(f));
        return {};
      }
      if (static_cast<Index>(g) != m.face[f]) fail(at + "the face found by its corners is not the child-face map's");
      if (static_cast<Index>(g) != f && report.first_level_faces_differ < 0) report.first_level_faces_differ = l;
      const Far::Index c = parent.GetFaceChildVertex(g);
      next.vertex[nv + f] = static_cast<Index>(c);
      if (c != onv + g) report.osd_layout = false;
      // Our child face offset(f) + i sits at corner c_i, which is OSD's corner j = (rot + i) mod k.
      Far::ConstIndexArray kids = parent.GetFaceChildFaces(g);
      for (Index i = 0; i < k; ++i) {
        const int j = static_cast<int>((static_cast<Index>(rot) + i) % k);
        next.face[off + i] = static_cast<Index>(kids[j]);
        parent_quad[off + i] = k == 4;
        parent_corner[off + i] = j;
      }
    }
    for (Index e = 0; e < ne; ++e) {
      const Far::Index a = static_cast<Far::Index>(m.vertex[t.edge_verts[2 * e]]);
      const Far::Index b = static_cast<Far::Index>(m.vertex[t.edge_verts[2 * e + 1]]);
      const Far::Index oe = parent.FindEdge(a, b);
      if (oe < 0) {
        fail(at + "no OpenSubdiv edge for our edge " + std::to_string(e));
        return {};
      }
      const Far::Index c = parent.GetEdgeChildVertex(oe);
      next.vertex[nv + nf + e] = static_cast<Index>(c);
      if (c != onv + onf + oe) report.osd_layout = false;
      if (static_cast<Index>(oe) != e && report.first_level_edges_differ < 0) report.first_level_edges_differ = l;
    }
    SubdivTopology ct = refine_subdiv_topology(t, true);
    for (Index cf = 0; cf < ct.num_faces; ++cf) {
      Far::ConstIndexArray fv = child.GetFaceVertices(static_cast<Far::Index>(next.face[cf]));
      const int r = parent_quad[cf] ? parent_corner[cf] : 0;
      bool same = fv.size() == 4;
      for (int i = 0; same && i < 4; ++i)
        same = static_cast<Index>(fv[(r + i) % 4]) ==
               next.vertex[ct.face_verts[4 * std::size_t{cf} + static_cast<Index>(i)]];
      if (!same) report.child_rotation = false;
    }
    t = std::move(ct);
  }
  return maps;
}

// True when `map` is a bijection onto [0, n).
bool is_bijection(const std::vector<Index>& map, std::size_t n) {
  if (map.size() != n) return false;
  std::vector<std::uint8_t> hit(n, 0);
  for (Index x : map) {
    if (x >= n || hit[x]) return false;
    hit[x] = 1;
  }
  return true;
}

double bbox_diagonal(const PolyMesh& mesh) {
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const glm::dvec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  return glm::length(hi - lo);
}

// Compares 2L binary steps with OpenSubdiv level L for L = 1..levels: the map, the positions and (on a
// refiner refined to exactly L, as Limit needs the last level) the limit positions. Errors are relative
// to the bounding-box diagonal of `base`; the worst per level go to the log.
void compare_with_osd(const std::string& name, const PolyMesh& base, int levels) {
  const double diag = bbox_diagonal(base);
  auto refiner = make_osd_refiner(base, levels);
  ASSERT_NE(refiner, nullptr) << name << ": OpenSubdiv rejected the mesh";
  MapReport report;
  const std::vector<LevelMap> maps = osd_correspondence(base, *refiner, levels, report);
  ASSERT_TRUE(report.error.empty()) << name << ": " << report.error;
  EXPECT_TRUE(report.osd_layout) << name << ": OpenSubdiv's child vertices are not [vertices | faces | edges]";
  EXPECT_TRUE(report.child_rotation) << name << ": OpenSubdiv's child faces are not ours rotated as documented";
  const auto osd = osd_positions(*refiner, base);
  struct {
    std::vector<double> positions, limits;
  } err;
  err.positions.assign(static_cast<std::size_t>(levels) + 1, 0.0);
  err.limits.assign(static_cast<std::size_t>(levels) + 1, 0.0);
  for (int l = 1; l <= levels; ++l) {
    const auto ul = static_cast<std::size_t>(l);
    const SubdivMesh ours = subdivide(base, SubdivScheme::kCatmullClark, 2 * l);
    const auto& osd_l = osd[ul];
    EXPECT_EQ(ours.positions.size(), osd_l.size()) << name << " L=" << l;
    EXPECT_TRUE(is_bijection(maps[ul].vertex, osd_l.size())) << name << " L=" << l << ": vertex map";
    EXPECT_TRUE(is_bijection(maps[ul].face, static_cast<std::size_t>(refiner->GetLevel(l).GetNumFaces())))
        << name << " L=" << l << ": face map";
    if (ours.positions.size() != osd_l.size()) continue;
    double worst = 0.0;
    for (std::size_t v = 0; v < ours.positions.size(); ++v)
      worst = std::max(worst, glm::length(ours.positions[v] - osd_l[maps[ul].vertex[v]].vec()));
    err.positions[ul] = worst / diag;
    EXPECT_LE(err.positions[ul], kTolerance) << name << " L=" << l << ": positions";

    const auto limit_refiner = make_osd_refiner(base, l);
    ASSERT_NE(limit_refiner, nullptr) << name;
    std::vector<OsdPoint> osd_limit(osd_l.size());
    {
      const auto limit_src = osd_positions(*limit_refiner, base);
      Far::PrimvarRefinerReal<double> primvar(*limit_refiner);
      const OsdPoint* src = limit_src[ul].data();
      OsdPoint* out = osd_limit.data();
      primvar.Limit(src, out);
    }
    const std::vector<glm::dvec3> our_limit = catmull_clark_limit_positions(ours);
    worst = 0.0;
    for (std::size_t v = 0; v < our_limit.size(); ++v) {
      if (!ours.topo.vertex_border[v] && ours.topo.valence[v] == 2) continue;  // Limit's corner mask (top)
      worst = std::max(worst, glm::length(our_limit[v] - osd_limit[maps[ul].vertex[v]].vec()));
    }
    err.limits[ul] = worst / diag;
    EXPECT_LE(err.limits[ul], kTolerance) << name << " L=" << l << ": limit positions";
  }
  std::printf("[ osd      ] %-22s numbering differs from level: edges %d, faces %d;", name.c_str(),
              report.first_level_edges_differ, report.first_level_faces_differ);
  for (int l = 1; l <= levels; ++l)
    std::printf(" L%d pos %.1e lim %.1e", l, err.positions[static_cast<std::size_t>(l)],
                err.limits[static_cast<std::size_t>(l)]);
  std::printf("\n");
}

// Worst limit errors against Bfr, relative to the bounding-box diagonal.
struct BfrErrors {
  double other = 0.0;          // catmull_clark_limit_positions, away from interior valence-2 vertices
  double valence2_ours = 0.0;  // catmull_clark_limit_positions at interior valence-2 vertices
  std::size_t valence2_count = 0;
};

// Limit positions of every vertex of 2L binary steps against Bfr (OpenSubdiv's limit surface evaluator,
// independent of PrimvarRefiner::Limit), on an all-quad base mesh: each vertex is evaluated at its dyadic
// (u, v) in a base face it lies on (child face (c_i, e_i, f, e_{i-1}) of a face with corner parameters
// p_0..p_3 has corners p_i, (p_i + p_{i+1})/2, the centre, (p_{i-1} + p_i)/2).
BfrErrors compare_limit_with_bfr(const std::string& name, const PolyMesh& base, int l) {
  BfrErrors err;
  if (!base.all_quads()) {
    ADD_FAILURE() << name << ": compare_limit_with_bfr needs an all-quad mesh";
    return err;
  }
  const double diag = bbox_diagonal(base);
  auto refiner = make_osd_refiner(base, 0);
  Bfr::SurfaceFactory::Options options;
  options.SetApproxLevelSmooth(std::max(l, 2));  // patches exact at the level-L vertices
  // Debian's OpenSubdiv 3.5.0 crashed in PreparePatchPoints with its patch cache on and many Surfaces
  // alive (the paired cow); without the cache it does not.
  options.EnableCaching(false);
  const Bfr::RefinerSurfaceFactory<> factory(*refiner, options);
  std::vector<double> mesh_points;
  for (const glm::dvec3& q : base.positions) mesh_points.insert(mesh_points.end(), {q.x, q.y, q.z});

  // Per face of the current level: its base face and the (u, v) of its corners.
  struct FaceParam {
    Index base_face;
    double uv[4][2];
  };
  std::vector<FaceParam> params(base.num_faces());
  for (Index f = 0; f < base.num_faces(); ++f) {
    params[f].base_face = f;
    const Bfr::Parameterization param = factory.GetFaceParameterization(static_cast<Far::Index>(f));
    for (int i = 0; i < 4; ++i) param.GetVertexCoord(i, params[f].uv[i]);
  }
  SubdivTopology t = make_subdiv_topology(base);
  for (int s = 0; s < l; ++s) {
    std::vector<FaceParam> next(t.face_verts.size());
    for (Index f = 0; f < t.num_faces; ++f)
      for (int i = 0; i < 4; ++i) {
        const FaceParam& pf = params[f];
        FaceParam& c = next[4 * std::size_t{f} + static_cast<Index>(i)];
        c.base_face = pf.base_face;
        const double* p0 = pf.uv[i];
        const double* p1 = pf.uv[(i + 1) & 3];
        const double* p2 = pf.uv[(i + 2) & 3];
        const double* p3 = pf.uv[(i + 3) & 3];
        for (int k = 0; k < 2; ++k) {
          c.uv[0][k] = p0[k];
          c.uv[1][k] = 0.5 * (p0[k] + p1[k]);
          c.uv[2][k] = 0.25 * (p0[k] + p1[k] + p2[k] + p3[k]);
          c.uv[3][k] = 0.5 * (p3[k] + p0[k]);
        }
      }
    params.swap(next);
    t = refine_subdiv_topology(t, true);
  }
  const SubdivMesh ours = subdivide(base, SubdivScheme::kCatmullClark, 2 * l);
  const std::vector<glm::dvec3> our_limit = catmull_clark_limit_positions(ours);

  // One Bfr surface per base face, prepared on demand.
  std::vector<std::unique_ptr<Bfr::Surface<double>>> surfaces(base.num_faces());
  std::vector<std::vector<double>> patch_points(base.num_faces());
  std::vector<std::uint8_t> done(t.num_vertices, 0);
  for (Index f = 0; f < t.num_faces; ++f)
    for (int i = 0; i < 4; ++i) {
      const Index v = t.face_verts[4 * std::size_t{f} + static_cast<Index>(i)];
      if (done[v]) continue;
      done[v] = 1;
      const Index bf = params[f].base_face;
      if (!surfaces[bf]) {
        surfaces[bf] = std::make_unique<Bfr::Surface<double>>();
        EXPECT_TRUE(factory.InitVertexSurface(static_cast<Far::Index>(bf), surfaces[bf].get())) << name;
        patch_points[bf].resize(3 * static_cast<std::size_t>(surfaces[bf]->GetNumPatchPoints()));
        surfaces[bf]->PreparePatchPoints(mesh_points.data(), 3, patch_points[bf].data(), 3);
      }
      double q[3];
      surfaces[bf]->Evaluate(params[f].uv[i], patch_points[bf].data(), 3, q);
      const glm::dvec3 bfr(q[0], q[1], q[2]);
      const double e = glm::length(our_limit[v] - bfr) / diag;
      if (!t.vertex_border[v] && t.valence[v] == 2) {
        ++err.valence2_count;
        err.valence2_ours = std::max(err.valence2_ours, e);
      } else {
        err.other = std::max(err.other, e);
      }
    }
  std::printf("[ osd      ] %-22s L%d limit vs Bfr %.1e; %zu interior valence-2: %.1e\n", name.c_str(), l,
              err.other, err.valence2_count, err.valence2_ours);
  return err;
}

// Counts of the vertices the special rules apply to, for the log and to prove a fixture exercises them.
struct SpecialCounts {
  std::size_t interior_valence2 = 0, border_corner = 0, border = 0, non_quads = 0;
};
SpecialCounts special_counts(const PolyMesh& mesh) {
  const SubdivTopology t = make_subdiv_topology(mesh);
  SpecialCounts s;
  for (std::size_t v = 0; v < t.num_vertices; ++v) {
    if (t.valence[v] == 0) continue;
    if (t.vertex_border[v]) {
      ++s.border;
      if (t.valence[v] == 2) ++s.border_corner;
    } else if (t.valence[v] == 2) {
      ++s.interior_valence2;
    }
  }
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) s.non_quads += mesh.face_size(f) != 4;
  return s;
}

// An nx x ny grid of quads over [0, 1]^2 with a bumpy height: an open mesh whose four corners have one face.
PolyMesh make_grid_patch(int nx, int ny) {
  PolyMesh m;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double x = double(i) / nx, y = double(j) / ny;
      m.positions.push_back({x, y, 0.3 * std::sin(5.0 * x + 1.0) * std::cos(4.0 * y) + 0.1 * x * y});
    }
  auto id = [nx](int i, int j) { return static_cast<Index>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Index q[4] = {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)};
      m.add_face(q);
    }
  return m;
}

// A closed "pillow": two quads glued along their four edges; all four vertices are interior with 2 edges.
PolyMesh make_pillow() {
  PolyMesh m;
  m.positions = {{-1.0, -1.0, 0.0}, {1.0, -1.0, 0.1}, {1.0, 1.0, 0.0}, {-1.0, 1.0, -0.2}};
  const Index top[4] = {0, 1, 2, 3}, bottom[4] = {3, 2, 1, 0};
  m.add_face(top);
  m.add_face(bottom);
  return m;
}

// A closed mixed-polygon mesh: a slightly irregular pentagonal prism (2 pentagons, 5 quads).
PolyMesh make_pentagonal_prism() {
  PolyMesh m;
  for (int h = 0; h < 2; ++h)
    for (int i = 0; i < 5; ++i) {
      const double a = 2.0 * 3.14159265358979323846 * i / 5.0 + 0.1 * h;
      m.positions.push_back({std::cos(a) * (1.0 + 0.1 * i), std::sin(a), h ? 1.3 : -0.2 * i});
    }
  const Index bottom[5] = {4, 3, 2, 1, 0}, top[5] = {5, 6, 7, 8, 9};
  m.add_face(bottom);
  m.add_face(top);
  for (Index i = 0; i < 5; ++i) {
    const Index j = (i + 1) % 5;
    const Index q[4] = {i, j, 5 + j, 5 + i};
    m.add_face(q);
  }
  return m;
}

// A closed triangle mesh taken face for face (no pairing): an irregular octahedron.
PolyMesh make_triangle_octahedron() {
  TriMesh t;
  t.positions = {{1.0f, 0.0f, 0.0f}, {-1.2f, 0.1f, 0.0f}, {0.0f, 1.0f, 0.2f},
                 {0.0f, -0.9f, 0.0f}, {0.1f, 0.0f, 1.1f}, {0.0f, 0.0f, -1.0f}};
  t.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return poly_from_triangles(t);
}

// Drops the vertices no face uses. PolyMesh allows them; OpenSubdiv keeps such a vertex where it is
// (RULE_CORNER), subdiv.cpp does not (its valence-0 weights), and they are not part of the surface.
PolyMesh drop_unreferenced(const PolyMesh& mesh) {
  std::vector<Index> remap(mesh.num_vertices(), kInvalid);
  PolyMesh out;
  out.face_offsets = mesh.face_offsets;
  out.corners = mesh.corners;
  for (Index& c : out.corners) {
    if (remap[c] == kInvalid) {
      remap[c] = static_cast<Index>(out.positions.size());
      out.positions.push_back(mesh.positions[c]);
    }
    c = remap[c];
  }
  return out;
}

TEST(SubdivOsd, CubeMatchesLevelByLevel) {
  const PolyMesh cube = make_quad_cube();
  compare_with_osd("cube", cube, 4);
}

TEST(SubdivOsd, TorusMatchesLevelByLevel) {
  const PolyMesh torus = make_quad_torus(12, 7, 1.0, 0.35);
  compare_with_osd("torus 12x7", torus, 4);
}

TEST(SubdivOsd, PairedCowMatchesLevelByLevel) {
  VARMESH_REQUIRE_SHARED(path, "meshes/cow_cgal_2904v.off");
  std::size_t leftovers = 0;
  const PolyMesh cow = pair_triangles(read_mesh(path), &leftovers);
  EXPECT_EQ(leftovers, 0u);
  const SpecialCounts s = special_counts(cow);
  std::printf("[ osd      ] cow: %zu faces, %zu interior valence-2 vertices\n", cow.num_faces(), s.interior_valence2);
  compare_with_osd("cow (paired)", cow, 4);
}

TEST(SubdivOsd, PairedClosedBunnyMatchesLevelByLevel) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bunny_libigl_3485v.off");
  std::size_t leftovers = 0;
  const PolyMesh bunny = pair_triangles(read_mesh(path), &leftovers);
  EXPECT_EQ(leftovers, 0u);
  const SpecialCounts s = special_counts(bunny);
  std::printf("[ osd      ] bunny: %zu faces, %zu interior valence-2 vertices\n", bunny.num_faces(),
              s.interior_valence2);
  compare_with_osd("bunny 3485v (paired)", bunny, 3);
}

TEST(SubdivOsd, OpenGridPatchMatchesLevelByLevel) {
  const PolyMesh grid = make_grid_patch(5, 4);
  const SpecialCounts s = special_counts(grid);
  ASSERT_EQ(s.border_corner, 4u);
  // OpenSubdiv classifies a corner with one face as a crease (VTX_BOUNDARY_EDGE_ONLY sharpens no vertex).
  const auto level0 = make_osd_refiner(grid, 0);
  ASSERT_NE(level0, nullptr);
  EXPECT_EQ(level0->GetLevel(0).GetVertexRule(0), Sdc::Crease::RULE_CREASE);
  compare_with_osd("grid 5x4 (open)", grid, 4);
}

TEST(SubdivOsd, InteriorValenceTwoMatchesLevelByLevel) {
  const PolyMesh pillow = make_pillow();
  ASSERT_EQ(special_counts(pillow).interior_valence2, 4u);
  const auto level0 = make_osd_refiner(pillow, 0);
  ASSERT_NE(level0, nullptr);
  for (Far::Index v = 0; v < 4; ++v) EXPECT_EQ(level0->GetLevel(0).GetVertexRule(v), Sdc::Crease::RULE_SMOOTH);
  compare_with_osd("pillow (valence 2)", pillow, 4);
}

TEST(SubdivOsd, PolygonsAndTrianglesMatchLevelByLevel) {
  const PolyMesh prism = make_pentagonal_prism();
  ASSERT_EQ(special_counts(prism).non_quads, 2u);
  compare_with_osd("pentagonal prism", prism, 4);
  const PolyMesh octa = make_triangle_octahedron();
  ASSERT_EQ(special_counts(octa).non_quads, 8u);
  compare_with_osd("octahedron (triangles)", octa, 4);
}

TEST(SubdivOsd, PairedBunnyWithHolesMatchesLevelByLevel) {
  VARMESH_REQUIRE_SHARED(path, "meshes/bun_zipper_35947v.obj");
  std::size_t leftovers = 0;
  const PolyMesh bunny = drop_unreferenced(pair_triangles(read_mesh(path), &leftovers));
  const SpecialCounts s = special_counts(bunny);
  std::printf("[ osd      ] bun_zipper: %zu faces (%zu triangles left), %zu border vertices (%zu with one face), "
              "%zu interior valence-2\n",
              bunny.num_faces(), leftovers, s.border, s.border_corner, s.interior_valence2);
  EXPECT_GT(s.border, 0u);
  compare_with_osd("bun_zipper (paired)", bunny, 2);
}

// Bfr agrees with catmull_clark_limit_positions everywhere, interior valence-2 vertices included.
TEST(SubdivOsd, LimitMatchesBfr) {
  for (int l = 1; l <= 3; ++l) {
    EXPECT_LE(compare_limit_with_bfr("cube", make_quad_cube(), l).other, kTolerance) << l;
    EXPECT_LE(compare_limit_with_bfr("grid 5x4 (open)", make_grid_patch(5, 4), l).other, kTolerance) << l;
    const BfrErrors pillow = compare_limit_with_bfr("pillow (valence 2)", make_pillow(), l);
    EXPECT_LE(pillow.other, kTolerance) << l;
    EXPECT_EQ(pillow.valence2_count, 4u);
    EXPECT_LE(pillow.valence2_ours, kTolerance) << l;
  }
}

TEST(SubdivOsd, PairedCowLimitMatchesBfr) {
  VARMESH_REQUIRE_SHARED(path, "meshes/cow_cgal_2904v.off");
  const PolyMesh cow = pair_triangles(read_mesh(path));
  for (int l = 1; l <= 2; ++l) {
    const BfrErrors e = compare_limit_with_bfr("cow (paired)", cow, l);
    EXPECT_LE(e.other, kTolerance) << l;
    EXPECT_GT(e.valence2_count, 0u);
    EXPECT_LE(e.valence2_ours, kTolerance) << l;
  }
}

}  // namespace
}  // namespace varmesh
