// A program outside the varmesh tree, built against the installed package: a 4-8 terrain hierarchy
// extracted within an error bound, a progressive-mesh hierarchy refined selectively, by hand and by a
// view query, a subdivision surface, uniform and adaptive, 4-k hierarchies of surfaces with their triangle
// strips, and a Multi-Triangulation built by hand. Exits non-zero if anything is off, so CI
// notices a broken install. The pm and subdivision parts are the examples README shows.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <fourk/grid48.hpp>
#include <fourk/adaptive.hpp>
#include <fourk/poly_mesh.hpp>
#include <fourk/semiregular.hpp>
#include <fourk/strips.hpp>
#include <fourk/subdiv.hpp>
#include <multitri/camera.hpp>
#include <multitri/mt.hpp>
#include <multitri/mt_front.hpp>
#include <multitri/query.hpp>
#include <multitri/shapes.hpp>
#include <multitri/terrain_gen.hpp>
#include <pm/qem_analysis.hpp>
#include <pm/sr_mesh.hpp>

namespace {

bool terrain() {
  const varmesh::HeightField field = varmesh::make_fractal_terrain(65, 65, 1, 20.0f);
  const varmesh::Grid48 hierarchy(field);
  varmesh::Grid48Front front(hierarchy);
  varmesh::Query q;
  q.criterion = varmesh::Criterion::object_error(0.5f);
  varmesh::extract(front, q);
  const varmesh::TriMesh mesh = front.to_mesh();
  const double error = hierarchy.max_vertical_error(mesh);
  std::printf("consumer: terrain %zu triangles, max vertical error %.3f (asked 0.5)\n", mesh.num_faces(), error);
  return mesh.num_faces() > 2 && error <= 0.5;
}

bool progressive_mesh() {
  const varmesh::TriMesh mesh = varmesh::make_torus(48, 24, 1.0f, 0.35f, 0.1f);  // or varmesh::read_mesh(path)
  const varmesh::VertexHierarchy h = varmesh::build_vertex_hierarchy(mesh);     // down to the smallest base mesh
  varmesh::SrMesh sr(h);  // RefinementScheme::kKimLee; kHoppe97 and kXiaVarshney give the baselines

  // By hand: split any active vertex that has children, then collapse it again (section 4 of the paper).
  varmesh::Index vs = varmesh::kInvalid;
  for (const varmesh::Index v : sr.active_vertices())
    if (!h.is_leaf(v)) vs = v;
  const std::size_t before = sr.num_active_vertices();
  const bool split = vs != varmesh::kInvalid && sr.vsplit(vs);
  const bool one_more = sr.num_active_vertices() == before + 1;
  const bool collapsed = split && sr.ecol(vs);  // false only when postponed (degenerate case, section 4.4)

  // By query: fine where the camera looks, coarse elsewhere; update() moves the same front for a new view.
  varmesh::Camera cam;
  cam.eye = {3.0f, 0.0f, 1.0f};
  cam.target = {0.0f, 0.0f, 0.0f};
  varmesh::Query q;
  q.criterion = varmesh::Criterion::screen_error(cam, 1080.0f, 1.0f);
  q.focus.frusta = {cam.frustum()};
  varmesh::extract(sr, q);
  const std::size_t near_faces = sr.num_faces();
  cam.eye = {6.0f, 0.0f, 2.0f};  // twice as far: fewer faces
  q.criterion = varmesh::Criterion::screen_error(cam, 1080.0f, 1.0f);
  q.focus.frusta = {cam.frustum()};
  varmesh::update(sr, q);
  const varmesh::TriMesh out = sr.to_mesh();
  std::printf("consumer: pm %zu -> %zu nodes; vsplit %d ecol %d; %zu faces near, %zu far\n", mesh.num_vertices(),
              h.num_nodes(), split, collapsed, near_faces, out.num_faces());
  return split && one_more && near_faces > out.num_faces() && out.num_faces() > 0;
}

bool subdivision() {
  const varmesh::PolyMesh cube = varmesh::make_quad_cube();  // or pair_triangles(read_mesh(path))
  // Uniform: two binary 4-8 steps are one Catmull-Clark level; four steps, two levels.
  const varmesh::SubdivMesh cc = varmesh::subdivide(cube, varmesh::SubdivScheme::kCatmullClark, 4);
  const std::vector<glm::dvec3> limit = varmesh::catmull_clark_limit_positions(cc);
  const varmesh::TriMesh uniform = cc.to_tri_mesh();
  // The limit surface of a cube lies strictly inside it (its control points are the cube's corners).
  double reach = 0.0;
  for (const glm::dvec3& p : limit) reach = std::max({reach, std::abs(p.x), std::abs(p.y), std::abs(p.z)});

  // Adaptive: the binary steps of 4-8 subdivision as a Multi-Triangulation; any query gives a conforming
  // front through points of the uniform result, here within 1 % of the cube's size of it.
  varmesh::SubdivMtInfo info;
  const varmesh::Mt mt = varmesh::build_subdivision_mt(cube, varmesh::SubdivScheme::kFourEight, 8, &info);
  varmesh::MtFront front(mt);
  varmesh::Query q;
  q.criterion = varmesh::Criterion::object_error(0.02f);
  varmesh::extract(front, q);
  const varmesh::TriMesh adaptive = front.to_mesh();
  std::printf("consumer: subdiv Catmull-Clark 2 levels %zu quads, limit within %.3f of the centre; 4-8 adaptive %zu of %zu triangles\n",
              cc.topo.num_faces, reach, adaptive.num_faces(), info.uniform_faces);
  return cc.topo.num_faces == 6 * 16 && uniform.num_faces() == 2 * cc.topo.num_faces && limit.size() == cc.topo.num_vertices &&
         reach < 1.0 && adaptive.num_faces() > 12 && adaptive.num_faces() < info.uniform_faces;
}

bool four_k() {
  // Semi-regular 4-8: the faces paired and bisected 4 times; a query picks any level anywhere.
  const varmesh::TriMesh base = varmesh::make_torus(16, 8, 1.0f, 0.35f, 0.0f);  // or read_mesh(path)
  const varmesh::Mt semi = varmesh::build_semiregular_mt(base, 4);
  varmesh::MtFront front(semi);
  varmesh::Query q;
  q.criterion = varmesh::Criterion::object_error(0.0f);  // everything: the finest level
  varmesh::extract(front, q);
  const std::size_t finest = front.num_faces();

  // Adaptive: newest-vertex bisection of the paper's torus until every face is within the tolerance; the
  // front in the finest state is one generalized triangle strip (a bisection hierarchy's strip plan).
  varmesh::AdaptiveOptions options;
  options.tolerance = 0.0685f;  // the paper's figure
  const varmesh::AdaptiveHierarchy torus = varmesh::build_adaptive_parametric(varmesh::torus_parametric(), options);
  varmesh::MtFront adaptive(torus.mt);
  varmesh::extract(adaptive, q);
  const varmesh::StripPlan plan(torus.mt);
  const varmesh::StripRuns runs = varmesh::hierarchical_strip(plan, adaptive.faces());
  const varmesh::StripCheck check = varmesh::check_strip(torus.mt, adaptive.faces(), runs);
  const std::vector<varmesh::Index> indices = varmesh::encode_strip(torus.mt, runs);  // GL_TRIANGLE_STRIP
  std::printf("consumer: 4-k semi-regular %zu -> %zu faces; adaptive torus %zu faces in %zu strip run(s), %zu indices\n",
              base.num_faces(), finest, adaptive.num_faces(), runs.size(), indices.size());
  return finest == base.num_faces() * 16 && adaptive.num_faces() == torus.num_finest_faces && check.ok &&
         runs.size() == 1 && indices.size() >= adaptive.num_faces() + 2;
}

bool hand_made_mt() {
  // A unit square of two triangles (diagonal 0-2) and one modification: a vertex raised 0.1 above the
  // diagonal's midpoint splits both triangles into four. The node's error is how far its pre-image (the
  // flat square) is from the finest data.
  varmesh::MtBuilder b;
  const varmesh::VertexId v0 = b.add_vertex({0, 0, 0}), v1 = b.add_vertex({1, 0, 0}), v2 = b.add_vertex({1, 1, 0}),
                          v3 = b.add_vertex({0, 1, 0}), m = b.add_vertex({0.5f, 0.5f, 0.1f});
  const varmesh::FaceId base[] = {b.add_face(v0, v1, v2), b.add_face(v0, v2, v3)};
  const varmesh::FaceId fine[] = {b.add_face(v0, v1, m), b.add_face(v1, v2, m), b.add_face(v2, v3, m), b.add_face(v3, v0, m)};
  b.set_base(base);
  b.add_node(varmesh::NodeKind::kSplit, base, fine, 0.1f);
  const varmesh::Mt mt = std::move(b).build();  // checks the definition; throws InvalidInput naming the node

  varmesh::MtFront front(mt);
  varmesh::Query q;
  q.criterion = varmesh::Criterion::object_error(0.05f);  // the flat square is 0.1 off: refine
  varmesh::extract(front, q);
  const std::size_t fine_faces = front.num_faces();
  q.criterion = varmesh::Criterion::object_error(0.2f);  // within 0.2: the base is enough
  varmesh::update(front, q);
  std::printf("consumer: hand-made MT of %zu nodes: %zu faces at error 0.05, %zu at 0.2\n", mt.num_nodes(), fine_faces,
              front.num_faces());
  return mt.num_nodes() == 2 && fine_faces == 4 && front.num_faces() == 2;
}

}  // namespace

int main() {
  const bool ok_terrain = terrain();
  const bool ok_pm = progressive_mesh();
  const bool ok_subdiv = subdivision();
  const bool ok_fourk = four_k();
  const bool ok_mt = hand_made_mt();
  return ok_terrain && ok_pm && ok_subdiv && ok_fourk && ok_mt ? 0 : 1;
}
